"""The OpenSim export, checked by OpenSim itself.

For a fixed point of the 6-link walker, of a per-leg design (data/designs/), of the
kneed walker and of the rolling-feet walker, two steps (one stride: each leg once in each
role) are exported and read back by OpenSim in a child process (OpenSim and CasADi cannot share one:
pdw_casadi/report/opensim_check.py). OpenSim's marker positions must equal the toolkit's
points to 1e-9 m at every frame of the motion, its reading of the force table the written
forces, and its inverse dynamics with the exported external loads, at the toolkit's exact
speeds and accelerations, the toolkit's joint torques (springs, dampers, knee locks).

Tolerance of the inverse dynamics, 1e-9 N m (N for the pelvis translations): both sides
compute the same equations of motion in double precision, from coordinates and forces that
round-trip exactly through the text files (17 significant digits; the degrees of the motion
cost one rounding in the conversion), so their difference is rounding. Its size: terms up
to the ground reaction after heel strike times its lever (~1500 N x 1 m) over ~10^2
operations give ~1500 * 2.2e-16 * 100 = 3e-11 N m, and OpenSim evaluates the force table
through a spline (GCVSpline through the samples), exact at the samples up to the rounding
of its coefficients, which are large next to a jump of the force (heel strike: 250 N to
1500 N between two samples). Measured: at most 1.5e-12 N m for the cases here, 6.4e-11 N m
for notebook 02's fitted gait and 7.7e-11 N m for its compliance rounded to 7 digits (at
the samples beside heel strike). The bound keeps a
factor of 13 over that and lies eight orders of magnitude below the torques checked (knee
springs to ~40 N m, kneed-walker knee locks to ~0.1 N m): a 0.1 % error in the forces gives
1 N m.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from pdw_casadi.model.problem import load_problem
from pdw_casadi.report.opensim import (
    SIDES,
    export_gait,
    force_columns,
    read_back,
    read_storage,
)

ROOT = Path(__file__).resolve().parents[1]
#: the read-back tests need OpenSim (the export itself does not)
needs_opensim = pytest.mark.skipif(importlib.util.find_spec("opensim") is None,
                                   reason="the opensim package is not installed "
                                          "(pip install -e '.[opensim]')")

POSITION_TOL = 1e-9  # m, the bound
ID_TOL = 1e-9  # N m (N), see the module docstring
CASES = {
    "humanlike_6link": "humanlike_6link",
    # a walker whose legs differ (the results page's 28.9 % design: its gait's validity
    # does not matter to the export)
    "prosthesis29": str(ROOT / "docs" / "results" / "designs" /
                        "humanlike_6link_prosthesis29.toml"),
    "kneed_walker": "kneed_walker",
    # rolling feet (toe arcs of 5 cm): the force acts at the arc's moving contact point
    "humanlike_6link_arc": "humanlike_6link_arc",
}
#: every toolkit point a marker must follow
MARKERS = {
    "humanlike_6link": ["hip"] + [f"{p}_{s}" for s in SIDES
                                  for p in ("knee", "ankle", "heel", "toe")],
    "kneed_walker": ["hip"] + [f"{p}_{s}" for s in SIDES for p in ("knee", "foot")],
}


def _gait(problem) -> tuple[np.ndarray, np.ndarray]:
    """(section state, parameters) of ``problem``'s periodic gait. A walker whose legs
    differ (a shipped design) carries its stride's fixed point in its file: one stride of
    the simulator from it must return to it (the Newton solve of the stride map and its
    sensitivities are tested in tests/test_stride.py)."""
    if problem.asymmetric:
        from pdw_casadi.gait.poincare import PoincareMap

        stride = PoincareMap(problem, steps=2)
        theta = stride.default_parameters()
        x = problem.state_vector()
        back = stride.evaluate(x, theta, jacobian=False)
        assert np.abs(back.x_next - x).max() < 1e-9
        return x, theta
    from pdw_casadi.gait.fixed_point import find_fixed_point

    res = find_fixed_point(problem, tol=1e-10)
    assert res.converged and res.residual < 1e-9
    return res.state, res.parameters


#: in the slow set: the rolling-foot walker's own compilation (its commands are slow too in
#: tests/test_walkers_matrix.py); the default run keeps the three walkers of the export issue
SLOW_CASES = {"humanlike_6link_arc"}


@pytest.fixture(scope="module", params=[
    pytest.param(c, marks=[needs_opensim, *([pytest.mark.slow] if c in SLOW_CASES else [])])
    for c in CASES])
def exported(request, tmp_path_factory):
    """(problem, gait state, export, OpenSim's read-back with inverse dynamics at every
    sample) of one case."""
    problem = load_problem(CASES[request.param])
    state, parameters = _gait(problem)
    out = tmp_path_factory.mktemp(f"osim_{request.param}")
    ex = export_gait(problem, state, out, parameters=parameters, steps=2)
    return problem, state, ex, read_back(ex, tool=True)


def test_files_and_headers(exported):
    problem, _, ex, _ = exported
    for path in (ex.model, ex.motion, ex.forces, ex.external_loads, ex.torques, ex.id_setup):
        assert path.is_file() and path.stat().st_size > 0
    header, cols, data = read_storage(ex.motion)
    assert header["inDegrees"] == "yes"
    assert int(header["nRows"]) == len(data) == len(ex.samples.time)
    assert int(header["nColumns"]) == len(cols) == data.shape[1]
    assert cols[0] == "time" and np.all(np.diff(data[:, 0]) > 0)
    # two steps: the motion covers both and walks down the slope (the pelvis advances by
    # two step lengths along the ground's downhill direction)
    header, cols, f = read_storage(ex.forces)
    assert header["inDegrees"] == "no" and cols[1:] == force_columns("l") + force_columns("r")
    u = ex.samples.u
    assert u[-1, 1] - u[0, 1] > 0.3 and u[-1, 2] < u[0, 2]
    xml = ex.external_loads.read_text()
    assert xml.count("<ExternalForce ") == 2 and ex.forces.name in xml


def test_marker_positions_equal_the_toolkits(exported):
    problem, _, ex, rb = exported
    names = [str(n) for n in rb["marker_names"]]
    expected = MARKERS["kneed_walker" if problem.family == "kneed_walker"
                       else "humanlike_6link"]
    assert sorted(names) == sorted(expected)
    assert len(rb["motion_time"]) == len(ex.samples.time)
    pos = rb["marker_positions"]
    for k, n in enumerate(names):
        err = np.abs(pos[:, k, :2] - ex.samples.points[n]).max()
        assert err <= POSITION_TOL, f"{n}: |OpenSim - toolkit| = {err:.3g} m"
    assert np.abs(pos[:, :, 2]).max() == 0.0  # planar


def test_body_masses(exported):
    problem, _, _, rb = exported
    masses = dict(zip(map(str, rb["body_names"]), rb["masses"], strict=True))
    assert masses["pelvis"] == problem.anthropometry["m_h"]
    total = problem.anthropometry["m_h"]
    for side, s in (("left", "l"), ("right", "r")):
        a = problem.leg_values(side)[1]
        if problem.family == "kneed_walker":
            assert masses[f"thigh_{s}"] == a["m_t"] and masses[f"shank_{s}"] == a["m_s"]
            total += a["m_t"] + a["m_s"]
        else:
            assert (masses[f"thigh_{s}"], masses[f"shank_{s}"], masses[f"foot_{s}"]) == \
                (a["m_t"], a["m_s"], a["m_f"])
            total += a["m_t"] + a["m_s"] + a["m_f"]
    assert rb["total_mass"] == pytest.approx(total, rel=1e-15)


def test_forces_read_back(exported):
    _, _, ex, rb = exported
    cols = [str(c) for c in rb["force_columns"]]
    assert cols == force_columns("l") + force_columns("r")
    np.testing.assert_array_equal(rb["force_time"], ex.samples.time)
    smp = ex.samples
    for s in SIDES:
        got = {c: rb["force_data"][:, cols.index(c)] for c in force_columns(s)}
        np.testing.assert_array_equal(got[f"ground_force_{s}_vx"], smp.force[s][:, 0])
        np.testing.assert_array_equal(got[f"ground_force_{s}_vy"], smp.force[s][:, 1])
        np.testing.assert_array_equal(got[f"ground_force_{s}_px"], smp.cop[s][:, 0])
        np.testing.assert_array_equal(got[f"ground_force_{s}_py"], smp.cop[s][:, 1])
        np.testing.assert_array_equal(got[f"ground_torque_{s}_z"], smp.free_moment[s])
        # the contact carries the walker, and the centre of pressure lies on the ground
        # line: within 1e-9 m, because a pivot's force acts at the toolkit's point, which
        # the integration of the constrained dynamics lets drift off the ground by ~2e-11 m
        # over a phase (the heel in phase III of this gait)
        assert np.max(smp.force[s][:, 1]) > 10.0
        gamma = float(rb["slope"])
        on = np.abs(smp.force[s]).sum(axis=1) > 0
        height = smp.cop[s][on] @ np.array([math.sin(gamma), math.cos(gamma)])
        assert np.abs(height).max() < 1e-9


def test_slope_frame(exported):
    """OpenSim's orientation of the ground's slope frame is the problem's slope."""
    problem, _, _, rb = exported
    assert abs(float(rb["slope"]) - problem.slope) < 1e-15


def test_picture_of_the_model(exported, tmp_path):
    """The body frames as OpenSim places them: each frame's origin is its proximal joint
    (hip, knee, ankle markers), and the picture is written."""
    from pdw_casadi.report.opensim import plot_opensim_frames

    problem, _, _, rb = exported
    bodies = [str(b) for b in rb["body_names"]]
    names = [str(m) for m in rb["marker_names"]]
    frames, markers = rb["body_frames"], rb["marker_positions"]
    for s in SIDES:
        child = "shank" if problem.family == "kneed_walker" else "foot"
        joint = "knee" if child == "shank" else "ankle"
        err = np.abs(frames[:, bodies.index(f"{child}_{s}"), 0]
                     - markers[:, names.index(f"{joint}_{s}")]).max()
        assert err <= POSITION_TOL
        assert np.abs(frames[:, bodies.index(f"thigh_{s}"), 0]
                      - markers[:, names.index("hip")]).max() <= POSITION_TOL
    path = tmp_path / "model.png"
    plot_opensim_frames(rb, path)
    assert path.stat().st_size > 10_000


def test_inverse_dynamics_reproduces_the_joint_torques(exported):
    problem, _, ex, rb = exported
    names = [str(n) for n in rb["coordinate_names"]]
    smp = ex.samples
    assert sorted(names) == sorted(smp.coordinates)
    worst = {}
    for j, c in enumerate(smp.coordinates):
        worst[c] = np.abs(rb["id_forces"][:, names.index(c)] - smp.tau[:, j]).max()
    assert max(worst.values()) <= ID_TOL, worst
    # what is checked is not nothing: the knees carry torques (springs and dampers; the
    # kneed walker's locks), the pelvis and hips none (no hip spring, no residual)
    knee = max(np.abs(smp.tau[:, smp.coordinates.index(f"knee_angle_{s}")]).max()
               for s in SIDES)
    assert knee > (0.05 if problem.family == "kneed_walker" else 10.0)
    for c in ("pelvis_tilt", "pelvis_tx", "pelvis_ty", "hip_flexion_l", "hip_flexion_r"):
        assert np.abs(smp.tau[:, smp.coordinates.index(c)]).max() < 1e-9
    if problem.family != "kneed_walker":
        ankle = np.abs(smp.tau[:, smp.coordinates.index("ankle_angle_l")]).max()
        assert ankle > 1.0


def test_inverse_dynamics_tool_from_the_setup_file(exported):
    """OpenSim's inverse-dynamics tool, run from the exported setup file as a user would,
    differentiates splines of the coordinates. Across an impact, a knee spring's
    disengagement or the ends of the motion its accelerations are wrong (velocities and
    accelerations jump there); elsewhere the spline through samples 0.5 ms apart gives
    the accelerations to the tool's output precision, so the median sample agrees with
    the toolkit's torques to better than 1e-6 N m (N)."""
    _, _, ex, rb = exported
    smp = ex.samples
    cols = [str(c) for c in rb["tool_columns"]]
    np.testing.assert_allclose(rb["tool_time"], smp.time, rtol=0, atol=1e-8)
    header, ref_cols, ref = read_storage(ex.torques)
    assert sorted(cols) == sorted(ref_cols[1:])
    for j, c in enumerate(ref_cols[1:]):
        err = np.abs(rb["tool_data"][:, cols.index(c)] - ref[:, j + 1])
        assert np.median(err) < 1e-6, (c, np.median(err))


# -- the commands (no OpenSim needed: they write the files) -------------------------------
def _exported_files(out: Path, name: str) -> list[Path]:
    return [out / f"{name}{suffix}" for suffix in
            (".osim", ".mot", "_grf.sto", "_external_loads.xml", "_joint_torques.sto",
             "_id_setup.xml")]


def _run_command(main, argv) -> int:
    """A command's exit code, whether it returns it or exits with it."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def test_fixed_point_command_exports(tmp_path, capsys):
    """``pdw-fixed-point --export opensim`` writes the files of two steps of its fixed
    point: the pelvis advances by two step lengths along the slope."""
    import json

    from pdw_casadi.cli import fixed_point_main

    out = tmp_path / "fp"
    assert _run_command(fixed_point_main, ["--problem", "humanlike_6link", "--export",
                                           "opensim", "--out", str(out)]) == 0
    files = _exported_files(out, "humanlike_6link")
    assert all(p.is_file() and p.stat().st_size > 0 for p in files)
    assert "wrote OpenSim files" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    header, cols, data = read_storage(files[1])
    assert header["inDegrees"] == "yes" and int(header["nRows"]) == len(data) > 100
    slope = load_problem("humanlike_6link").slope
    walked = (data[-1, cols.index("pelvis_tx")] - data[0, cols.index("pelvis_tx")]) \
        / math.cos(slope)
    assert walked == pytest.approx(2 * summary["step_length_m"], rel=1e-9)


def test_simulate_command_exports_every_step(tmp_path, capsys):
    import pandas as pd

    from pdw_casadi.cli import simulate_main

    out = tmp_path / "sim"
    assert _run_command(simulate_main, ["--problem", "compass_gait", "--steps", "3",
                                        "--export", "opensim", "--out", str(out)]) == 0
    files = _exported_files(out, "compass_gait")
    assert all(p.is_file() for p in files)
    _, cols, data = read_storage(files[1])
    t = pd.read_csv(out / "trajectory.csv").iloc[:, 0].to_numpy()
    # one frame per distinct time of the trajectory (an impact's two samples are one)
    assert len(data) == len(np.unique(t)) and data[-1, 0] == t.max()
    assert cols == ["time", "pelvis_tilt", "pelvis_tx", "pelvis_ty", "hip_flexion_l",
                    "hip_flexion_r"]


def test_fit_command_exports_the_fitted_gait(tmp_path, capsys, monkeypatch):
    """``pdw-fit --export opensim`` exports the gait of the fit's summary (compliance,
    slope, fixed point); the fit itself is replaced by one whose answer is known: the
    problem's fixed point, which differs from its initial state (Table 2)."""
    import pdw_casadi.report.fit_report as fit_report
    import pdw_casadi.studies.fit_run as fit_run
    from pdw_casadi.cli import fit_main
    from pdw_casadi.gait.fixed_point import find_fixed_point

    changed = load_problem("humanlike_6link")
    fp = find_fixed_point(changed)
    assert fp.converged
    assert abs(fp.state[1] - fp.state[0] - (changed.initial_state["q2"]
                                            - changed.initial_state["q1"])) > 1e-6

    from types import SimpleNamespace

    from pdw_casadi.engine.clock import Stopwatch

    the_fit = SimpleNamespace(times=Stopwatch())  # what the command reads of a FitRun

    def fake_fit(problem_, human, opts, before_work=None, **kw):
        before_work()  # the command creates its output folder here
        return the_fit

    def fake_report(run, out):
        assert run is the_fit
        comp, slope = changed.split_parameters(fp.parameters)
        return {"compliance": comp, "slope": slope, "stable": True, "valid": True,
                "fixed_point": dict(zip(changed.state_names, map(float, fp.state),
                                        strict=True)),
                "headline": "fake fit"}

    monkeypatch.setattr(fit_run, "run_fit", fake_fit)
    monkeypatch.setattr(fit_report, "write_fit_report", fake_report)
    out = tmp_path / "fit"
    assert _run_command(fit_main, ["--gait", "female_fast.csv", "--export", "opensim",
                                   "--out", str(out)]) == 0
    files = _exported_files(out, "humanlike_6link")
    assert all(p.is_file() for p in files)
    # the fitted gait, not the problem's: the first frame is the fixed point's section
    _, cols, data = read_storage(files[1])
    knee = -data[0, cols.index("knee_angle_l")]  # flexion of leg 1 (left) at the section
    q1, q2 = fp.state[0], fp.state[1]
    assert knee == pytest.approx(math.degrees(q2 - q1), abs=1e-9)


def test_unknown_export_format_is_a_usage_error(tmp_path, capsys):
    from pdw_casadi.cli import fixed_point_main

    out = tmp_path / "fp"
    assert _run_command(fixed_point_main, ["--export", "bvh", "--out", str(out)]) == 2
    assert not out.exists()


def test_the_slope_is_the_parameters(tmp_path):
    """A gait on another slope than the problem file's (a fit may move it) is exported on
    its own slope: the slope frame and the ground line of the centres of pressure."""
    import re

    problem = load_problem("compass_gait")
    p = problem.parameter_vector()
    p[problem.parameter_names.index("slope")] += 0.002
    gamma = float(p[problem.parameter_names.index("slope")])
    ex = export_gait(problem, problem.state_vector(), tmp_path, parameters=p, steps=2)
    frame = re.search(r'<PhysicalOffsetFrame name="slope">.*?<orientation>([^<]+)'
                      r'</orientation>', ex.model.read_text(), re.S)
    assert float(frame.group(1).split()[2]) == -gamma
    for s in SIDES:
        on = np.abs(ex.samples.force[s]).sum(axis=1) > 0
        height = ex.samples.cop[s][on] @ np.array([math.sin(gamma), math.cos(gamma)])
        assert on.any() and np.abs(height).max() < 1e-9
