"""The user jobs that were scripts, now under the CLI contract (issue 46, item 4): the timing
study (``pdw-compare``), the sweep's timing per point (``pdw-sweep --timing``), the
conditioning of a fit's answer (``pdw-fixed-point --conditioning``) and the three seed
searches (``pdw-seed arc|heeloff|toes``). One contract test per former script: ``--help``
names the option and its units; a bad argument is one ``error:`` line, exit code 2, nothing
written; a small real run where it is cheap (the long ones are marked slow)."""

from __future__ import annotations

import inspect
import json
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from conftest import run

import pdw_casadi.cli.compare as cli_compare
import pdw_casadi.cli.fixed_point as cli_fixed_point
import pdw_casadi.cli.seed as cli_seed
from pdw_casadi.cli import COMMANDS, compare_main, fixed_point_main, seed_main, sweep_main
from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.problem import load_problem
from pdw_casadi.report.conditioning_report import conditioning_lines, write_conditioning
from pdw_casadi.studies.compare_run import ANKLE_STUDY, CompareFit, CompareRequest
from pdw_casadi.studies.conditioning import ConditioningRun, fit_option_values

ROOT = Path(__file__).resolve().parents[1]

#: each former script and the command line that does its job now
FORMER_SCRIPTS = {
    "timing_study.py": ("compare", "--table-only"),
    "sweep_timing.py": ("sweep", "--timing"),
    "fixed_point_conditioning.py": ("fixed-point", "--conditioning"),
    "arc_seed.py": ("seed", "--r-toe"),
    "heeloff_seed.py": ("seed", "--lengthen-ms"),
    "toes_seed.py": ("seed", "--continue"),
}


def assert_usage_error(code, err, *fragments):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for f in fragments:
        assert f in lines[0], lines[0]


def help_text(capsys, main) -> str:
    code, out, _ = run(capsys, main, ["--help"])
    assert code == 0
    return " ".join(out.split())


# -- scripts/ keeps benchmarks and data builders; every former script is an option ---------------
def test_scripts_keep_benchmarks_and_data_builders_only():
    names = sorted(p.name for p in (ROOT / "scripts").glob("*.py"))
    others = [n for n in names if not (n.startswith(("bench_", "make_"))
                                       or n in ("faults.py", "bad_inputs.py"))]
    assert others == [], others
    assert not any((ROOT / "scripts" / name).exists() for name in FORMER_SCRIPTS)


def test_the_new_commands_keep_the_contract():
    # parse, check (outputs.check()) before anything is created, one run(outputs, body)
    for fn in (cli_seed.seed_main, cli_compare.compare_main):
        src = inspect.getsource(fn)
        assert "Parser(" in src and "return run(outputs, body)" in src, fn.__name__
        assert src.index("outputs.check()") < src.index("outputs.create()"), fn.__name__
    src = inspect.getsource(cli_fixed_point._conditioning_body)
    assert src.index("outputs.check()") < src.index("outputs.create()")


@pytest.mark.parametrize("script", sorted(FORMER_SCRIPTS))
def test_every_former_script_is_an_option_of_a_command(capsys, script):
    command, option = FORMER_SCRIPTS[script]
    code, out, _ = run(capsys, COMMANDS[command], ["--help"])
    assert code == 0 and f"usage: pdw-{command}" in out and option in out


# -- timing_study.py -> pdw-compare ------------------------------------------------------------
def test_compare_help_names_the_table_and_its_units(capsys):
    text = help_text(capsys, compare_main)
    for word in ("study.csv", "study.md", "% of the gait cycle", "steps/min", "(m/s)", "(ms)",
                 "--table-only", "--rerun", *ANKLE_STUDY):
        assert word in text, word


@pytest.mark.parametrize("args, fragment", [
    (["--problems", "no_such_walker"], "no_such_walker"),
    (["--problems", "compass_gait"], "has no knee"),
    (["--problems", "humanlike_6link", "humanlike_6link"], "named twice"),
    (["--table-only", "--rerun"], "--table-only runs nothing"),
    (["--table-only"], "no fit summary"),
    (["--gait", "no_such_curves.csv", "--problems", "humanlike_6link"], "no_such_curves.csv"),
    (["--rounds", "0"], "--rounds must be >= 1"),
])
def test_compare_refuses_bad_input_and_writes_nothing(tmp_path, capsys, args, fragment):
    out = tmp_path / "study"
    code, _, err = run(capsys, compare_main, [*args, "--out", str(out)])
    assert_usage_error(code, err, fragment)
    assert not out.exists()


def _summary(ds: float) -> dict:
    """A fit's summary.json as pdw-fit writes it (the fields the table reads)."""
    return {"timing": {"double_support_pct": [ds, ds + 0.1], "stance_pct": 55.0,
                       "heel_off_pct": 50.0, "toe_off_pct": 55.0, "cadence_steps_min": 101.5,
                       "speed_m_s": 1.21, "phase_durations_s": {"I": 0.05, "II": 0.5}},
            "r2_knee": 0.8, "r2_hip": 0.7, "r2_thigh": 0.9, "spectral_radius": 0.88,
            "stable": True, "valid": True, "margins": {},
            "compliance": {"k_knee": 100.123456}}


def test_compare_fits_what_is_missing_and_tabulates(tmp_path, capsys, monkeypatch):
    calls = []

    def fake_fit(request, fit, folder):  # pdw-fit's part: a whole folder with its summary
        calls.append((fit, cli_compare.fit_command(request, fit, folder)))
        folder.mkdir(parents=True)
        (folder / "summary.json").write_text(json.dumps(_summary(5.0 + len(calls))))
        return 0

    monkeypatch.setattr(cli_compare, "_fit_process", fake_fit)
    out = tmp_path / "study"
    (out / "humanlike_6link").mkdir(parents=True)  # a fit of an earlier run: read, not rerun
    (out / "humanlike_6link" / "summary.json").write_text(json.dumps(_summary(3.0)))
    args = ["--problems", "humanlike_6link", "humanlike_6link_ankle", "--timing",
            "--rounds", "1", "--max-iter", "20", "--out", str(out)]
    code, stdout, err = run(capsys, compare_main, args)
    assert code == 0, err
    assert [f.label for f, _ in calls] == ["humanlike_6link_timing", "humanlike_6link_ankle",
                                           "humanlike_6link_ankle_timing"]
    assert calls[0][1] == ["--gait", "female_fast.csv", "--problem", "humanlike_6link", "--out",
                           str(out / "humanlike_6link_timing"), "--quiet", "--rounds", "1",
                           "--max-iter", "20", "--timing"]
    table = pd.read_csv(out / "study.csv")
    assert list(table["fit"]) == ["humanlike_6link", "humanlike_6link_timing",
                                  "humanlike_6link_ankle", "humanlike_6link_ankle_timing"]
    assert list(table.columns[:3]) == ["fit", "double_support_pct", "double_support_2_pct"]
    assert table["double_support_pct"].tolist() == [3.0, 6.0, 7.0, 8.0]
    assert table["phases_ms"][0] == "I 50.0 II 500.0"
    assert json.loads(table["compliance"][0]) == {"k_knee": 100.1235}
    assert table["tightest margins"][0] == "-"
    md = (out / "study.md").read_text()
    assert md.startswith("| fit | double_support_pct |") and "compliance" not in md
    assert "| humanlike_6link | 3.000 |" in md
    assert "cadence_steps_min" in stdout and "3 fits run, 1 read" in stdout
    assert not list(out.glob(".pdw-partial-*"))

    calls.clear()  # the same command again: everything is on disk
    code, stdout, _ = run(capsys, compare_main, args)
    assert code == 0 and calls == [] and "0 fits run, 4 read" in stdout
    code, stdout, _ = run(capsys, compare_main, [*args, "--table-only"])
    assert code == 0 and calls == []


def test_compare_without_any_summary_is_no_gait(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli_compare, "_fit_process", lambda request, fit, folder: 1)
    out = tmp_path / "study"
    code, _, err = run(capsys, compare_main, ["--problems", "humanlike_6link", "--out", str(out)])
    assert code == 1 and err.strip().splitlines()[-1].startswith("no gait: no fit left")
    assert not (out / "study.csv").exists()


def test_compare_request_folders():
    request = CompareRequest(problems=("humanlike_6link", "problems/x.toml"), only_timing=True)
    assert request.fits() == [CompareFit("humanlike_6link_timing", "humanlike_6link", True),
                              CompareFit("x_timing", "problems/x.toml", True)]


@pytest.mark.slow
def test_compare_runs_pdw_fit_per_walker(tmp_path, capsys):
    out = tmp_path / "study"
    code, stdout, err = run(capsys, compare_main, ["--problems", "humanlike_6link", "--rounds",
                                                   "1", "--max-iter", "30", "--out", str(out)])
    assert code == 0, err
    assert (out / "humanlike_6link" / "summary.json").is_file()
    table = pd.read_csv(out / "study.csv")
    assert list(table["fit"]) == ["humanlike_6link"] and table["r2_knee"][0] > 0.5


# -- sweep_timing.py -> pdw-sweep --timing --------------------------------------------------------
def test_sweep_help_names_the_timing_and_its_units(capsys):
    text = help_text(capsys, sweep_main)
    assert "--timing" in text and "% of the gait cycle" in text and "(ms)" in text


def test_sweep_timing_refuses_a_walker_whose_legs_differ(tmp_path, capsys):
    text = load_problem("humanlike_6link").source.read_text()
    path = tmp_path / "pros.toml"
    path.write_text(text + "\n[compliance.right]\nk_ankle = 7.5\n")
    out = tmp_path / "sw"
    code, _, err = run(capsys, sweep_main, ["--problem", str(path), "--from", "0.148", "--to",
                                            "0.149", "--timing", "--out", str(out)])
    assert_usage_error(code, err, "its legs differ", "pdw-fixed-point --stride")
    assert not out.exists()


def test_sweep_timing_prints_the_timing_of_every_point(tmp_path, capsys):
    pb = load_problem("compass_gait")
    out = tmp_path / "sw"
    code, stdout, err = run(capsys, sweep_main, [
        "--problem", "compass_gait", "--from", str(pb.slope), "--to", str(pb.slope + 0.002),
        "--num", "3", "--timing", "--out", str(out)])
    assert code == 0, err
    table = pd.read_csv(out / "sweep.csv")
    lines = [ln for ln in stdout.splitlines() if ln.startswith("slope_rad = ")]
    assert len(lines) == len(table) >= 3
    for line, value, ok in zip(lines, table["slope_rad"], table["converged"], strict=True):
        assert line.startswith(f"slope_rad = {value:.6g}: ")
        if ok:  # point feet: no double support; the one phase of the step in ms
            assert re.search(r": valid (True|False), stable (True|False), rho \d\.\d{4}, "
                             r"double support none, stance \d+\.\d\d %, phases swing "
                             r"\d+\.\d ms$", line), line
    assert table["converged"].any()


# -- fixed_point_conditioning.py -> pdw-fixed-point --conditioning --------------------------------
def test_fixed_point_help_names_the_conditioning_and_its_units(capsys):
    text = help_text(capsys, fixed_point_main)
    for word in ("--conditioning FILE", "--set KEY=VALUE", "--samples", "conditioning.json",
                 "answer.npz", "rad, rad/s", "Henrici"):
        assert word in text, word


@pytest.mark.parametrize("args, fragment", [
    (["--samples", "3"], "--samples: only with --conditioning FILE"),
    (["--set", "threads=1"], "--fit-option/--set: only with --conditioning FILE"),
    (["--conditioning", "no_such_curves.csv"], "no_such_curves.csv"),
    (["--conditioning", "female_fast.csv", "--set", "bogus=1"], "no field 'bogus'"),
    (["--conditioning", "female_fast.csv", "--set", "threads=x"], "FitOptions.threads = x"),
    (["--conditioning", "female_fast.csv", "--set", "rounds"], "expected KEY=VALUE"),
    (["--conditioning", "female_fast.csv", "--stride"], "neither --stride nor --export"),
    (["--conditioning", "female_fast.csv", "--problem", "compass_gait"], "has no knee"),
    (["--conditioning", "female_fast.csv", "--samples", "0"], "--samples must be >= 1"),
])
def test_conditioning_refuses_bad_input_and_writes_nothing(tmp_path, capsys, args, fragment):
    out = tmp_path / "cond"
    code, _, err = run(capsys, fixed_point_main, [*args, "--out", str(out)])
    assert_usage_error(code, err, fragment)
    assert not out.exists()


def test_fit_option_values_take_each_field_in_its_kind():
    assert fit_option_values(["threads=1", "max_iter=15", "atlas=", "knee_floor=0.5",
                              "slope_bounds=[0.1, 0.2]", "stall_window=null"]) == {
        "threads": 1, "max_iter": 15, "atlas": "", "knee_floor": 0.5,
        "slope_bounds": (0.1, 0.2), "stall_window": None}
    for bad in ("max_iter=1.5", "verbose=1", "keep_best_feasible=yes"):
        with pytest.raises(ProblemError, match="not a value of its kind"):
            fit_option_values([bad])


def test_conditioning_report_renders_the_measurement(tmp_path):
    pb = load_problem("humanlike_6link")
    figures = {"residual": 5.2e-9, "rho": 0.8807, "sigma_min_I_minus_J": 1.5e-3,
               "inv_norm": 666.7, "max_entry": 12.3, "henrici": 0.987, "newton_step": 3.1e-6,
               "path": [{"t": 0.5, "rho": 0.88, "dJ": 1e-3, "same_plan": True,
                         "residual": 1e-9},
                        {"t": 1.0, "failure": "step failed: toe_scuff in phase II"}]}
    measured = ConditioningRun(
        problem=pb, start="problem", status="Maximum_Iterations_Exceeded", iterations=300,
        wall_time_s=12.34, objective=0.675721, fallback_iteration=136,
        state=pb.state_vector(), parameters=pb.parameter_vector(), figures=figures,
        newton=SimpleNamespace(converged=False, spectral_radius=math.nan, failure=None))
    lines = conditioning_lines(measured, "WBDS18_late.csv")
    assert lines[0] == ("WBDS18_late.csv: start problem; Maximum_Iterations_Exceeded after 300 "
                        "iterations (12.3 s); best feasible iterate (iteration 136), objective "
                        "0.67572")
    assert lines[1] == "simulator residual |P(x) - x|       5.20e-09"
    assert lines[5] == "Newton step |d|                     3.10e-06 (596 x the residual)"
    assert lines[7].endswith("True        1.00e-09")
    assert lines[8].endswith("simulator failure: step failed: toe_scuff in phase II")
    assert lines[9] == ("Newton on the simulator's map from x: converged False, rho nan "
                        "(no convergence)")
    summary_path, answer = write_conditioning(measured, tmp_path, "WBDS18_late.csv")
    summary = json.loads(summary_path.read_text())
    assert summary["solve"]["fallback_iteration"] == 136 and summary["henrici"] == 0.987
    assert summary["units"]["state"]["q1"] == "rad" and summary["units"]["state"]["dq1"] == \
        "rad/s"
    assert summary["units"]["parameters"]["k_knee"] == "N m/rad"
    assert summary["units"]["parameters"]["slope"] == "rad"
    with np.load(answer) as npz:
        np.testing.assert_array_equal(npz["x"], pb.state_vector())
        np.testing.assert_array_equal(npz["p"], pb.parameter_vector())


@pytest.mark.slow
def test_conditioning_of_a_short_fit(tmp_path, capsys):
    out = tmp_path / "cond"
    code, stdout, err = run(capsys, fixed_point_main, [
        "--conditioning", "female_fast.csv", "--max-iter", "5", "--set", "threads=1",
        "--samples", "2", "--out", str(out)])
    assert code == 0, err
    lines = stdout.splitlines()
    assert lines[0].startswith("female_fast.csv: start ")
    assert any(ln.startswith("Newton on the simulator's map from x: ") for ln in lines)
    summary = json.loads((out / "conditioning.json").read_text())
    assert len(summary["path"]) <= 2 and summary["units"]["residual"].startswith("max norm")
    assert (out / "answer.npz").is_file()


# -- the seed searches: arc_seed.py, heeloff_seed.py, toes_seed.py -> pdw-seed -------------------
def test_seed_help_names_the_searches_and_their_units(capsys):
    text = help_text(capsys, seed_main)
    for word in ("arc, heeloff, toes", "(m; required)", "(N m) that ends the push",
                 "N m/rad", "(ms)", "seed.json", "scan.json", "continuation.json",
                 "--range KEY LO HI", "--continue KEY TO NUM"):
        assert word in text, word


@pytest.mark.parametrize("args, fragment", [
    (["arc", "--r-toe", "0.05"], "pdw-seed arc needs --r-heel (m)"),
    (["arc", "--r-toe", "0.5", "--r-heel", "0"], "--r-toe 0.5: 'r_toe' = 0.5 lies outside"),
    (["arc", "--r-toe", "-0.01", "--r-heel", "0"], "'r_toe' = -0.01"),
    (["arc", "--r-toe", "nan", "--r-heel", "0"], "--r-toe must be a finite number"),
    (["arc", "--r-toe", "0", "--r-heel", "0", "--samples", "3"],
     "--samples: option of pdw-seed toes, not of pdw-seed arc"),
    (["heeloff", "--gait", "female_fast.csv"], "--gait: only with --stability"),
    (["heeloff", "--stability", "--gait", "no_such_curves.csv"], "no_such_curves.csv"),
    (["heeloff", "--lengthen-ms", "-1"], "--lengthen-ms must be >= 0"),
    (["heeloff", "--r-toe", "0.1"], "--r-toe: option of pdw-seed arc"),
    (["toes", "--range", "k_nope", "0", "1"], "no compliance key 'k_nope'"),
    (["toes", "--range", "k_mtp", "5", "1"], "expected finite LO <= HI"),
    (["toes", "--range", "k_mtp", "x", "1"], "--range k_mtp: LO must be a number"),
    (["toes", "--range", "k_mtp", "1000", "2000"], "lies outside the bounds"),
    (["toes", "--continue", "k_mtp", "40", "1"], "NUM must be >= 2"),
    (["toes", "--continue", "k_nope", "40", "5"], "no parameter 'k_nope'"),
    (["toes", "--continue", "k_mtp", "40", "5", "--samples", "3"], "takes no --samples"),
    (["toes", "--problem", "compass_gait"], "needs a walker of the humanlike_toes family"),
    (["toes", "--samples", "0"], "--samples must be >= 1"),
    (["toes", "--state", "no_such_state.json"], "no_such_state.json"),
    (["arc", "--r-toe", "0", "--r-heel", "0", "--compliance", "c.json"],
     "--compliance: option of pdw-seed toes, not of pdw-seed arc"),
    (["guess"], "invalid choice"),
])
def test_seed_refuses_bad_input_and_writes_nothing(tmp_path, capsys, args, fragment):
    out = tmp_path / "seed"
    code, _, err = run(capsys, seed_main, [*args, "--out", str(out)])
    assert_usage_error(code, err, fragment)
    assert not out.exists()


def test_seed_toes_continues_the_walker_given_by_state_and_compliance(tmp_path, capsys):
    """``--state`` and ``--compliance`` (a fit's summary.json, or a table) set the toe
    walker the continuation starts from: its first point has the overridden value, it is
    a fixed point of that walker (converged, a finite spectral radius), and the record
    names the file the values came from."""
    comp = tmp_path / "c.json"
    comp.write_text(json.dumps({"k_clutch": 14.0}))
    out = tmp_path / "c"
    code, _, err = run(capsys, seed_main, ["toes", "--compliance", str(comp), "--continue",
                                           "k_clutch", "14.1", "2", "--out", str(out)])
    assert code == 0, err
    record = json.loads((out / "continuation.json").read_text())
    assert record["problem"] == f"humanlike_toes (compliance from {comp})"
    points = record["continuation"]
    assert points[0]["k_clutch"] == 14.0 and points[-1]["k_clutch"] == pytest.approx(14.1)
    assert points[0]["converged"] and math.isfinite(points[0]["rho"])


def test_seed_toes_scan_writes_its_tally_with_units(tmp_path, capsys):
    out = tmp_path / "scan"
    code, stdout, err = run(capsys, seed_main, ["toes", "--samples", "3", "--seed", "0",
                                                "--out", str(out)])
    assert code == 0, err
    scan = json.loads((out / "scan.json").read_text())
    assert scan["problem"] == "humanlike_toes" and scan["samples"] == 3 and scan["seed"] == 0
    assert sum(scan["step_ends"].values()) == 3
    assert scan["units"]["wall_time_s"] == "s" and scan["units"]["gaits[].phases_s"] == "s"
    assert scan["units"]["gaits[].compliance"]["k_mtp"] == "N m/rad"
    lines = stdout.splitlines()
    assert lines[-2].startswith("how the steps ended: {")
    assert lines[-1].startswith(f"{sum(scan['heel_off_step_ends'].values())} of 3 samples "
                                f"lifted the stance heel") and lines[-1].endswith(
        f"written to {out / 'scan.json'}")


@pytest.mark.slow
def test_seed_toes_continuation(tmp_path, capsys):
    pb = load_problem("humanlike_toes")
    out = tmp_path / "c"
    stop = pb.compliance["k_mtp"] + 0.2
    code, stdout, err = run(capsys, seed_main, ["toes", "--continue", "k_mtp", str(stop), "2",
                                                "--out", str(out)])
    assert code == 0, err
    rec = json.loads((out / "continuation.json").read_text())
    assert [r["k_mtp"] for r in rec["continuation"]][0] == pytest.approx(pb.compliance["k_mtp"])
    assert rec["units"]["continuation[].k_mtp"] == "N m/rad"


@pytest.mark.slow
def test_seed_arc_at_radius_zero_is_the_ankle_walkers_gait(tmp_path, capsys):
    out = tmp_path / "start"
    code, stdout, err = run(capsys, seed_main, ["arc", "--r-toe", "0", "--r-heel", "0",
                                                "--n-min", "2", "--out", str(out)])
    assert code == 0, err
    seed = json.loads((out / "seed.json").read_text())
    assert seed["converged"] and seed["compliance"]["r_toe"] == 0.0
    assert seed["units"]["fixed_point"]["q1"] == "rad" and seed["units"]["slope"] == "rad"
    assert json.loads(stdout.splitlines()[-1])["valid"] in (True, 1.0)


@pytest.mark.slow
def test_seed_heeloff_pushes_towards_heel_off(tmp_path, capsys):
    out = tmp_path / "h"
    code, stdout, err = run(capsys, seed_main, ["heeloff", "--rounds", "1", "--max-iter", "5",
                                                "--max-steps", "1", "--out", str(out)])
    # one short round rarely reaches heel off: then no gait, nothing written
    assert code in (0, 1), err
    assert stdout.startswith("push round 0: ")
    if code == 1:
        assert err.strip().splitlines()[-1].startswith("no gait: ")
        assert not (out / "seed.json").exists()
    else:
        assert "II_toe" in json.loads((out / "seed.json").read_text())["phases_s"]
