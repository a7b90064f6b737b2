"""``pdw-sweep``: follow a gait over a parameter and locate its bifurcations."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pdw_casadi.cli.common import (
    TOL_RANGE,
    check_curve_walker,
    common_parser,
    gait_file,
    load_cli_problem,
    parallel_arguments,
    parse_command,
    tolerance,
)
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    connect_scheduler,
    finite_float,
    int_range,
    run,
)
from pdw_casadi.cli.fit import load_fit_start
from pdw_casadi.report.sweep_timing_report import sweep_timing_lines
from pdw_casadi.studies.sweep_run import SweepRequest, check_sweep, run_sweep
from pdw_casadi.studies.sweep_timing import check_sweep_timing, sweep_timing

if TYPE_CHECKING:  # annotations only
    from pdw_casadi.model.gait_data import GaitCurves
    from pdw_casadi.model.problem import Problem
    from pdw_casadi.model.units import Units
    from pdw_casadi.report.sweep_report import SweepRows
    from pdw_casadi.studies.sweep_run import SweepRun


def sweep_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-sweep``: follow a periodic gait over a parameter; bifurcations and boundaries.

    Starts from the fixed point of the problem (its initial state; or ``--from-fit``), covers
    ``--num`` values from ``--from`` to ``--to`` of ``--param`` (the slope in rad, or a
    compliance name in its unit, within the problem's compliance_bounds) and writes to
    ``--out``: ``sweep.csv`` (one row per point: parameter, section state, step time, step
    length, speed, spectral radius, eigenvalues, margins, stable, valid, R^2 with
    ``--gait``), ``events.json`` (located bifurcations and gait-pattern boundaries, stable
    valid ranges) and ``sweep.png`` (step length, speed and spectral radius against the
    parameter). Rows are appended to ``sweep.partial.csv`` as each is found, which becomes
    ``sweep.csv`` when the sweep completes: an interrupted or failed run leaves the
    ``sweep.csv`` of an earlier run untouched and its own rows in ``sweep.partial.csv``.
    ``--workers K`` spreads independent work (grid points, the two directions from an
    interior start) over K processes; ``--scheduler ADDRESS`` over a Dask cluster (checked
    to answer before anything is written). ``--timing`` also prints the gait timing of
    every point (double support per period and stance in % of the gait cycle, phase
    durations in ms: :func:`pdw_casadi.studies.sweep_timing.sweep_timing`). Exit code 1
    when the start has no gait. The sweep itself is the workflow
    :func:`pdw_casadi.studies.sweep_run.run_sweep`; its files and lines are rendered by
    :mod:`pdw_casadi.report.sweep_report`.
    """
    parser = Parser(
        prog="pdw-sweep", parents=[common_parser()],
        description="Parameter sweep of a periodic gait by continuation, with bifurcations.")
    _sweep_arguments(parser)
    args, outputs = parse_command(parser, argv)

    def body() -> int:
        problem, human = _checked_problem(args)
        outputs.check()
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
        # deferred: tqdm and the sweep's report (matplotlib), only for a run (fast --help)
        from tqdm import tqdm

        from pdw_casadi.report.sweep_report import (
            SweepRows,
            sweep_lines,
            sweep_units,
            write_sweep_report,
        )

        units = sweep_units(problem)
        request = SweepRequest(parameter=args.param, start=args.start, stop=args.stop,
                               num=args.num, mode=args.mode, predictor=args.predictor,
                               tol=args.tol, gait=args.gait, refit=args.refit)
        out = outputs.create()
        csv_path, partial = out / "sweep.csv", out / "sweep.partial.csv"
        outputs.keep_on_interrupt(partial.name)  # the rows found stay after a Ctrl-C
        outputs.obsolete.append(partial.name)  # a completed sweep ends an earlier one's
        rows = SweepRows(partial, units)
        append = _noting_rows(outputs, rows, outputs.final(csv_path))
        print(f"sweeping {args.param} of {problem.name} from {args.start:g} to {args.stop:g} "
              f"({args.num} values, {args.mode})...", file=sys.stderr)
        try:
            with tqdm(total=args.num, unit="pt", desc="pdw-sweep", file=sys.stderr) as bar:
                swept = run_sweep(problem, request, human, workers=args.workers,
                                  scheduler=args.scheduler, on_row=append,
                                  progress=bar.update)
        except NoGait:
            partial.unlink(missing_ok=True)
            raise
        partial.replace(csv_path)
        outputs.notes.clear()
        outputs.wrote(csv_path)
        outputs.wrote(out / "events.json")
        outputs.wrote(out / "sweep.png")
        write_sweep_report(swept, out, units)
        print("\n".join(sweep_lines(swept)))
        if args.timing:
            print("\n".join(_timing_lines(problem, swept, units)))
        print(f"wrote {outputs.dir}")
        return 0

    return run(outputs, body)


def _sweep_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags of ``pdw-sweep`` beside the common ones: the parameter and its grid (in
    the parameter's unit), mode and predictor, the start, the gait curves, where the work
    runs and the fixed points' tolerance (rad, rad/s)."""
    parser.add_argument("--param", default="slope", metavar="NAME",
                        help="parameter to sweep: slope (rad) or a compliance name; for a "
                             "walker whose legs differ also one leg's value, e.g. "
                             "right.k_ankle or right.m_s (default: %(default)s)")
    parser.add_argument("--from", dest="start", type=finite_float("--from"), required=True,
                        metavar="A", help="first value of the grid (unit of the parameter)")
    parser.add_argument("--to", dest="stop", type=finite_float("--to"), required=True,
                        metavar="B", help="last value of the grid")
    parser.add_argument("--num", type=int_range("--num", 2, 10000), default=25, metavar="N",
                        help="grid values from A to B, 2..10000 (default: %(default)s)")
    parser.add_argument("--mode", choices=("continuation", "grid"), default="continuation",
                        help="continuation from the start, or every grid value solved on its "
                             "own from the start (default: %(default)s)")
    parser.add_argument("--predictor", choices=("tangent", "secant"),
                        default=SweepRequest.predictor,
                        help="continuation predictor (default: %(default)s)")
    parser.add_argument("--from-fit", type=Path, metavar="FILE",
                        help="start from a fit summary.json (compliance, slope, fixed_point)")
    parser.add_argument("--gait", metavar="FILE",
                        help="gait-curve CSV: add R^2 of knee and hip to every row")
    parser.add_argument("--refit", action="store_true",
                        help="refit the compliance to --gait at every point (a full pdw-fit "
                             "per point, warm-started from the neighbour; slow)")
    parser.add_argument("--timing", action="store_true",
                        help="also print the gait timing of every point: valid, stable, the "
                             "spectral radius, double support per period and stance (%% of "
                             "the gait cycle) and the phase durations (ms)")
    parallel_arguments(parser, "independent work")
    parser.add_argument("--tol", type=tolerance(), default=SweepRequest.tol,
                        help=f"|P(x) - x| of every fixed point, in [{TOL_RANGE[0]:g}, "
                             f"{TOL_RANGE[1]:g}] (default: %(default)s)")


def _checked_problem(args: argparse.Namespace) -> tuple[Problem, GaitCurves | None]:
    """The walker to sweep (``--problem`` with its overrides, or ``--from-fit``) and the
    ``--gait`` curves (None without), every flag checked against it before any output."""
    if args.start == args.stop:
        raise UsageError(f"--from and --to must differ, got {args.start:g} twice")
    if args.refit:
        if args.gait is None:
            raise UsageError("--refit needs --gait FILE (the curves to refit to)")
        if args.param != "slope":
            raise UsageError("--refit sweeps the slope (the compliance is refitted)")
    problem = load_cli_problem(args)
    if problem.asymmetric and (args.gait or args.refit or args.from_fit):
        raise UsageError(f"{problem.name}: its legs differ; --gait, --refit and "
                         f"--from-fit need a walker with one set of values for both legs "
                         f"(its gait is swept on the stride map without them)")
    if args.from_fit is not None:
        problem = load_fit_start(problem, args.from_fit)
    if args.timing:
        check_sweep_timing(problem)
    check_sweep(problem, args.param,
                [(f"{flag} {v:g}", v) for flag, v in (("--from", args.start), ("--to", args.stop))])
    human = None
    if args.gait is not None:
        human = gait_file(args.gait)  # a bad file is a user error now, not mid-sweep
        check_curve_walker(problem, "--gait")
    return problem, human


def _timing_lines(problem: Problem, swept: SweepRun, units: Units) -> list[str]:
    """The ``--timing`` lines of a finished sweep, one per point in the order found."""
    points = sweep_timing(problem, swept.result.table)
    return sweep_timing_lines(points, swept.request.parameter, units)


def _noting_rows(outputs: Outputs, rows: SweepRows, final_csv: Path) -> Callable[[dict], None]:
    """``rows.append`` (a :class:`~pdw_casadi.report.sweep_report.SweepRows`) that also
    keeps the interruption line's note up to date: where the rows found so far are, and
    that an earlier run's ``sweep.csv`` is untouched."""
    final_partial = outputs.final(rows.path)

    def note() -> None:
        found = (f"{rows.count} rows found so far are in {final_partial}" if rows.count
                 else "no sweep rows found yet")
        outputs.notes[:] = [found + (f" ({final_csv} of an earlier run untouched)"
                                     if final_csv.exists() else "")]

    def append(row: dict) -> None:
        rows.append(row)
        note()

    note()
    return append
