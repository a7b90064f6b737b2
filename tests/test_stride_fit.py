"""The per-leg fit on the stride: its curve rows are the simulator's per-leg curves, at equal
legs and equal sides they are the one-step fit's twice, and an end-to-end per-side fit of a
real subject re-simulates as a stable valid stride."""

from __future__ import annotations

import json

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.fit.objective import curve_errors
from pdw_casadi.fit.stride_objective import side_targets, stride_curve_errors
from pdw_casadi.gait.stride import stride_map, stride_report
from pdw_casadi.model.gait_data import SideCurves, load_gait_curves, load_side_curves
from pdw_casadi.nlp.shooting import ShootingNLP
from pdw_casadi.studies.prosthesis import atlas_problem

SUBJECT = bundled_dir("data") / "subjects" / "WBDS09_fast_sides.csv"
#: the atlas gait fitted to the bundled curves (the one-step fit's answer, re-solved)
FITTED = "humanlike_6link-female_fast-rho0.86"


@pytest.fixture(scope="module")
def fitted():
    """The fitted symmetric gait, its one-step NLP and its stride NLP (both built at the
    same fixed point, nothing free)."""
    from pdw_casadi.gait.fixed_point import find_fixed_point

    pb = atlas_problem(FITTED)
    fp = find_fixed_point(pb, fallback=False)
    assert fp.converged
    smap = stride_map(pb)
    one = ShootingNLP(pb, fp.state, fp.parameters)
    stride = ShootingNLP.stride(pb, fp.state, smap.default_parameters())
    return pb, smap, fp, one, stride


def _values(nlp, expr, w):
    return ca.Function("v", [nlp.w], [expr])(w).full().ravel()


def test_stride_nlp_leg_curves_are_the_simulators(fitted):
    """At the symmetric fitted gait, each leg's model curve in the stride NLP's error rows
    (error + that side's human curve, the subject's two different sides) equals the
    simulator's curve of that leg (stride_report) at every one of the 101 cycle points to
    2e-3 deg (of a 57 deg knee range; the largest gap is at 0 %, which the NLP extrapolates
    from its first two samples after heel strike), and to 1e-4 deg at the median."""
    pb, smap, fp, _, stride = fitted
    sides = load_side_curves(SUBJECT)
    errs = stride_curve_errors(stride, sides, ("knee", "hip"))
    assert set(errs) == set(side_targets(("knee", "hip")))
    rep = stride_report(smap, fp.state, smap.default_parameters())
    for side in ("left", "right"):
        h = sides.side(side).resample(101)
        for joint in ("knee", "hip"):
            model = _values(stride, errs[f"{side}.{joint}"][0], stride.w0) + \
                getattr(h, f"{joint}_deg")
            sim = rep["curves"][side][f"{joint}_deg"].to_numpy()
            gap = np.abs(model - sim)
            assert gap.max() < 2e-3 and np.median(gap) < 1e-4, (side, joint, gap.max())


def test_stride_objective_at_equal_sides_is_twice_the_step_objective(fitted):
    """With a per-side curve set whose two sides are the bundled mean curves and the
    symmetric walker, the stride objective (sum over legs of 1 - R^2 of knee and hip) at
    the one-step fit's gait is twice the one-step objective, to 1e-9 relative: at the
    NLPs' own starting points and at a perturbed one-step point repeated twice (the rows
    agree as functions of the unknowns, not only on the orbit)."""
    *_, one, stride = fitted
    h = load_gait_curves("female_fast")
    sides = SideCurves(h, h, h.source, "equal sides")
    e1, e2 = curve_errors(one, h), stride_curve_errors(stride, sides)

    def objective(nlp, errs, w):
        return sum(float(_values(nlp, ca.sumsqr(r.err) / r.ss_tot, w)[0]) for r in errs.values())

    f1, f2 = objective(one, e1, one.w0), objective(stride, e2, stride.w0)
    assert f1 > 0.1  # the comparison is of a non-trivial misfit
    assert abs(f2 - 2 * f1) < 1e-9 * f1
    rng = np.random.default_rng(3)
    w1 = one.w0 * (1 + 1e-4 * rng.standard_normal(one.w0.size))
    ns, n1 = one.xs.shape[0], len(one.specs)
    xs, T, X = w1[:ns], w1[ns: ns + n1], w1[ns + n1:]
    w2 = np.r_[xs, T, T, X, X, xs]
    f1p, f2p = objective(one, e1, w1), objective(stride, e2, w2)
    assert abs(f1p - f1) > 1e-6 * f1  # the perturbation moves the objective
    assert abs(f2p - 2 * f1p) < 1e-9 * f1p


def test_stride_free_names_and_bounds(fitted):
    """--side frees one leg's compliance only, named as the stride's physical parameters;
    the stride's stability bound is the per-step one squared."""
    from pdw_casadi.fit.options import FitOptions
    from pdw_casadi.fit.stride_fit import stride_free_names

    pb, smap, fp, *_ = fitted
    both = stride_free_names(pb, FitOptions())
    right = stride_free_names(pb, FitOptions(side="right", free=("k_ankle", "k_knee"),
                                             free_slope=True))
    assert both == tuple(f"{s}.{k}" for s in ("left", "right") for k in pb.compliance_names)
    assert right == ("right.k_ankle", "right.k_knee", "slope")
    assert set(both) <= set(smap.parameter_names) and set(right) <= set(smap.parameter_names)
    with pytest.raises(ValueError, match="side must be"):
        stride_free_names(pb, FitOptions(side="middle"))
    opts = FitOptions(max_radius=0.91)
    assert opts.radius_bound(2) == pytest.approx(0.9 ** 2)
    assert opts.radius_bound(1) == opts.max_radius - opts.radius_margin


def test_a_stride_takes_each_step_rows_multipliers_from_the_one_step_nlp(fitted):
    """The stride NLP's shooting rows, built at the symmetric gait, pair up block by block
    with the one-step NLP's (each step's segment rows with the step's, the leg swap into
    step 2 and the stride's periodicity with the step's periodicity, step 2's section rows
    with the section rows): every row gets a multiplier, each step the one step's values."""
    from pdw_casadi.nlp.multipliers import map_multipliers

    _, _, _, one, stride = fitted
    lam = np.arange(1.0, len(one.g_names) + 1)
    out, mapped = map_multipliers(one.g_names, lam, stride.g_names)
    assert mapped == len(stride.g_names) == out.size == 2 * lam.size
    names = np.array(stride.g_names)
    K = len(one.specs)
    assert len(stride.specs) == 2 * K
    # the stride's rows are the step's twice, in the step's order (step 1's section rows
    # where the step starts, the leg swap into step 2 where the step closes its period)
    assert np.array_equal(out, np.r_[lam, lam])
    per = lam[np.array(one.g_names) == "periodicity"]
    assert np.array_equal(out[names == "step_link[1]"], per)
    assert np.array_equal(out[names == "section[1]"], lam[np.array(one.g_names) == "section"])



def test_multipliers_of_another_grid_are_resampled_along_the_segment():
    """A one-step NLP built at another gait has other numbers of shooting intervals per
    segment: its continuity multipliers (costates, nx per node) are interpolated in the
    segment's fraction, its sample rows' multipliers (inequalities) shared out so that their
    sum over the segment is kept; blocks of the same size are copied."""
    from pdw_casadi.nlp.multipliers import map_multipliers, resample_block

    nodes = np.array([1.0, 10.0, 2.0, 20.0])  # two nodes of two states
    assert np.allclose(resample_block(nodes, 8, 2, density=False),
                       [1, 10, 1, 10, 1.5, 15, 2, 20])
    shares = np.array([0.0, 0.0, 4.0, 0.0])
    finer = resample_block(shares, 8, 1, density=True)
    assert finer.sum() == pytest.approx(shares.sum()) and finer.max() == pytest.approx(2.0)
    assert np.array_equal(resample_block(shares, 4, 1, density=True), shares)
    one = ["section"] * 2 + ["continuity[0]"] * 4 + ["sign[0]:e"] * 4 + ["guard[0]:e"] + \
        ["periodicity"] * 2
    lam = np.r_[5.0, 6.0, nodes, shares, 7.0, 8.0, 9.0]
    stride = ["section"] * 2 + ["continuity[0]"] * 8 + ["sign[0]:e"] * 8 + ["guard[0]:e"] + \
        ["step_link[1]"] * 2 + ["section[1]"] * 2 + ["continuity[1]"] * 8 + \
        ["sign[1]:e"] * 8 + ["guard[1]:e"] + ["periodicity"] * 2
    out, mapped = map_multipliers(one, lam, stride, nx=2)
    assert mapped == len(stride)
    step = np.r_[resample_block(nodes, 8, 2, False), finer, 7.0]
    assert np.allclose(out, np.r_[5, 6, step, 8, 9, 5, 6, step, 8, 9])


def test_bound_multipliers_follow_the_parameters_scales_and_segments():
    """A free parameter's bound multiplier is the source's rescaled to this NLP's scale
    (unknowns are p / scale: the multiplier of p's bound is lam / scale), times its weight;
    segment k's duration takes segment k modulo the source's segments; the section state
    and the nodes (unbounded) get 0."""
    from types import SimpleNamespace

    import casadi as ca

    from pdw_casadi.nlp.multipliers import bound_multipliers

    # source: 2 section states, free (k, slope) scaled (10, 0.1), 2 segments, 1 node
    lam_src = np.array([9.0, 9.0, 3.0, -2.0, 0.5, 0.7, 9.0])
    nlp = SimpleNamespace(w=ca.MX.sym("w", 2 + 3 + 4 + 1), xs=ca.MX.sym("xs", 2),
                          free=["left.k", "right.k", "slope"],
                          p_scale=np.array([20.0, 5.0, 0.1]), specs=[None] * 4)
    out = bound_multipliers(lam_src, ("k", "slope"), (10.0, 0.1), 2, nlp,
                            source=lambda n: n.rsplit(".", 1)[-1],
                            weight=lambda n: 2.0 if n == "slope" else 1.0)
    assert np.allclose(out, [0, 0, 6.0, 1.5, -4.0, 0.5, 0.7, 0.5, 0.7, 0])


def _candidate(radius: float, steps: int, max_radius: float = 0.91, valid: bool = True,
               deviation: float = 0.0):
    """A checked gait of the ``steps``-step map whose spectral radius is ``radius`` (no
    simulation: a stand-in fixed point with that radius)."""
    from pdw_casadi.fit.result import Candidate
    from pdw_casadi.gait.fixed_point import FixedPointResult

    fp = FixedPointResult(
        state=np.zeros(2), state_names=("q", "u"), parameters=np.zeros(1),
        parameter_names=("k",), residual=0.0, iterations=1, converged=True,
        jacobian=np.diag([radius, 0.0]), jacobian_p=np.zeros((2, 1)),
        eigenvalues=np.array([radius, 0.0]), spectral_radius=radius, step_time_s=0.5 * steps,
        step_length_m=0.6 * steps, margins={}, valid=valid, failure=None, method="newton",
        wall_time_s=0.0)
    if steps == 1:
        scores = {"r2_knee": 0.9, "r2_hip": 0.7}
    else:
        scores = {"left": {"r2_knee": 0.9, "r2_hip": 0.7},
                  "right": {"r2_knee": 0.8, "r2_hip": 0.6}}
    return Candidate(-1, fp.state, fp.parameters, fp, scores, None, deviation, steps=steps,
                     max_radius=max_radius)


@pytest.mark.parametrize("max_radius", [0.91, 0.86, 0.5])
def test_one_stability_rule_for_the_step_and_the_stride(max_radius):
    """One verdict for one step and for the stride: a gait with per-step radius r on the
    step map (rho = r) and on the stride (rho = r^2) is stable and good alike, for r just
    below, at and just above ``max_radius`` (the per-step radius); invalid or re-simulated
    off its NLP answer, neither is good; both rank by their mean R^2 (a stride's over both
    legs)."""
    from pdw_casadi.fit.options import FitOptions

    for r, expected in ((max_radius - 1e-6, True), (max_radius, True),
                        (max_radius + 1e-6, False), (1.0, False), (1.2, False)):
        step, stride = _candidate(r, 1, max_radius), _candidate(r ** 2, 2, max_radius)
        assert step.stable is stride.stable is expected, r
        assert step.good is stride.good is expected, r
        assert step.per_step_radius == r
        assert stride.per_step_radius == pytest.approx(r, rel=1e-15)
    for c in (_candidate(0.8, 1, valid=False), _candidate(0.64, 2, valid=False),
              _candidate(0.8, 1, deviation=FitOptions.resim_tol),
              _candidate(0.64, 2, deviation=FitOptions.resim_tol)):
        assert c.stable and not c.valid and not c.good
    assert _candidate(0.8, 1).mean_score(("knee", "hip")) == pytest.approx(0.8)
    assert _candidate(0.64, 2).mean_score(("knee", "hip")) == pytest.approx(0.75)


def test_the_accepted_radius_has_one_home():
    """pdw_casadi.gait.stability holds the accepted per-step radius and the NLP's margin;
    the fit's verdict, the bound of a subject's body (the fit's NLP bound) and the
    prosthesis design's stride verdict (that bound squared, by the fit's rule for a map of
    n steps) derive from it, with the values they had (0.91, 0.9, 0.81: exactly), and the
    commands' flags default to them."""
    import argparse

    from pdw_casadi.cli.common import fit_arguments
    from pdw_casadi.fit.options import FitOptions
    from pdw_casadi.gait.stability import MAX_RADIUS, RADIUS_BOUND, RADIUS_MARGIN, map_radius
    from pdw_casadi.studies.cohort import CohortOptions
    from pdw_casadi.studies.prosthesis import DesignNLPOptions
    from pdw_casadi.studies.scaling import BODY_MAX_RADIUS

    fit, design = FitOptions(), DesignNLPOptions()
    assert (fit.max_radius, fit.radius_margin) == (MAX_RADIUS, RADIUS_MARGIN) == (0.91, 0.01)
    assert fit.radius_bound(1) == RADIUS_BOUND == BODY_MAX_RADIUS == 0.9
    assert CohortOptions().body_max_radius == BODY_MAX_RADIUS
    assert design.max_stride_radius == fit.radius_bound(2) == map_radius(0.9, 2) == 0.81
    assert design.max_step_radius == RADIUS_BOUND and design.radius_margin == RADIUS_MARGIN
    assert fit.accepted_radius(2) == MAX_RADIUS ** 2
    parser = argparse.ArgumentParser()
    fit_arguments(parser, fit)
    assert parser.parse_args([]).max_radius == MAX_RADIUS


@pytest.mark.slow  # the symmetric start fit and one stride NLP solve: 32 s warm, 2 cores
def test_pdw_fit_per_side_subject_file(tmp_path, capsys):
    """pdw-fit on a real subject's per-side file: the stride fit re-simulates as a stable
    (stride radius <= 0.91^2) valid stride (20 steps within 1e-6 of the NLP), each leg is
    scored against its own side, the objective is no worse than the symmetric start's, and
    the NLP objective is the re-simulated sum of 1 - R^2 (1e-3 relative)."""
    from pdw_casadi.cli import fit_main
    from pdw_casadi.fit.options import FitOptions

    out = tmp_path / "fit"
    code = fit_main(["--gait", str(SUBJECT), "--out", str(out), "--quiet"])
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    print(printed)
    assert code == 0 and summary["accepted"]
    assert summary["stride_spectral_radius"] <= FitOptions().accepted_radius(2)
    assert summary["valid"] and summary["resimulation_deviation"] < FitOptions.resim_tol
    legs, start = summary["legs"], summary["start"]["scores"]
    miss = sum(1 - legs[s][f"r2_{j}"] for s in ("left", "right") for j in ("knee", "hip"))
    miss0 = sum(1 - start[s][f"r2_{j}"] for s in ("left", "right") for j in ("knee", "hip"))
    assert miss <= miss0 + 1e-6
    assert abs(summary["objective"] - miss) <= 1e-3 * miss
    assert set(summary["legs"]["right"]["compliance"]) == set(atlas_problem().compliance)
    for name in ("summary.json", "curves.csv", "fit.png", "table.md"):
        assert (out / name).is_file()


def test_the_strides_row_at_a_symmetric_gait_is_the_steps_squared(fitted):
    """The stride's stability row bounds the growth of a perturbation over the same steps
    as the one step's (FitOptions.row_power): at the symmetric fitted gait, where the
    stride's Poincare Jacobian is the step's squared, the stride's row is the step's row
    squared to 1e-6 relative, so the stride's bound (the per-step bound squared) holds
    exactly where the step's does. The stride's row over twice the steps (the power the
    step uses, on the stride's map) is a looser bound there by more than 5 %: a stride
    started on the step's active bound would start far inside its own."""
    from pdw_casadi.fit.options import FitOptions
    from pdw_casadi.nlp.stability import StabilityRow, power_bound

    *_, one, stride = fitted
    opts = FitOptions()
    assert (opts.row_power(1), opts.row_power(2)) == (opts.stability_power,
                                                      opts.stability_power // 2)
    step = StabilityRow(one, bound="power", power=opts.row_power(1))
    both = StabilityRow(stride, bound="power", power=opts.row_power(2))
    r1, r2 = step.value(one.w0), both.value(stride.w0)
    J1, J2 = step.poincare_jacobian(one.w0), both.poincare_jacobian(stride.w0)
    assert np.allclose(J2, J1 @ J1, rtol=1e-6, atol=1e-8 * np.abs(J1).max())
    assert abs(r2 - r1 ** 2) < 1e-6 * r1 ** 2, (r1, r2)
    loose, _ = power_bound(J2, opts.stability_power)
    assert loose < 0.95 * r1 ** 2, (loose, r1 ** 2)
    with pytest.raises(ValueError, match="power of two"):
        FitOptions(stability_power=6).row_power(2)


def test_a_strides_solve_keeps_its_own_lbfgs_history():
    """IPOPT's L-BFGS memory is a setting of the fit's options, one for a one-step solve and
    one for a stride's (FitOptions.lbfgs_history, stride_lbfgs_history); it reaches IPOPT
    only under the limited-memory Hessian (an exact Hessian has no history)."""
    from pdw_casadi.fit.options import FitOptions
    from pdw_casadi.nlp.driver import ipopt_settings

    opts = FitOptions()
    assert opts.stride_lbfgs_history is not None and opts.stride_lbfgs_history > 6
    got = ipopt_settings("limited-memory", 10, 1e-8, history=opts.stride_lbfgs_history)
    assert got["limited_memory_max_history"] == opts.stride_lbfgs_history
    assert "limited_memory_max_history" not in ipopt_settings("limited-memory", 10, 1e-8)
    assert "limited_memory_max_history" not in ipopt_settings("exact", 10, 1e-8, history=50)
