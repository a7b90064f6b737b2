"""``pdw-atlas``: rebuild a walker's gait atlas (stable gaits fitted to curve files)."""

from __future__ import annotations

import sys
from pathlib import Path

from pdw_casadi.cli.common import check_curve_walker
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    check_output_file,
    open_interval,
    output_path,
    run,
)
from pdw_casadi.fit.atlas import RADII, VARIANTS, build_atlas
from pdw_casadi.fit.starts import atlas_path, load_atlas, save_atlas, warm_path
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import DEFAULT_PROBLEM, load_problem


def atlas_main(argv=None) -> int:
    """``pdw-atlas``: fit stable gaits of ``--problem`` at each ``--radius`` to its own
    curves (and ``--variants``) and each ``--curves`` file; write the atlas (JSON). Every
    argument, curve file and the output path are checked before the fits; the atlas file is
    replaced only when the rebuild completes (exit code 1, nothing written, when no target
    gives a stable valid gait)."""
    ap = Parser(prog="pdw-atlas", description="Rebuild a walker's gait atlas.")
    ap.add_argument("--problem", default=DEFAULT_PROBLEM)
    ap.add_argument("--radius", type=open_interval("--radius", 0.0, 1.0), nargs="+",
                    default=list(RADII),
                    help="spectral-radius limits of the seeds (default: %(default)s)")
    ap.add_argument("--variants", choices=("own", "all"), default="own",
                    help="targets: the walker's own curves only, or also a set of "
                         "their deformations (VARIANTS)")
    ap.add_argument("--curves", nargs="*", default=["female_fast.csv"], metavar="FILE",
                    help="gait-curve files to seed from too (default: the "
                         "bundled female_fast.csv; none with an empty list)")
    ap.add_argument("--out", type=output_path("--out"), metavar="FILE.json",
                    help="atlas file (default: the bundled one)")
    ap.add_argument("--keep", action="store_true",
                    help="keep the entries already in the atlas file that this build does "
                         "not replace (same label: replaced), after the new ones")
    args = ap.parse_args(argv)
    outputs = Outputs(Path("."))  # one file, staged beside it

    def body() -> int:
        problem = load_problem(args.problem)
        check_curve_walker(problem, "pdw-atlas")
        curves = tuple(load_gait_curves(f) for f in args.curves)
        out = args.out or atlas_path(problem.name)
        check_output_file(out, "--out", (".json",))
        outputs.dir = Path(out)
        # read before the fits: a damaged or foreign atlas is refused before any work
        kept = load_atlas(problem, out) if args.keep and Path(out).is_file() else []
        entries = build_atlas(problem, tuple(args.radius),
                              VARIANTS if args.variants == "all" else VARIANTS[:1], curves,
                              log=lambda m: print(m, file=sys.stderr, flush=True))
        if not entries:
            raise NoGait(f"no stable valid gait of {problem.name} for any target (nothing "
                         f"written)")
        labels = {e.label for e in entries}
        entries += [e for e in kept if e.label not in labels]
        save_atlas(problem, entries, outputs.wrote(outputs.staged(out)),
                   outputs.wrote(outputs.staged(warm_path(Path(out)))))
        print(f"wrote {out}")
        return 0

    return run(outputs, body)
