"""Faults a user meets beside bad input (issue 28), one test per defect: Ctrl-C swallowed by
IPOPT, failed writes leaving mixtures, a damaged compile cache, work before checks, two runs
into one output, degenerate curves, pdw-scale's TOML and walkers, ``--out ''``, and
pdw-design / pdw-atlas under the contract. The whole corpus is ``scripts/faults.py``."""

from __future__ import annotations

import errno
import json
import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
import tomllib
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from conftest import run

from pdw_casadi.cli import atlas_main, design_main, fit_main, scale_main, simulate_main
from pdw_casadi.cli.contract import Outputs, UsageError
from pdw_casadi.engine import interrupt
from pdw_casadi.engine.errors import GaitDataError
from pdw_casadi.model.gait_data import load_gait_curves, load_side_curves
from pdw_casadi.model.problem import load_problem

ROOT = Path(__file__).resolve().parents[1]
CG = ["--problem", "compass_gait"]




def one_error_line(code, err, *fragments, exit_code=2):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == exit_code, err
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for f in fragments:
        assert f in lines[0], lines[0]


def earlier_run(path: Path) -> dict[str, bytes]:
    path.mkdir(parents=True, exist_ok=True)
    for name in ("summary.json", "trajectory.csv", "ipopt.log", "sweep.csv"):
        (path / name).write_text(f"earlier {name}\n")
    return snapshot(path)


def snapshot(path: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(path.iterdir())}


def env(**extra) -> dict:
    e = {**os.environ, "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1", **extra}
    e.pop("PDW_DEBUG", None)
    return e


def command(*args) -> list[str]:
    return [sys.executable, "-m", "pdw_casadi.cli", *args]


# -- 1. Ctrl-C is not swallowed by IPOPT / CasADi -------------------------------------------------
def _progress(n=1, m=1):
    from pdw_casadi.nlp.driver import Progress

    g, x = np.zeros(m), np.zeros(n)
    return Progress(n, m, g, g, x - 10, x + 10, lambda x: {}, False, None)


def test_1_progress_callback_asks_ipopt_to_stop_when_a_signal_is_pending():
    progress = _progress()
    args = [ca.DM(np.zeros(s.shape)) for s in
            (progress.sparsity_in(i) for i in range(progress.n_in()))]
    with interrupt.handling():
        assert progress.eval(args) == [0]
        interrupt._pending.append(signal.SIGINT)  # as the handler records it
        assert progress.eval(args) != [0]
        with pytest.raises(KeyboardInterrupt):
            interrupt.check()


def test_1_ctrl_c_inside_an_ipopt_callback_ends_the_solve_and_is_raised_after_it():
    """The signal lands inside a Python callback of the NLP: CasADi catches the exception
    and IPOPT returns; the driver's check re-raises it instead of carrying on."""
    from pdw_casadi.engine.callback import NumericFunction

    calls = []

    def value(a):
        calls.append(1)
        if len(calls) == 3:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.5)  # the handler runs here
        return [ca.sumsqr(a[0] - 3)]

    xs, o = ca.SX.sym("x", 2), ca.SX.sym("o")
    jac = ca.Function("jac_f", [xs, o], [ca.jacobian(ca.sumsqr(xs - 3), xs)])
    x = ca.MX.sym("x", 2)
    f = NumericFunction("f", [ca.Sparsity.dense(2, 1)], [ca.Sparsity.dense(1, 1)], value,
                        lambda name: jac)
    progress = _progress(2, 0)  # CasADi does not hold Python callbacks alive
    solver = ca.nlpsol("s", "ipopt", {"x": x, "f": f(x)},
                       {"ipopt.print_level": 0, "print_time": False,
                        "ipopt.hessian_approximation": "limited-memory",
                        "iteration_callback": progress})
    with interrupt.handling(), pytest.raises(KeyboardInterrupt):
        solver(x0=[0, 0])
        interrupt.check()
    assert len(calls) < 50  # the solve stopped, not ran to the end


@pytest.mark.slow
def test_1_sigint_during_an_ipopt_iteration_of_pdw_fit(tmp_path):
    """Acceptance: SIGINT after pdw-fit's first IPOPT iteration: exit 130 within 5 s, the
    ``interrupted:`` line, the earlier run's summary.json unchanged."""
    out = tmp_path / "fit"
    before = earlier_run(out)
    p = subprocess.Popen(command("fit", "--gait", "female_fast.csv", "--out", str(out),
                                 "--max-iter", "30", "--rounds", "1"),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env(), cwd=tmp_path)
    for line in p.stderr:
        if line.startswith("iter"):
            break
    t0 = time.perf_counter()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    took = time.perf_counter() - t0
    assert p.returncode == 130, err
    assert took < 5.0, took
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines[-1].startswith("interrupted:") and "Traceback" not in err
    assert snapshot(out) == before


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_1_signal_while_simulating_ends_the_process_and_keeps_the_earlier_run(tmp_path,
                                                                             signum, code):
    out = tmp_path / "o"
    before = earlier_run(out)
    p = subprocess.Popen(command("simulate", *CG, "--steps", "400", "--out", str(out)),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=env(), cwd=tmp_path)
    buf = ""
    while "pdw-simulate:" not in buf:  # the progress bar: the run is stepping
        ch = p.stderr.read(1)
        assert ch, buf
        buf += ch
    t0 = time.perf_counter()
    p.send_signal(signum)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, buf + err
    assert time.perf_counter() - t0 < 5.0
    assert err.strip().splitlines()[-1].startswith("interrupted:")
    assert snapshot(out) == before


def test_1_a_swallowed_interrupt_still_ends_the_run_as_interrupted(tmp_path, capsys,
                                                                  monkeypatch):
    """A solver that catches the KeyboardInterrupt and returns: the run must not go on to
    write a result over the earlier one."""
    from pdw_casadi.gait.simulate import Simulator

    real = Simulator.run

    def swallowing(self, *a, **k):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
        except KeyboardInterrupt:
            pass  # what CasADi does to an exception in a callback
        return real(self, *a, **k)

    monkeypatch.setattr(Simulator, "run", swallowing)
    out = tmp_path / "o"
    before = earlier_run(out)
    code, _, err = run(capsys, simulate_main, [*CG, "--out", str(out)])
    assert code == 130 and err.strip().startswith("interrupted:"), err
    assert snapshot(out) == before


# -- 2. a failed write: exit 1, the earlier run whole, no mixture ---------------------------------
def test_2_a_failed_write_keeps_the_earlier_run_and_names_the_file(tmp_path, capsys,
                                                                  monkeypatch):
    import pdw_casadi.report.plots as plots

    def full(*a, **k):
        raise OSError(errno.EFBIG, "File too large")

    monkeypatch.setattr(plots, "plot_stick", full)
    out = tmp_path / "o"
    before = earlier_run(out)
    code, _, err = run(capsys, simulate_main, [*CG, "--steps", "2", "--out", str(out)])
    one_error_line(code, err, "could not write", str(out), "File too large", exit_code=1)
    assert snapshot(out) == before  # no new trajectory.csv beside the old summary.json


def test_2_a_file_size_limit_is_a_write_error_not_bad_input(tmp_path):
    out = tmp_path / "o"
    before = earlier_run(out)

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    res = subprocess.run(command("simulate", *CG, "--steps", "20", "--out", str(out)),
                         capture_output=True, text=True, env=env(), cwd=tmp_path,
                         preexec_fn=limit, timeout=300)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip() and "\r" not in ln]
    assert res.returncode == 1, res.stderr
    assert lines[-1].startswith(f"error: could not write {out}"), res.stderr
    assert snapshot(out) == before
    assert not [p for p in out.iterdir() if p.name.startswith(".pdw-partial")]


def test_2_scale_writes_its_file_whole_or_not_at_all(tmp_path, capsys, monkeypatch):
    import pdw_casadi.cli.scale as cli_scale

    target = tmp_path / "p.toml"
    target.write_text("# earlier\n")

    def cut(problem, header=""):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(cli_scale, "problem_toml", cut)
    # test_scaling's body: one scaled walker compiled for both (a new body is a new build)
    code, _, err = run(capsys, scale_main, ["--mass", "62.5", "--height", "1.70", "--body",
                                            "uniform", "--out", str(target)])
    assert code == 1 and "could not write" in err, err
    assert target.read_text() == "# earlier\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.toml"]


# -- 3. a damaged compile cache heals --------------------------------------------------------------
_CACHE_SCRIPT = textwrap.dedent("""
    import sys
    import casadi as ca
    import numpy as np
    from pdw_casadi.engine.compile import native
    x = ca.SX.sym("x", 3)
    f = ca.Function("pdw_faults_probe", [x], [ca.sin(x) * 2 + x[0]])
    out = native([f], ("-O0",))[0](np.array([0.1, 0.2, 0.3]))
    want = np.asarray(f(np.array([0.1, 0.2, 0.3])))
    assert np.allclose(out, want), (out, want)
    print("ok")
""")


def _probe(cache) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", _CACHE_SCRIPT], capture_output=True,
                          text=True, env=env(PDW_CACHE=str(cache)), timeout=300)


@pytest.mark.parametrize("damage", ["truncated", "empty", "foreign", "no-record-truncated"])
def test_3_a_damaged_cached_library_is_rebuilt_with_one_warning(tmp_path, damage):
    cache = tmp_path / "cache"
    first = _probe(cache)
    assert first.returncode == 0 and first.stdout == "ok\n", first.stderr
    [so] = cache.glob("pdw_faults_probe_*.so")
    data = so.read_bytes()
    if damage in ("truncated", "no-record-truncated"):
        so.write_bytes(data[: len(data) // 2])
    elif damage == "empty":
        so.write_bytes(b"")
    else:  # another build's library under this name
        y = ca.SX.sym("y")
        other = ca.Function("other", [y], [y ** 2])
        from pdw_casadi.engine.compile import _library

        os.environ["PDW_CACHE"], saved = str(tmp_path / "other"), os.environ.get("PDW_CACHE")
        try:
            lib = _library([other], ("-O0",))
        finally:
            if saved is None:
                del os.environ["PDW_CACHE"]
            else:
                os.environ["PDW_CACHE"] = saved
        so.write_bytes(lib.read_bytes())
    if damage.startswith("no-record"):  # a cache of the code before the checksums
        for rec in cache.glob("*.sum"):
            rec.unlink()
    second = _probe(cache)
    assert second.returncode == 0 and second.stdout == "ok\n", second.stderr
    warnings = [ln for ln in second.stderr.splitlines() if ln.startswith("warning:")]
    assert len(warnings) == 1 and "damaged compiled library" in warnings[0], second.stderr
    third = _probe(cache)
    assert third.returncode == 0 and third.stderr == "", third.stderr


def test_3_an_older_cache_without_records_is_kept(tmp_path):
    cache = tmp_path / "cache"
    assert _probe(cache).returncode == 0
    for rec in cache.glob("*.sum"):
        rec.unlink()
    again = _probe(cache)
    assert again.returncode == 0 and again.stderr == "", again.stderr
    assert list(cache.glob("*.sum"))  # probed once, then recorded


def test_3_an_unusable_cache_path_falls_back_with_one_warning(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    res = _probe(blocker / "cache")
    assert res.returncode == 0 and res.stdout == "ok\n", res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: compile cache"), res.stderr


# -- 4. checks before work ------------------------------------------------------------------------
def test_4_design_checks_its_output_before_designing(tmp_path, capsys, monkeypatch):
    import pdw_casadi.cli.design as cli_design

    def never(*a, **k):
        raise AssertionError("designed before the checks")

    monkeypatch.setattr(cli_design, "design_prosthesis_nlp", never)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    code, _, err = run(capsys, design_main, ["--out", str(blocker / "p.toml")])
    one_error_line(code, err, "--out")


def test_4_atlas_checks_its_output_and_curves_before_fitting(tmp_path, capsys, monkeypatch):
    import pdw_casadi.cli.atlas as cli_atlas

    def never(*a, **k):
        raise AssertionError("fitted before the checks")

    monkeypatch.setattr(cli_atlas, "build_atlas", never)  # the name the command calls
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    code, _, err = run(capsys, atlas_main, ["--out", str(blocker / "a.json")])
    one_error_line(code, err, "--out")
    code, _, err = run(capsys, atlas_main, ["--curves", str(tmp_path / "missing.csv"),
                                            "--out", str(tmp_path / "a.json")])
    one_error_line(code, err, "missing.csv")


def test_4_a_malformed_atlas_is_bad_input_and_keeps_the_earlier_log(tmp_path, capsys):
    out = tmp_path / "fit"
    before = earlier_run(out)
    bad = tmp_path / "atlas.json"
    bad.write_text('{"entries": [{"label": 1}]}')
    code, _, err = run(capsys, fit_main, ["--gait", "female_fast.csv", "--atlas", str(bad),
                                          "--out", str(out)])
    one_error_line(code, err, "--atlas", "not a gait atlas")
    assert snapshot(out) == before


# -- 5. one run per output directory --------------------------------------------------------------
def test_5_a_second_run_into_a_busy_directory_is_refused(tmp_path):
    first, second = Outputs(tmp_path / "o"), Outputs(tmp_path / "o")
    stage = first.create()
    with pytest.raises(UsageError, match="another run"):
        second.create()
    (stage / "sweep.csv").write_text("rows\n")
    first.commit()
    assert (tmp_path / "o" / "sweep.csv").read_text() == "rows\n"
    second.create()  # free again once the first run is done
    second.discard()
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["sweep.csv"]


@pytest.mark.slow
def test_5_two_sweeps_into_one_directory_leave_one_whole_sweep(tmp_path):
    out = tmp_path / "o"
    args = command("sweep", *CG, "--from", "0.04", "--to", "0.06", "--num", "7", "--out",
                   str(out))
    procs = [subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=env(), cwd=tmp_path) for _ in range(2)]
    results = [(p.wait(600), p.stderr.read()) for p in procs]
    codes = sorted(c for c, _ in results)
    assert codes in ([0, 0], [0, 2]), results
    for c, err in results:
        if c == 2:
            assert "another run" in err
    # every grid point (a continuation adds located points): not 2 of 7 as two runs sharing
    # one partial file left
    assert len((out / "sweep.csv").read_text().splitlines()) >= 1 + 7


# -- 6. degenerate curves are rejected at validation --------------------------------------------
def _curves(tmp_path, name, **cols):
    pct = np.linspace(0, 100, 51)
    base = {"knee_mean_deg": 30 + 30 * np.sin(2 * np.pi * pct / 100),
            "hip_mean_deg": 10 + 20 * np.cos(2 * np.pi * pct / 100)}
    base.update({k: (np.full_like(pct, v) if np.isscalar(v) else v) for k, v in cols.items()})
    if any("_left_" in k for k in cols):
        base.pop("knee_mean_deg")
        base.pop("hip_mean_deg")
    lines = [",".join(["cycle_pct", *base])]
    lines += [",".join(repr(float(v)) for v in row) for row in zip(pct, *base.values(),
                                                                    strict=True)]
    path = tmp_path / f"{name}.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("cols, fragment", [
    ({"knee_mean_deg": 20.0}, "constant"),
    ({"hip_mean_deg": -5.0}, "constant"),
    ({"knee_mean_deg": 1e7}, "beyond"),
    ({"knee_sd_deg": 1e9}, "beyond"),
])
def test_6_degenerate_curves_fail_validation(tmp_path, cols, fragment):
    path = _curves(tmp_path, "c", **cols)
    with pytest.raises(GaitDataError, match=fragment):
        load_gait_curves(path)


def test_6_a_constant_side_fails_validation(tmp_path):
    pct = np.linspace(0, 100, 51)
    knee = 30 + 30 * np.sin(2 * np.pi * pct / 100)
    hip = 10 + 20 * np.cos(2 * np.pi * pct / 100)
    path = _curves(tmp_path, "sides", knee_left_mean_deg=knee, hip_left_mean_deg=hip,
                   knee_right_mean_deg=15.0, hip_right_mean_deg=hip)
    with pytest.raises(GaitDataError, match="knee_right_mean_deg.*constant"):
        load_side_curves(path)


def test_6_a_constant_knee_is_one_error_line_of_pdw_fit(tmp_path, capsys):
    path = _curves(tmp_path, "c", knee_mean_deg=20.0)
    code, _, err = run(capsys, fit_main, ["--gait", str(path), "--out", str(tmp_path / "o")])
    one_error_line(code, err, "constant")
    assert not (tmp_path / "o").exists()


# -- 7. pdw-scale ---------------------------------------------------------------------------------
def test_7_problem_toml_makes_its_header_comments():
    """A header given without its comment sign (scripts/make_prosthetist_study.py wrote
    "10 % lighter: ...") still gives a file that loads, to the same walker; a header that
    is already a comment is kept as it is."""
    from pdw_casadi.model.problem import load_problem, problem_toml

    pb = load_problem("humanlike_6link")
    for header in ("10 % lighter: data/corpus/WBDS09_sides.csv",
                   "two lines\n# and a comment\n", "# written by pdw-design\n",
                   "a form feed\x0c and a vertical tab\x0b inside\r"):
        text = problem_toml(pb, header)
        data = tomllib.loads(text)
        assert data["compliance"] == {k: float(v) for k, v in pb.compliance.items()}
        assert text.splitlines()[0].startswith("# ")
    assert problem_toml(pb, "# written by pdw-design\n").startswith(
        "# written by pdw-design\n\n[walker]")


def test_7_problem_toml_quotes_a_title_with_quotes_and_backslashes():
    from pdw_casadi.model.problem import problem_toml

    title = 'a "quoted" title with a back\\slash\tand a tab'
    pb = load_problem("humanlike_6link").replace(title=title)
    assert tomllib.loads(problem_toml(pb))["walker"]["title"] == title


def test_7_scale_refuses_a_walker_without_thigh_and_shank_in_one_line(tmp_path, capsys):
    code, out, err = run(capsys, scale_main, ["--problem", "compass_gait", "--mass", "60",
                                              "--height", "1.7",
                                              "--out", str(tmp_path / "p.toml")])
    one_error_line(code, err, "compass_gait", "cannot be scaled")
    assert not (tmp_path / "p.toml").exists()


# -- 8. --out '' ----------------------------------------------------------------------------------
@pytest.mark.parametrize("main, args", [
    (simulate_main, CG), (fit_main, ["--gait", "female_fast.csv"]),
    (scale_main, ["--mass", "60", "--height", "1.7"]), (design_main, []), (atlas_main, [])])
def test_8_an_empty_out_is_refused(tmp_path, capsys, monkeypatch, main, args):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, main, [*args, "--out", ""])
    one_error_line(code, err, "--out")
    assert list(tmp_path.iterdir()) == []


# -- 9. pdw-design and pdw-atlas keep the contract ------------------------------------------------
@pytest.mark.parametrize("main, args, fragment", [
    (design_main, ["--lighter", "nan"], "--lighter"),
    (design_main, ["--lighter", "-0.3"], "--lighter"),
    (design_main, ["--start", "no_such_walker.toml"], "--start"),
    (design_main, ["--max-iter", "-1"], "--max-iter"),
    (design_main, ["--family", "humanlike_6link_ankle", "--extension", "k=nan"],
     "--extension"),
    (design_main, ["--no-such-flag"], "unrecognized"),
    (atlas_main, ["--radius", "nan"], "--radius"),
    (atlas_main, ["--radius", "1.5"], "--radius"),
    (atlas_main, ["--problem", "no_such_walker"], "no_such_walker"),
])
def test_9_design_and_atlas_errors_are_one_line(capsys, main, args, fragment):
    code, _, err = run(capsys, main, args)
    one_error_line(code, err, fragment)
    assert "Traceback" not in err


def test_9_design_writes_its_walker_through_the_contract(tmp_path, capsys, monkeypatch):
    """An unexpected failure inside the design is one line, exit 1, and no file."""
    import pdw_casadi.cli.design as cli_design

    def broken(*a, **k):
        raise RuntimeError("boom")

    monkeypatch.setattr(cli_design, "design_prosthesis_nlp", broken)
    code, _, err = run(capsys, design_main, ["--out", str(tmp_path / "p.toml")])
    assert code == 1 and err.startswith("error: internal error"), err
    assert len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_the_fault_corpus_lists_at_least_60_cases():
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "faults.py"), "--list"],
                         capture_output=True, text=True, timeout=120, env=env())
    assert res.returncode == 0, res.stderr
    n = int(res.stdout.strip().splitlines()[-1].split()[0])
    assert n >= 60
    kinds = {line.split("-")[0] for line in res.stdout.splitlines()[:-1]}
    assert {"signal", "fsize", "cache", "concurrent", "degenerate"} <= kinds


def test_json_of_a_summary_is_still_strict(tmp_path):
    """The staged write goes through the same JSON writer (NaN -> null)."""
    from pdw_casadi.engine.jsonio import write_json

    p = write_json(tmp_path / "s.json", {"x": float("nan")})
    assert json.loads(p.read_text()) == {"x": None}


# -- 10. pdw-scale --subject with a damaged subjects table ------------------------------------
@pytest.mark.parametrize("case, fragment", [("no mass column", "no column mass_kg"),
                                            ("mass nan", "outside the adult range"),
                                            ("height text", "must be numbers")])
@pytest.mark.parametrize("body", ["deleva", "uniform"])
def test_10_scale_refuses_a_damaged_subjects_table_before_any_progress_line(
        tmp_path, capsys, monkeypatch, case, fragment, body):
    """The subjects table is checked before the first progress line: a missing column or a
    mass/height that is not a number in the table's range ends in one error line naming the
    table, exit code 2, nothing written (it was an internal KeyError, or a progress line
    followed by the error)."""
    import pandas as pd

    from pdw_casadi.engine.resources import bundled_dir
    from pdw_casadi.studies import scaling

    table = pd.read_csv(bundled_dir("data") / scaling.SUBJECTS_FILE)
    if case == "no mass column":
        table = table.drop(columns="mass_kg")
    elif case == "mass nan":
        table["mass_kg"] = float("nan")
    else:
        table["height_m"] = table["height_m"].astype(object)
        table.loc[:, "height_m"] = "tall"
    path = tmp_path / "subjects.csv"
    table.to_csv(path, index=False)
    monkeypatch.setattr(scaling, "SUBJECTS_FILE", str(path))  # an absolute path wins
    out = tmp_path / "w.toml"
    code, _, err = run(capsys, scale_main, ["--subject", str(table["subject_id"][0]),
                                            "--body", body, "--out", str(out)])
    one_error_line(code, err, "subjects.csv", fragment)
    assert not out.exists()
