"""One periodic map of n steps: the step map (n = 1) and the stride (n = 2, the parameters
following the physical legs) are one class, one fixed point, and the per-leg fit runs
through the same fit function and the same NLP rounds as the symmetric fit."""

from __future__ import annotations

import numpy as np
import pytest

import pdw_casadi.fit.core as core
from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.fit import FitOptions, fit_gait
from pdw_casadi.fit.result import FitResult
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import find_stride_fixed_point, stride_map
from pdw_casadi.model.gait_data import load_side_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.studies.prosthesis import atlas_problem


@pytest.fixture(scope="module")
def step():
    pb = load_problem("humanlike_6link")
    fp = find_fixed_point(pb, tol=1e-11)
    assert fp.converged
    return pb, fp


def test_the_stride_is_the_step_map_twice_one_class(step):
    """For the equal-legged 6-link walker at its fixed point the two-step map equals two
    applications of the one-step map of the same walker to 1e-12 (value, Jacobians, time),
    both are instances of the one class, and to rounding (1e-10) two steps of the walker's
    own step map."""
    pb, fp = step
    stride, one = PoincareMap(pb, steps=2), PoincareMap(pb)
    assert type(stride) is type(one) is type(stride_map(pb))
    assert (stride.steps, one.steps) == (2, 1) and stride.per_leg
    # the step map of the walker the stride is built on (its per-leg build)
    one_pl = PoincareMap(pb, hs=stride.hs)
    assert type(one_pl) is PoincareMap
    theta = stride.default_parameters()
    p1, p2 = stride.step_parameters(theta)
    np.testing.assert_array_equal(p1, p2)  # equal legs: both roles carry the same values
    assert not np.array_equal(stride.perms[0], stride.perms[1])  # yet the roles swap
    r1 = one_pl.evaluate(fp.state, p1)
    r2 = one_pl.evaluate(r1.x_next, p2)
    s = stride.evaluate(fp.state, theta)
    scale = np.abs(s.dx).max()
    assert np.abs(s.x_next - r2.x_next).max() < 1e-12
    assert np.abs(s.dx - r2.dx @ r1.dx).max() < 1e-12 * scale
    assert np.abs(s.dp - (r2.dx @ r1.dp + r2.dp @ stride.Pi[1])).max() < 1e-12 * scale
    assert abs(s.step_time - (r1.step_time + r2.step_time)) < 1e-12
    assert [r.x_next.tolist() for r in s.steps] == [r1.x_next.tolist(), r2.x_next.tolist()]
    # the walker's own (baked) step map: the same equations, another order of operations
    assert np.abs(s.x_next - one(one(fp.state))).max() < 1e-10
    assert np.abs(s.x_next - fp.state).max() < 1e-10  # a period-1 gait is period-2 too
    # the re-simulation check of both maps: the gait repeats at every step's node (to its
    # 1e-11 residual grown over 20 steps of this slightly unstable orbit, rho 1.0068); a
    # node 1e-3 off is seen as 1e-3 off
    dev1 = one.resimulation_deviation([fp.state], steps=20)
    dev2 = stride.resimulation_deviation([fp.state, fp.state], theta, steps=20)
    assert dev1 < 1e-7 and dev2 < 1e-7
    off = stride.resimulation_deviation([fp.state, fp.state + 1e-3], theta, steps=20)
    assert abs(off - 1e-3) < 1e-7


def test_find_fixed_point_solves_both_maps(step):
    """find_fixed_point on the two-step map (steps=2) finds the step's fixed point again,
    with the squared eigenvalues, and find_stride_fixed_point is that same solve."""
    pb, fp = step
    two = find_fixed_point(pb, x0=fp.state, tol=1e-11, steps=2)
    same = find_stride_fixed_point(pb, x0=fp.state, tol=1e-11)
    assert two.converged and same.converged
    assert np.abs(two.state - fp.state).max() < 1e-10
    np.testing.assert_array_equal(two.state, same.state)
    assert abs(two.spectral_radius - fp.spectral_radius ** 2) < 1e-8
    assert abs(two.step_time_s - 2 * fp.step_time_s) < 1e-10


def test_per_leg_fit_runs_through_the_fit_function(monkeypatch):
    """fit_gait with per-side curves is the per-leg fit: one function (no alias of it), the
    same rounds (fit_rounds) on the two-step map, where the symmetric fit
    runs them on the one-step map; one IPOPT iteration each (the path, not the answer)."""
    seen = []
    rounds = core.fit_rounds

    def spy(fit, x, p, opts, log=print, **kw):
        seen.append(fit)
        return rounds(fit, x, p, opts, log=log, **kw)

    monkeypatch.setattr(core, "fit_rounds", spy)
    assert not hasattr(core, "fit_stride")
    pb = atlas_problem("humanlike_6link-female_fast-rho0.86")
    sides = load_side_curves(bundled_dir("data") / "subjects" / "WBDS09_fast_sides.csv")
    # without the stability row: its blocks are tests/test_shooting.py's (and a per-leg
    # walker's take a minute to compile)
    cheap = dict(rounds=1, max_iter=1, verbose=False, atlas="", stability_constraint=False)
    per_leg = fit_gait(pb, sides, FitOptions(start="atlas", side="right", **cheap),
                       log=lambda m: None)
    sym = fit_gait(pb, sides.mean(), FitOptions(**cheap), log=lambda m: None)
    assert isinstance(per_leg, FitResult) and isinstance(sym, FitResult)
    assert per_leg.start is not None and sym.start is None
    assert [f.steps for f in seen] == [2, 1]
    # the stride's NLP: the two-step map of the one class, only the right leg's compliance
    nlp = seen[0].nlp(np.asarray(per_leg.start["state"]),
                      np.asarray(per_leg.start["parameters"]))
    assert type(nlp.stride_map) is PoincareMap and nlp.stride_map.steps == 2
    assert all(n.startswith("right.") for n in nlp.free)
    # each fit's one solve is that of its rounds: one iteration, the objective finite
    for res in (per_leg, sym):
        assert len(res.solves) == 1 and res.solves[0].iterations == 1
        assert np.isfinite(res.solves[0].objective)
