"""``pdw-simulate``: simulate steps of a walker and write its trajectory, events and plots."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from pdw_casadi.cli.common import (
    MAX_SAMPLES,
    MAX_STEPS,
    common_parser,
    export_argument,
    load_gait_problem,
    parse_command,
    write_exports,
    write_summary,
)
from pdw_casadi.cli.contract import (
    NoGait,
    Parser,
    check_output_file,
    int_range,
    output_path,
    run,
)


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-simulate``: simulate N steps and write trajectory, events, summary and plots.

    Writes to ``--out``: ``trajectory.csv`` (one row per integration step: time, step,
    phase, coordinates, velocities and outputs), ``events.csv`` (guards, mode switches,
    failure), ``summary.json`` (phases, step time/length, speed, Poincare states, residual
    ||F(x0) - x0||, energy balance, failure, margins, problem, compliance, slope, timing
    per step and per cycle of two steps: :mod:`pdw_casadi.gait.timing`),
    ``angles.png`` and ``stick.png``; with ``--animate FILE.gif`` also an animation of the
    walker over all steps (:mod:`pdw_casadi.report.animation`); with ``--export opensim``
    the OpenSim files of all the steps (:mod:`pdw_casadi.report.opensim`). A walker that
    falls is a result, not an error: the outputs are written, ``failure`` says why, a
    warning goes to stderr, exit code 0. A numerical divergence (non-finite or absurd
    states, a broken energy balance: the step size is too large for the walker's
    stiffness) is not a fall: the outputs are written (no export) and the exit code is 1.
    Long runs show a progress bar on stderr.
    """
    parser = Parser(
        prog="pdw-simulate", parents=[common_parser()],
        description="Simulate steps of a passive walker from its section state.")
    parser.add_argument("--steps", type=int_range("--steps", 1, MAX_STEPS), default=1,
                        metavar="N", help=f"number of steps, 1..{MAX_STEPS} "
                                          "(default: %(default)s)")
    parser.add_argument("--snapshots", type=int_range("--snapshots", 2, 100), default=8,
                        metavar="K",
                        help="stick-figure snapshots of the first step, 2..100 "
                             "(default: %(default)s)")
    parser.add_argument("--animate", type=output_path("--animate"), metavar="FILE.gif",
                        help="also write an animated GIF of the walker walking down the slope "
                             "over all simulated steps")
    parser.add_argument("--fps", type=int_range("--fps", 1, 100), default=25, metavar="F",
                        help="frames per simulated second of the animation, 1..100 (default: "
                             "%(default)s)")
    export_argument(parser, "all the simulated steps")
    args, outputs = parse_command(parser, argv)

    def body() -> int:
        problem = load_gait_problem(args, outputs)
        if args.animate is not None:
            check_output_file(args.animate, "--animate", (".gif",))
        # the simulation workflow (the gait layer), its report (matplotlib) and tqdm:
        # deferred: only when the command runs (fast --help)
        from tqdm import tqdm

        from pdw_casadi.report.simulate_report import (
            fall_warning,
            trajectory,
            write_simulation_animation,
            write_simulation_figures,
            write_simulation_tables,
            wrote_line,
        )
        from pdw_casadi.studies.simulate_run import run_simulation, simulation_setup

        setup = simulation_setup(problem)  # legs that differ: parameters alternate
        out = outputs.create()
        with tqdm(total=args.steps, unit="step", desc="pdw-simulate", file=sys.stderr,
                  disable=args.steps < 10) as bar:
            sim = run_simulation(problem, args.steps, max_samples=MAX_SAMPLES, setup=setup,
                                 progress=lambda k: bar.update(k - bar.n))
        for path in write_simulation_tables(sim, out):
            outputs.wrote(path)
        write_summary(outputs, out, sim.summary, sim.sim.hs)
        for path in write_simulation_figures(sim, out, args.snapshots):
            outputs.wrote(path)
        moving = not trajectory(sim).empty
        if args.animate is not None and moving:
            outputs.wrote(write_simulation_animation(sim, outputs.staged(args.animate),
                                                     args.fps))
        diverged = sim.divergence
        if moving and not diverged:  # a divergence has no motion worth exporting
            # deferred: the OpenSim export (report layer), imported only for --export opensim
            from pdw_casadi.report.opensim import export_opensim

            write_exports(args, outputs, lambda: export_opensim(
                problem, sim.result, out, sim.sim.hs, sim.parameter_steps or [sim.parameters]))
        print(wrote_line(sim, outputs.dir, args.steps))
        if diverged:
            raise NoGait(diverged)
        warning = fall_warning(sim)
        if warning is not None:
            print(warning, file=sys.stderr)
        return 0

    return run(outputs, body)


