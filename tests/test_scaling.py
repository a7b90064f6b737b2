"""Subject scaling (de Leva 1996 table, uniform scaling law), design continuation and the
prosthetic-leg design."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pdw_casadi.cli import scale_main
from pdw_casadi.gait.design import DesignOptions, continue_design
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import (
    per_leg_system,
    physical_parameter_names,
    physical_parameter_vector,
)
from pdw_casadi.model.problem import load_problem
from pdw_casadi.studies.prosthesis import atlas_problem, design_prosthesis, lighter_mass
from pdw_casadi.studies.scaling import (
    BODY_MAX_RADIUS,
    DE_LEVA_1996,
    reference_mass,
    scale_problem,
    scaled_state,
    subject_anthropometry,
    subject_row,
)


def _runtime_map(pb):
    """The step map of the per-leg walker (body as runtime parameters, no recompilation)."""
    return PoincareMap(pb, per_leg_system(pb)), physical_parameter_vector(pb)


@pytest.fixture(scope="module")
def reference():
    pb = load_problem("humanlike_6link")
    P, theta = _runtime_map(pb)
    fp = find_fixed_point(pb, tol=1e-11, p=theta, pmap=P)
    assert fp.converged
    return pb, fp


@pytest.mark.parametrize("s, m", [(1.1, 1.25), (0.93, 0.8)])
def test_uniform_scaling_law(reference, s, m):
    """Lengths x s, masses x m: the scaled reference gait is a fixed point of the scaled
    walker (angles equal, rates / sqrt(s)), same eigenvalues, times x sqrt(s)."""
    pb, fp = reference
    big = scale_problem(pb, s, m)
    P, theta = _runtime_map(big)
    x = scaled_state(pb, fp.state, s)
    r = P.evaluate(x, theta)
    assert np.abs(r.x_next - x).max() < 1e-9
    fps = find_fixed_point(big, x0=x, tol=1e-11, p=theta, pmap=P)
    assert fps.converged and np.abs(fps.state - x).max() < 1e-9
    want = list(fp.eigenvalues)
    for lam in fps.eigenvalues:
        k = int(np.argmin([abs(lam - w) for w in want]))
        assert abs(lam - want.pop(k)) < 1e-9
    assert abs(fps.step_time_s / fp.step_time_s - math.sqrt(s)) < 1e-9
    assert abs(fps.step_length_m / fp.step_length_m - s) < 1e-9
    assert abs(reference_mass(big) / reference_mass(pb) - m) < 1e-12


def test_de_leva_table_at_its_reference_subject():
    """At the table's own reference stature and mass the segments are the published ones."""
    for sex, t in DE_LEVA_1996.items():
        a = subject_anthropometry(t["mass_kg"], t["stature_m"], sex)
        L, mf, cm, rg = t["thigh"]
        assert abs(a["l_t"] - L) < 1e-12 and abs(a["m_t"] - mf * t["mass_kg"]) < 1e-12
        assert abs(a["l_tc"] - (1 - cm) * L) < 1e-12
        assert abs(a["J_t"] - mf * t["mass_kg"] * (rg * L) ** 2) < 1e-12
        L, mf, cm, _ = t["shank"]
        assert abs(a["l_s"] - L) < 1e-12 and abs(a["l_sc"] - (1 - cm) * L) < 1e-12
        assert abs(a["m_f"] - t["foot"][1] * t["mass_kg"]) < 1e-12
        total = a["m_h"] + 2 * (a["m_t"] + a["m_s"] + a["m_f"])
        assert abs(total - t["mass_kg"]) < 1e-9
        assert abs(a["l_ft"] + a["l_fh"] - a["l_f"]) < 1e-12
    # female: 14.78 % thigh, 4.81 % shank, 1.29 % foot (de Leva 1996, Table 4)
    a = subject_anthropometry(60.0, 1.70, "female")
    assert abs(a["m_t"] - 8.868) < 1e-9 and abs(a["m_s"] - 2.886) < 1e-9


def test_subject_rows_from_the_bundled_file():
    row = subject_row("WBDS09")
    assert row == {"mass_kg": 61.25, "height_m": 1.691, "sex": "female"}


def test_pdw_scale_uniform_writes_a_walking_problem(tmp_path, capsys):
    out = tmp_path / "me.toml"
    assert scale_main(["--mass", "62.5", "--height", "1.70", "--body", "uniform",
                       "--out", str(out)]) == 0
    pb = load_problem(out)
    assert abs(reference_mass(pb) - 62.5) < 1e-9
    P, theta = _runtime_map(pb)
    x = pb.state_vector()
    assert np.abs(P(x, theta) - x).max() < 1e-9  # its initial state is its gait
    with pytest.raises(SystemExit) as exc:
        scale_main(["--mass", "62.5", "--out", str(tmp_path / "x.toml")])
    assert exc.value.code == 2 and "--height" in capsys.readouterr().err
    assert not (tmp_path / "x.toml").exists()


def test_continuation_with_adapted_compliance(reference):
    """A 0.5 % heavier thigh reached by continuation, compliance adapted (min-norm): the
    end point is a fixed point of the walker with the returned parameters."""
    pb, fp = reference
    P, theta0 = _runtime_map(pb)
    names = list(physical_parameter_names(pb))
    theta1 = theta0.copy()
    for side in ("left", "right"):
        theta1[names.index(f"{side}.m_t")] *= 1.005
    free = [[names.index(f"{s}.{k}") for s in ("left", "right")] for k in ("k_ankle", "k_knee")]
    run = continue_design(P, fp.state, theta0, theta1, free, options=DesignOptions(n_min=2))
    assert run.reached
    th = run.last.theta
    assert abs(th[names.index("left.m_t")] - theta1[names.index("left.m_t")]) < 1e-12
    assert th[names.index("left.k_ankle")] == th[names.index("right.k_ankle")]
    check = find_fixed_point(pb, x0=run.last.state, tol=1e-10, p=th, pmap=P)
    assert check.converged and np.abs(check.state - run.last.state).max() < 1e-9


def test_prosthesis_design_makes_the_gait_symmetric():
    """A slightly lighter right shank and foot: the designed right-leg compliance gives
    equal step lengths and times (exactly, to the solver tolerance) on a valid gait. Without
    holding phase I's duration the 0.4 % lighter leg's gait is valid too: the phase a step's
    last impact enters is the next step's, so its trailing toe (the other leg's) is checked
    with the next step's parameters and pushes the ground after both foot strikes."""
    pb = atlas_problem()
    loose = design_prosthesis(pb, lighter=0.004, hold_first_phase=False,
                              options=DesignOptions(n_min=2))
    assert loose.reached and loose.fixed_point.converged and loose.fixed_point.valid
    ahead = {k: v for k, v in loose.fixed_point.margins.items()
             if k.endswith("foot_strike:toe_off_ahead")}
    assert sorted(ahead) == ["left.foot_strike:toe_off_ahead",
                             "right.foot_strike:toe_off_ahead"]
    assert min(ahead.values()) > 0.0
    res = design_prosthesis(pb, lighter=0.004, options=DesignOptions(n_min=2))
    assert res.reached and res.fixed_point.converged and res.fixed_point.valid
    assert abs(lighter_mass(res.problem) - 0.996) < 1e-12
    assert abs(res.report["step_length_asymmetry_pct"]) < 1e-6
    assert abs(res.report["step_time_asymmetry_pct"]) < 1e-6
    assert res.compliance["k_ankle"] != pb.compliance["k_ankle"]
    assert res.problem.asymmetric


# about 30 s warm (a 20-point design continuation): in the slow set
@pytest.mark.slow
def test_subject_continuation_keeps_the_gait_valid():
    """The de Leva body of a bundled subject (longer shank, shorter thigh than Table 1's):
    without holds the swing toe's clearance falls below its 5 mm requirement on the way;
    with the validity margins held (exact margin gradients) the continuation reaches the
    subject with a valid gait whose held clearance sits at its target and whose first phase
    keeps its duration."""
    from pdw_casadi.studies.scaling import walker_for_subject

    who = subject_row("WBDS09")
    start = atlas_problem("humanlike_6link-female_fast-rho0.86")
    fp0 = find_fixed_point(start)
    assert fp0.converged and fp0.valid
    res = walker_for_subject(who["mass_kg"], who["height_m"], who["sex"], start, fp0.state)
    assert res.reached and res.fixed_point.valid
    assert "II:min_clearance_toe2" in res.held
    _, target = res.held["II:min_clearance_toe2"]
    assert abs(res.fixed_point.margins["II:min_clearance_toe2"] - target) < 1e-8
    assert target >= start.validity["min_clearance"]
    body = res.problem.anthropometry
    want = subject_anthropometry(who["mass_kg"], who["height_m"], who["sex"], start)
    assert all(abs(body[k] - want[k]) < 1e-12 for k in want)
    loose = walker_for_subject(who["mass_kg"], who["height_m"], who["sex"], start, fp0.state,
                               options=DesignOptions())
    assert not (loose.reached and loose.fixed_point.valid)


# a continuation to the subject's body and a fit to its own curves: minutes; in the slow set
@pytest.mark.slow
def test_pdw_scale_writes_a_stable_gait_that_pdw_fixed_point_finds(tmp_path, capsys):
    """``pdw-scale --mass 62.45 --height 1.695`` (the continued gait has spectral radius
    1.013) writes the nearest stable gait: pdw-fixed-point on that file converges there,
    stable with rho <= the default 0.9, valid, and the body is the subject's."""
    import json

    from pdw_casadi.cli import fixed_point_main

    out = tmp_path / "w.toml"
    assert scale_main(["--mass", "62.45", "--height", "1.695", "--out", str(out)]) == 0
    pb = load_problem(out)
    assert abs(reference_mass(pb) - 62.45) < 1e-9
    want = subject_anthropometry(62.45, 1.695, "female")
    assert all(abs(pb.anthropometry[k] - want[k]) < 1e-12 for k in want)
    assert fixed_point_main(["--problem", str(out), "--out", str(tmp_path / "fp")]) == 0
    s = json.loads((tmp_path / "fp" / "summary.json").read_text())
    assert s["converged"] and s["stable"] and s["valid"]
    assert s["spectral_radius"] <= BODY_MAX_RADIUS


def test_a_female_subject_gets_the_shipped_body_by_the_scaling_law():
    """Every female de Leva body is one walker in dimensionless form: the shipped stable
    body scaled to 62.45 kg, 1.695 m is de Leva's body for that subject (to rounding), and
    its scaled gait is a fixed point there with the shipped gait's spectral radius."""
    from pdw_casadi.gait.fixed_point import find_fixed_point
    from pdw_casadi.studies.scaling import (
        shipped_body,
        stable_subject_walker,
        subject_anthropometry,
    )

    ref = load_problem("humanlike_6link")
    res = stable_subject_walker(62.45, 1.695, "female", ref)
    assert res.status == "accepted" and res.continued is None
    want = subject_anthropometry(62.45, 1.695, "female", ref)
    got = res.problem.anthropometry
    assert max(abs(got[k] - v) / abs(v) for k, v in want.items() if v) < 1e-12
    fp = find_fixed_point(res.problem, fallback=False)
    assert fp.converged and fp.iterations == 0 and fp.stable and fp.valid
    rho0 = find_fixed_point(shipped_body("female"), fallback=False).spectral_radius
    assert fp.spectral_radius == pytest.approx(rho0, abs=1e-9)
    assert fp.spectral_radius <= BODY_MAX_RADIUS
