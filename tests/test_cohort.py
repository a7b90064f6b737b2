"""pdw-cohort: reading a study, one row per fit whatever happens to it, resuming after a cut,
the same table from a process pool, a Dask cluster and a killed-and-resumed run, and the
command's contract."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import run

from pdw_casadi.cli import COMMANDS
from pdw_casadi.cli.cohort import cohort_main
from pdw_casadi.engine.errors import UsageError
from pdw_casadi.engine.parallel import map_tasks
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.studies.cohort import (
    CohortOptions,
    FitTask,
    StudyEntry,
    cohort_table,
    plan_cohort,
    read_bodies,
    read_study,
    result_columns,
    run_cohort,
    save_fit,
)

ROOT = Path(__file__).resolve().parents[1]
SUBJECTS = ROOT / "data" / "subjects"
BODIES = ROOT / "data" / "anthropometry" / "subjects.csv"
#: the small real configuration: the point-foot kneed walker fitting its slope, at most
#: twenty iterations (the eight-step bound converges in 16 from the walker's start)
SMALL = ["--problem", "kneed_walker", "--free-slope", "--max-iter", "20", "--rounds", "1",
         "--body", "paper", "--quiet"]




# -- reading a study -------------------------------------------------------------------------
def test_a_directory_is_every_curve_file_by_kind():
    entries, left = read_study([str(SUBJECTS)])
    assert len(entries) == 8 and not left
    by_id = {e.fit_id: e for e in entries}
    assert set(by_id) == {f"WBDS{n}_fast_{k}" for n in ("09", "10", "18", "20")
                          for k in ("symmetric", "sides")}
    e = by_id["WBDS09_fast_sides"]
    assert (e.subject_id, e.condition, e.kind) == ("WBDS09", "fast", "sides")
    assert not e.has_body
    sym, left = read_study([str(SUBJECTS)], kind="symmetric")
    assert {e.kind for e in sym} == {"symmetric"} and len(sym) == 4 and len(left) == 4
    sides, _ = read_study([str(SUBJECTS / "*_sides.csv")], kind="sides")
    assert [e.subject_id for e in sides] == ["WBDS09", "WBDS10", "WBDS18", "WBDS20"]


def test_body_data_from_a_bodies_table_and_a_study_table(tmp_path):
    bodies = read_bodies(BODIES)
    assert bodies["WBDS20"] == {"mass_kg": 62.45, "height_m": 1.695, "sex": "female"}
    entries, _ = read_study([str(SUBJECTS)], "symmetric", bodies)
    assert all(e.has_body for e in entries)
    table = tmp_path / "study.csv"
    table.write_text("file,subject_id,condition,mass_kg,height_m,sex,speed_m_s\n"
                     f"{SUBJECTS / 'WBDS09_fast.csv'},S1,fast,70,1.8,M,1.6\n"
                     f"{SUBJECTS / 'WBDS10_fast.csv'},S2,fast,,,,\n")
    entries, _ = read_study([str(table)], "auto", bodies)
    assert entries[0] == StudyEntry(str((SUBJECTS / "WBDS09_fast.csv").resolve()), "S1",
                                    "fast", "symmetric", 70.0, 1.8, "male", 1.6)
    assert not entries[1].has_body  # S2 is not in the bodies table


@pytest.mark.parametrize("text, message", [
    ("file\nnope.csv\n", "not found"),
    ("file,mass_kg,height_m\n{f},500,1.7\n", "outside 20..200 kg"),
    ("file,mass_kg\n{f},60\n", "give both mass_kg and height_m"),
    ("file,sex,mass_kg,height_m\n{f},X,60,1.7\n", "sex must be"),
    ("file,weight\n{f},60\n", "unknown column"),
    ("file,subject_id,condition\n{f},A,x\n{g},A,x\n", "the same fit"),
])
def test_bad_study_tables_are_usage_errors(tmp_path, text, message):
    table = tmp_path / "study.csv"
    table.write_text(text.format(f=SUBJECTS / "WBDS09_fast.csv",
                                 g=SUBJECTS / "WBDS10_fast.csv"))
    with pytest.raises(UsageError, match=message):
        read_study([str(table)])


def test_a_bad_curve_file_is_found_before_anything_runs(tmp_path):
    bad = tmp_path / "S1_fast.csv"
    bad.write_text("cycle_pct,knee_mean_deg\n0,1\n")
    with pytest.raises(ValueError, match="S1_fast.csv"):
        read_study([str(tmp_path)])


# -- running: a fake fit function (the bookkeeping, fast) ------------------------------------
CALLS = "PDW_TEST_COHORT_CALLS"


def fake_fit(task: FitTask) -> dict:
    """A stand-in for the fit: a row from the file's numbers; fails for subject WBDS18.
    Each call appends the fit id to the file named by $PDW_TEST_COHORT_CALLS."""
    with open(os.environ[CALLS], "a") as fh:
        fh.write(task.entry.fit_id + "\n")
    row = {"fit_id": task.entry.fit_id, "subject_id": task.entry.subject_id,
           "condition": task.entry.condition, "kind": task.entry.kind, "body": task.body,
           "gait_file": Path(task.entry.gait_file).name, "wall_time_s": 0.1}
    if task.entry.subject_id == "WBDS18":
        row.update(status="failed", reason="RuntimeError: a fit that breaks")
    else:
        knee = pd.read_csv(task.entry.gait_file).filter(like="knee").to_numpy()
        row.update(status="accepted", reason="", r2_knee=float(knee.mean() / 100),
                   r2_hip=0.5, k_knee_N_m_per_rad=float(knee.max()))
    return {"fit_id": task.entry.fit_id, "fingerprint": task.fingerprint, "row": row,
            "curves": {"cycle_pct": [0.0, 50.0, 100.0], "knee_deg": [1.0, 2.0, 3.0]}}


def _calls(path: Path) -> list[str]:
    return path.read_text().split() if path.exists() else []


@pytest.fixture
def fake_plan(monkeypatch, tmp_path):
    monkeypatch.setenv(CALLS, str(tmp_path / "calls.txt"))
    entries, _ = read_study([str(SUBJECTS)], "symmetric")
    opts = CohortOptions(problem="humanlike_6link", body="paper",
                         fit=FitOptions(verbose=False, max_iter=5))
    return plan_cohort(entries, opts), tmp_path / "calls.txt"


def test_every_fit_is_a_row_and_a_second_run_skips_the_complete_ones(fake_plan, tmp_path):
    plan, calls = fake_plan
    out = tmp_path / "out"
    table = run_cohort(plan, out, fit_fn=fake_fit)
    assert list(table["fit_id"]) == [e.fit_id for e in plan.entries]
    assert list(table["status"]) == ["accepted", "accepted", "failed", "accepted"]
    assert table.loc[2, "reason"] == "RuntimeError: a fit that breaks"
    assert (out / "cohort.csv").is_file()
    assert pd.read_csv(out / "cohort.csv")["status"].tolist() == list(table["status"])
    assert len(_calls(calls)) == 4
    again = run_cohort(plan, out, fit_fn=fake_fit)
    assert len(_calls(calls)) == 4  # nothing re-run: every fit was complete
    pd.testing.assert_frame_equal(table, again, check_exact=True)
    # a fit cut off (no result.json: only its curves, or a half-written temporary file)
    cut = out / "fits" / "WBDS10_fast_symmetric"
    (cut / "result.json").unlink()
    (cut / ".result.json.123.tmp").write_text('{"fit_id": "WBDS10_fa')
    # a result whose curves file is gone is not complete either
    (out / "fits" / "WBDS20_fast_symmetric" / "curves.csv").unlink()
    resumed = run_cohort(plan, out, fit_fn=fake_fit)
    assert _calls(calls)[4:] == ["WBDS10_fast_symmetric", "WBDS20_fast_symmetric"]
    pd.testing.assert_frame_equal(table, resumed, check_exact=True)


def test_changed_inputs_are_fitted_again(fake_plan, tmp_path):
    plan, calls = fake_plan
    out = tmp_path / "out"
    run_cohort(plan, out, fit_fn=fake_fit)
    entries, _ = read_study([str(SUBJECTS)], "symmetric")
    other = plan_cohort(entries, CohortOptions(
        problem="humanlike_6link", body="paper", fit=FitOptions(verbose=False, max_iter=6)))
    run_cohort(other, out, fit_fn=fake_fit)
    assert len(_calls(calls)) == 8  # another max_iter: every fit again
    # a saved record that is not JSON (a disk that filled up) is redone too
    (out / "fits" / "WBDS09_fast_symmetric" / "result.json").write_text("{")
    run_cohort(other, out, fit_fn=fake_fit)
    assert _calls(calls)[8:] == ["WBDS09_fast_symmetric"]


def test_a_fit_that_never_reported_is_a_row_with_its_reason(fake_plan, tmp_path):
    plan, _ = fake_plan
    out = tmp_path / "out"
    save_fit(out, fake_fit(next(iter(_tasks(plan)))))
    table = cohort_table(plan, out)
    assert list(table["status"]) == ["accepted", "failed", "failed", "failed"]
    assert table.loc[1, "reason"].startswith("no result")


def _tasks(plan):
    from pdw_casadi.studies.cohort import fit_tasks

    return fit_tasks(plan, {})[0]


def test_the_pool_gives_the_serial_table_with_a_fake_fit(fake_plan, tmp_path):
    plan, _ = fake_plan
    serial = run_cohort(plan, tmp_path / "a", fit_fn=fake_fit)
    pooled = run_cohort(plan, tmp_path / "b", workers=2, fit_fn=fake_fit)
    pd.testing.assert_frame_equal(serial, pooled, check_exact=True)


def test_map_tasks_unordered_yields_every_result_once():
    items = [0.3, 0.0, 0.1, 0.2]
    for workers in (1, 2):
        got = list(map_tasks(_sleep_and_return, items, workers, ordered=False))
        assert sorted(got) == sorted(items)
        assert list(map_tasks(_sleep_and_return, [], workers, ordered=False)) == []
    assert list(map_tasks(_sleep_and_return, items, 2, ordered=True)) == items


def _sleep_and_return(x: float) -> float:
    time.sleep(x)
    return x


# -- the figures -----------------------------------------------------------------------------
def test_the_summary_figures_draw_symmetric_and_per_side_rows(tmp_path):
    from pdw_casadi.report.cohort import compliance_names, plot_cohort

    table = pd.DataFrame([
        {"subject_id": "A", "condition": "fast", "kind": "symmetric", "body": "own",
         "status": "accepted", "mass_kg": 60.0, "r2_knee": 0.8, "r2_hip": 0.7,
         "k_knee_N_m_per_rad": 110.0, "c_ankle_N_m_s_per_rad": 2.0},
        {"subject_id": "B", "condition": "fast", "kind": "sides", "body": "own",
         "status": "rejected", "mass_kg": 65.0, "r2_knee": 0.6, "r2_hip": 0.5,
         "k_knee_left_N_m_per_rad": 100.0, "k_knee_right_N_m_per_rad": 120.0},
        {"subject_id": "C", "condition": "fast", "kind": "symmetric", "body": "own",
         "status": "failed", "mass_kg": 70.0, "r2_knee": np.nan, "r2_hip": np.nan}])
    assert compliance_names(table) == ["k_knee", "c_ankle"]
    paths = plot_cohort(table, tmp_path)
    assert [p.name for p in paths] == ["r2_by_subject.png", "compliance.png"]
    assert all(p.read_bytes()[:4] == b"\x89PNG" for p in paths)


# -- the command's contract ------------------------------------------------------------------
def test_cohort_is_a_command():
    # the dispatcher imports a command on first call; it runs cohort_main, and the
    # console script pdw-cohort is declared
    import tomllib

    assert COMMANDS["cohort"].__name__ == cohort_main.__name__
    with pytest.raises(SystemExit) as exc:
        COMMANDS["cohort"](["--version"])
    assert exc.value.code == 0
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["pdw-cohort"] == "pdw_casadi.cli.scripts:cohort"


@pytest.mark.parametrize("args, fragment", [
    ([str(SUBJECTS / "nope.csv")], "no such file"),
    ([str(SUBJECTS), "--kind", "sides", "--problem", "kneed_walker"], "no compliance"),
    ([str(SUBJECTS / "WBDS09_fast.csv"), "--kind", "sides"], "no sides curve file"),
    ([str(SUBJECTS), "--scheduler", "localhost:8786"], "not a scheduler address"),
    ([str(SUBJECTS), "--scheduler", "tcp://127.0.0.1:9"], "cannot connect"),
    ([str(SUBJECTS), "--bodies", str(SUBJECTS / "WBDS09_fast.csv")], "missing column"),
    ([str(SUBJECTS), "--workers", "0"], "--workers must be >= 1"),
    ([str(SUBJECTS), "--max-radius", "1.5"], "--max-radius must be in"),
    ([str(SUBJECTS), "--problem", "kneed_walker", "--kind", "symmetric"],
     "no compliance values to fit"),
    ([str(SUBJECTS), "--problem", "kneed_walker", "--free-slope", "--kind", "symmetric",
      "--bodies", str(BODIES)], "de Leva scaling needs the 6-link body"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, args, fragment):
    out = tmp_path / "out"
    code, _, err = run(capsys, cohort_main, [*args, "--out", str(out)])
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), err
    assert fragment in lines[0], lines[0]
    assert not out.exists()


def test_an_output_path_that_is_a_file_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    out.write_text("mine")
    code, _, err = run(capsys, cohort_main, [str(SUBJECTS), "--out", str(out)])
    assert code == 2 and "not a directory" in err
    assert out.read_text() == "mine"


# -- real fits: pool, Dask, killed and resumed (small configuration) -------------------------
#: two subjects: in SMALL, WBDS09's fit is accepted, WBDS20's stops at its iteration limit
#: (a failed row, which must come out the same way too)
FILES = [str(SUBJECTS / f"WBDS{n}_fast.csv") for n in ("09", "20")]


def _cli(tmp_path, name, *extra):
    return [*FILES, *SMALL, "--out", str(tmp_path / name), *extra]


def _table(path: Path) -> pd.DataFrame:
    t = pd.read_csv(path / "cohort.csv")
    return t[result_columns(t)]


def test_real_fits_same_table_from_pool_dask_and_a_killed_resumed_run(tmp_path, capsys):
    distributed = pytest.importorskip("dask.distributed")
    code, out, err = run(capsys, cohort_main, _cli(tmp_path, "pool", "--workers", "2"))
    assert code in (0, 1) and "error" not in err, err
    pool = _table(tmp_path / "pool")
    assert len(pool) == 2 and set(pool["status"]) <= {"accepted", "rejected", "failed"}
    assert (pool["status"] == "accepted").any() and pool["r2_hip"].notna().any()
    # every fit not accepted says why (with both accepted there is none to check: the
    # column then holds no strings for pandas' .str)
    assert all(isinstance(r, str) and r for r in pool.loc[pool["status"] != "accepted",
                                                           "reason"])
    assert "2 fits:" in out
    # each fit keeps IPOPT's log of its solve, ending with IPOPT's verdict
    for fit_id, iterations in zip(pool["fit_id"], pool["iterations"], strict=True):
        log = (tmp_path / "pool" / "fits" / fit_id / "ipopt.log").read_text()
        assert "EXIT:" in log and f"Number of Iterations....: {iterations:.0f}" in log
    # the same fits on a Dask LocalCluster, given by its address
    with distributed.LocalCluster(processes=True, n_workers=2, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        code, out, err = run(capsys, cohort_main,
                             _cli(tmp_path, "dask", "--scheduler", cluster.scheduler_address))
    assert code in (0, 1) and "error" not in err, err
    pd.testing.assert_frame_equal(pool, _table(tmp_path / "dask"), check_exact=True)
    # a run stopped by Ctrl-C during its second fit (most likely inside IPOPT, which turns
    # Ctrl-C into a failed solve: that fit must not be saved as a failed result), resumed
    killed = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "pdw_casadi.cli", "cohort",
                             *_cli(tmp_path, "killed", "--workers", "1")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 600
        while not list(killed.glob("fits/*/result.json")):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.2)
        time.sleep(1.0)  # into the second fit
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("interrupted: ") and "1 of 2 fits complete" in last, err
    done = {p.parent.name: p.read_bytes() for p in killed.glob("fits/*/result.json")}
    assert len(done) == 1 and not (killed / "cohort.csv").exists()
    code, out, err = run(capsys, cohort_main, _cli(tmp_path, "killed", "--workers", "1"))
    assert code in (0, 1) and "error" not in err, err
    assert "(1 complete from an earlier run)" in out
    for name, saved in done.items():  # the fit done before the kill was not run again
        assert (killed / "fits" / name / "result.json").read_bytes() == saved
    pd.testing.assert_frame_equal(pool, _table(killed), check_exact=True)


def test_a_row_reports_the_status_of_the_solve_its_gait_came_from():
    """A fit whose second round stops at its iteration limit while the gait kept is the
    first round's converged answer: the row's solver_status is the first round's (it said
    the last solve's, beside certified = True); iterations and solves count every solve;
    without a gait the row reports the last solve's status."""
    from types import SimpleNamespace

    from pdw_casadi.fit.result import Solve
    from pdw_casadi.studies.cohort import _fit_outcome

    solves = [Solve(0, 0, "Solve_Succeeded", 31, 49.0, 0.85),
              Solve(0, 1, "Maximum_Iterations_Exceeded", 300, 900.0, 0.84)]
    kept = SimpleNamespace(solver_status="Solve_Succeeded", certified=True)
    res = SimpleNamespace(best=kept, candidates=[kept], solves=solves)
    cand, accepted, row = _fit_outcome(res, lambda c: 0.0)
    assert cand is kept and accepted
    assert row == {"solver_status": "Solve_Succeeded", "iterations": 331, "solves": 2}
    none = SimpleNamespace(best=None, candidates=[], solves=solves)
    assert _fit_outcome(none, lambda c: 0.0)[2]["solver_status"] == "Maximum_Iterations_Exceeded"
