"""The prosthetist's study of docs/results/prosthesis.md ("A prosthetist's study"):
one subject's sound side fitted, the prosthetic leg designed 10, 20 and 30 % lighter
(:func:`pdw_casadi.studies.prosthetist.prosthetist_study`). Writes ``study.csv`` (the
table), ``study.png`` (the figure) and each level's designed walker as a problem file
into ``--out``.

    python scripts/make_prosthetist_study.py --sides data/corpus/WBDS09_sides.csv --out study
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from pdw_casadi.model.gait_data import load_side_curves
from pdw_casadi.model.problem import load_problem, problem_toml
from pdw_casadi.report.prosthetist import plot_prosthetist_study
from pdw_casadi.studies.prosthesis import DesignNLPOptions
from pdw_casadi.studies.prosthetist import (
    StudyOptions,
    prosthetist_study,
    study_design_options,
)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sides", required=True, help="a per-side curve file")
    ap.add_argument("--problem", default="humanlike_6link", help="the symmetric walker")
    ap.add_argument("--levels", default="0.1,0.2,0.3",
                    help="mass reductions of the prosthetic leg (fractions, ascending)")
    ap.add_argument("--max-iter", type=int, default=DesignNLPOptions.max_iter,
                    help="IPOPT iterations per design solve")
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    args = ap.parse_args(argv)
    levels = tuple(float(v) for v in args.levels.split(","))
    t0 = time.perf_counter()
    study = prosthetist_study(load_problem(args.problem), load_side_curves(args.sides),
                              StudyOptions(levels=levels, design=dataclasses.replace(
                                  study_design_options(), max_iter=args.max_iter)))
    args.out.mkdir(parents=True, exist_ok=True)
    study.table.to_csv(args.out / "study.csv", index=False)
    plot_prosthetist_study(study.table, title=f"{study.fitted.name}: {study.sides.name}") \
        .savefig(args.out / "study.png", dpi=110)
    for level in levels:
        try:
            walker, _ = study.design.design_at(level)
        except KeyError:
            continue
        (args.out / f"prosthesis_{round(100 * level)}pct.toml").write_text(
            problem_toml(walker, header=f"{100 * level:g} % lighter: {args.sides}"))
    print(study.table.to_string())
    print(f"wall time {time.perf_counter() - t0:.1f} s; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
