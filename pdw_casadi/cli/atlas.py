"""``pdw-atlas``: rebuild a walker's gait atlas (stable gaits fitted to curve files)."""

from __future__ import annotations

import sys
from pathlib import Path

from pdw_casadi.cli.contract import Parser
from pdw_casadi.fit.atlas import VARIANTS, build_atlas
from pdw_casadi.fit.starts import atlas_path, save_atlas
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem


def atlas_main(argv=None) -> int:
    ap = Parser(prog="pdw-atlas",
                                 description="Rebuild a walker's gait atlas.")
    ap.add_argument("--problem", default="humanlike_6link")
    ap.add_argument("--radius", type=float, nargs="+", default=[0.91, 0.86],
                    help="stability levels of the seeds")
    ap.add_argument("--variants", choices=("own", "all"), default="own",
                    help="fit the walker's own curves only (the shipped atlas) or also "
                         "their deformations (VARIANTS)")
    ap.add_argument("--curves", nargs="*", default=["female_fast.csv"], metavar="FILE",
                    help="human curve files whose fitted gaits become entries (default: the "
                         "bundled female_fast.csv; none with an empty list)")
    ap.add_argument("--out", type=Path, help="atlas file (default: the bundled one)")
    args = ap.parse_args(argv)
    problem = load_problem(args.problem)
    entries = build_atlas(problem, tuple(args.radius),
                          VARIANTS if args.variants == "all" else VARIANTS[:1],
                          tuple(load_gait_curves(f) for f in args.curves))
    if not entries:
        print("error: no entry", file=sys.stderr)
        return 1
    print(f"wrote {save_atlas(problem, entries, args.out or atlas_path(problem.name))}")
    return 0

