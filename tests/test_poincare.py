"""The exact AD sensitivities of the Poincare map agree with finite differences of the
event-driven simulator (humanlike 6-link at Table 2, and the compass gait)."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem

EPS = 1e-5
RTOL = 1e-5


def _run(sim, x, p):
    s = sim.run(np.asarray(x, float), np.asarray(p, float), steps=1, record=False).steps[0]
    return np.asarray(s.x_section_end, float), float(s.step_time)


def _fd(fun, v, scale):
    """Central differences of fun (returning (x_end, T)) w.r.t. v, step EPS * scale[j]."""
    cols_x, cols_t = [], []
    for j in range(v.size):
        h = EPS * scale[j]
        e = np.zeros(v.size)
        e[j] = h
        (xp, tp), (xm, tm) = fun(v + e), fun(v - e)
        cols_x.append((xp - xm) / (2 * h))
        cols_t.append((tp - tm) / (2 * h))
    return np.array(cols_x).T, np.array(cols_t)


def _close(A, B, rtol=RTOL):
    err = np.max(np.abs(A - B)) / max(np.max(np.abs(A)), 1e-300)
    print(f"relative error {err:.2e}")
    assert err < rtol, err


_CASES: dict = {}


def _case(name):
    if name not in _CASES:
        pb = load_problem(name)
        x, p = pb.state_vector(), pb.parameter_vector()
        _CASES[name] = (pb, Simulator(pb), x, p, PoincareMap(pb).evaluate(x, p))
    return _CASES[name]


@pytest.fixture(scope="module", params=["humanlike_6link", "compass_gait"])
def case(request):
    return _case(request.param)


def test_map_value_equals_simulator(case):
    _, sim, x, p, m = case
    x_end, T = _run(sim, x, p)
    np.testing.assert_allclose(m.x_next, x_end, rtol=0, atol=1e-8)
    assert abs(m.step_time - T) < 1e-8


def test_dx_and_dT_dx_match_finite_differences(case):
    _, sim, x, p, m = case
    Jx, dT = _fd(lambda v: _run(sim, v, p), x, np.ones(x.size))
    _close(m.dx, Jx)
    _close(np.asarray(m.dT_dx).ravel(), dT)


def test_dp_matches_finite_differences():
    """dP/dp (8 compliance values + slope) of the 6-link map, eps = 1e-5 max(1, |p_i|)."""
    _, sim, x, p, m = _case("humanlike_6link")
    Jp, _ = _fd(lambda v: _run(sim, x, v), p, np.maximum(1.0, np.abs(p)))
    _close(m.dp, Jp)


def test_margin_gradients_match_finite_differences():
    """Each validity margin's smallest sample (a contact force, a CoP distance, the swing
    toe's clearance, an impulse) equals the simulator's, and its exact gradient in the
    section state and the compliance agrees with central differences of the simulator's
    margins."""
    pb = load_problem("humanlike_6link")
    P = PoincareMap(pb)
    x, p = pb.state_vector(), pb.parameter_vector()
    r = P.evaluate(x, p, margin_gradients=True)

    def margins(xx, pp):
        return P.evaluate(xx, pp, jacobian=False, margins=True).sim.steps[0].margins

    base = margins(x, p)
    assert set(r.margin_grads) == set(P.hs.margin_specs)
    for key, (v, _, _) in r.margin_grads.items():
        assert abs(v - base[key]) <= 1e-12 * max(1.0, abs(v))
    worst = 0.0
    for which, v0, names in (("x", x, P.state_names), ("p", p, P.parameter_names)):
        for j, name in enumerate(names):
            if name == "slope" or name.startswith("theta_"):
                h = 1e-6
            else:
                h = 1e-6 * max(1.0, abs(v0[j]))
            e = np.zeros(v0.size)
            e[j] = h
            hi = margins(x + e, p) if which == "x" else margins(x, p + e)
            lo = margins(x - e, p) if which == "x" else margins(x, p - e)
            for key, (_, gx, gp) in r.margin_grads.items():
                exact = (gx if which == "x" else gp)[j]
                fd = (hi[key] - lo[key]) / (2 * h)
                worst = max(worst, abs(fd - exact) / (1.0 + abs(exact)))
    assert worst < 1e-4
