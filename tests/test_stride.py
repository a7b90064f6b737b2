"""The stride map (two steps, one per physical leg) and per-leg parameters."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import (
    find_stride_fixed_point,
    physical_parameter_names,
    physical_parameter_vector,
    stride_map,
    stride_report,
    with_physical_parameters,
)
from pdw_casadi.model.problem import ProblemError, load_problem, problem_from_dict


@pytest.fixture(scope="module")
def symmetric():
    pb = load_problem("humanlike_6link")
    step = find_fixed_point(pb, tol=1e-11)
    assert step.converged
    return pb, step


def test_equal_legs_stride_fixed_point_is_two_steps(symmetric):
    pb, step = symmetric
    smap = stride_map(pb)
    assert smap.per_leg  # the per-leg build, with equal values on both legs
    stride = find_stride_fixed_point(pb, x0=step.state, tol=1e-11, smap=smap)
    assert stride.converged
    P = PoincareMap(pb)
    two = P(P(step.state))
    assert np.abs(stride.state - step.state).max() < 1e-10
    assert np.abs(stride.state - two).max() < 1e-10
    # eigenvalues of dS/dx are the squares of the step map's
    want = list(step.eigenvalues ** 2)
    for lam in stride.eigenvalues:
        k = int(np.argmin([abs(lam - w) for w in want]))
        assert abs(lam - want.pop(k)) < 1e-8
    assert abs(stride.step_time_s - 2 * step.step_time_s) < 1e-10
    rep = stride_report(smap, stride.state, curves=False)
    assert abs(rep["step_length_asymmetry_pct"]) < 1e-8
    assert abs(rep["step_time_asymmetry_pct"]) < 1e-8
    assert abs(rep["legs"]["left"]["step_length_m"] - step.step_length_m) < 1e-10


def test_per_leg_build_is_the_baked_walker(symmetric):
    """The runtime-parameter walker computes the same step as the one with numbers baked in."""
    pb, step = symmetric
    smap = stride_map(pb)
    p1, _ = smap.step_parameters(smap.default_parameters())
    a = smap.evaluate_step(step.state, p1)
    b = PoincareMap(pb).evaluate(step.state)
    # the same equations; only the order of the floating-point operations differs (symbols
    # instead of folded constants), so the two agree to rounding carried through ~1400 RK4
    # steps and three located events (about 1e-11 here), not bit for bit
    assert np.abs(a.x_next - b.x_next).max() < 1e-10
    assert np.abs(a.dx - b.dx).max() < 1e-8
    assert abs(a.step_time - b.step_time) < 1e-11


def _asymmetric(pb, **right):
    return pb.replace(legs={"right": {"compliance": right}})


def test_stride_jacobian_against_finite_differences(symmetric):
    pb, step = symmetric
    pb = _asymmetric(pb, k_ankle=5.15)
    smap = stride_map(pb)
    theta = smap.default_parameters()
    r = smap.evaluate(step.state, theta)
    names = list(smap.parameter_names)
    for name, d in (("right.k_ankle", 1e-4), ("left.c_knee_ext", 1e-5), ("right.m_s", 1e-5),
                    ("m_h", 1e-4)):
        i = names.index(name)
        e = np.zeros_like(theta)
        e[i] = d
        fd = (smap(step.state, theta + e) - smap(step.state, theta - e)) / (2 * d)
        assert np.abs(fd - r.dp[:, i]).max() < 1e-5 * max(1.0, np.abs(fd).max()), name
    i = 2
    e = np.zeros(7)
    e[i] = 1e-6
    fd = (smap(step.state + e, theta) - smap(step.state - e, theta)) / 2e-6
    assert np.abs(fd - r.dx[:, i]).max() < 1e-5 * max(1.0, np.abs(fd).max())


def test_parameters_follow_the_physical_leg(symmetric):
    """Mirroring the legs (left <-> right) shifts the periodic gait by one step: the mirror
    walker's stride fixed point is the original's state after its left-stance step."""
    pb, step = symmetric
    pb = _asymmetric(pb, k_ankle=5.15, c_ankle=0.83)
    fp = find_stride_fixed_point(pb, x0=step.state, tol=1e-11)
    assert fp.converged and fp.valid
    c_left, _ = pb.leg_values("left")
    c_right, _ = pb.leg_values("right")
    mirror = pb.replace(compliance=c_right, legs={"right": {"compliance": c_left}})
    smap = stride_map(pb)
    mid = smap.evaluate(fp.state, jacobian=False).steps[0].x_next
    fpm = find_stride_fixed_point(mirror, x0=mid, tol=1e-11)
    assert fpm.converged
    assert np.abs(fpm.state - mid).max() < 1e-9
    # an asymmetric gait: the step lengths differ, and swap with the legs
    rep = stride_report(smap, fp.state, curves=False)
    repm = stride_report(stride_map(mirror), fpm.state, curves=False)
    assert abs(rep["step_length_asymmetry_pct"]) > 1e-3
    assert abs(rep["step_length_asymmetry_pct"] + repm["step_length_asymmetry_pct"]) < 1e-6
    assert abs(rep["legs"]["left"]["step_time_s"] - repm["legs"]["right"]["step_time_s"]) < 1e-9


def test_section_step_length_matches_the_simulator(symmetric):
    pb, step = symmetric
    pb = _asymmetric(pb, c_knee_ext=1.21)
    smap = stride_map(pb)
    theta = smap.default_parameters()
    r = smap.evaluate(step.state, theta, jacobian=False)
    p1, p2 = smap.step_parameters(theta)
    r1, r2 = r.steps
    ell1, gx, gp = smap.step_length(r1.x_next, p2)
    # the section rebuilds the trailing toe exactly on the ground; the simulated one sits
    # there up to the integrator's drift of the contact constraints and the event location
    # (~1e-11 m), so the two lengths agree to that, not bit for bit
    assert abs(ell1 - r1.sim.steps[0].step_length) < 1e-9
    ell2, _, _ = smap.step_length(r2.x_next, p1)
    assert abs(ell2 - r2.sim.steps[0].step_length) < 1e-9
    e = np.zeros(7)
    e[0] = 1e-6
    fd = (smap.step_length(r1.x_next + e, p2)[0] - smap.step_length(r1.x_next - e, p2)[0]) / 2e-6
    assert abs(fd - gx[0]) < 1e-6


def test_per_leg_problem_file(tmp_path):
    text = load_problem("humanlike_6link").source.read_text()
    text += "\n[compliance.right]\nk_ankle = 7.5\n\n[anthropometry.right]\nm_s = 1.9\n"
    path = tmp_path / "pros.toml"
    path.write_text(text)
    pb = load_problem(path)
    assert pb.asymmetric
    c, a = pb.leg_values("right")
    assert c["k_ankle"] == 7.5 and a["m_s"] == 1.9 and a["m_t"] == pb.anthropometry["m_t"]
    assert pb.leg_values("left")[0]["k_ankle"] == pb.compliance["k_ankle"]
    back = pickle.loads(pickle.dumps(pb))
    assert back.leg_values("right") == pb.leg_values("right")
    theta = physical_parameter_vector(pb)
    names = physical_parameter_names(pb)
    assert theta[names.index("right.k_ankle")] == 7.5
    again = with_physical_parameters(pb, theta)
    assert np.array_equal(physical_parameter_vector(again), theta)
    assert not load_problem("humanlike_6link").asymmetric
    for bad, msg in (("[compliance.right]\nk_ankel = 1.0\n", "unknown per-leg"),
                     ("[anthropometry.left]\nm_h = 30.0\n", "unknown per-leg"),
                     ("[compliance.right]\nk_ankle = -1.0\n", ">= 0"),
                     ("[anthropometry.right]\nl_sc = 0.5\n", "shorter")):
        path.write_text(load_problem("humanlike_6link").source.read_text() + "\n" + bad)
        with pytest.raises(ProblemError, match=msg):
            load_problem(path)


def test_point_foot_walker_has_no_per_leg_values():
    raw = load_problem("compass_gait").to_dict()
    raw = {"walker": {"family": "compass_gait"}, "environment": {"g": raw["g"],
           "slope": raw["slope"]}, "anthropometry": {**raw["anthropometry"],
           "right": {"m": 4.0}}, "initial_state": raw["initial_state"]}
    with pytest.raises(ProblemError, match="no per-leg"):
        problem_from_dict(raw)


def test_stride_map_of_a_point_foot_walker():
    """Walkers without a per-leg build: the stride map is the step map applied twice."""
    pb = load_problem("compass_gait")
    step = find_fixed_point(pb, tol=1e-12)
    fp = find_stride_fixed_point(pb, x0=step.state, tol=1e-12)
    assert fp.converged and np.abs(fp.state - step.state).max() < 1e-10
    assert abs(fp.spectral_radius - step.spectral_radius ** 2) < 1e-8


def test_fixed_point_cli_on_an_asymmetric_problem(tmp_path, capsys):
    import json

    from pdw_casadi.cli import fixed_point_main

    text = load_problem("humanlike_6link").source.read_text()
    path = tmp_path / "asym.toml"
    path.write_text(text + "\n[compliance.right]\nk_ankle = 5.15\nc_ankle = 0.83\n")
    out = tmp_path / "fp"
    assert fixed_point_main(["--problem", str(path), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["map"].startswith("stride")
    legs = summary["stride"]["legs"]
    total = legs["left"]["step_time_s"] + legs["right"]["step_time_s"]
    assert abs(total - summary["step_time_s"]) < 1e-9  # the stride's time: both steps
    asym = summary["stride"]["step_length_asymmetry_pct"]
    want = 100 * (legs["left"]["step_length_m"] - legs["right"]["step_length_m"]) / (
        0.5 * (legs["left"]["step_length_m"] + legs["right"]["step_length_m"]))
    assert abs(asym - want) < 1e-12 and abs(asym) > 1e-3
    curves = (out / "leg_curves.csv").read_text().splitlines()
    assert len(curves) == 1 + 2 * 101 and (out / "leg_curves.png").stat().st_size > 0


def test_one_leg_commands_refuse_an_asymmetric_problem(tmp_path, capsys):
    """The fit and a sweep with gait curves describe one leg: they refuse a walker whose
    legs differ before writing anything (the plain sweep runs on the stride map)."""
    from pdw_casadi.cli import fit_main, sweep_main

    path = tmp_path / "asym.toml"
    path.write_text(load_problem("humanlike_6link").source.read_text()
                    + "\n[compliance.right]\nk_ankle = 5.15\n")
    out = tmp_path / "sw"
    with pytest.raises(SystemExit) as exc:
        sweep_main(["--problem", str(path), "--param", "slope", "--from", "0.148",
                    "--to", "0.149", "--num", "2", "--gait", "female_fast.csv",
                    "--out", str(out)])
    assert exc.value.code == 2 and "legs differ" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        fit_main(["--gait", "female_fast.csv", "--problem", str(path), "--out", str(out)])
    assert exc.value.code == 2 and "legs differ" in capsys.readouterr().err
    assert not out.exists()


def test_stride_validity_reads_both_steps_margins(symmetric):
    """The stride's margins (keys prefixed with the stance leg) are checked against the
    walker's requirements like a step's: with equal legs every slack of each step equals
    the step fixed point's, and a requirement above the gait's smallest normal force makes
    both the step and the stride gait invalid."""
    from pdw_casadi.gait.fixed_point import validity_slacks

    pb, step = symmetric
    smap = stride_map(pb)
    stride = find_stride_fixed_point(pb, x0=step.state, tol=1e-11, smap=smap)
    step_slacks = validity_slacks(step.margins, pb)
    stride_slacks = validity_slacks(stride.margins, pb, smap.hs)
    assert len(stride_slacks) == 2 * len(step_slacks) > 0
    for side in ("left", "right"):
        for key, slack in step_slacks.items():
            assert abs(stride_slacks[f"{side}.{key}"] - slack) < 1e-6
    assert step.valid and stride.valid
    weakest = min(v for k, v in step.margins.items() if ":min_N_" in k)
    strict = pb.replace(validity={**pb.validity, "min_normal_force": weakest + 1.0})
    smap_s = stride_map(strict)
    assert not find_fixed_point(strict, x0=step.state, tol=1e-11).valid
    bad = find_stride_fixed_point(strict, x0=step.state, tol=1e-11, smap=smap_s)
    assert bad.converged and not bad.valid and "min_N_" in bad.failure


def test_sweep_cli_on_an_asymmetric_problem(tmp_path):
    """pdw-sweep over one leg's value: the table's columns carry that value's unit and both
    legs' margins; every row is a converged stride gait."""
    import pandas as pd

    from pdw_casadi.cli import sweep_main

    pb = load_problem("humanlike_6link")
    step = find_fixed_point(pb, tol=1e-11)
    path = tmp_path / "asym.toml"
    state = "\n".join(f"{n} = {float(v)!r}" for n, v in zip(pb.initial_state, step.state,
                                                      strict=True))
    text = pb.source.read_text()
    head = text[:text.index("[initial_state]")]
    tail = text[text.index("[numerics]"):]
    path.write_text(f"{head}[initial_state]\n{state}\n\n{tail}\n[compliance.right]\n"
                    f"k_ankle = 5.1545\n")
    out = tmp_path / "sw"
    assert sweep_main(["--problem", str(path), "--param", "right.k_ankle", "--from", "5.1545",
                       "--to", "5.1045", "--num", "2", "--out", str(out)]) == 0
    tab = pd.read_csv(out / "sweep.csv")
    assert "right.k_ankle_N_m_per_rad" in tab.columns
    assert tab["converged"].all() and len(tab) == 2
    legs = {c.split(".")[0] for c in tab.columns if c.startswith("margin:") and "." in c}
    assert legs == {"margin:left", "margin:right"}


def test_stride_timing_per_leg(symmetric):
    """Each leg's gait-cycle timing at a stride gait: its cycle lasts the stride, its speed
    is the stride length over the stride time, its stance share equals the stride report's
    (phase sums), and with equal legs both legs' timing is the step fixed point's."""
    from pdw_casadi.gait.stride import stride_timing
    from pdw_casadi.gait.timing import fixed_point_timing

    pb, step = symmetric
    smap = stride_map(pb)
    same = stride_timing(smap, step.state)
    one = fixed_point_timing(pb, step.state, step.parameters)
    for t in same.values():
        assert abs(t.stance_pct - one.stance_pct) < 1e-9
        assert np.allclose(t.double_support_pct, one.double_support_pct, atol=1e-9)
        assert abs(t.speed_m_s - one.speed_m_s) < 1e-9
    asym = _asymmetric(pb, c_knee_ext=1.21)
    smap = stride_map(asym)
    fp = find_stride_fixed_point(asym, x0=step.state, smap=smap)
    assert fp.converged
    rep = stride_report(smap, fp.state, curves=False)
    timing = stride_timing(smap, fp.state)
    for side, t in timing.items():
        assert abs(t.cycle_time_s - rep["stride_time_s"]) < 1e-12
        assert abs(t.stride_length_m - rep["stride_length_m"]) < 1e-12
        assert abs(t.speed_m_s - rep["speed_m_s"]) < 1e-12
        assert abs(t.stance_pct - rep["legs"][side]["stance_pct"]) < 1e-9
    assert abs(timing["left"].step_length_m - timing["right"].step_length_m) > 1e-6


@pytest.mark.slow  # two further walkers (the ankle walker and its per-leg build) to compile
def test_per_leg_ankle_walker_follows_each_leg():
    """The ankle walker's per-leg build (its extension's elements per leg too): with equal
    legs one step is the baked walker's; the loading damper acts on the leading leg (leg 2)
    from heel strike to foot flat, so with only the right leg's damper changed the stride's
    left-stance step is the baked walker's step at the right leg's value and its
    right-stance step the one at the left leg's (the values follow the physical leg)."""
    pb = load_problem("humanlike_6link_ankle_ds")  # all four extension elements on
    x = pb.state_vector()
    smap = stride_map(pb)
    assert smap.per_leg
    p1, _ = smap.step_parameters(smap.default_parameters())
    a = smap.evaluate_step(x, p1)
    b = PoincareMap(pb).evaluate(x)
    # rounding carried through the steps and events, as for the paper's walker above
    assert np.abs(a.x_next - b.x_next).max() < 1e-10
    assert np.abs(a.dx - b.dx).max() < 1e-8
    right = {"c_ankle_load": 1.4}
    r = stride_map(_asymmetric(pb, **right)).evaluate(x, jacobian=False)
    one = PoincareMap(pb.replace(compliance=right)).evaluate(x, jacobian=False)
    assert np.abs(r.steps[0].x_next - one.x_next).max() < 1e-10
    two = PoincareMap(pb).evaluate(one.x_next, jacobian=False)
    assert np.abs(r.steps[1].x_next - two.x_next).max() < 1e-10
    same = PoincareMap(pb).evaluate(x, jacobian=False)
    assert np.abs(r.steps[0].x_next - same.x_next).max() > 1e-4  # the value matters


_EXTENSION_OFF = {"c_ankle_load": 0.0, "ankle_rest": 0.0, "k_clutch": 0.0, "phi_clutch": 1.5708}


def test_in_family_carries_a_gait_into_the_extended_walker():
    """The paper's walker as an ankle walker with the extension off (no loading damper,
    rest angle 0, clutch spring 0) has the same fixed point and spectral radius; a per-leg
    problem keeps its legs' values (their stride: the slow test below)."""
    pb = load_problem("humanlike_6link")
    ext = pb.in_family("humanlike_6link_ankle", _EXTENSION_OFF)
    assert ext.family == "humanlike_6link_ankle" and not ext.asymmetric
    assert ext.compliance_bounds["ankle_rest"] == (-0.6, 0.6)  # the family file's bounds
    fa = find_fixed_point(pb, tol=1e-11)
    fb = find_fixed_point(ext, x0=fa.state, tol=1e-11)
    assert fa.converged and fb.converged
    assert np.abs(fa.state - fb.state).max() < 1e-9
    assert abs(fa.spectral_radius - fb.spectral_radius) < 1e-7
    asym = _asymmetric(pb, k_ankle=5.15).in_family("humanlike_6link_ankle", _EXTENSION_OFF)
    assert asym.leg_values("right")[0]["k_ankle"] == 5.15
    assert asym.leg_values("left")[0]["k_ankle"] == pb.compliance["k_ankle"]
    with pytest.raises(ProblemError, match="exactly its extra compliance keys"):
        pb.in_family("humanlike_6link_ankle", {"ankle_rest": 0.0})
    with pytest.raises(ProblemError, match="does not extend"):
        load_problem("humanlike_6link_ankle").in_family("humanlike_6link", {})


@pytest.mark.slow
def test_in_family_carries_a_per_leg_gait_into_the_extended_walker():
    """The same with legs that differ: the stride fixed points and radii agree."""
    pb = load_problem("humanlike_6link")
    asym = _asymmetric(pb, k_ankle=5.15)
    ext = asym.in_family("humanlike_6link_ankle", _EXTENSION_OFF)
    assert ext.family == "humanlike_6link_ankle" and ext.leg_values("right")[0]["k_ankle"] == 5.15
    fa = find_stride_fixed_point(asym, tol=1e-11)
    fb = find_stride_fixed_point(ext, x0=fa.state, tol=1e-11)
    assert fa.converged and fb.converged
    assert np.abs(fa.state - fb.state).max() < 1e-9
    assert abs(fa.spectral_radius - fb.spectral_radius) < 1e-7
