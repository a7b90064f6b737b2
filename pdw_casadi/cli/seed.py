"""``pdw-seed``: a first gait of a walker whose fit needs a seed with a feature its shipped
gait lacks (rolling feet, heel off, the toes' heel off)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from pdw_casadi.cli.common import gait_file, load_cli_problem
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    finite_float,
    int_range,
    output_path,
    positive_float,
    run,
)
from pdw_casadi.model.problem import Problem
from pdw_casadi.report.seed_report import SEED_FILES, seed_lines, write_seed
from pdw_casadi.studies.seed_run import (
    SEARCHES,
    TOES_FAMILY,
    TOES_RANGES,
    ArcRequest,
    HeelOffRequest,
    SeedRun,
    ToesContinuation,
    ToesRequest,
    check_arc_request,
    check_toes_request,
    run_arc_seed,
    run_heeloff_seed,
    run_toes_continuation,
    run_toes_scan,
)

#: each search's own flags (argparse dests); a flag of another search is refused
OWNED = {"arc": ("r_toe", "r_heel", "n_min"),
         "heeloff": ("stability", "gait", "weight", "rounds", "max_iter", "threshold", "step",
                     "max_steps", "lengthen_ms"),
         "toes": ("problem", "state", "compliance", "samples", "seed", "newton", "range",
                  "cont")}
#: the defaults the searches' flags fall back to (shown in --help)
HEELOFF_DEFAULTS, TOES_DEFAULTS = HeelOffRequest(), ToesRequest()


def _flag(dest: str) -> str:
    return "--continue" if dest == "cont" else "--" + dest.replace("_", "-")


def nonnegative_float(flag: str) -> Callable[[str], float]:
    """Type: a finite float >= 0."""
    def parse(text: str) -> float:
        v = finite_float(flag)(text)
        if v < 0:
            raise argparse.ArgumentTypeError(f"{flag} must be >= 0, got {text!r}")
        return v
    parse.__name__ = "number"
    return parse


def seed_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-seed SEARCH --out DIR``: a seed gait of a walker, by one of three searches.

    ``arc``: the rolling-foot walker (humanlike_6link_arc) at toe and heel arc radii
    ``--r-toe``, ``--r-heel`` (m), carried from the ankle walker's gait by the design
    continuation; ``heeloff``: a first heel-off gait of the forefoot-rocker walker
    (humanlike_6link_heeloff) in three stages (push, cross, lengthen); ``toes``: a sampled
    search for heel-off gaits of the toe-foot walker (humanlike_toes), or with
    ``--continue`` its fixed point followed in one parameter
    (:mod:`pdw_casadi.studies.seed_run`). Writes ``seed.json`` (arc, heeloff: ``fixed_point``
    and ``compliance`` for ``pdw-fit --state FILE --compliance FILE``), ``scan.json`` or
    ``continuation.json`` (toes), each with a ``units`` block
    (:mod:`pdw_casadi.report.seed_report`). Exit code 1 when the arc search's end point has
    no fixed point (its record written) or the heel-off search loses its gait (nothing
    written); a toes scan that finds no gait is a result (its tally).
    """
    parser = Parser(prog="pdw-seed", description="A seed gait of a walker: the rolling-foot "
                    "walker at given radii (arc), a first heel-off gait of the forefoot-"
                    "rocker walker (heeloff), a search for heel-off gaits of the toe-foot "
                    "walker (toes).")
    _seed_arguments(parser)
    args = parser.parse_args(argv)
    outputs = Outputs(args.out)

    def body() -> int:
        request, problem, human = _checked(args)
        outputs.check()
        out = outputs.create()

        def log(line: str) -> None:
            print(line, flush=True)

        print(f"pdw-seed {args.search}: searching...", file=sys.stderr, flush=True)
        found = _search(args, request, problem, human, log)
        path = outputs.wrote(write_seed(found, out))
        print("\n".join(seed_lines(found, outputs.final(path))))
        if args.search == "arc" and not found.found:
            raise NoGait(f"Newton found no fixed point at the end of the continuation "
                         f"(lambda = {found.record['lambda']:.4f}); the record is in "
                         f"{outputs.final(path)}")
        if args.search == "heeloff" and not found.found:
            raise NoGait(f"Newton found no fixed point at the heel-off gait the stages ended "
                         f"on; the record is in {outputs.final(path)}")
        return 0

    return run(outputs, body)


def _seed_arguments(parser: argparse.ArgumentParser) -> None:
    """The search, ``--out`` and each search's flags in a group of its own (their defaults
    are set by :func:`_checked`: a flag given to another search is refused)."""
    parser.add_argument("search", choices=SEARCHES, metavar="SEARCH",
                        help=f"the search: {', '.join(SEARCHES)}")
    parser.add_argument("--out", type=output_path("--out"), required=True, metavar="DIR",
                        help=f"output directory (created if missing) of the search's JSON "
                             f"file: {SEED_FILES['arc']} (arc, heeloff), {SEED_FILES['toes']} "
                             f"(toes) or {SEED_FILES['toes-continuation']} (toes --continue)")
    a = parser.add_argument_group(
        "arc", "the rolling-foot walker (humanlike_6link_arc) at toe and heel arc radii, from "
               "the ankle walker's gait at radii 0 by the design continuation (every other "
               "compliance value free, validity margins held); --r-toe 0 --r-heel 0 writes "
               "that start")
    a.add_argument("--r-toe", type=finite_float("--r-toe"), metavar="R",
                   help="toe arc radius to reach (m; required)")
    a.add_argument("--r-heel", type=finite_float("--r-heel"), metavar="R",
                   help="heel arc radius to reach (m; required)")
    a.add_argument("--n-min", type=int_range("--n-min", 1, 10000), metavar="N",
                   help=f"continuation steps at least (default: {ArcRequest.n_min})")
    h = parser.add_argument_group(
        "heeloff", "a first heel-off gait of the forefoot-rocker walker "
                   "(humanlike_6link_heeloff) from the ankle walker's gait: push the centre "
                   "of pressure to the toe with the shooting NLP, cross into heel off by a "
                   "k_clutch continuation, lengthen the toe-rocker phase II_toe")
    h.add_argument("--stability", action="store_true", default=None,
                   help="push with the fit's NLP (curves, timing, stability bound)")
    h.add_argument("--gait", metavar="FILE",
                   help=f"curves of --stability (default: {HEELOFF_DEFAULTS.gait})")
    h.add_argument("--weight", type=positive_float("--weight"), metavar="W",
                   help=f"weight (1/(N m)) of the heel-off margin with --stability "
                        f"(default: {HEELOFF_DEFAULTS.weight:g})")
    h.add_argument("--rounds", type=int_range("--rounds", 1, 1000), metavar="N",
                   help=f"NLP rounds per stage at most (default: {HEELOFF_DEFAULTS.rounds})")
    h.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000), metavar="N",
                   help=f"IPOPT iterations per round (default: {HEELOFF_DEFAULTS.max_iter})")
    h.add_argument("--threshold", type=positive_float("--threshold"), metavar="NM",
                   help=f"heel-off margin (N m) that ends the push (default: "
                        f"{HEELOFF_DEFAULTS.threshold:g})")
    h.add_argument("--step", type=positive_float("--step"), metavar="K",
                   help=f"k_clutch continuation step (N m/rad, default: {HEELOFF_DEFAULTS.step:g})")
    h.add_argument("--max-steps", type=int_range("--max-steps", 1, 1_000_000), metavar="N",
                   help=f"continuation steps at most (default: {HEELOFF_DEFAULTS.max_steps})")
    h.add_argument("--lengthen-ms", type=nonnegative_float("--lengthen-ms"), metavar="MS",
                   help=f"II_toe duration (ms) the lengthening stage aims at (0: skip; "
                        f"default: {HEELOFF_DEFAULTS.lengthen_ms:g})")
    _toes_arguments(parser)


def _toes_arguments(parser: argparse.ArgumentParser) -> None:
    ranges = ", ".join(f"{k} {lo:g}..{hi:g}" for k, (lo, hi) in TOES_RANGES.items())
    t = parser.add_argument_group(
        "toes", "heel-off gaits of the toe-foot walker: sample compliance values at the "
                "problem's section state, simulate one step from each, tally how the steps "
                "ended (and those whose stance heel lifted in single support), solve for the "
                "fixed point of every whole heel-off step (timing in % of the gait cycle, "
                f"spectral radius, validity); sampled by default: {ranges} (k_ in N m/rad, c_ in "
                "N m s/rad, angles in rad)")
    t.add_argument("--problem", metavar="NAME_OR_PATH",
                   help=f"the walker and its section state (default: {TOES_FAMILY})")
    t.add_argument("--state", type=Path, metavar="FILE",
                   help="section-state overrides (rad, rad/s) of the walker, a JSON/TOML "
                        "table; a summary.json of this toolkit also works (e.g. a fit's)")
    t.add_argument("--compliance", type=Path, metavar="FILE",
                   help="compliance overrides of the walker, a JSON/TOML table; a "
                        "summary.json also works (the problem's compliance_bounds apply; "
                        "a scan draws its sampled keys anew)")
    t.add_argument("--samples", type=int_range("--samples", 1, 1_000_000), metavar="N",
                   help=f"compliance samples (default: {TOES_DEFAULTS.samples})")
    t.add_argument("--seed", type=int_range("--seed", 0, 2**32 - 1), metavar="N",
                   help=f"random seed (default: {TOES_DEFAULTS.seed})")
    t.add_argument("--newton", type=int_range("--newton", 1, 1000), metavar="N",
                   help=f"Newton iterations at most (default: {TOES_DEFAULTS.newton})")
    t.add_argument("--range", nargs=3, action="append", metavar=("KEY", "LO", "HI"),
                   help="sample only the keys given so, in the key's unit (repeatable); the "
                        "others at the problem's values")
    t.add_argument("--continue", dest="cont", nargs=3, metavar=("KEY", "TO", "NUM"),
                   help="instead: continue the problem's fixed point in parameter KEY up to "
                        "TO (its unit) in NUM steps")


def _checked(args: argparse.Namespace):
    """The search's request, its walker (toes) and curves (heeloff --stability), every flag
    checked: a flag of another search, a missing radius, a bad range or curve file is a
    :class:`UsageError` (or a ProblemError naming the flag) before any output."""
    for search, dests in OWNED.items():
        if search == args.search:
            continue
        given = [_flag(d) for d in dests if getattr(args, d) not in (None, False, [])]
        if given:
            raise UsageError(f"{', '.join(given)}: option{'s' if len(given) > 1 else ''} of "
                             f"pdw-seed {search}, not of pdw-seed {args.search}")
    if args.search == "arc":
        missing = [f for f, v in (("--r-toe", args.r_toe), ("--r-heel", args.r_heel))
                   if v is None]
        if missing:
            raise UsageError(f"pdw-seed arc needs {' and '.join(missing)} (m)")
        request = ArcRequest(args.r_toe, args.r_heel,
                             args.n_min if args.n_min is not None else ArcRequest.n_min)
        check_arc_request(request)
        return request, None, None
    if args.search == "heeloff":
        return _checked_heeloff(args)
    return _checked_toes(args)


def _given(args: argparse.Namespace, defaults, names: Sequence[str]) -> dict:
    """The values of ``names`` given on the command line, the others ``defaults``'."""
    return {n: getattr(defaults, n) if getattr(args, n) is None else getattr(args, n)
            for n in names}


def _checked_heeloff(args: argparse.Namespace):
    unused = [f for f, v in (("--gait", args.gait), ("--weight", args.weight))
              if v is not None]
    if unused and not args.stability:
        raise UsageError(f"{', '.join(unused)}: only with --stability")
    values = _given(args, HEELOFF_DEFAULTS, ("gait", "weight", "rounds", "max_iter",
                                             "threshold", "step", "max_steps", "lengthen_ms"))
    request = HeelOffRequest(stability=bool(args.stability), **values)
    human = gait_file(request.gait) if request.stability else None
    return request, None, human


def _checked_toes(args: argparse.Namespace):
    name = args.problem or TOES_FAMILY
    # the walker with --state and --compliance applied (a fit's summary.json: its gait)
    problem = load_cli_problem(argparse.Namespace(problem=name, state=args.state,
                                                  compliance=args.compliance))
    if args.cont is not None:
        skipped = [_flag(d) for d in ("samples", "seed", "newton", "range")
                   if getattr(args, d) is not None]
        if skipped:
            raise UsageError(f"--continue follows the fixed point; it takes no "
                             f"{', '.join(skipped)}")
        key, stop, num = args.cont
        request = ToesContinuation(key, _finite(f"--continue {key}: TO", stop),
                                   _count(f"--continue {key}: NUM", num))
    else:
        ranges = tuple((key, _finite(f"--range {key}: LO", lo), _finite(f"--range {key}: HI", hi))
                       for key, lo, hi in (args.range or []))
        request = ToesRequest(ranges=ranges,
                              **_given(args, TOES_DEFAULTS, ("samples", "seed", "newton")))
    check_toes_request(problem, request)
    return (request, name), problem, None


def _finite(what: str, text: str) -> float:
    """``text`` as a finite number, else a UsageError naming ``what``."""
    try:
        return finite_float(what)(text)
    except argparse.ArgumentTypeError as exc:
        raise UsageError(str(exc)) from None


def _count(what: str, text: str) -> int:
    """``text`` as a step count of a continuation (2..100000), else a UsageError."""
    try:
        return int_range(what, 2, 100000)(text)
    except argparse.ArgumentTypeError as exc:
        raise UsageError(str(exc)) from None


def _search(args: argparse.Namespace, request, problem: Problem | None, human,
            log: Callable[[str], None]) -> SeedRun:
    """Run the search that ``args.search`` names with its checked request."""
    if args.search == "arc":
        return run_arc_seed(request, log)
    if args.search == "heeloff":
        return run_heeloff_seed(request, human, log)
    request, name = request
    # the record names where the walker's state and compliance came from
    given = [f"{what} from {path}" for what, path in (("state", args.state),
                                                      ("compliance", args.compliance)) if path]
    if given:
        name = f"{name} ({', '.join(given)})"
    if isinstance(request, ToesContinuation):
        return run_toes_continuation(problem, request, label=name, log=log)
    return run_toes_scan(problem, request, label=name, log=log)
