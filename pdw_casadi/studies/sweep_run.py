"""The sweep workflow: everything ``pdw-sweep`` computes, returned as data for the report.

:func:`run_sweep` follows the periodic gait of a walker over one parameter as a
:class:`SweepRequest` asks (:func:`pdw_casadi.gait.sweep.sweep`: continuation from the
start, or every grid value on its own; with ``refit`` the compliance refitted to human
curves at every point, :class:`~pdw_casadi.fit.RefitCorrector`) and returns a
:class:`SweepRun`: the table of points and the located bifurcations and gait-pattern
boundaries. Every row is handed to the caller as soon as it is found (``on_row``), so a
report can keep it on disk before the sweep ends. The report layer
(:mod:`pdw_casadi.report.sweep_report`) only renders the result.

:func:`check_sweep` checks a request against its walker (the parameter exists, the grid's
ends lie within the problem's bounds) before any work.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pdw_casadi.engine.errors import NoGait, NoStartGait
from pdw_casadi.gait.continuation import parameter_index
from pdw_casadi.gait.sweep import SweepResult, SweepSettings, sweep
from pdw_casadi.model.gait_data import GaitCurves, load_gait_curves
from pdw_casadi.model.problem import Problem, check_bounds


@dataclass(frozen=True)
class SweepRequest:
    """What :func:`run_sweep` sweeps.

    ``parameter``: the slope (rad) or a compliance name (its own unit; for a walker whose
    legs differ also one leg's value, e.g. ``right.k_ankle``); ``num`` values from
    ``start`` to ``stop`` (the parameter's unit); ``mode``: ``"continuation"`` from the
    start or ``"grid"`` (every value solved on its own from the start); ``predictor``
    (``"tangent"`` or ``"secant"``) and ``tol`` (|P(x) - x| of every fixed point, rad and
    rad/s) as in :class:`~pdw_casadi.gait.sweep.SweepSettings`; ``gait``: a gait-curve file
    whose R^2 every row carries; ``refit``: refit the compliance to ``gait`` at every point
    (the slope swept).
    """

    parameter: str
    start: float
    stop: float
    num: int = 25
    mode: str = "continuation"
    predictor: str = SweepSettings.predictor
    tol: float = SweepSettings.tol
    gait: str | None = None
    refit: bool = False

    @property
    def grid(self) -> np.ndarray:
        """The ``num`` values from ``start`` to ``stop``, evenly spaced (parameter's unit)."""
        return np.linspace(self.start, self.stop, self.num)


@dataclass
class SweepRun:
    """A parameter sweep and what its report shows (:func:`run_sweep`)."""

    #: the walker swept (its initial state and parameters give the start fixed point)
    problem: Problem
    request: SweepRequest
    #: the table of points (one row each) and the located events
    result: SweepResult


def check_sweep(problem: Problem, parameter: str, ends: Sequence[tuple[str, float]]) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless ``parameter`` is a
    parameter of ``problem`` and each value of ``ends`` ((label, value) pairs: the grid's
    ends in the parameter's unit, the label naming each in the message) lies within the
    problem's bounds (compliance bounds, non-negative dampers, |slope| < pi/4)."""
    parameter_index(problem, parameter)  # an unknown name fails before any work
    for label, value in ends:
        check_bounds(problem, {parameter: value}, label)


def run_sweep(problem: Problem, request: SweepRequest, human: GaitCurves | None = None,
              workers: int = 1, scheduler: str | None = None,
              on_row: Callable[[dict], None] | None = None,
              progress: Callable[[int], None] | None = None) -> SweepRun:
    """Sweep ``problem``'s gait as ``request`` asks.

    ``human``: the curves of ``request.gait`` when the caller has read them already (the
    refit fits them; None: read here when needed); ``workers`` processes or a Dask
    ``scheduler`` share the independent work (grid points, the two directions from an
    interior start); ``on_row`` gets every row as soon as it is found, ``progress`` the
    number of grid values newly covered. Raises :class:`~pdw_casadi.engine.errors.NoGait`
    when the start has no valid fixed point (nothing to follow).
    """
    corrector = None
    if request.refit:
        # deferred: the fit stack, imported only for --refit
        from pdw_casadi.fit import FitOptions, RefitCorrector

        curves = human if human is not None else load_gait_curves(request.gait)
        corrector = RefitCorrector(problem, curves, FitOptions(verbose=False, knee_floor=None))
    try:
        result = sweep(problem, request.grid, parameter=request.parameter, mode=request.mode,
                       corrector=corrector, workers=workers, scheduler=scheduler,
                       gait=request.gait,
                       settings=SweepSettings(tol=request.tol, predictor=request.predictor),
                       on_row=on_row, progress=progress)
    except NoStartGait as exc:
        raise NoGait(str(exc)) from None
    return SweepRun(problem=problem, request=request, result=result)
