"""Parameter sweeps of a periodic gait: the sweep table, its events and stable ranges.

``sweep(problem, values, parameter="slope")`` starts from the fixed point of ``problem``
(its initial state and its own parameter values, e.g. a fit result) and covers the grid
``values`` of one scalar parameter (the slope in rad, or a compliance value in its own unit):

- ``mode="continuation"`` (default): natural-parameter continuation
  (:mod:`pdw_casadi.gait.continuation`) from the start towards the grid; when the start lies
  inside the grid, the two directions are two independent branches. Each branch stops where
  the gait pattern ends. Bifurcations between neighbouring points and the branch ends are
  located and named (:mod:`pdw_casadi.gait.bifurcation`).
- ``mode="grid"``: every grid value is solved on its own, from the tangent prediction of the
  start; no point depends on another, so all of them spread over the workers. Events are
  then located between neighbouring grid points.

Independent work (the branches, the grid points) runs through
:func:`pdw_casadi.engine.parallel.map_tasks`: serial, a process pool (``workers``) or a Dask cluster
(``scheduler``), with identical results. Every row is handed to ``on_row`` as soon as it is
known (the CLI appends it to ``sweep.csv``; serial runs stream point by point, parallel runs
branch by branch or point by point in order).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from pdw_casadi.engine.errors import NoStartGait, ProblemError
from pdw_casadi.engine.parallel import map_tasks
from pdw_casadi.gait.bifurcation import BranchEvent, Locator, boundary, branch_end, crossings
from pdw_casadi.gait.continuation import (
    Branch,
    BranchPoint,
    Corrector,
    NewtonCorrector,
    continue_branch,
    parameter_index,
    predict,
    sweep_parameters,
    with_value,
)
from pdw_casadi.gait.curves import cycle_curves, fit_scores
from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL, FixedPointResult
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import Problem, check_bounds


@dataclass(frozen=True)
class SweepSettings:
    """Numerical settings of a sweep.

    ``tol``: |P(x) - x| of every fixed point (rad, rad/s); ``max_iter``: Newton iterations
    per correction; ``refinements``: the smallest continuation step is the grid spacing /
    2**refinements (also how closely a branch end is bracketed); ``xtol``: events are located
    to this fraction of the grid spacing; ``fold_tol``: a branch end counts as a fold when a
    real eigenvalue is within this of +1; ``predictor``: ``"tangent"`` or ``"secant"``.
    """

    tol: float = FIXED_POINT_TOL
    max_iter: int = 10
    refinements: int = 12
    xtol: float = 1e-6
    fold_tol: float = 0.1
    predictor: str = "tangent"


@dataclass
class SweepResult:
    """The sweep table (one row per point, see :func:`point_row`) and the located events."""

    parameter: str
    table: pd.DataFrame
    events: list[BranchEvent]
    mode: str
    start_value: float
    grid: list[float] = field(default_factory=list)

    def stable_ranges(self) -> list[dict]:
        """Parameter intervals with a stable (spectral radius < 1) and valid gait.

        Each run of neighbouring stable, valid points is widened to the located events
        (bifurcation, boundary, fold) that lie between it and its neighbours, so the ends
        are as exact as the event location; an end without such an event is the last
        point found (``"to_event": None``).
        """
        return stable_ranges(self.table, self.events, self.parameter)

    def to_dict(self) -> dict:
        return {"parameter": self.parameter, "mode": self.mode, "start_value": self.start_value,
                "grid": list(self.grid), "points": len(self.table),
                "events": [e.to_dict() for e in self.events],
                "stable_valid_ranges": self.stable_ranges()}


# -- rows ------------------------------------------------------------------------------------
def point_row(problem: Problem, parameter: str, point: BranchPoint, gait=None) -> dict:
    """One row of the sweep table (SI units: rad, rad/s, s, m, m/s, N, N s).

    Columns: the parameter, branch, on_grid, converged, valid, stable, failure, the section
    state, step_time_s, step_length_m, speed_m_s, spectral_radius, eig{i}_re / eig{i}_im
    (sorted by modulus, largest first), margin:<name> (validity margins), the parameter
    vector as param:<name>, residual, iterations and, with a gait file, r2_knee, r2_hip
    (and r2_thigh).
    """
    r = point.result
    ok = bool(r.converged)
    row = {parameter: float(point.value), "branch": point.branch, "on_grid": point.on_grid,
           "converged": ok, "valid": bool(ok and r.valid), "stable": bool(ok and r.stable),
           "failure": r.failure or ("" if ok else "not converged")}
    row.update({n: float(v) if ok else math.nan
                for n, v in zip(r.state_names, r.state, strict=True)})
    row["step_time_s"] = r.step_time_s if ok else math.nan
    row["step_length_m"] = r.step_length_m if ok else math.nan
    row["speed_m_s"] = r.speed_m_s if ok else math.nan
    row["spectral_radius"] = r.spectral_radius if ok else math.nan
    for i in range(len(r.state_names)):
        e = r.eigenvalues[i] if ok else complex(math.nan, math.nan)
        row[f"eig{i}_re"], row[f"eig{i}_im"] = float(e.real), float(e.imag)
    if ok:
        row.update({f"margin:{k}": float(v) for k, v in r.margins.items()})
    row.update({f"param:{n}": float(v)
                for n, v in zip(r.parameter_names, r.parameters, strict=True)})
    row["residual"], row["iterations"] = float(r.residual), int(r.iterations)
    if gait is not None:
        row.update(gait_scores(problem, r, gait))
    return row


@functools.lru_cache(maxsize=4)
def _gait_curves(source: str):
    return load_gait_curves(source)


def gait_scores(problem: Problem, res: FixedPointResult, gait: str) -> dict:
    """R^2 of the gait cycle of fixed point ``res`` against the gait file ``gait`` (NaN when
    the point is not a converged gait)."""
    human = _gait_curves(str(gait))
    nan = {"r2_knee": math.nan, "r2_hip": math.nan}
    if human.thigh_deg is not None:
        nan["r2_thigh"] = math.nan
    if not res.converged:
        return nan
    sim = Simulator(problem)
    curves = cycle_curves(sim, res.state, res.parameters)
    return nan if curves is None else fit_scores(curves, human)


def stable_ranges(table: pd.DataFrame, events: list[BranchEvent], parameter: str) -> list[dict]:
    """See :meth:`SweepResult.stable_ranges`."""
    rows = table[table["converged"].astype(bool)].sort_values(parameter, kind="stable")
    rows = rows.drop_duplicates(subset=parameter)
    values = rows[parameter].to_numpy()
    good = (rows["stable"].astype(bool) & rows["valid"].astype(bool)).to_numpy()
    out = []
    i = 0
    while i < len(values):
        if not good[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(values) and good[j + 1]:
            j += 1
        lo_gap = (values[i - 1] if i > 0 else -math.inf, values[i])
        hi_gap = (values[j], values[j + 1] if j + 1 < len(values) else math.inf)
        lo_ev = [e for e in events if lo_gap[0] <= e.value <= lo_gap[1]]
        hi_ev = [e for e in events if hi_gap[0] <= e.value <= hi_gap[1]]
        lo = max(lo_ev, key=lambda e: e.value, default=None)
        hi = min(hi_ev, key=lambda e: e.value, default=None)
        out.append({"from": float(lo.value if lo else values[i]),
                    "to": float(hi.value if hi else values[j]),
                    "from_event": lo.kind if lo else None, "to_event": hi.kind if hi else None,
                    "points": int(j - i + 1)})
        i = j + 1
    return out


# -- the sweep -------------------------------------------------------------------------------
def start_point(problem: Problem, index: int, corrector: Corrector) -> BranchPoint:
    """The fixed point of ``problem`` at its own parameters, from its initial state."""
    p = sweep_parameters(problem)[1]
    return BranchPoint(float(p[index]), corrector(problem.state_vector(), p), branch=0)


@dataclass
class _Leg:
    """A continuation branch as a picklable task."""

    problem: Problem
    parameter: str
    index: int
    start: BranchPoint
    targets: list[float]
    corrector: Corrector
    settings: SweepSettings
    spacing: float
    branch: int
    gait: str | None


def _events_along(branch: Branch, leg: _Leg) -> list[BranchEvent]:
    s = leg.settings
    loc = Locator(leg.corrector, leg.index, leg.parameter, s.predictor)
    xtol = s.xtol * leg.spacing
    bisect_tol = leg.spacing / 2 ** s.refinements
    events = []
    pts = [pt for pt in branch.points if pt.result.converged]
    for a, b in zip(pts[:-1], pts[1:], strict=True):
        events += crossings(a, b, loc, xtol)
    if branch.end is not None:
        events.append(branch_end(branch.end, leg.problem, loc, xtol, bisect_tol, s.fold_tol))
    for e in events:
        e.branch = leg.branch
    return events


def run_leg(leg: _Leg, on_row: Callable[[dict], None] | None = None,
            on_grid_point: Callable[[], None] | None = None
            ) -> tuple[list[dict], list[BranchEvent]]:
    """Follow one branch and locate its events; rows exclude the (shared) start point."""
    rows: list[dict] = []

    def on_point(pt: BranchPoint):
        pt.branch = leg.branch
        row = point_row(leg.problem, leg.parameter, pt, leg.gait)
        rows.append(row)
        if on_row is not None:
            on_row(row)
        if pt.on_grid and on_grid_point is not None:
            on_grid_point()

    branch = continue_branch(leg.start, leg.targets, leg.index, leg.corrector, leg.parameter,
                             leg.settings.predictor,
                             min_step=leg.spacing / 2 ** leg.settings.refinements,
                             branch=leg.branch, on_point=on_point)
    return rows, _events_along(branch, leg)


def _run_leg_task(leg: _Leg):
    return run_leg(leg)


@dataclass
class _GridTask:
    problem: Problem
    parameter: str
    index: int
    start: BranchPoint
    value: float
    corrector: Corrector
    gait: str | None


def _solve_grid_point(task: _GridTask) -> tuple[BranchPoint, dict]:
    guess = predict([task.start], task.value, task.index, "tangent")
    res = task.corrector(guess, with_value(task.start.result.parameters, task.index,
                                           task.value))
    pt = BranchPoint(task.value, res, on_grid=True, branch=0)
    return pt, point_row(task.problem, task.parameter, pt, task.gait)


def sweep(problem: Problem, values, parameter: str = "slope", mode: str = "continuation",
          corrector: Corrector | None = None, workers: int = 1, scheduler: str | None = None,
          gait: str | None = None, settings: SweepSettings | None = None,
          on_row: Callable[[dict], None] | None = None,
          progress: Callable[[int], None] | None = None) -> SweepResult:
    """Sweep ``parameter`` of ``problem`` over the grid ``values`` (see the module docstring).

    Args:
        problem: walker problem; its initial state and parameters give the start fixed point.
        values: grid of parameter values (unit of the parameter: rad for the slope).
        parameter: ``"slope"`` or a compliance name of the problem; when the problem's legs
            differ (the gait is a fixed point of the stride map), a physical leg's value
            such as ``right.k_ankle`` or ``right.m_s`` (:func:`sweep_parameters`).
        mode: ``"continuation"`` or ``"grid"``.
        corrector: (x_guess, p) -> FixedPointResult; default Newton at fixed compliance.
        workers / scheduler: where independent work runs (:func:`map_tasks`).
        gait: gait-curve file; adds R^2 columns (walkers with one set of values for both
            legs: the curves are one leg's).
        on_row: called with every row as soon as it is known.
        progress: called with the number of grid values newly covered.
    Raises:
        ProblemError: unknown parameter, bad grid or mode, no fixed point at the start.
    """
    settings = settings or SweepSettings()
    index = parameter_index(problem, parameter)
    if gait is not None and problem.asymmetric:
        raise ProblemError(f"{problem.name}: its legs differ, so one gait-curve file does "
                           f"not describe both; sweep it without gait curves")
    grid = [float(v) for v in values]
    if len(grid) < 2 or len(set(grid)) != len(grid) or not all(map(math.isfinite, grid)):
        shown = ", ".join(f"{v:g}" for v in grid[:6]) + (", ..." if len(grid) > 6 else "")
        raise ProblemError(f"sweep grid must hold at least 2 distinct finite values, "
                           f"got [{shown}]")
    # the problem's bounds (compliance_bounds, non-negative dampers, |slope| < pi/4) hold
    # for a sweep as for the problem file and the overrides: the grid's ends are checked
    for v in (min(grid), max(grid)):
        check_bounds(problem, {parameter: v}, f"sweep of {parameter}")
    if mode not in ("continuation", "grid"):
        raise ProblemError(f"unknown sweep mode {mode!r}: use 'continuation' or 'grid'")
    corrector = corrector or NewtonCorrector(problem, settings.tol, settings.max_iter)
    start = start_point(problem, index, corrector)
    if not start.ok:
        why = start.result.failure or "Newton did not converge"
        raise NoStartGait(f"no valid fixed point at the start ({parameter} = {start.value:.8g}"
                           f", from the problem's initial state): {why}")
    start.on_grid = any(abs(v - start.value) <= 1e-12 * max(1.0, abs(v)) for v in grid)
    rows: list[dict] = []

    def emit(row):
        rows.append(row)
        if on_row is not None:
            on_row(row)

    emit(point_row(problem, parameter, start, gait))
    if start.on_grid and progress:
        progress(1)
    spacing = float(np.max(np.abs(np.diff(sorted(grid)))))
    if mode == "grid":
        events = _grid(problem, parameter, index, start, grid, corrector, settings, spacing,
                       workers, scheduler, gait, emit, progress)
    else:
        events = _continuation(problem, parameter, index, start, grid, corrector, settings,
                               spacing, workers, scheduler, gait, emit, progress)
    events.sort(key=lambda e: e.value)
    return SweepResult(parameter, pd.DataFrame(rows), events, mode, start.value, grid)


def _continuation(problem, parameter, index, start, grid, corrector, settings, spacing,
                  workers, scheduler, gait, emit, progress) -> list[BranchEvent]:
    below = sorted((v for v in grid if v < start.value and not _same(v, start.value)),
                   reverse=True)
    above = sorted(v for v in grid if v > start.value and not _same(v, start.value))
    legs = [_Leg(problem, parameter, index, start, targets, corrector, settings, spacing, b,
                 gait) for b, targets in enumerate((below, above), start=1) if targets]
    events: list[BranchEvent] = []
    if workers <= 1 and scheduler is None:
        for leg in legs:  # stream row by row
            on_grid = (lambda: progress(1)) if progress else None
            rows, evs = run_leg(leg, emit, on_grid)
            events += evs
            if progress:
                progress(len(leg.targets) - sum(1 for r in rows if r["on_grid"]))
        return events
    for leg, (rows, evs) in zip(legs, map_tasks(_run_leg_task, legs, workers, scheduler),
                                strict=True):
        for row in rows:
            emit(row)
        events += evs
        if progress:
            progress(len(leg.targets))
    return events


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-12 * max(1.0, abs(a), abs(b))


def _grid(problem, parameter, index, start, grid, corrector, settings, spacing, workers,
          scheduler, gait, emit, progress) -> list[BranchEvent]:
    tasks = [_GridTask(problem, parameter, index, start, v, corrector, gait)
             for v in grid if not _same(v, start.value)]
    points = [start]
    for pt, row in map_tasks(_solve_grid_point, tasks, workers, scheduler):
        points.append(pt)
        emit(row)
        if progress:
            progress(1)
    points.sort(key=lambda pt: pt.value)
    loc = Locator(corrector, index, parameter, settings.predictor)
    xtol = settings.xtol * spacing
    bisect_tol = spacing / 2 ** settings.refinements
    events: list[BranchEvent] = []
    for a, b in zip(points[:-1], points[1:], strict=True):
        if a.result.converged and b.result.converged:
            events += crossings(a, b, loc, xtol)
        if a.ok != b.ok:
            good, bad = (a, b) if a.ok else (b, a)
            events.append(boundary(good, bad.value, bad if bad.result.converged else None,
                                   bad.result.failure, problem, loc, xtol, bisect_tol))
    return events
