"""Natural-parameter continuation of a periodic gait (a fixed point of the Poincare map).

One scalar parameter lambda of the parameter vector p (the slope, rad, or any compliance
value in its own unit) is stepped from a known fixed point x*(lambda_0) towards a list of
target values. Each step

1. predicts the fixed point at the new value: *tangent* x + dx/dlambda * dlambda with
   dx/dlambda = -(dP/dx - I)^-1 dP/dlambda (exact, from the AD Jacobians the fixed-point
   solve already returned), or *secant* through the last two points;
2. corrects it with a :data:`Corrector` (default: Newton on P(x) - x, :class:`NewtonCorrector`);
3. adapts the step: a failed correction halves it (down to ``min_step``), a success doubles
   it again (up to the spacing of the targets).

A branch ends when a corrected fixed point breaks the gait pattern (a validity margin below
its minimum: the point is kept and flagged), or when no correction succeeds even at the
smallest step (the orbit fails, or Newton cannot converge, e.g. beyond a fold). What
happened is returned as a :class:`BranchEnd`; :mod:`pdw_casadi.gait.bifurcation` names and locates
it. Continuation along one branch is sequential by nature; independent branches (both
directions from an interior start) can run in parallel (:mod:`pdw_casadi.engine.parallel`).

The corrector is a seam: a corrector that also refits the compliance at every point (to a
gait file) only has to return a :class:`~pdw_casadi.gait.fixed_point.FixedPointResult` whose
``parameters`` hold the refitted compliance; the next step starts from those.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL, FixedPointResult, find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import (
    period_steps,
    physical_parameter_names,
    physical_parameter_vector,
)
from pdw_casadi.model.problem import Problem, ProblemError

#: (x_guess, p) -> fixed point at parameters p (which hold the new lambda)
Corrector = Callable[[np.ndarray, np.ndarray], FixedPointResult]


class NewtonCorrector:
    """Newton on P(x) - x at fixed compliance (:func:`find_fixed_point`, no IPOPT fallback);
    P is the periodic map of :func:`~pdw_casadi.gait.stride.period_steps` steps (the stride
    when the problem's legs differ, so p is then its physical parameter vector,
    :func:`sweep_parameters`).

    ``tol``: |P(x) - x| to reach (rad, rad/s). ``max_iter``: a good prediction converges in
    a few iterations; more means the prediction is off and a shorter step is cheaper.
    Picklable (the Poincare map is rebuilt from the walker cache in another process).
    """

    def __init__(self, problem: Problem, tol: float = FIXED_POINT_TOL, max_iter: int = 10):
        self.problem = problem
        self.tol = tol
        self.max_iter = max_iter
        self._pmap = None

    @property
    def pmap(self):
        if self._pmap is None:
            self._pmap = PoincareMap(self.problem, steps=period_steps(self.problem))
        return self._pmap

    def __call__(self, x_guess, p) -> FixedPointResult:
        return find_fixed_point(self.problem, x_guess, p, tol=self.tol, max_iter=self.max_iter,
                                fallback=False, pmap=self.pmap)

    def __getstate__(self):
        return {**self.__dict__, "_pmap": None}


@dataclass
class BranchPoint:
    """A corrected fixed point at parameter value ``value`` (unit of the swept parameter)."""

    value: float
    result: FixedPointResult
    on_grid: bool = False
    branch: int = 0

    @property
    def ok(self) -> bool:
        """Converged and inside the gait pattern (all validity margins met)."""
        return bool(self.result.converged and self.result.valid)


@dataclass
class BranchEnd:
    """Why a branch stopped before its last target.

    ``kind``: ``"invalid"`` (a converged fixed point broke a validity margin: ``point``) or
    ``"lost"`` (no correction succeeded at the smallest step; ``failed_value`` is the nearest
    value tried, ``failure`` the orbit's failure reason or None for a Newton that did not
    converge, ``attempt`` that last corrector result). ``last``: the last good point.
    """

    kind: str
    last: BranchPoint
    failed_value: float
    failure: str | None = None
    point: BranchPoint | None = None
    attempt: FixedPointResult | None = None


@dataclass
class Branch:
    """Points in the order found (``points[0]`` is the start) and how the branch ended."""

    parameter: str
    index: int
    points: list[BranchPoint] = field(default_factory=list)
    end: BranchEnd | None = None


def sweep_parameters(problem: Problem) -> tuple[tuple[str, ...], np.ndarray]:
    """(names, values) of the parameters a gait of ``problem`` is continued in: the
    problem's parameter vector (compliance..., slope), or, when its legs differ, the stride
    map's physical one (``left.k_ankle``, ..., ``right.m_s``, ..., ``slope``; SI units)."""
    if problem.asymmetric:
        return physical_parameter_names(problem), physical_parameter_vector(problem)
    return tuple(problem.parameter_names), problem.parameter_vector()


def parameter_index(problem: Problem, name: str) -> int:
    """Index of parameter ``name`` in the vector of :func:`sweep_parameters`."""
    names = list(sweep_parameters(problem)[0])
    if name not in names:
        raise ProblemError(f"{problem.name}: no parameter {name!r}; parameters: "
                           f"{', '.join(names)}")
    return names.index(name)


def tangent(result: FixedPointResult, index: int) -> np.ndarray:
    """dx*/dlambda = -(dP/dx - I)^-1 dP/dlambda at a fixed point (state units per unit of
    the parameter); implicit function theorem on P(x, lambda) - x = 0."""
    n = result.state.size
    return -np.linalg.solve(result.jacobian - np.eye(n), result.jacobian_p[:, index])


def predict(points: list[BranchPoint], value: float, index: int,
            method: str = "tangent") -> np.ndarray:
    """Predicted fixed point at ``value`` from the last point(s) of a branch."""
    last = points[-1]
    dv = value - last.value
    if method == "secant" and len(points) >= 2:
        prev = points[-2]
        return last.result.state + (last.result.state - prev.result.state) * (
            dv / (last.value - prev.value))
    if method not in ("tangent", "secant"):
        raise ValueError(f"unknown predictor {method!r}: use 'tangent' or 'secant'")
    return last.result.state + tangent(last.result, index) * dv


def with_value(p, index: int, value: float) -> np.ndarray:
    """Copy of parameter vector ``p`` with entry ``index`` set to ``value``."""
    p = np.array(p, dtype=float)
    p[index] = value
    return p


def continue_branch(start: BranchPoint, targets, index: int, corrector: Corrector,
                    parameter: str = "slope", predictor: str = "tangent",
                    min_step: float | None = None, branch: int = 0,
                    on_point: Callable[[BranchPoint], None] | None = None) -> Branch:
    """Follow the fixed point of ``start`` through ``targets`` (monotone, away from start).

    Every accepted point (targets and the intermediate values the step control needed) is
    appended to the branch and passed to ``on_point`` at once. ``min_step``: smallest step
    (parameter unit) before the branch is declared ended; default 1/4096 of the spacing of
    the targets, which is also how closely the end is bracketed.
    """
    targets = [float(t) for t in targets]
    out = Branch(parameter, index, [start])
    if not targets:
        return out
    spacing = max(abs(targets[0] - start.value),
                  *(abs(b - a) for a, b in zip(targets[:-1], targets[1:], strict=True))) \
        if len(targets) > 1 else abs(targets[0] - start.value)
    if min_step is None:
        min_step = spacing / 4096
    h = spacing
    last = start
    for target in targets:
        sign = 1.0 if target > last.value else -1.0
        while last.value != target:
            remaining = abs(target - last.value)
            # land exactly on the target rather than a hair short of it
            value = target if remaining <= h * (1 + 1e-9) else last.value + sign * h
            step = abs(value - last.value)
            guess = predict(out.points, value, index, predictor)
            res = corrector(guess, with_value(last.result.parameters, index, value))
            if res.converged:
                point = BranchPoint(value, res, on_grid=value == target, branch=branch)
                out.points.append(point)
                if on_point is not None:
                    on_point(point)
                if not res.valid:
                    out.end = BranchEnd("invalid", last, value, res.failure, point=point)
                    return out
                last = point
                h = min(2 * h, spacing)
                continue
            if step <= min_step * (1 + 1e-9):
                out.end = BranchEnd("lost", last, value, res.failure, attempt=res)
                return out
            h = step / 2
    return out
