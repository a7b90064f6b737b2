"""Benchmark the fit: the humanlike 6-link walker (all eight compliance values free, slope
fixed, ``pdw-fit`` defaults) on curve files.

Default files: the bundled ``female_fast.csv`` and each subject's own curves
(``data/subjects``). ``--corpus``: every one-curve file of the robustness corpus
(``data/corpus``, built by ``scripts/make_corpus.py``).

Per file: the whole ``pdw-fit`` command's work in this process (reference solves, fit,
re-simulation, plots and report files into a temporary folder; compiled functions warmed up
first, so compilation is not timed), of which the fit; IPOPT status and iterations; knee /
hip / thigh R^2; spectral radius of the simulator's fixed point; re-simulation deviation;
the Table-3 compliance's R^2 on the same file. Targets checked per file: whole command
<= 15 s, Solve_Succeeded in every solve, rho <= 0.9, valid, re-simulation < 1e-6, knee
R^2 and mean(knee, hip) R^2 above Table 3's. Totals at the end (median and max wall).

    python scripts/bench_fit.py [FILE ...]
    python scripts/bench_fit.py --corpus [--only WBDS09] [--json out.json]
    python scripts/bench_fit.py --corpus --set stability_bound=power   # a FitOptions variant
    python scripts/bench_fit.py --corpus --process   # each file as its own pdw-fit process

A per-side curve file (``--sides``: every per-side file of the corpus) runs the per-leg fit
on the stride (both legs free) and its row reads the stride's answer: each leg's knee / hip
R^2, the stride's spectral radius, whether the answer is certified; targets: whole command
<= 60 s, Solve_Succeeded in every solve, certified, stable, valid, re-simulation < 1e-6.

    python scripts/bench_fit.py --sides [--set 'ipopt={...}']

``--process``: each file is fitted by its own ``pdw-fit --gait FILE --quiet`` process, as a
user runs it (warm compile cache); its wall time is the whole process's, start-up and
imports included, and the rest of the row is read from the ``summary.json`` it writes (the
targets as above, with the whole-command goals: every file <= 20 s, median <= 10 s).
No ``--set`` with ``--process``: the command's own defaults are measured.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import fields
from pathlib import Path

import numpy as np

from pdw_casadi.fit import FitOptions
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.stability import RADIUS_BOUND
from pdw_casadi.model.gait_data import SideCurves, load_gait_file
from pdw_casadi.model.problem import load_problem
from pdw_casadi.report.fit_report import write_fit_report
from pdw_casadi.report.fit_stride_report import write_fit_stride_report
from pdw_casadi.studies.fit_run import run_fit

ROOT = Path(__file__).resolve().parents[1]
GOAL_S = 15.0  # whole command, warm, per file (in one process)
GOAL_PROCESS_S = 20.0  # whole pdw-fit process, warm, per file
GOAL_MEDIAN_S = 10.0
GOAL_SIDES_S = 60.0  # a per-leg fit's whole command, warm, per file


def corpus_files(sides: bool = False) -> list[str]:
    """The corpus's one-curve files (``--sides``: the per-side files instead)."""
    pat = "*_sides.csv" if sides else "*.csv"
    files = sorted(str(p) for p in (ROOT / "data" / "corpus").glob(pat))
    return files if sides else [f for f in files if not f.endswith("_sides.csv")]


def parse_set(items: list[str], options=FitOptions) -> dict:
    """``KEY=VALUE`` pairs of the dataclass ``options``' fields (VALUE parsed as JSON, else a
    string)."""
    names = {f.name for f in fields(options)}
    out = {}
    for item in items:
        key, _, value = item.partition("=")
        if key not in names:
            raise SystemExit(f"error: {options.__name__} has no field {key!r}")
        try:
            out[key] = json.loads(value)
        except ValueError:
            out[key] = value
        if isinstance(out[key], list):
            out[key] = tuple(out[key])
    return out


def process_summary(f: str) -> tuple[dict, float]:
    """``pdw-fit --gait f`` as its own process: its summary.json and wall time (s)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "fit"
        t0 = time.perf_counter()
        done = subprocess.run(["pdw-fit", "--gait", f, "--out", str(out), "--quiet"],
                              capture_output=True, text=True, env=os.environ.copy())
        wall = time.perf_counter() - t0
        if not (out / "summary.json").is_file():
            raise SystemExit(f"error: pdw-fit on {f} wrote no summary (exit "
                             f"{done.returncode}): {done.stderr.strip()[-300:]}")
        return json.loads((out / "summary.json").read_text()), wall


def bench_one(problem, f: str, overrides: dict, process: bool = False) -> dict:
    """The whole fit command on one file: its timing, solver outcome, checks (``process``:
    as its own ``pdw-fit`` process)."""
    if process:
        s, wall = process_summary(f)
        return _row(f, s, wall, GOAL_PROCESS_S)
    human = load_gait_file(f)
    opts = FitOptions(verbose=False, **overrides)
    sides = isinstance(human, SideCurves)
    write = write_fit_stride_report if sides else write_fit_report
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        s = write(run_fit(problem, human, opts, log=lambda m: None), Path(tmp))
        wall = time.perf_counter() - t0
    return _sides_row(f, s, wall) if sides else _row(f, s, wall, GOAL_S)


def _sides_row(f: str, s: dict, wall: float) -> dict:
    """A per-side file's row from its per-leg fit's summary.json ``s`` and the command's
    wall time (s)."""
    solver = s["solver"]
    legs = s.get("legs", {})
    row = {"file": Path(f).name, "wall_s": wall, "fit_s": solver["wall_time_s"],
           "status": solver["status"], "statuses": [x["status"] for x in solver["solves"]],
           "iterations": [x["iterations"] for x in solver["solves"]],
           **{f"r2_{j}_{leg}": legs.get(leg, {}).get(f"r2_{j}", np.nan)
              for leg in ("left", "right") for j in ("knee", "hip")},
           "stride_rho": s.get("stride_spectral_radius", np.nan),
           "resim": s.get("resimulation_deviation", np.nan),
           "accepted": bool(s.get("accepted")), "certified": bool(s.get("certified")),
           "valid": bool(s["valid"]), "stable": bool(s["stable"])}
    row["checks"] = {
        "time": wall <= GOAL_SIDES_S,
        "ipopt": bool(solver["solves"]) and all(x == "Solve_Succeeded"
                                                 for x in row["statuses"]),
        "certified": row["certified"],
        "stable": row["stable"],
        "valid": row["valid"] and row["resim"] < FitOptions.resim_tol,
    }
    return row


def _row(f: str, s: dict, wall: float, goal_s: float) -> dict:
    """A file's row from its summary.json ``s`` and the command's wall time (s)."""
    solver = s["solver"]
    t3 = s["comparison"]["table3"]
    row = {"file": Path(f).name, "wall_s": wall, "fit_s": solver["wall_time_s"],
           "status": solver["status"], "statuses": [x["status"] for x in solver["solves"]],
           "iterations": [x["iterations"] for x in solver["solves"]],
           "r2_knee": s.get("r2_knee", np.nan), "r2_hip": s.get("r2_hip", np.nan),
           "r2_thigh": s.get("r2_thigh", np.nan), "rho": s.get("spectral_radius", np.nan),
           "resim": s.get("resimulation_deviation", np.nan),
           "t3_knee": t3.get("r2_knee", np.nan), "t3_hip": t3.get("r2_hip", np.nan),
           "t3_thigh": t3.get("r2_thigh", np.nan), "accepted": bool(s.get("accepted")),
           "valid": bool(s["valid"]), "stable": bool(s["stable"])}
    row["checks"] = {
        "time": wall <= goal_s,
        "ipopt": bool(solver["solves"]) and all(x == "Solve_Succeeded"
                                                 for x in row["statuses"]),
        "stable": row["stable"] and row["rho"] <= RADIUS_BOUND,  # the fit's NLP bound
        "valid": row["valid"] and row["resim"] < FitOptions.resim_tol,
        "knee>T3": row["r2_knee"] > row["t3_knee"],
        "mean>T3": row["r2_knee"] + row["r2_hip"] > row["t3_knee"] + row["t3_hip"],
    }
    return row


def line(r: dict) -> str:
    missed = [k for k, v in r["checks"].items() if not v]
    it = "+".join(str(i) for i in r["iterations"]) or "-"
    if "stride_rho" in r:  # a per-side file's row
        return (f"{r['file']:22s} {r['wall_s']:6.1f} {r['fit_s']:6.1f} "
                f"{str(r['status'])[:16]:16s} {it:>11s} L {r['r2_knee_left']:6.3f} "
                f"{r['r2_hip_left']:6.3f} R {r['r2_knee_right']:6.3f} {r['r2_hip_right']:6.3f} "
                f"{r['stride_rho']:6.4f} {r['resim']:8.1e} | "
                f"{'all met' if not missed else 'missed: ' + ', '.join(missed)}")
    return (f"{r['file']:22s} {r['wall_s']:6.1f} {r['fit_s']:6.1f} {str(r['status'])[:16]:16s} "
            f"{it:>7s} {r['r2_knee']:6.3f} {r['r2_hip']:6.3f} {r['r2_thigh']:6.3f} "
            f"{r['rho']:6.4f} {r['resim']:8.1e} | {r['t3_knee']:6.3f} {r['t3_hip']:6.3f} "
            f"{r['t3_thigh']:6.3f} | {'all met' if not missed else 'missed: ' + ', '.join(missed)}")


def totals(rows: list[dict]) -> str:
    n = len(rows)
    walls = np.array([r["wall_s"] for r in rows])
    count = {k: sum(r["checks"][k] for r in rows) for k in rows[0]["checks"]} if rows else {}
    met = sum(all(r["checks"].values()) for r in rows)
    return (f"{n} files: all targets met on {met}; " +
            ", ".join(f"{k} {v}/{n}" for k, v in count.items()) +
            f"; wall median {np.median(walls):.1f} s, max {walls.max():.1f} s, "
            f"total {walls.sum():.0f} s; iterations median "
            f"{np.median([sum(r['iterations']) for r in rows]):.0f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--corpus", action="store_true", help="the corpus's one-curve files")
    ap.add_argument("--problem", default="humanlike_6link",
                    help="the walker (a bundled name or a problem file; not with --process)")
    ap.add_argument("--sides", action="store_true",
                    help="the corpus's per-side files (the per-leg fit)")
    ap.add_argument("--only", default="", help="only files whose name contains this")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a FitOptions field (repeatable)")
    ap.add_argument("--json", type=Path, help="write the rows to this JSON file")
    ap.add_argument("--process", action="store_true",
                    help="each file as its own pdw-fit process (whole-command wall time)")
    args = ap.parse_args(argv)
    files = list(args.files)
    if args.corpus:
        files += corpus_files()
    if args.sides:
        files += corpus_files(sides=True)
    if not files:
        files = ["female_fast.csv", *sorted(str(p) for p in (ROOT / "data" / "subjects").glob(
            "*_fast.csv"))]
    files = [f for f in files if args.only in Path(f).name]
    sides = [isinstance(load_gait_file(f), SideCurves) for f in files]
    if any(sides) and not all(sides):
        raise SystemExit("error: per-side and one-curve files in one run: their rows and "
                         "targets differ (run them apart)")
    if any(sides) and args.process:
        raise SystemExit("error: --process measures one-curve files (pdw-fit's summary of a "
                         "per-leg fit has other fields)")
    overrides = parse_set(args.set)
    if args.process and overrides:
        raise SystemExit("error: --process measures the command's defaults (no --set)")
    if args.process and args.problem != "humanlike_6link":
        raise SystemExit("error: --process measures the bundled walker's command")
    problem = load_problem(args.problem)
    if args.process:
        print(f"each file as its own pdw-fit process; load average {os.getloadavg()[0]:.2f}")
    else:
        find_fixed_point(problem)  # warm-up: the simulator's libraries
        # the first file's kind of fit, one iteration: the rows' times are warm (a per-side
        # file's first row would otherwise pay for compiling the stride's functions)
        warm = bench_one(problem, files[0] if files and sides[0] else "female_fast.csv",
                         {**overrides, "max_iter": 1, "rounds": 1})
        print(f"warm-up done ({warm['wall_s']:.1f} s); options {overrides or 'defaults'}")
    if files and all(sides):
        print(f"{'file':22s} {'wall':>6s} {'fit':>6s} {'status':16s} {'iter':>11s}   "
              f"{'knee':>6s} {'hip':>6s}   {'knee':>6s} {'hip':>6s} {'rho2':>6s} "
              f"{'resim':>8s} | targets (L: left leg, R: right, rho2: the stride's)",
              flush=True)
    else:
        print(f"{'file':22s} {'wall':>6s} {'fit':>6s} {'status':16s} {'iter':>7s} {'knee':>6s} "
              f"{'hip':>6s} {'thigh':>6s} {'rho':>6s} {'resim':>8s} | {'T3knee':>6s} "
              f"{'T3hip':>6s} {'T3thi':>6s} | targets", flush=True)
    rows = []
    for f in files:
        r = bench_one(problem, f, overrides, process=args.process)
        rows.append(r)
        print(line(r), flush=True)
        if args.json:
            args.json.write_text(json.dumps({"options": overrides, "rows": rows}, indent=1,
                                            default=float))
    print(totals(rows))
    if args.process:
        print(f"median whole command {np.median([r['wall_s'] for r in rows]):.1f} s (goal "
              f"<= {GOAL_MEDIAN_S:g} s); load average {os.getloadavg()[0]:.2f}")
    return 0 if all(all(r["checks"].values()) for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
