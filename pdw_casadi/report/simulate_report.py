"""The report of a simulation: the files ``pdw-simulate`` writes and the lines it prints.

The simulation is computed by :func:`pdw_casadi.studies.simulate_run.run_simulation`; this
module renders its :class:`~pdw_casadi.studies.simulate_run.SimulationRun`: the trajectory
and the events with their units, the joint angles and the stick figures, the animation and
the warning on a walker that fell. Nothing here solves or simulates (the animation replays
the recorded trajectory).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from pdw_casadi.model.units import with_units
from pdw_casadi.report import plots

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.simulate_run import SimulationRun


def trajectory(run: SimulationRun) -> pd.DataFrame:
    """The recorded trajectory (one row per integration step; empty when none)."""
    traj = run.result.trajectory
    return pd.DataFrame() if traj is None else traj


def write_simulation_tables(run: SimulationRun, out: Path) -> list[Path]:
    """Write ``trajectory.csv`` (time in s, coordinates in rad, velocities in rad/s,
    outputs) and ``events.csv`` (guards, mode switches, failure) with the units of their
    columns into ``out``; returns their paths."""
    out = Path(out)
    traj_path, events_path = out / "trajectory.csv", out / "events.csv"
    with_units(trajectory(run), run.sim.hs).to_csv(traj_path, index=False)
    with_units(run.result.events, run.sim.hs).to_csv(events_path, index=False)
    return [traj_path, events_path]


def write_simulation_figures(run: SimulationRun, out: Path, snapshots: int) -> list[Path]:
    """Write ``angles.png`` (joint angles, deg, against time, s) and ``stick.png``
    (``snapshots`` stick figures of the first step) into ``out``; returns their paths."""
    out = Path(out)
    angles, stick = out / "angles.png", out / "stick.png"
    traj = trajectory(run)
    # through the module: a test stands in for a figure there
    plots.plot_angles(traj, angles, title=f"{run.problem.name}: joint angles",
                      faces=run.faces)
    plots.plot_stick(run.sim.hs, traj, run.parameters, stick, n=snapshots)
    return [angles, stick]


def write_simulation_animation(run: SimulationRun, path: Path, fps: int) -> Path:
    """Write the animated GIF of the walker over all simulated steps (``fps`` frames per
    simulated second) to ``path``; returns it."""
    # deferred: the animation, imported only for --animate
    from pdw_casadi.report.animation import animate_walk

    animate_walk(run.sim.hs, run.result, run.parameters, path, fps=fps,
                 title=f"{run.problem.name}: {run.result.completed_steps} steps down a slope "
                       f"of {run.problem.slope:.4f} rad")
    return Path(path)


def wrote_line(run: SimulationRun, where: Path, steps: int) -> str:
    """The line ``pdw-simulate`` ends on: the output folder and the steps completed of the
    ``steps`` asked for."""
    return f"wrote {where} ({run.summary['completed_steps']} of {steps} steps)"


def fall_warning(run: SimulationRun) -> str | None:
    """The warning on a simulation that stopped (step, phase, time in s, reason), None
    when it did not."""
    f = run.result.failure
    if f is None:
        return None
    return (f"warning: simulation stopped in step {f.step}, phase {f.phase}, at "
            f"t = {f.time:.4f} s: {f.reason}"
            + (f" ({f.detail})" if f.reason == "sample_limit" else ""))
