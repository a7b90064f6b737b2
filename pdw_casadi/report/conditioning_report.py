"""The report of ``pdw-fixed-point --conditioning``: the lines it prints, ``conditioning.json``
and ``answer.npz``.

The measurement is :func:`pdw_casadi.studies.conditioning.run_conditioning`; this module
renders its :class:`~pdw_casadi.studies.conditioning.ConditioningRun`. Nothing here solves.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.model.system import gait_system
from pdw_casadi.model.units import DESCRIBED, Units

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.conditioning import ConditioningRun

#: the unit of a max norm of section-state differences
STATE_NORM = DESCRIBED["residual"].replace("norm", "max norm")


def conditioning_lines(run: ConditioningRun, source: str) -> list[str]:
    """The lines that sum the measurement up (``source``: the curve file's name): the solve
    and which point was measured, the simulator's residual, the Jacobian's figures, the
    Newton step, the path along it and Newton on the simulator's map."""
    c = run.figures
    lines = [f"{source}: start {run.start}; {run.status} after {run.iterations} iterations "
             f"({run.wall_time_s:.1f} s); {run.which}, objective {run.objective:.5f}",
             f"simulator residual |P(x) - x|       {c['residual']:.2e}",
             f"spectral radius of J                {c['rho']:.4f}",
             f"sigma_min(I - J), ||(I - J)^-1||    {c['sigma_min_I_minus_J']:.3e}, "
             f"{c['inv_norm']:.1f}",
             f"largest |J_ij|, Henrici departure   {c['max_entry']:.1f}, {c['henrici']:.3f}",
             f"Newton step |d|                     {c['newton_step']:.2e} "
             f"({c['newton_step'] / max(c['residual'], 1e-300):.0f} x the residual)",
             "along x + t d:   t    rho     |dJ| per step   same plan   |P - x - t d|"]
    for s in c["path"]:
        if "failure" in s:
            lines.append(f"              {s['t']:.2f}  simulator failure: {s['failure']}")
        else:
            lines.append(f"              {s['t']:.2f}  {s['rho']:.4f}  {s['dJ']:.2e}        "
                         f"{str(s['same_plan']):5s}       {s['residual']:.2e}")
    fp = run.newton
    lines.append(f"Newton on the simulator's map from x: converged {fp.converged}, "
                 f"rho {fp.spectral_radius:.4f}" + ("" if fp.converged else
                                                    f" ({fp.failure or 'no convergence'})"))
    return lines


def conditioning_summary(run: ConditioningRun, source: str) -> dict:
    """The content of ``conditioning.json``: the walker, the curve file, the solve, the
    measured state and parameters by name, the figures of
    :func:`~pdw_casadi.studies.conditioning.conditioning`, Newton on the simulator's map and
    a ``units`` block."""
    problem = run.problem
    state = dict(zip(problem.state_names, map(float, run.state), strict=True))
    params = dict(zip(problem.parameter_names, map(float, run.parameters), strict=True))
    fp = run.newton
    summary = {"problem": problem.name, "gait_file": source, "start": run.start,
               "solve": {"status": run.status, "iterations": run.iterations,
                         "wall_time_s": run.wall_time_s, "objective": run.objective,
                         "fallback_iteration": run.fallback_iteration,
                         "measured": run.which},
               "state": state, "parameters": params, **run.figures,
               "newton": {"converged": bool(fp.converged),
                          "spectral_radius": float(fp.spectral_radius),
                          "failure": fp.failure}}
    units = Units(gait_system(problem))
    summary["units"] = {
        "state": {k: units.of(k) for k in state}, "parameters": {
            k: u for k in params if (u := units.of(k)) is not None},
        "solve.wall_time_s": "s", "residual": STATE_NORM, "newton_step": STATE_NORM,
        "path[].t": "dimensionless (fraction of the Newton step)",
        "path[].residual": STATE_NORM,
        "path[].dJ": "dimensionless (largest change of an entry of J)",
        "rho, sigma_min_I_minus_J, inv_norm, max_entry, henrici": "dimensionless"}
    return summary


def write_conditioning(run: ConditioningRun, out: Path, source: str) -> tuple[Path, Path]:
    """Write ``conditioning.json`` (:func:`conditioning_summary`) and ``answer.npz`` (the
    measured section state ``x`` in rad, rad/s and parameters ``p``, compliance then slope
    in rad, in the problem's order) into ``out``; returns their paths."""
    out = Path(out)
    summary, answer = out / "conditioning.json", out / "answer.npz"
    write_json(summary, conditioning_summary(run, source))
    np.savez(answer, x=run.state, p=run.parameters)
    return summary, answer
