"""The report of a fixed point: the files ``pdw-fixed-point`` writes besides its summary and
the lines it prints.

The solve is :func:`pdw_casadi.studies.fixed_point_run.run_fixed_point`; this module renders
its :class:`~pdw_casadi.studies.fixed_point_run.FixedPointRun`: the per-leg curves of a
stride (``leg_curves.csv``, ``leg_curves.png``), the limit cycle of a one-step gait
(``limit_cycle.png``, the paper's Fig. 4), the result lines and the reason for no gait.
Nothing here solves.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from pdw_casadi.report import plots

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.fixed_point_run import FixedPointRun


def write_leg_curves(run: FixedPointRun, out: Path) -> list[Path]:
    """Write a converged stride's knee and hip curves per leg (deg against % of the leg's
    gait cycle) to ``leg_curves.csv`` and ``leg_curves.png`` in ``out``; returns their
    paths (none without curves)."""
    if run.leg_curves is None:
        return []
    out = Path(out)
    csv, png = out / "leg_curves.csv", out / "leg_curves.png"
    frame = pd.concat([c.assign(leg=side) for side, c in run.leg_curves.items()],
                      ignore_index=True)
    frame.to_csv(csv, index=False)
    plots.plot_leg_curves(run.leg_curves, png,
                          title=f"{run.pmap.problem.name}: knee and hip per leg")
    return [csv, png]


def stride_line(run: FixedPointRun) -> str | None:
    """The step lengths (m) and times (s) per leg with their asymmetry (%) of a converged
    stride; None otherwise."""
    rep = run.summary.get("stride")
    if rep is None:
        return None
    legs = rep["legs"]
    return (f"step length L/R {legs['left']['step_length_m']:.4f} / "
            f"{legs['right']['step_length_m']:.4f} m "
            f"(asymmetry {rep['step_length_asymmetry_pct']:+.3f} %), step time L/R "
            f"{legs['left']['step_time_s']:.4f} / {legs['right']['step_time_s']:.4f}"
            f" s (asymmetry {rep['step_time_asymmetry_pct']:+.3f} %)")


def write_limit_cycle(run: FixedPointRun, out: Path) -> Path | None:
    """Write ``limit_cycle.png`` (one leg's angles against their rates over two steps) of a
    converged one-step gait into ``out``; returns its path (None without one)."""
    if run.limit_cycle is None:
        return None
    path = Path(out) / "limit_cycle.png"
    plots.plot_limit_cycle(run.limit_cycle, path, faces=run.faces,
                           title=f"{run.problem.name}: limit cycle of one leg over two steps")
    return path


def result_lines(run: FixedPointRun, where: Path) -> list[str]:
    """The lines that sum the solve up: convergence, residual, iterations, spectral radius
    (-), stability and validity; the eigenvalues; the output folder ``where`` and the wall
    time (s)."""
    res = run.result
    ev = ", ".join(f"{e.real:+.4f}{e.imag:+.4f}i" for e in res.eigenvalues)
    wall = run.wall_time_s
    return [f"converged={res.converged} residual={res.residual:.2e} "
            f"iterations={res.iterations} spectral radius={res.spectral_radius:.4f} "
            f"({'stable' if res.stable else 'NOT stable'}) valid={res.valid}"
            f"{'' if res.valid else ' (' + str(res.failure) + ')'}",
            f"eigenvalues: {ev}",
            f"wrote {where}" + (f" ({wall:.2f} s)" if wall is not None else "")]


def no_gait_message(run: FixedPointRun, tol: float, summary: Path) -> str:
    """Why no fixed point was found (the residual against ``tol``, or the fall from the
    initial state) and where the summary is."""
    res = run.result
    why = (f"|P(x) - x| = {res.residual:.3g} > {tol:g}"
           f"{', ' + str(res.failure) if res.failure else ''}"
           if math.isfinite(res.residual) else
           f"the walker fails in the first step from it: {res.failure}")
    return (f"no fixed point of {run.problem.name} near its initial state ({why}); "
            f"the summary is in {summary}")
