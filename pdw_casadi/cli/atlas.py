"""``pdw-atlas``: rebuild a walker's gait atlas (stable gaits fitted to curve files)."""

from __future__ import annotations

import sys
from pathlib import Path

from pdw_casadi.cli.common import check_curve_walker
from pdw_casadi.cli.contract import (
    Outputs,
    Parser,
    check_output_file,
    open_interval,
    output_path,
    run,
)
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import DEFAULT_PROBLEM, load_problem
from pdw_casadi.report.atlas_report import write_atlas, wrote_line
from pdw_casadi.studies.atlas_run import (
    RADII,
    VARIANT_SETS,
    atlas_file,
    atlas_variants,
    build_atlas,
    kept_entries,
    run_atlas,
    warm_path,
)


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
    ap.add_argument("--variants", choices=VARIANT_SETS, default="own",
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
        out = atlas_file(problem, args.out)
        check_output_file(out, "--out", (".json",))
        outputs.dir = Path(out)
        kept = kept_entries(problem, out, args.keep)  # a damaged atlas: refused before work
        # the builder by the name this module holds: a test stands in for the fits there
        atlas = run_atlas(problem, args.radius, atlas_variants(args.variants), curves, kept,
                          log=lambda m: print(m, file=sys.stderr, flush=True),
                          build=build_atlas)
        write_atlas(atlas, outputs.wrote(outputs.staged(out)),
                    outputs.wrote(outputs.staged(warm_path(Path(out)))))
        print(wrote_line(out))
        return 0

    return run(outputs, body)
