"""``pdw-simulate``: simulate steps of a walker and write its trajectory, events and plots."""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence

import numpy as np
import pandas as pd

from pdw_casadi.cli.common import (
    MAX_SAMPLES,
    MAX_STEPS,
    command_map,
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
from pdw_casadi.gait.timing import simulation_timing, timing_or_none
from pdw_casadi.model.faces import walker_faces
from pdw_casadi.model.problem import Problem
from pdw_casadi.model.units import with_units


# --------------------------------------------------------------------------------------------
# pdw-simulate
# --------------------------------------------------------------------------------------------
def simulation_summary(problem: Problem, result, steps_requested: int | None = None) -> dict:
    """The summary.json content of a simulation (SI units; see :func:`simulate_main`)."""
    names = list(problem.state_names)
    done = [s for s in result.steps if s.x_section_end is not None]
    first = done[0] if done else None
    poincare = [dict(zip(names, map(float, row), strict=True))
                for row in np.atleast_2d(result.poincare_states) if len(row)]
    residual = None
    if first is not None:
        residual = float(np.linalg.norm(first.x_section_end - first.x_section_start))
    energy = [float(s.energy_residual_J) for s in done]
    margins: dict[str, float] = {}
    for s in result.steps:
        for k, v in s.margins.items():
            margins[k] = min(float(v), margins.get(k, math.inf))
    step_time = first.step_time if first else None
    step_length = first.step_length if first else None
    speed = step_length / step_time if first and step_time else None
    return {
        "problem": {"name": problem.name, "family": problem.family,
                    "source": problem.source, "title": problem.title},
        "slope": problem.slope,
        "compliance": dict(problem.compliance),
        "initial_state": dict(problem.initial_state),
        "steps_requested": steps_requested,
        "completed_steps": len(done),
        "phases": [[{"name": n, "duration_s": d} for n, d in s.phases] for s in result.steps],
        "step_time_s": step_time,
        "step_length_m": step_length,
        "speed_m_s": speed,
        "poincare_states": poincare,
        "residual": residual,
        "energy_balance_J": energy,
        "energy_balance_max_abs_J": max((abs(e) for e in energy), default=None),
        "failure": result.failure.to_dict() if result.failure else None,
        "steps": [s.to_dict() for s in result.steps],
        "margins": margins,
        "timing": timing_or_none(lambda: simulation_timing(problem.family, result)),
    }


def _divergence(result) -> str | None:
    f = result.failure
    if f is not None and f.reason == "numerical_divergence":
        return (f"numerical divergence in step {f.step}, phase {f.phase}, at t = "
                f"{f.time:.4f} s: {f.detail}")
    return None


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
        # deferred: tqdm, the stride and matplotlib, only when the command runs (fast --help)
        from tqdm import tqdm

        from pdw_casadi.gait.stride import stride_simulator
        from pdw_casadi.report.plots import plot_angles, plot_stick

        pmap = command_map(problem)  # legs that differ: parameters alternate with the stance leg
        sim, p_steps = stride_simulator(pmap) if pmap.steps > 1 else (pmap.sim, None)
        faces = walker_faces(problem, sim.hs)
        p = p_steps[0] if p_steps else problem.parameter_vector()
        out = outputs.create()
        with tqdm(total=args.steps, unit="step", desc="pdw-simulate", file=sys.stderr,
                  disable=args.steps < 10) as bar:
            result = sim.run(problem.state_vector(), p, steps=args.steps, record=True,
                             progress=lambda k: bar.update(k - bar.n),
                             max_samples=MAX_SAMPLES, p_steps=p_steps)
        traj = result.trajectory
        if traj is None:
            traj = pd.DataFrame()
        with_units(traj, sim.hs).to_csv(outputs.wrote(out / "trajectory.csv"), index=False)
        with_units(result.events, sim.hs).to_csv(outputs.wrote(out / "events.csv"),
                                                 index=False)
        summary = simulation_summary(problem, result, args.steps)
        write_summary(outputs, out, summary, sim.hs)
        plot_angles(traj, outputs.wrote(out / "angles.png"),
                    title=f"{problem.name}: joint angles", faces=faces)
        plot_stick(sim.hs, traj, p, outputs.wrote(out / "stick.png"), n=args.snapshots)
        if args.animate is not None and not traj.empty:
            # deferred: the animation (report layer), imported only for --animate
            from pdw_casadi.report.animation import animate_walk

            animate_walk(sim.hs, result, p, outputs.wrote(outputs.staged(args.animate)),
                         fps=args.fps,
                         title=f"{problem.name}: {result.completed_steps} steps down a slope "
                               f"of {problem.slope:.4f} rad")
        diverged = _divergence(result)
        if not traj.empty and not diverged:  # a divergence has no motion worth exporting
            # deferred: the OpenSim export (report layer), imported only for --export opensim
            from pdw_casadi.report.opensim import export_opensim

            write_exports(args, outputs, lambda: export_opensim(
                problem, result, out, sim.hs, p_steps or [p]))
        print(f"wrote {outputs.dir} ({summary['completed_steps']} of {args.steps} steps)")
        if diverged:
            raise NoGait(diverged)
        if result.failure is not None:
            f = result.failure
            print(f"warning: simulation stopped in step {f.step}, phase {f.phase}, at "
                  f"t = {f.time:.4f} s: {f.reason}"
                  + (f" ({f.detail})" if f.reason == "sample_limit" else ""), file=sys.stderr)
        return 0

    return run(outputs, body)


