"""The fixed-point workflow: everything ``pdw-fixed-point`` computes, returned as data for the
report.

:func:`run_fixed_point` solves for a periodic gait of a walker on the map the command works
on (:func:`~pdw_casadi.studies.simulate_run.command_map`: the step map, or the stride with
``--stride`` or when the legs differ; Newton with its IPOPT fallback,
:func:`~pdw_casadi.gait.fixed_point.find_fixed_point`) and returns a
:class:`FixedPointRun`: the result, the ``summary.json`` content, the per-leg report and
curves of a stride and the limit cycle of a one-step gait. The report layer
(:mod:`pdw_casadi.report.fixed_point_report`) only renders it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from pdw_casadi.engine.compile import build_libraries
from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL, find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap, sensitivity_libraries
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stride import stride_report, stride_timing
from pdw_casadi.gait.timing import fixed_point_timing, timing_or_none
from pdw_casadi.model.faces import WalkerFaces, walker_faces
from pdw_casadi.model.problem import Problem


@dataclass
class FixedPointRun:
    """A fixed-point solve and what its report shows (:func:`run_fixed_point`)."""

    problem: Problem
    #: the map solved on (``steps`` 2: the stride, parameters following the physical legs)
    pmap: PoincareMap
    #: the fixed point (:class:`~pdw_casadi.gait.fixed_point.FixedPointResult`)
    result: Any
    #: the summary.json content (SI units; without the wall time)
    summary: dict
    #: wall time of the solve, s (None: not measured)
    wall_time_s: float | None
    #: the one-step walker's faces (None on the stride)
    faces: WalkerFaces | None
    #: a converged stride: knee and hip curves per leg (side -> frame); else None
    leg_curves: dict[str, pd.DataFrame] | None = None
    #: a converged one-step gait: two recorded steps from it (its limit cycle); else None
    limit_cycle: pd.DataFrame | None = None

    @property
    def stride(self) -> bool:
        """Solved on the stride map (two steps, one per physical leg)."""
        return self.pmap.steps > 1


def _stride_summary(pmap: PoincareMap, res) -> tuple[dict, dict[str, pd.DataFrame]]:
    """The per-leg report of a stride fixed point (per leg its step, stance and swing and
    the timing of its own gait cycle; the per-step equivalent spectral radius, -) and the
    per-leg knee/hip curves."""
    rep = stride_report(pmap, res.state, res.parameters)
    timing = timing_or_none(lambda: stride_timing(pmap, res.state, res.parameters))
    if timing is not None:  # each physical leg's own gait cycle
        for side, t in timing.items():
            rep["legs"][side]["timing"] = t.to_dict()
    curves = rep.pop("curves")
    rep["step_spectral_radius_equivalent"] = float(np.sqrt(res.spectral_radius))
    return rep, curves


def run_fixed_point(problem: Problem, pmap: PoincareMap, tol: float = FIXED_POINT_TOL,
                    log: Callable[[str], None] = print) -> FixedPointRun:
    """Solve for a fixed point of ``pmap`` (of ``problem``) near the problem's section
    state to ``|P(x) - x| <= tol``; ``log`` receives the progress lines (the compile of a
    first run on this machine, the start of the solve). Returns the
    :class:`FixedPointRun`, converged or not."""
    stride = pmap.steps > 1
    faces = None if stride else walker_faces(problem)
    # a first run on this machine: the walker and its sensitivities, side by side
    build_libraries([*pmap.hs.libraries(), *sensitivity_libraries(pmap.hs)], log=log)
    log(f"solving for a fixed point of {problem.name} (slope {problem.slope} rad)...")
    res = find_fixed_point(problem, tol=tol, pmap=pmap, verbose=not stride)
    summary = res.to_dict()
    wall = summary.pop("wall_time_s", None)  # timings are not part of the result
    summary["distance_from_initial"] = float(np.linalg.norm(res.state - problem.state_vector()))
    summary["problem"] = problem.name
    summary["initial_state"] = dict(problem.initial_state)
    if res.converged and not stride:
        summary["timing"] = timing_or_none(lambda: fixed_point_timing(
            problem, res.state, res.parameters))
    run = FixedPointRun(problem=problem, pmap=pmap, result=res, summary=summary,
                        wall_time_s=wall, faces=faces)
    if stride:
        summary["map"] = "stride (left-stance step, then right-stance step)"
        if res.converged:
            summary["stride"], run.leg_curves = _stride_summary(pmap, res)
    elif res.converged:
        two = Simulator(problem).run(res.state, res.parameters, steps=2, record=True)
        run.limit_cycle = two.trajectory
    return run
