"""``pdw-scale``: a problem file for a subject's body (de Leva 1996 segment table)."""

from __future__ import annotations

import sys

from pdw_casadi.cli.contract import (
    Outputs,
    Parser,
    check_output_file,
    open_interval,
    output_path,
    run,
)
from pdw_casadi.model.problem import DEFAULT_PROBLEM, load_problem, problem_toml
from pdw_casadi.report.scale_report import starting_line, write_scaled_walker, wrote_line
from pdw_casadi.studies.scale_run import BODIES, run_scale, subject_of
from pdw_casadi.studies.scaling import (
    BODY_MAX_RADIUS,
    HEIGHT_RANGE_M,
    MASS_RANGE_KG,
    SEXES,
    check_scalable,
)


def scale_main(argv=None) -> int:
    """``pdw-scale``: a problem file for a subject's body (see the module docstring).

    ``--mass KG --height M [--sex female|male]`` or ``--subject ID`` (a bundled subject);
    ``--body deleva`` (default: the de Leva 1996 body, reached by continuation from the
    uniformly scaled reference, compliance adapted, then the nearest gait with spectral
    radius <= ``--max-radius``: :func:`~pdw_casadi.studies.scaling.stable_subject_walker`)
    or ``--body uniform`` (the reference scaled by the exact law only). Writes ``--out
    FILE.toml`` with the gait found as its initial state; exit code 1 (nothing written)
    when the continuation does not reach the subject or no stable valid gait is found there.
    """
    parser = Parser(prog="pdw-scale", description="Scale the walker to a subject's body "
                    "(de Leva 1996 segment table).")
    parser.add_argument("--mass", type=open_interval("--mass", *MASS_RANGE_KG), metavar="KG",
                        help="body mass, kg ({:g}..{:g})".format(*MASS_RANGE_KG))
    parser.add_argument("--height", type=open_interval("--height", *HEIGHT_RANGE_M),
                        metavar="M", help="height, m ({:g}..{:g})".format(*HEIGHT_RANGE_M))
    parser.add_argument("--sex", choices=SEXES, default="female")
    parser.add_argument("--subject", metavar="ID",
                        help="a bundled subject (mass, height and sex from "
                             "data/anthropometry/subjects.csv), e.g. WBDS09")
    parser.add_argument("--body", choices=BODIES, default="deleva")
    parser.add_argument("--max-radius", type=open_interval("--max-radius", 0.0, 1.0),
                        default=BODY_MAX_RADIUS, metavar="R",
                        help="de Leva body: the largest spectral radius of the gait written "
                             "(default: %(default)s)")
    parser.add_argument("--problem", default=DEFAULT_PROBLEM,
                        help="reference problem (default: %(default)s)")
    parser.add_argument("--out", type=output_path("--out"), required=True, metavar="FILE.toml")
    args = parser.parse_args(argv)
    outputs = Outputs(args.out)  # one file, staged beside it

    def body() -> int:
        check_output_file(args.out, "--out", (".toml",))
        who = subject_of(args.subject, args.mass, args.height, args.sex)
        ref = load_problem(args.problem)
        check_scalable(ref)
        print(starting_line(ref.name, who, args.body), file=sys.stderr)
        scaled = run_scale(ref, who, args.body, args.out.stem, max_radius=args.max_radius,
                           log=lambda line: print(line, file=sys.stderr))
        # the renderer by the name this module holds: a test stands in for a write there
        write_scaled_walker(scaled, outputs.wrote(outputs.staged(args.out)), toml=problem_toml)
        print(wrote_line(scaled, args.out))
        return 0

    return run(outputs, body)
