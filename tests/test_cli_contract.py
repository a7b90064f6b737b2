"""The CLI contract (pdw_casadi.cli.contract) and one test per defect of the walker/input
review: every bad input is one ``error:`` line and exit code 2 with nothing written or
deleted; "no gait" is exit code 1 with a reason; numerical blow-ups are not falls."""

from __future__ import annotations

import inspect
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run

import pdw_casadi
import pdw_casadi.cli as cli
import pdw_casadi.cli.common as cli_common
import pdw_casadi.cli.fit as cli_fit
from pdw_casadi.cli import (
    fit_main,
    fixed_point_main,
    load_fit_start,
    simulate_main,
    sweep_main,
)
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import ProblemError, load_overrides, load_problem, problem_from_dict

ROOT = Path(__file__).resolve().parents[1]
HL = (ROOT / "problems" / "humanlike_6link.toml").read_text()
CG = (ROOT / "problems" / "compass_gait.toml").read_text()




def assert_usage_error(code, err, *fragments):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    for f in fragments:
        assert f in lines[0], lines[0]


def earlier_run(path: Path) -> dict[str, str]:
    """An output directory holding the files of an earlier run; returns its contents."""
    path.mkdir(parents=True, exist_ok=True)
    (path / "sweep.csv").write_text("slope,converged\n0.05,True\n")
    (path / "summary.json").write_text('{"earlier": true}\n')
    return {p.name: p.read_text() for p in path.iterdir()}


def contents(path: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in path.iterdir()}


def problem_file(tmp_path, text, name="p.toml") -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


# -- walkers (defects 1-4) -------------------------------------------------------------------
def test_d1_fixed_point_of_compass_gait_plots_its_limit_cycle(tmp_path, capsys):
    out = tmp_path / "fp"
    code, _, err = run(capsys, fixed_point_main, ["--problem", "compass_gait", "--out", str(out)])
    assert code == 0, err
    assert (out / "limit_cycle.png").read_bytes()[:4] == b"\x89PNG"


def test_d2_one_phase_walker_steps_are_not_merged(tmp_path):
    from pdw_casadi.model.faces import walker_faces
    from pdw_casadi.report.plots import _instants, phase_spans, snapshot_rows

    pb = load_problem("compass_gait")
    sim = Simulator(pb)
    res = sim.run(pb.state_vector(), pb.parameter_vector(), steps=3)
    traj = res.trajectory
    spans = phase_spans(traj)
    assert [(s, ph) for s, ph, _, _ in spans] == [(0, "swing"), (1, "swing"), (2, "swing")]
    T = res.steps[0].step_time
    assert spans[0][3] == pytest.approx(T, abs=1e-9)  # the first "step" is one step long
    rows = snapshot_rows(traj, n=8)
    assert traj.loc[rows, "t"].max() <= T + 1e-9
    faces = walker_faces(pb, sim.hs)
    assert _instants(traj[traj["step"] == 0], faces) == {"heel_strike+": 0,
                                                         "heel_strike-": int(
                                                             (traj["step"] == 0).sum()) - 1}


def test_d2_six_link_instants_keep_the_paper_labels(table2_step, problem):
    from pdw_casadi.model.faces import walker_faces
    from pdw_casadi.report.plots import _instants

    marks = _instants(table2_step.trajectory, walker_faces(problem))
    assert list(marks) == ["a+", "b", "c-", "c+", "a-"]


def test_d2_no_phase_names_outside_the_six_link_walker():
    # the 6-link walker's phases are named by its own modules: its assembly and its parts
    # (model/sixlink, model/feet); nothing generic may rely on them
    pkg = Path(pdw_casadi.__file__).parent
    walker = [pkg / "model" / "sixlink", pkg / "model" / "feet"]
    for path in pkg.rglob("*.py"):
        if path.name == "humanlike_6link.py" or any(d in path.parents for d in walker):
            continue
        text = path.read_text()
        for name in ('"I"', '"II"', '"III"', "'III'"):
            assert name not in text, f"{path.relative_to(pkg)} names phase {name}"


def test_d3_sweep_gait_scores_for_the_kneed_walker(tmp_path, capsys):
    pb = load_problem("kneed_walker")
    out = tmp_path / "sw"
    code, _, err = run(capsys, sweep_main, ["--problem", "kneed_walker", "--from",
                                            str(pb.slope), "--to", str(pb.slope + 0.002),
                                            "--num", "2", "--gait", "female_fast.csv",
                                            "--out", str(out)])
    assert code == 0, err
    table = pd.read_csv(out / "sweep.csv")
    assert table["converged"].all() and np.isfinite(table["r2_knee"]).all()
    assert np.isfinite(table["r2_hip"]).all()


def test_d3_gait_cycle_of_point_feet_uses_the_model(capsys):
    from pdw_casadi.gait.curves import gait_cycle

    pb = load_problem("kneed_walker")
    sim = Simulator(pb)
    one = sim.run(pb.state_vector(), pb.parameter_vector(), steps=1)
    assert sim.hs.model.heel_strike_phase is None
    c = gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase)
    assert len(c) == 101 and np.isfinite(c["knee_deg"]).all()
    with pytest.raises(ValueError, match="no phase"):
        gait_cycle(one.trajectory, "no_such_phase")


@pytest.mark.parametrize("args, message", [
    (["--problem", "compass_gait"], "has no knee"),
    (["--problem", "kneed_walker"], "no compliance values to fit"),
])
def test_d3_fit_needs_a_walker_with_knee_hip_and_something_to_fit(tmp_path, capsys, args,
                                                                  message):
    out = tmp_path / "fit"
    code, _, err = run(capsys, fit_main, [*args, "--gait", "female_fast.csv", "--out",
                                          str(out)])
    assert_usage_error(code, err, message)
    assert not out.exists()


def test_d4_fit_runs_the_comparison_walker_only_for_its_family(monkeypatch):
    import pdw_casadi.studies.fit_run as fr

    calls = []

    class Stop(Exception):
        pass

    def fake_reference(problem, human):
        calls.append(problem.name)
        return {"curves": None, "spectral_radius": 0.5, "stable": True, "valid": True}

    def fake_fit(*a, **k):
        raise Stop

    monkeypatch.setattr(fr, "reference_gait", fake_reference)
    monkeypatch.setattr(fr, "fit_gait", fake_fit)
    from pdw_casadi.model.gait_data import load_gait_curves

    human = load_gait_curves("female_fast.csv")
    for name, expected in (("kneed_walker", ["kneed_walker"]),
                           ("humanlike_6link", ["humanlike_6link", "comparison_kneed_6link"])):
        calls.clear()
        with pytest.raises(Stop):
            fr.run_fit(load_problem(name), human, None)
        assert calls == expected


# -- inputs (defects 5-14) -------------------------------------------------------------------
def test_d5_hip_target_thigh_without_thigh_column_fails_first(tmp_path, capsys):
    frame = pd.read_csv(ROOT / "data" / "female_fast.csv")
    gait = tmp_path / "no_thigh.csv"
    frame[[c for c in frame if not c.startswith("thigh")]].to_csv(gait, index=False)
    out = tmp_path / "fit"
    t0 = time.perf_counter()
    code, _, err = run(capsys, fit_main, ["--gait", str(gait), "--hip-target", "thigh",
                                          "--out", str(out)])
    assert time.perf_counter() - t0 < 10  # before any reference solve
    assert_usage_error(code, err, "--hip-target thigh needs a thigh column")
    assert not out.exists()


def test_d6_compliance_bounds_not_a_table(tmp_path, capsys):
    path = problem_file(tmp_path, "compliance_bounds = 5\n" + CG)
    with pytest.raises(ProblemError, match="must be a table"):
        load_problem(path)
    code, _, err = run(capsys, simulate_main, ["--problem", path, "--out", str(tmp_path / "o")])
    assert_usage_error(code, err, "[compliance_bounds] must be a table")


@pytest.mark.parametrize("text, kind", [("0.05", "a number"), ('"summary"', "a string"),
                                        ("[1, 2]", "a list"), ("null", "null")])
def test_d7_from_fit_that_is_not_an_object(tmp_path, text, kind):
    path = tmp_path / "summary.json"
    path.write_text(text)
    with pytest.raises(ProblemError, match=f"must be a JSON object.*got {kind}"):
        load_fit_start(load_problem("compass_gait"), path)


def test_d8_scheduler_address_checked_before_anything(tmp_path, capsys):
    out = tmp_path / "sw"
    base = ["--problem", "compass_gait", "--from", "0.05", "--to", "0.06", "--num", "3",
            "--out", str(out)]
    t0 = time.perf_counter()
    code, _, err = run(capsys, sweep_main, [*base, "--scheduler", "not a url"])
    assert_usage_error(code, err, "not a scheduler address")
    assert time.perf_counter() - t0 < 5 and not out.exists()
    t0 = time.perf_counter()
    code, _, err = run(capsys, sweep_main, [*base, "--scheduler", "tcp://127.0.0.1:1"])
    assert_usage_error(code, err, "cannot connect")
    assert time.perf_counter() - t0 < 20 and not out.exists()


def test_d8_a_scheduler_that_answers_is_used(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "sw"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None, protocol="tcp") as cluster:
        code, _, err = run(capsys, sweep_main, [
            "--problem", "compass_gait", "--from", "0.05", "--to", "0.06", "--num", "3",
            "--mode", "grid", "--scheduler", cluster.scheduler_address, "--out", str(out)])
    assert code == 0, err
    assert int(pd.read_csv(out / "sweep.csv")["on_grid"].sum()) == 3


@pytest.mark.parametrize("extra, message", [
    (["--problem", "humanlike_6link", "--from", "0.1484", "--to", "0.1485", "--refit"],
     "--refit needs --gait"),
    (["--from", "nan", "--to", "0.06"], "--from must be a finite number"),
    (["--from=-inf", "--to", "0.06"], "--from must be a finite number"),
    (["--from", "0.05", "--to", "0.06", "--tol", "-1"], "--tol must lie in"),
])
def test_d9_failed_sweep_keeps_earlier_results(tmp_path, capsys, extra, message):
    out = tmp_path / "sw"
    before = earlier_run(out)
    args = extra if "--problem" in extra else ["--problem", "compass_gait", *extra]
    code, _, err = run(capsys, sweep_main, [*args, "--num", "2", "--out", str(out)])
    assert_usage_error(code, err, message)
    assert contents(out) == before
    fresh = tmp_path / "fresh"
    code, _, err = run(capsys, sweep_main, [*args, "--num", "2", "--out", str(fresh)])
    assert code == 2 and not fresh.exists()


def test_d9_completed_sweep_replaces_sweep_csv_and_leaves_no_partial(tmp_path, capsys):
    out = tmp_path / "sw"
    earlier_run(out)
    code, _, err = run(capsys, sweep_main, ["--problem", "compass_gait", "--from", "0.05",
                                            "--to", "0.055", "--num", "2", "--out", str(out)])
    assert code == 0, err
    table = pd.read_csv(out / "sweep.csv")  # this run's: the start and the two grid values
    assert "branch" in table and int(table["on_grid"].sum()) == 2 and len(table) == 3
    assert not (out / "sweep.partial.csv").exists()


def test_d10_unwritable_animation_fails_before_writing(tmp_path, capsys):
    out = tmp_path / "sim"
    code, _, err = run(capsys, simulate_main, ["--problem", "compass_gait", "--animate",
                                               "/proc/x/walk.gif", "--out", str(out)])
    assert_usage_error(code, err, "--animate /proc/x/walk.gif")
    assert not out.exists()


@pytest.mark.parametrize("tol", ["-1", "nan", "inf", "0"])
def test_d11_tolerance_is_validated(tmp_path, capsys, tol):
    out = tmp_path / "fp"
    code, _, err = run(capsys, fixed_point_main, ["--problem", "compass_gait", f"--tol={tol}",
                                                  "--out", str(out)])
    assert_usage_error(code, err, "--tol")
    assert not out.exists()


def test_d12_overrides_and_sweeps_obey_the_problem_bounds(tmp_path, capsys):
    comp = tmp_path / "k.json"
    comp.write_text('{"k_knee": 1e9}')
    code, _, err = run(capsys, simulate_main, ["--compliance", str(comp), "--out",
                                               str(tmp_path / "a")])
    assert_usage_error(code, err, "'k_knee' = 1e+09 lies outside its bounds [10, 1000]")
    code, _, err = run(capsys, sweep_main, ["--param", "c_ankle", "--from", "-0.5", "--to",
                                            "0.8", "--out", str(tmp_path / "b")])
    assert_usage_error(code, err, "'c_ankle' = -0.5 must be >= 0")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_d12_library_sweep_rejects_a_grid_outside_the_bounds():
    from pdw_casadi.gait.sweep import sweep

    with pytest.raises(ProblemError, match="outside its bounds"):
        sweep(load_problem("humanlike_6link"), [5.0, 120.0], parameter="k_knee")


def test_d12_blow_up_is_a_numerical_divergence_not_a_fall(tmp_path, capsys):
    """Without bounds in the problem file, a stiff damper blows the RK4 step up: the
    simulator says so instead of reporting a contact failure."""
    text = HL.replace("c_ankle = [0.05, 5.0]\n", "")
    pb = problem_from_dict(__import__("tomllib").loads(text), name="no_bounds")
    pb = pb.replace(compliance={"c_ankle": 1e6})
    res = Simulator(pb).run(pb.state_vector(), pb.parameter_vector(), steps=1)
    assert res.failure is not None and res.failure.reason == "numerical_divergence"
    assert "step size" in res.failure.detail
    comp = tmp_path / "c.json"
    comp.write_text('{"c_ankle": 1e6}')
    code, _, err = run(capsys, simulate_main, ["--problem", problem_file(tmp_path, text),
                                               "--compliance", str(comp), "--out",
                                               str(tmp_path / "o")])
    assert code == 1 and "no gait: numerical divergence" in err and "Traceback" not in err


@pytest.mark.parametrize("step, ok", [(0.5, False), (1e-9, False), (5e-4, True)])
def test_d12_d13_step_size_is_bounded(tmp_path, step, ok):
    path = problem_file(tmp_path, CG.replace("step_size = 5e-4", f"step_size = {step}"))
    if ok:
        assert load_problem(path).numerics["step_size"] == step
    else:
        with pytest.raises(ProblemError, match="'numerics.step_size' must lie in"):
            load_problem(path)


def test_d13_huge_step_count_rejected_and_samples_bounded(tmp_path, capsys):
    code, _, err = run(capsys, simulate_main, ["--problem", "compass_gait", "--steps",
                                               "1000000000", "--out", str(tmp_path / "o")])
    assert_usage_error(code, err, "--steps must be <= 1000")
    pb = load_problem("compass_gait")
    res = Simulator(pb).run(pb.state_vector(), pb.parameter_vector(), steps=10,
                            max_samples=2000)
    assert res.failure.reason == "sample_limit" and res.completed_steps == 2


def test_d14_fixed_point_that_fails_at_the_start_is_quiet(tmp_path, capfd):
    state = tmp_path / "s.json"
    state.write_text('{"dq1": -3.5}')  # the swing toe scuffs in the first step
    t0 = time.perf_counter()
    try:
        code = fixed_point_main(["--state", str(state), "--out", str(tmp_path / "fp")])
    except SystemExit as exc:
        code = exc.code
    err = capfd.readouterr().err
    assert code == 1 and time.perf_counter() - t0 < 20
    assert "Traceback" not in err and "WARNING" not in err
    assert [ln for ln in err.splitlines() if ln.startswith("no gait:")]


def test_d14_ipopt_fallback_output_is_discarded(capfd):
    """Failed map evaluations inside IPOPT print tracebacks and CasADi warnings on the
    file descriptor 2; the fallback discards them (the result says what happened)."""
    import os
    import sys

    from pdw_casadi.gait.fixed_point import _quiet_stderr

    with _quiet_stderr():
        print("Traceback (most recent call last): from Python", file=sys.stderr)
        os.write(2, b"CasADi - WARNING from C++\n")
    print("after", file=sys.stderr)
    assert capfd.readouterr().err == "after\n"


def test_d14_interrupted_simulation_says_what_is_on_disk(tmp_path, capsys, monkeypatch):
    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(Simulator, "run", interrupted)
    code, _, err = run(capsys, simulate_main, ["--problem", "compass_gait", "--out",
                                               str(tmp_path / "o")])
    assert code == 130 and "Traceback" not in err
    assert err.strip().splitlines() == [f"interrupted: nothing written to {tmp_path / 'o'}"]


def test_unexpected_exception_is_one_line_not_a_traceback(tmp_path, capsys, monkeypatch):
    def broken(*a, **k):
        raise ZeroDivisionError("boom")

    monkeypatch.setattr(Simulator, "run", broken)
    monkeypatch.delenv("PDW_DEBUG", raising=False)
    code, _, err = run(capsys, simulate_main, ["--problem", "compass_gait", "--out",
                                               str(tmp_path / "o")])
    assert code == 1 and "Traceback" not in err
    assert err.startswith("error: internal error (ZeroDivisionError: boom)")


# -- minor -----------------------------------------------------------------------------------
@pytest.mark.parametrize("main, args", [
    (simulate_main, ["--bogus"]), (simulate_main, ["--steps"]), (fixed_point_main, []),
    (sweep_main, ["--out", "x"]), (fit_main, ["--hip-target", "knee"]),
])
def test_argparse_errors_are_one_line(capsys, main, args):
    code, _, err = run(capsys, main, args)
    assert_usage_error(code, err)


def test_num_says_the_same_bound_for_0_and_1(tmp_path, capsys):
    msgs = []
    for n in ("0", "1"):
        code, _, err = run(capsys, sweep_main, ["--from", "0.1", "--to", "0.2", "--num", n,
                                                "--out", str(tmp_path)])
        assert code == 2
        msgs.append(err.replace(f"got {n}", ""))
    assert msgs[0] == msgs[1] and "--num must be >= 2" in msgs[0]


@pytest.mark.parametrize("edit, fragment", [
    (lambda f: f.assign(knee_sd_deg=-1.0), "negative value -1.0"),
    (lambda f: f.assign(cycle_pct=f["cycle_pct"] / 100), "got 1.0"),
    (lambda f: f.assign(hip_mean_deg=np.inf), "non-finite value inf"),
])
def test_no_numpy_reprs_in_gait_file_messages(tmp_path, edit, fragment):
    from pdw_casadi.model.gait_data import GaitDataError, load_gait_curves

    path = tmp_path / "g.csv"
    edit(pd.read_csv(ROOT / "data" / "female_fast.csv")).to_csv(path, index=False)
    with pytest.raises(GaitDataError) as info:
        load_gait_curves(path)
    assert "np." not in str(info.value) and fragment in str(info.value), str(info.value)


def test_no_numpy_reprs_in_messages(tmp_path):
    path = tmp_path / "s.json"
    path.write_text('{"q1": Infinity}')
    with pytest.raises(ProblemError) as info:
        load_overrides(path, "state")
    assert "np.float64" not in str(info.value) and "got inf" in str(info.value)
    from pdw_casadi.model.problem import _num

    with pytest.raises(ProblemError) as info:
        _num("x", "k", np.float64("nan"))
    assert "np." not in str(info.value)


def test_reversed_bounds_are_named_reversed(tmp_path):
    path = problem_file(tmp_path, HL.replace("k_knee = [10.0, 1000.0]",
                                             "k_knee = [1000.0, 10.0]"))
    with pytest.raises(ProblemError, match=r"is reversed \(lower > upper\)"):
        load_problem(path)


def test_directory_as_state_file_is_named(tmp_path):
    with pytest.raises(ProblemError, match="is a directory"):
        load_overrides(tmp_path, "state")


@pytest.mark.parametrize("name", ["state.txt", "state.JSON", "state"])
def test_json_override_in_any_file_name(tmp_path, name):
    path = tmp_path / name
    path.write_text('{"q1": 0.25}')
    assert load_overrides(path, "state") == {"q1": 0.25}


def test_toml_override_without_suffix(tmp_path):
    path = tmp_path / "comp.cfg"
    path.write_text("k_knee = 120\n")
    assert load_overrides(path, "compliance") == {"k_knee": 120.0}


def test_fixed_point_summary_is_reproducible(tmp_path, capsys):
    outs = []
    for k in range(2):
        out = tmp_path / f"fp{k}"
        code, stdout, _ = run(capsys, fixed_point_main, ["--problem", "compass_gait", "--out",
                                                         str(out)])
        assert code == 0
        outs.append((out / "summary.json").read_text())
    assert outs[0] == outs[1] and "wall_time" not in outs[0]


def test_commands_share_the_contract():
    for name in ("simulate_main", "fixed_point_main", "fit_main", "sweep_main"):
        src = inspect.getsource(getattr(cli, name))
        assert "Parser(" in src and "return run(outputs, body)" in src, name
        # fit_main creates its folder through _fit_output, which is the only place that does
        created = [src.find(c) for c in ("outputs.create()", "_fit_output(outputs")]
        created = [i for i in created if i >= 0]
        assert created, name
        # load_gait_problem (pdw-simulate, pdw-fixed-point) checks the outputs itself
        checked = [src.find(c) for c in ("outputs.check()", "load_gait_problem(args, outputs)")]
        checked = [i for i in checked if i >= 0]
        assert checked and min(checked) < min(created), name
    assert "outputs.create()" in inspect.getsource(cli_fit._fit_output)
    assert "outputs.check()" in inspect.getsource(cli_common.load_gait_problem)
    # the per-side fit path validates its inputs before it creates the folder too
    src = inspect.getsource(cli_fit._fit_stride_body)
    assert src.index("outputs.check()") < src.index("_fit_output(outputs"), "_fit_stride_body"


def test_json_summary_of_a_simulation_round_trips(tmp_path, capsys):
    out = tmp_path / "s"
    code, _, err = run(capsys, simulate_main, ["--problem", "kneed_walker", "--out", str(out)])
    assert code == 0, err
    s = json.loads((out / "summary.json").read_text())
    assert [p["name"] for p in s["phases"][0]] == ["unlocked", "locked"]


def test_a_finished_console_script_exits_with_its_code_handlers_run_and_buffers_flushed(
        tmp_path):
    """The end of a console script skips the interpreter's teardown (_exit_after_work):
    the process still exits with the command's code, its exit handlers run (temporary
    folders, logs), and what it wrote to Python's and to C's buffered standard output
    (IPOPT's and CasADi's prints) arrives."""
    import os
    import subprocess
    import sys

    mark = tmp_path / "handler_ran"
    code = f"""
import atexit, ctypes, sys
from pdw_casadi.cli import scripts
from pdw_casadi.engine import interrupt
interrupt.EXIT_AT_ONCE[0] = True
atexit.register(lambda: open({str(mark)!r}, "w").write("ran"))
print("python line", end="")
ctypes.CDLL(None).printf(b" c line")
scripts._exit_after_work(3)
"""
    # as on a user's machine: buffered standard output (this machine's shell unbuffers it)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60, env=env)
    assert done.returncode == 3, done.stderr
    assert done.stdout == "python line c line"
    assert mark.read_text() == "ran"
