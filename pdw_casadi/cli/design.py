"""Design a prosthetic leg's compliance: right shank and foot lighter, gait made symmetric.

Starts from a stable gait of the bundled atlas (``--entry``, default the walker's own gait
at spectral radius 0.83) and runs the stride-NLP design
:func:`pdw_casadi.studies.prosthesis.design_prosthesis_nlp` (equal step lengths and times,
stride spectral radius <= ``DesignNLPOptions.max_stride_radius``, least relative change of
the prosthetic leg's compliance; mass homotopy, every step re-simulated); ``--method
continuation`` runs the min-norm Newton continuation
:func:`pdw_casadi.studies.prosthesis.design_prosthesis` instead (symmetry without a stability
condition). Prints how far the design got, the step lengths and times per leg with their
asymmetry, the stride's spectral radius, validity, the compliance found and the wall time.
``--out FILE.toml`` writes the designed walker as a problem file (``pdw-fixed-point
--problem FILE.toml`` re-solves it on the stride map).

The command parses and checks its arguments, runs the design workflow
(:func:`pdw_casadi.studies.design_run.run_design`) and prints and writes its result through
:mod:`pdw_casadi.report.design_report`.

    pdw-design --lighter 0.3
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    ProblemError,
    check_input_file,
    check_output_file,
    finite_float,
    int_range,
    open_interval,
    output_path,
    positive_float,
    run,
)
from pdw_casadi.model.problem import Problem, load_problem
from pdw_casadi.report.design_report import (
    design_gait_lines,
    design_headline,
    write_designed_walker,
)
from pdw_casadi.studies.design_run import (
    METHODS,
    DesignRequest,
    check_compliance_keys,
    check_mass_distribution,
    run_design,
)
from pdw_casadi.studies.prosthesis import (
    NLP_FREE,
    START_ENTRY,
    DesignNLPOptions,
    atlas_problem,
    design_prosthesis,
    design_prosthesis_nlp,
)

#: the design's settings (pdw-design passes only what its flags change)
DEFAULTS = DesignNLPOptions()


def design_parser() -> Parser:
    """The parser of ``pdw-design``: the target (``--lighter``, a fraction), the start
    (``--entry``, ``--start``, ``--family`` with ``--extension`` in SI units), the method
    and the NLP design's settings (defaults: :class:`DesignNLPOptions`), ``--out``."""
    ap = Parser(prog="pdw-design", description=__doc__.splitlines()[0])
    ap.add_argument("--lighter", type=open_interval("--lighter", 0.0, 1.0), default=0.3,
                    help="fraction by which the right shank and foot are lighter")
    ap.add_argument("--entry", default=START_ENTRY,
                    help="label of the atlas entry to start from (default: %(default)s)")
    ap.add_argument("--method", choices=METHODS, default="nlp",
                    help="stride NLP with the stability row (default) or the min-norm "
                         "Newton continuation")
    ap.add_argument("--first-step", type=open_interval("--first-step", 0.0, 1.0),
                    default=DesignNLPOptions.first_step,
                    help="first mass homotopy step of the NLP design (default: %(default)s)")
    ap.add_argument("--no-hold", action="store_true",
                    help="continuation: symmetry conditions only (do not hold the first "
                         "phase's duration)")
    ap.add_argument("--out", type=output_path("--out"), metavar="FILE.toml",
                    help="write the designed walker to this TOML file")
    ap.add_argument("--start", metavar="FILE.toml",
                    help="NLP: start from this problem file instead of an atlas entry: a "
                         "walker written by --out (continues its design: its lighter leg, "
                         "compliance and gait) or a symmetric walker (its gait near its "
                         "initial state)")
    ap.add_argument("--diagnose", action="store_true",
                    help="NLP: after every solve, log what binds (rows and bounds by "
                         "|multiplier|) and the IPOPT inf_pr/inf_du trend")
    ap.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000),
                    default=DesignNLPOptions.max_iter,
                    help="IPOPT iterations per NLP solve (default: %(default)s)")
    ap.add_argument("--mass-distribution", default="",
                    help="NLP: comma-separated body values of the prosthetic leg designed "
                         "beside its compliance (among l_sc,J_s,l_fc,J_f; bounds in "
                         "DesignNLPOptions.mass_distribution_bounds)")
    ap.add_argument("--mass-bounds", default="",
                    help="NLP: bounds of the designed mass distribution as multiples of the "
                         "sound leg's values, e.g. l_fc=0.1:4,J_f=0.05:3 (others: "
                         "DesignNLPOptions.mass_distribution_bounds)")
    ap.add_argument("--max-step", type=open_interval("--max-step", 0.0, 1.0),
                    default=DesignNLPOptions.max_step,
                    help="NLP: largest mass homotopy step (default: %(default)s)")
    ap.add_argument("--max-solves", type=int_range("--max-solves", 1, 100000),
                    default=DesignNLPOptions.max_solves,
                    help="NLP: at most this many NLP solves (default: %(default)s)")
    ap.add_argument("--free-slope", action="store_true",
                    help="NLP: the slope free too (the walker's energy supply)")
    ap.add_argument("--symmetry-tol", type=finite_float("--symmetry-tol"),
                    default=DesignNLPOptions.symmetry_tol_pct,
                    help="NLP: largest accepted |step-length| and |step-time| asymmetry, %% "
                         f"below the verdict's {DEFAULTS.symmetry_verdict_pct:g} %% "
                         "(default: %(default)s: equal steps)")
    ap.add_argument("--t-min", type=positive_float("--t-min", 1.0),
                    default=DesignNLPOptions.t_min_s,
                    help="NLP: shortest gait segment, s (default: %(default)s)")
    ap.add_argument("--family",
                    help="carry the start walker into this family, whose compliance keys "
                         "extend it (e.g. humanlike_6link_ankle: the prosthetic foot's rest "
                         "angle, loading damper and clutch spring); its extra keys' values "
                         "in --extension")
    ap.add_argument("--extension", default="",
                    help="with --family: KEY=VALUE,... for the family's extra compliance "
                         "keys (SI units), on both legs at the start")
    ap.add_argument("--free", default=",".join(NLP_FREE),
                    help="NLP: comma-separated compliance keys of the prosthetic leg to "
                         "design (default: %(default)s)")
    ap.add_argument("--free-sound", default="",
                    help="NLP: comma-separated compliance keys of the sound (left) leg that "
                         "adapt too (default: none; the sound leg keeps its compliance)")
    ap.add_argument("--accept-verified", action="store_true",
                    help="NLP: accept a solve that stopped at the iteration limit when its "
                         "answer re-simulates as stable, valid and symmetric (below "
                         f"{DEFAULTS.symmetry_verdict_pct:g} %%)")
    return ap


def design_main(argv=None) -> int:
    """``pdw-design``: the prosthetic leg's design (module docstring); the contract of
    :mod:`pdw_casadi.cli.contract`: everything checked before the solves, one-line errors."""
    ap = design_parser()
    args = ap.parse_args(argv)
    outputs = Outputs(args.out or Path("."))  # only --out FILE.toml, staged beside it

    def body() -> int:
        if args.out is not None:
            check_output_file(args.out, "--out", (".toml",))
        if args.start:
            check_input_file(Path(args.start), "--start")
        start = _start_walker(ap, args)
        request = _design_request(ap, args, start)
        # the designs by the names this module holds: a test stands in for a solve there
        design = run_design(start, request, nlp=design_prosthesis_nlp,
                            continuation=design_prosthesis)
        print("\n".join(design_headline(design, args.start or f"atlas entry {args.entry}")))
        if not design.has_gait:
            raise NoGait("no stride fixed point of the simulator at the last answer")
        print("\n".join(design_gait_lines(design)))
        if args.out:
            write_designed_walker(design, outputs.wrote(outputs.staged(args.out)))
            print(f"wrote {args.out}")
        return 0

    return run(outputs, body)


def _start_walker(ap: Parser, args: argparse.Namespace) -> Problem:
    """The walker the design starts from: ``--start`` or the atlas entry ``--entry``,
    carried into ``--family`` with the ``--extension`` values (SI units) when given."""
    start = load_problem(args.start) if args.start else atlas_problem(args.entry)
    if not args.family:
        if args.extension:
            ap.error("--extension needs --family")
        return start
    extra = {}
    for item in (i for i in args.extension.split(",") if i):
        key, _, val = item.partition("=")
        try:
            extra[key] = finite_float("--extension")(val)
        except argparse.ArgumentTypeError:
            ap.error(f"--extension: {item!r} is not KEY=VALUE with a number (finite)")
    try:
        return start.in_family(args.family, extra)
    except (ProblemError, KeyError) as exc:
        ap.error(f"--family {args.family}: {exc}")


def _mass_bounds(ap: Parser, args: argparse.Namespace, dist: tuple[str, ...]) -> dict:
    """The bounds of the designed mass distribution (multiples of the sound leg's values,
    -): the defaults with ``--mass-bounds`` KEY=LO:HI applied."""
    bounds = dict(DesignNLPOptions().mass_distribution_bounds)
    for item in (i for i in args.mass_bounds.split(",") if i):
        key, _, rng = item.partition("=")
        if key not in dist or rng.count(":") != 1:
            ap.error(f"--mass-bounds: {item!r} is not KEY=LO:HI with KEY among the "
                     f"--mass-distribution keys ({', '.join(dist) or 'none given'})")
        try:
            lo, hi = (finite_float("--mass-bounds")(v) for v in rng.split(":"))
        except argparse.ArgumentTypeError:
            ap.error(f"--mass-bounds: {item!r}: LO and HI must be finite numbers")
        if not 0.0 < lo < hi:
            ap.error(f"--mass-bounds: {item!r} needs 0 < LO < HI")
        bounds[key] = (lo, hi)
    return bounds


def _design_request(ap: Parser, args: argparse.Namespace, start: Problem) -> DesignRequest:
    """The design the flags ask for, every rule checked (by the workflow that owns it)
    before any solve; a broken one is a one-line usage error naming its flag."""
    free = tuple(k for k in args.free.split(",") if k)
    free_sound = tuple(k for k in args.free_sound.split(",") if k)
    dist = tuple(k for k in args.mass_distribution.split(",") if k)
    for flag, keys, required in (("--free", free, True), ("--free-sound", free_sound, False)):
        try:
            check_compliance_keys(start, keys, required)
        except ProblemError as exc:
            ap.error(f"{flag}: {exc}")
    try:
        check_mass_distribution(dist)
    except ProblemError as exc:
        ap.error(f"--mass-distribution: {exc}")
    bounds = _mass_bounds(ap, args, dist)
    # the verdict asks for asymmetries below symmetry_verdict_pct: the NLP's tolerance
    # must lie inside it
    try:
        DesignNLPOptions(symmetry_tol_pct=args.symmetry_tol).check_symmetry_tol()
    except ProblemError as exc:
        ap.error(f"--symmetry-tol: {exc}")
    nlp_only = [flag for flag, given in (
        ("--start", args.start), ("--diagnose", args.diagnose),
        ("--mass-distribution", dist), ("--free-slope", args.free_slope),
        ("--symmetry-tol", args.symmetry_tol != DesignNLPOptions.symmetry_tol_pct),
        ("--free", free != NLP_FREE), ("--free-sound", free_sound),
        ("--accept-verified", args.accept_verified))
        if given]
    if args.method == "continuation" and nlp_only:
        ap.error(f"{', '.join(nlp_only)}: options of --method nlp only")
    options = DesignNLPOptions(first_step=args.first_step, diagnose=args.diagnose,
                               max_iter=args.max_iter, mass_distribution=dist,
                               mass_distribution_bounds=bounds, free_slope=args.free_slope,
                               free_sound=free_sound, accept_verified=args.accept_verified,
                               t_min_s=args.t_min, symmetry_tol_pct=args.symmetry_tol,
                               max_step=args.max_step, max_solves=args.max_solves)
    return DesignRequest(lighter=args.lighter, method=args.method, free=free,
                         hold_first_phase=not args.no_hold, options=options)
