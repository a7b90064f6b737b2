"""``pdw-sweep``: follow a gait over a parameter and locate its bifurcations."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

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
    Parser,
    UsageError,
    connect_scheduler,
    finite_float,
    int_range,
    run,
)
from pdw_casadi.cli.fit import load_fit_start
from pdw_casadi.engine.errors import NoStartGait
from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.gait.continuation import parameter_index
from pdw_casadi.gait.sweep import SweepSettings, sweep
from pdw_casadi.model.problem import check_bounds
from pdw_casadi.model.system import gait_system
from pdw_casadi.model.units import Units


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
    to answer before anything is written). Exit code 1 when the start has no gait.
    """
    parser = Parser(
        prog="pdw-sweep", parents=[common_parser()],
        description="Parameter sweep of a periodic gait by continuation, with bifurcations.")
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
                        default=SweepSettings.predictor,
                        help="continuation predictor (default: %(default)s)")
    parser.add_argument("--from-fit", type=Path, metavar="FILE",
                        help="start from a fit summary.json (compliance, slope, fixed_point)")
    parser.add_argument("--gait", metavar="FILE",
                        help="gait-curve CSV: add R^2 of knee and hip to every row")
    parser.add_argument("--refit", action="store_true",
                        help="refit the compliance to --gait at every point (a full pdw-fit "
                             "per point, warm-started from the neighbour; slow)")
    parallel_arguments(parser, "independent work")
    parser.add_argument("--tol", type=tolerance(), default=SweepSettings.tol,
                        help=f"|P(x) - x| of every fixed point, in [{TOL_RANGE[0]:g}, "
                             f"{TOL_RANGE[1]:g}] (default: %(default)s)")
    args, outputs = parse_command(parser, argv)

    def body() -> int:
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
        parameter_index(problem, args.param)  # an unknown name fails before any work
        for flag, v in (("--from", args.start), ("--to", args.stop)):
            check_bounds(problem, {args.param: v}, f"{flag} {v:g}")
        human = None
        if args.gait is not None:
            human = gait_file(args.gait)  # a bad file is a user error now, not mid-sweep
            check_curve_walker(problem, "--gait")
        outputs.check()
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
        # deferred: tqdm and matplotlib, only when the command runs (fast --help)
        from tqdm import tqdm

        from pdw_casadi.report.plots import plot_sweep

        units = Units(gait_system(problem))

        corrector = None
        if args.refit:
            # deferred: the fit stack, imported only for --refit
            from pdw_casadi.fit import FitOptions, RefitCorrector

            corrector = RefitCorrector(problem, human, FitOptions(verbose=False, knee_floor=None))
        out = outputs.create()
        csv_path, partial = out / "sweep.csv", out / "sweep.partial.csv"
        outputs.keep_on_interrupt(partial.name)  # the rows found stay after a Ctrl-C
        outputs.obsolete.append(partial.name)  # a completed sweep ends an earlier one's
        final_csv, final_partial = outputs.final(csv_path), outputs.final(partial)
        columns: list[str] = []
        found = [0]

        def note() -> None:
            rows = (f"{found[0]} rows found so far are in {final_partial}" if found[0]
                    else "no sweep rows found yet")
            outputs.notes[:] = [rows + (f" ({final_csv} of an earlier run untouched)"
                                        if final_csv.exists() else "")]

        note()

        def append(row: dict) -> None:
            # the first row (the start, a converged gait) fixes the columns; later rows that
            # lack some (a failed point has no margins) get empty cells
            if not columns:
                columns.extend(row)
            frame = units.frame(pd.DataFrame([row]).reindex(columns=columns))
            frame.to_csv(partial, mode="a", header=not partial.exists(), index=False)
            found[0] += 1
            note()

        grid = np.linspace(args.start, args.stop, args.num)
        print(f"sweeping {args.param} of {problem.name} from {args.start:g} to {args.stop:g} "
              f"({args.num} values, {args.mode})...", file=sys.stderr)
        try:
            with tqdm(total=args.num, unit="pt", desc="pdw-sweep", file=sys.stderr) as bar:
                res = sweep(problem, grid, parameter=args.param, mode=args.mode,
                            corrector=corrector, workers=args.workers,
                            scheduler=args.scheduler, gait=args.gait,
                            settings=SweepSettings(tol=args.tol, predictor=args.predictor),
                            on_row=append, progress=bar.update)
        except NoStartGait as exc:
            partial.unlink(missing_ok=True)
            raise NoGait(str(exc)) from None
        partial.replace(csv_path)
        outputs.notes.clear()
        outputs.wrote(csv_path)
        summary = {**res.to_dict(), "problem": problem.name,
                   "compliance": dict(problem.compliance), "slope": problem.slope}
        unit = units.of(args.param)  # grid, start and event values are in the parameter's
        summary["units"] = {**units.summary(summary), "start_value": unit, "grid": unit,
                            "events[].value": unit, "events[].bracket": unit}
        write_json(outputs.wrote(out / "events.json"), summary)
        plot_sweep(res.table, res.events, args.param, outputs.wrote(out / "sweep.png"),
                   title=f"{problem.name}: sweep over {args.param}")
        table = res.table
        print(f"{len(table)} points ({int(table['converged'].sum())} converged, "
              f"{int((table['stable'] & table['valid']).sum())} stable and valid)")
        for e in res.events:
            print(f"  {e.kind:16s} {args.param} = {e.value:.8g}  (bracket "
                  f"{min(e.bracket):.8g} .. {max(e.bracket):.8g}): {e.reason}")
        ranges = res.stable_ranges()
        if ranges:
            for r in ranges:
                print(f"stable valid gait: {args.param} in [{r['from']:.8g}, {r['to']:.8g}] "
                      f"(ends: {r['from_event'] or 'last point'}, "
                      f"{r['to_event'] or 'last point'})")
        else:
            print(f"no stable valid gait found over {args.param} = {args.start:g} .. "
                  f"{args.stop:g}")
        print(f"wrote {outputs.dir}")
        return 0

    return run(outputs, body)


