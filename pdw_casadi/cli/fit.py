"""``pdw-fit``: fit a walker's compliance and a stable periodic gait to human curves."""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from pdw_casadi.cli.common import (
    check_curve_walker,
    check_exports,
    common_parser,
    export_argument,
    fit_arguments,
    fit_options,
    load_cli_problem,
    parallel_arguments,
    parse_command,
    require_one_leg_set,
    write_exports,
)
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    check_input_file,
    connect_scheduler,
    run,
)
from pdw_casadi.cli.scripts import STARTED
from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.engine.parallel import ImportAhead
from pdw_casadi.model.problem import Problem, check_bounds


def _fit_output(outputs: Outputs, opts) -> Path:
    """Create a fit's output folder and point IPOPT's log at a fresh ``ipopt.log`` in it."""
    out = outputs.create()
    outputs.notes.append(f"the report files are written only at the end, into {outputs.dir}")
    opts.log_file = str(out / "ipopt.log")  # staged: an earlier run's log stays until the end
    return out


def check_atlas_file(problem: Problem, path: Path, same_parameters: bool = True) -> None:
    """Raise :class:`UsageError` unless ``path`` is a readable file that reads as a gait
    atlas (of ``problem``'s parameters with ``same_parameters``): a malformed file fails
    before anything is written, not after the fit's first solves (the rule:
    :func:`pdw_casadi.studies.fit_checks.check_atlas_file`)."""
    # deferred: the fit stack, only when the command runs (fast --help)
    from pdw_casadi.studies.fit_checks import check_atlas_file as check_atlas

    check_input_file(path, "--atlas")
    check_atlas(problem, path, same_parameters)


def fit_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fit --gait FILE``: fit the compliance and a stable periodic gait to human curves.

    One multiple-shooting IPOPT NLP per start (see :mod:`pdw_casadi.fit`), verified by a
    20-step re-simulation and the exact-AD spectral radius. Writes ``summary.json``,
    ``curves.csv``, ``fit.png`` (Fig. 5 with the problem's own compliance and, for a walker
    that has one, its comparison walker; the gait events marked), ``limit_cycle.png``
    (Fig. 4) and ``table.md`` (R^2, then the gait timing beside human values).
    ``--timing [W]`` adds the timing target (:class:`~pdw_casadi.fit.FitOptions`
    ``timing_weight``). ``--export opensim`` adds the OpenSim files of two steps of the
    fitted gait (:mod:`pdw_casadi.report.opensim`).
    Exit code 1 when no stable valid gait was found (the outputs then describe the best
    candidate and say so). The walker needs knee and hip outputs and something to fit
    (compliance values, or ``--free-slope``).
    """
    parser = Parser(
        prog="pdw-fit", parents=[common_parser(out_default="fit")],
        description="Fit compliance and a stable periodic gait to human knee/hip curves.")
    parser.add_argument("--gait", required=True, metavar="FILE",
                        help="gait-curve CSV (a path or a bundled name such as female_fast.csv)")
    per_leg = fit_arguments(parser, timing=True)
    per_leg.add_argument("--gait-right", metavar="FILE",
                         help="the right side's curve file; --gait is then the left side's")
    parallel_arguments(parser, "the multistart")
    export_argument(parser, "two steps of the fitted gait")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress lines (the IPOPT log is still written to "
                             "DIR/ipopt.log)")
    args, outputs = parse_command(parser, argv)

    def body() -> int:
        # deferred: pandas (via model.gait_data), only when the command runs (fast --help)
        from pdw_casadi.model.gait_data import SideCurves, load_gait_file, load_side_curves

        if args.gait_right is not None:
            human = load_side_curves(args.gait, args.gait_right)
        else:
            human = load_gait_file(args.gait)
        problem = load_cli_problem(args)
        check_exports(args, problem)
        if isinstance(human, SideCurves):
            return _fit_stride_body(args, outputs, problem, human)
        if args.side is not None:
            raise UsageError(f"--side needs per-side curves (columns such as "
                             f"knee_left_mean_deg, or --gait-right); {human.source} has one "
                             f"curve set")
        require_one_leg_set(problem)
        if args.hip_target == "thigh" and human.thigh_deg is None:
            raise UsageError(f"--hip-target thigh needs a thigh column in the gait file "
                             f"{human.source} (it has none); use --hip-target hip")
        check_curve_walker(problem, "pdw-fit")
        if not problem.compliance and not args.free_slope:
            raise UsageError(f"{problem.name} ({problem.family}) has no compliance values "
                             f"to fit; add --free-slope to fit the slope")
        outputs.check()
        # the report's plotting is imported on a thread while the fit sets up (its CasADi
        # work leaves the interpreter free most of a second)
        report = ImportAhead("pdw_casadi.report.fit_report")
        # deferred: the fit workflow, only when the command runs (fast --help)
        from pdw_casadi.studies.fit_run import run_fit

        opts = fit_options(args, per_leg=False, verbose=not args.quiet)
        if opts.atlas:
            check_atlas_file(problem, Path(opts.atlas))
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
        # the workflow checks the curves against the targets first, then (before_work)
        # the output folder is created: bad input writes nothing
        began = time.perf_counter()
        fit = run_fit(problem, human, opts, workers=args.workers, scheduler=args.scheduler,
                      log=lambda m: print(m, file=sys.stderr, flush=True),
                      before_work=lambda: _fit_output(outputs, opts))
        out = outputs.stage
        with fit.times.part("report files and figures"):
            summary = report.module().write_fit_report(fit, out)
        if STARTED[0] is not None:  # a console script: its start-up and imports first
            fit.times.parts = {"start-up and imports": began - STARTED[0], **fit.times.parts}
        for name in ("summary.json", "curves.csv", "fit.png", "limit_cycle.png", "table.md",
                     "ipopt.log"):
            outputs.wrote(out / name)
        _export_fit(args, outputs, problem, summary, out)
        if not args.quiet:
            print(fit.times.line(), file=sys.stderr, flush=True)
        print(summary["headline"])
        print(f"wrote {outputs.dir}")
        if not (summary["stable"] and summary["valid"]):
            raise NoGait(f"no stable valid gait: {summary['headline']}")
        return 0

    return run(outputs, body)


def _fit_stride_body(args, outputs: Outputs, problem: Problem, sides) -> int:
    """pdw-fit with per-side curves: each leg fitted to its side on the stride
    (:mod:`pdw_casadi.fit.stride_fit`); the report of :mod:`pdw_casadi.report.fit_stride_report`."""
    # deferred: the per-leg fit workflow and its report, only when the command runs (fast --help)
    from pdw_casadi.report.fit_stride_report import write_fit_stride_report
    from pdw_casadi.studies.fit_checks import check_stride_walker
    from pdw_casadi.studies.fit_run import run_fit

    if args.timing:
        raise UsageError("--timing is a one-step fit's target; a per-leg fit has none")
    if args.workers > 1 or args.scheduler is not None or args.multistart > 1:
        raise UsageError("--multistart, --workers and --scheduler are one-step fit options "
                         "(a per-leg fit solves one stride NLP)")
    if args.hip_target == "thigh" and (sides.left.thigh_deg is None):
        raise UsageError(f"--hip-target thigh needs thigh columns in {sides.source}")
    check_curve_walker(problem, "pdw-fit")
    if not problem.compliance:
        raise UsageError(f"{problem.name} ({problem.family}) has no compliance values to fit "
                         f"per leg")
    check_stride_walker(problem)
    outputs.check()
    opts = fit_options(args, verbose=not args.quiet)
    if opts.atlas:
        check_atlas_file(problem, Path(opts.atlas), same_parameters=not problem.asymmetric)
    # the workflow checks each side's curves first, then creates the output (before_work)
    fit = run_fit(problem, sides, opts, log=lambda m: print(m, file=sys.stderr, flush=True),
                  before_work=lambda: _fit_output(outputs, opts))
    out = outputs.stage
    summary = write_fit_stride_report(fit, out)
    for name in ("summary.json", "curves.csv", "fit.png", "table.md", "ipopt.log"):
        outputs.wrote(out / name)
    _export_fit(args, outputs, problem, summary, out)
    print(summary["headline"])
    print(f"wrote {outputs.dir}")
    if not summary["accepted"]:
        raise NoGait(f"no stable valid stride: {summary['headline']}")
    return 0


def _export_fit(args, outputs: Outputs, problem: Problem, summary: dict, out: Path) -> None:
    """--export: two steps of the fitted gait (the best candidate, as the report; none
    when no solve gave one)."""
    if "fixed_point" not in summary:
        return
    # deferred: the OpenSim export (report layer), imported only for --export opensim
    from pdw_casadi.report.opensim import export_gait, fitted_problem

    def export():
        fitted = fitted_problem(problem, summary)
        return export_gait(fitted, fitted.state_vector(), out, steps=2)

    write_exports(args, outputs, export)


def load_fit_start(problem: Problem, path: Path) -> Problem:
    """``problem`` with compliance, slope and section state taken from a fit summary.

    The summary (JSON) holds ``compliance`` (problem compliance names -> values), ``slope``
    (rad) and ``fixed_point`` (section-state names -> values, rad and rad/s). The
    compliance obeys the problem's ``compliance_bounds``.
    """
    path = check_input_file(path, "--from-fit")
    try:
        raw = json.loads(Path(path).read_text())
    except UnicodeDecodeError:
        raise ProblemError(f"{path}: not a fit summary (not UTF-8 text)") from None
    except ValueError as exc:
        raise ProblemError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(raw, dict):
        kind = {list: "a list", str: "a string", bool: "a boolean", type(None): "null",
                int: "a number", float: "a number"}.get(type(raw), type(raw).__name__)
        raise ProblemError(f"{path}: a fit summary must be a JSON object with the keys "
                           f"compliance, slope and fixed_point; got {kind}")
    missing = [k for k in ("compliance", "slope", "fixed_point") if k not in raw]
    if missing:
        raise ProblemError(f"{path}: a fit summary needs the keys compliance, slope and "
                           f"fixed_point; missing: {', '.join(missing)}")
    if not isinstance(raw["compliance"], dict) or not isinstance(raw["fixed_point"], dict):
        raise ProblemError(f"{path}: 'compliance' and 'fixed_point' must be tables")
    if isinstance(raw["slope"], bool) or not isinstance(raw["slope"], int | float) \
            or not math.isfinite(raw["slope"]):
        raise ProblemError(f"{path}: 'slope' must be a finite number (rad), got "
                           f"{raw['slope']!r}")
    for table in ("compliance", "fixed_point"):
        for k, v in raw[table].items():
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ProblemError(f"{path}: '{table}.{k}' must be a finite number, got "
                                   f"{v!r}")
    try:
        new = problem.replace(compliance=raw["compliance"], slope=float(raw["slope"])) \
            .with_state(raw["fixed_point"])
        check_bounds(new, raw["compliance"], path)
        return new
    except ProblemError as exc:
        text = str(exc)
        raise ProblemError(text if text.startswith(str(path)) else f"{path}: {text}") from None


