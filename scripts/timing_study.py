"""The ankle-extension study: which passive ankle element gives the 6-link walker humanlike
double support, judged by the fit.

    python scripts/timing_study.py --out study [--gait female_fast.csv] [--timing]
        [--only-timing] [--table-only] [--rounds 2] [--max-iter 300]
        [--problems humanlike_6link humanlike_6link_ankle_load ...]

runs ``pdw-fit --gait GAIT --problem P --out OUT/P[_timing]`` for every problem (one after
the other) and writes ``OUT/study.md`` and ``OUT/study.csv``: per fit the double support of
each period, the stance and the heel off (% of the cycle; heel off is 50 % where the
stance heel lifts at the other heel's strike, earlier only with the forefoot rocker of
humanlike_6link_heeloff), toe off, cadence, knee/hip/thigh R^2, the spectral radius,
whether it is stable and valid, and the tightest validity margins (what binds). A fit
already in OUT/P is read, not re-run (``--rerun`` to redo).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
STUDY = ("humanlike_6link", "humanlike_6link_ankle_load", "humanlike_6link_ankle_quasistiff",
         "humanlike_6link_ankle_clutch", "humanlike_6link_ankle", "humanlike_6link_heeloff",
         "humanlike_6link_arc")


def _binding(summary: dict, problem: str, n: int = 2) -> str:
    """The ``n`` smallest validity slacks (margin minus its required minimum)."""
    from pdw_casadi.gait.fixed_point import validity_slacks
    from pdw_casadi.model.problem import load_problem

    margins = summary.get("margins") or {}
    if not margins:
        return "-"
    slacks = validity_slacks(margins, load_problem(problem))
    return "; ".join(f"{k} {v:.3g}" for k, v in sorted(slacks.items(), key=lambda kv: kv[1])[:n])


def row(name: str, out: Path, problem: str) -> dict:
    s = json.loads((out / "summary.json").read_text())
    t = s.get("timing") or {}
    ds = t.get("double_support_pct") or [float("nan")] * 2
    return {"fit": name, "double_support_pct": ds[0], "double_support_2_pct": ds[-1],
            "stance_pct": t.get("stance_pct"), "heel_off_pct": t.get("heel_off_pct"),
            "toe_off_pct": t.get("toe_off_pct"),
            "cadence_steps_min": t.get("cadence_steps_min"), "speed_m_s": t.get("speed_m_s"),
            "r2_knee": s.get("r2_knee"), "r2_hip": s.get("r2_hip"),
            "r2_thigh": s.get("r2_thigh"), "spectral_radius": s.get("spectral_radius"),
            "stable": s.get("stable"), "valid": s.get("valid"),
            "phases_ms": " ".join(f"{k} {1000 * v:.1f}" for k, v in
                                  (t.get("phase_durations_s") or {}).items()),
            "tightest margins": _binding(s, problem),
            "compliance": json.dumps({k: round(v, 4) for k, v in
                                      (s.get("compliance") or {}).items()})}


def _markdown(frame: pd.DataFrame) -> str:
    def cell(v):
        return f"{v:.3f}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(frame.columns) + " |", "|---" * len(frame.columns) + "|"]
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in frame.itertuples(index=False)]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--gait", default="female_fast.csv")
    ap.add_argument("--problems", nargs="+", default=list(STUDY))
    ap.add_argument("--timing", action="store_true", help="also each fit with --timing")
    ap.add_argument("--rerun", action="store_true")
    ap.add_argument("--rounds", default="2", help="pdw-fit --rounds (default: 2)")
    ap.add_argument("--max-iter", default="300", help="pdw-fit --max-iter (default: 300)")
    ap.add_argument("--only-timing", action="store_true",
                    help="only the fits with --timing")
    ap.add_argument("--table-only", action="store_true",
                    help="run nothing: tabulate the fits already in OUT")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.problems:
        problem = str(ROOT / "problems" / f"{name}.toml")
        kinds = (True,) if args.only_timing else (False, True) if args.timing else (False,)
        for timing in kinds:
            label = name + ("_timing" if timing else "")
            out = args.out / label
            if not args.table_only and (args.rerun or not (out / "summary.json").exists()):
                cmd = ["pdw-fit", "--gait", args.gait, "--problem", problem, "--out", str(out),
                       "--quiet", "--rounds", args.rounds,
                       "--max-iter", args.max_iter, *(["--timing"] if timing else [])]
                print("$", " ".join(cmd), flush=True)
                subprocess.run(cmd, check=False)
            if (out / "summary.json").exists():
                rows.append(row(label, out, problem))
    table = pd.DataFrame(rows)
    table.to_csv(args.out / "study.csv", index=False)
    cols = [c for c in table.columns if c != "compliance"]
    (args.out / "study.md").write_text(_markdown(table[cols]))
    print(table[cols].to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
