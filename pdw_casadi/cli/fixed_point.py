"""``pdw-fixed-point``: a periodic gait, its eigenvalues and validity margins."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from pdw_casadi.cli.common import (
    TOL_RANGE,
    check_curve_walker,
    common_parser,
    export_argument,
    gait_file,
    load_cli_problem,
    load_gait_problem,
    parse_command,
    require_one_leg_set,
    tolerance,
    write_exports,
    write_summary,
)
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    check_input_file,
    int_range,
    run,
)
from pdw_casadi.report.conditioning_report import conditioning_lines, write_conditioning
from pdw_casadi.studies.fixed_point_run import (
    FIXED_POINT_TOL,
    run_fixed_point,
)
from pdw_casadi.studies.simulate_run import command_map


def fixed_point_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fixed-point``: find a periodic gait, its eigenvalues and validity margins.

    Writes ``summary.json`` (fixed_point, residual, iterations, eigenvalues as [re, im],
    spectral_radius, stable, step_time_s, step_length_m, speed_m_s, margins, valid,
    failure, distance_from_initial, timing: stance/swing/double support %, cadence, gait
    events, :mod:`pdw_casadi.gait.timing`; identical for identical runs) and ``limit_cycle.png``
    (paper's Fig. 4); with ``--export opensim`` the OpenSim files of two steps of the gait
    (:mod:`pdw_casadi.report.opensim`); the wall time goes to stdout only. Exit code 1
    when Newton (and its IPOPT fallback) found no fixed point.

    ``--conditioning FILE`` measures instead how well conditioned the fixed point at a
    fit's answer is (:mod:`pdw_casadi.studies.conditioning`): the fit's first start on the
    curves of FILE, one round; it prints the figures and writes ``conditioning.json`` and
    ``answer.npz`` (:mod:`pdw_casadi.report.conditioning_report`). Exit code 1 when the
    fit's start has no fixed point.
    """
    parser = Parser(
        prog="pdw-fixed-point", parents=[common_parser()],
        description="Newton on the Poincare map with its exact AD Jacobian.")
    parser.add_argument("--tol", type=tolerance(), default=FIXED_POINT_TOL,
                        help=f"|P(x) - x| to reach, in [{TOL_RANGE[0]:g}, {TOL_RANGE[1]:g}] "
                             "(default: %(default)s)")
    parser.add_argument("--stride", action="store_true",
                        help="solve on the stride map (two steps, one per physical leg); "
                             "always so when the problem's legs differ")
    export_argument(parser, "two steps of the periodic gait")
    _conditioning_arguments(parser)
    args, outputs = parse_command(parser, argv)

    def body() -> int:
        if args.conditioning is not None or _conditioning_flags(args):
            return _conditioning_body(args, outputs)
        problem = load_gait_problem(args, outputs)
        # deferred: the report's figures (matplotlib), only when the command runs (fast --help)
        from pdw_casadi.report.fixed_point_report import (
            no_gait_message,
            result_lines,
            stride_line,
            write_leg_curves,
            write_limit_cycle,
        )

        pmap = command_map(problem, args.stride)  # a stride: parameters follow the legs
        out = outputs.create()
        fp = run_fixed_point(problem, pmap, args.tol,
                             log=lambda m: print(m, file=sys.stderr, flush=True))
        res = fp.result
        for path in write_leg_curves(fp, out):
            outputs.wrote(path)
        line = stride_line(fp)
        if line is not None:
            print(line)
        write_summary(outputs, out, fp.summary, pmap.hs)
        limit_cycle = write_limit_cycle(fp, out)
        if limit_cycle is not None:
            outputs.wrote(limit_cycle)
        if res.converged:
            # deferred: the OpenSim export (report layer), imported only for --export opensim
            from pdw_casadi.report.opensim import export_gait

            write_exports(args, outputs, lambda: export_gait(
                problem, res.state, out, parameters=res.parameters, steps=2))
        print("\n".join(result_lines(fp, outputs.dir)))
        if not res.converged:
            raise NoGait(no_gait_message(fp, args.tol, outputs.dir / "summary.json"))
        return 0

    return run(outputs, body)


#: default points along the Newton step of ``--conditioning``
CONDITIONING_SAMPLES = 10


def _conditioning_arguments(parser) -> None:
    """The flags of ``--conditioning``: the curve file, the fit's settings, the samples."""
    g = parser.add_argument_group(
        "conditioning of a fit's answer",
        "instead of the fixed point: run the fit's first start on the curves of FILE (pdw-fit's "
        "defaults, one round), take the NLP's answer (or its best feasible iterate) and "
        "measure the simulator's step map P there: the residual |P(x) - x| (rad and rad/s "
        "mixed), the Jacobian J = dP/dx (spectral radius, sigma_min(I - J), ||(I - J)^-1||, "
        "Henrici's departure from normality), the path along the Newton step and Newton on "
        "the simulator's map; writes conditioning.json (with units) and answer.npz (x in "
        "rad, rad/s; p: compliance, slope in rad)")
    g.add_argument("--conditioning", metavar="FILE",
                   help="gait-curve CSV of the fit whose answer is measured")
    g.add_argument("--fit-option", "--set", dest="fit_option", action="append", default=[],
                   metavar="KEY=VALUE",
                   help="a FitOptions field of that fit, VALUE as JSON (e.g. threads=1; "
                        "repeatable)")
    g.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000), default=None,
                   metavar="N", help="IPOPT iterations of that fit's solve (default: pdw-fit's, "
                                     "FitOptions.max_iter)")
    g.add_argument("--samples", type=int_range("--samples", 1, 1000), default=None,
                   metavar="N", help=f"points along the Newton step (default: "
                                     f"{CONDITIONING_SAMPLES})")


def _conditioning_flags(args) -> list[str]:
    """The ``--conditioning`` flags given (they need ``--conditioning FILE``)."""
    given = {"--fit-option/--set": bool(args.fit_option), "--max-iter": args.max_iter is not None,
             "--samples": args.samples is not None}
    return [flag for flag, on in given.items() if on]


def _conditioning_body(args, outputs: Outputs) -> int:
    """``pdw-fixed-point --conditioning FILE``: checks every flag, then measures and writes
    through the report."""
    flags = _conditioning_flags(args)
    if args.conditioning is None:
        raise UsageError(f"{', '.join(flags)}: only with --conditioning FILE")
    if args.stride or args.export:
        raise UsageError("--conditioning measures the one-step fit's answer; it takes "
                         "neither --stride nor --export")
    # deferred: the fit stack, only for --conditioning (pdw-fixed-point starts without it)
    from pdw_casadi.studies.conditioning import (
        fit_option_values,
        measurement_options,
        run_conditioning,
    )

    problem = load_cli_problem(args)
    require_one_leg_set(problem)
    check_curve_walker(problem, "--conditioning")
    human = gait_file(args.conditioning, "--conditioning")
    values = fit_option_values(args.fit_option)
    if args.max_iter is not None:
        values["max_iter"] = args.max_iter
    options = measurement_options(values)
    if options.atlas:
        check_input_file(Path(options.atlas), "--fit-option atlas")
    outputs.check()
    out = outputs.create()
    print(f"measuring the conditioning at the fit's answer of {problem.name} on "
          f"{Path(args.conditioning).name}...", file=sys.stderr, flush=True)
    measured = run_conditioning(problem, human, options,
                                args.samples or CONDITIONING_SAMPLES)
    source = Path(args.conditioning).name
    for path in write_conditioning(measured, out, source):
        outputs.wrote(path)
    print("\n".join(conditioning_lines(measured, source)))
    print(f"wrote {outputs.dir}")
    return 0
