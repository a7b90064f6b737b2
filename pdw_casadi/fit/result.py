"""What a fit returns: solves, checked candidates and the result, with the checks."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from pdw_casadi.fit.options import FitOptions
from pdw_casadi.gait.curves import cycle_curves, fit_scores, gait_cycle
from pdw_casadi.gait.fixed_point import FixedPointResult, find_fixed_point, own_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stability import step_radius
from pdw_casadi.gait.timing import step_timing, timing_or_none
from pdw_casadi.model.gait_data import SIDES
from pdw_casadi.nlp.driver import succeeded


@dataclass
class Solve:
    """One IPOPT solve: status, iterations, wall time (s), objective (sum of 1 - R^2), the
    simulator's spectral radius at its answer and the NLP's own bound rho_32 there."""

    start: int
    round: int
    status: str
    iterations: int
    wall_time_s: float
    objective: float
    spectral_radius: float = float("nan")
    nlp_radius_bound: float = float("nan")  # the NLP's stability row at its answer
    #: the iteration whose feasible iterate stands for the answer of a solve that stopped
    #: short of convergence (None: IPOPT's own answer)
    fallback_iteration: int | None = None
    #: the stability row's relaxed bound of a continuation solve from an unstable start
    #: (:attr:`~pdw_casadi.fit.options.FitOptions.radius_stage_ratio`; None: the fit's own)
    stage_bound: float | None = None

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Candidate:
    """A fitted periodic gait of ``steps`` steps (1: the step; 2: the stride, the legs may
    differ) with its checks: fixed point of the ``steps``-step map (stability, validity),
    R^2, curves, re-simulation deviation (rad, rad/s) of the NLP's section state over
    ``resim_steps`` steps, the NLP objective (sum of 1 - R^2).

    A stride's ``parameters`` are the physical legs' (:mod:`pdw_casadi.gait.stride`), its
    ``scores`` and ``curves`` are per leg (``scores[side]``, ``curves[side]``) and ``report``
    is its per-leg report (:func:`~pdw_casadi.gait.stride.stride_report`; None for one
    step).

    Stability, one rule for any ``steps``: the spectral radius rho of the ``steps``-step
    map spans ``steps`` steps, so its per-step equivalent is rho^(1/steps)
    (:attr:`per_step_radius`); ``max_radius`` is the largest accepted per-step radius
    (:attr:`FitOptions.max_radius`).
    """

    start: int
    state: np.ndarray
    parameters: np.ndarray
    fixed_point: FixedPointResult
    scores: dict
    curves: pd.DataFrame | dict
    resimulation_deviation: float
    objective: float = math.nan
    resim_tol: float = FitOptions.resim_tol
    #: IPOPT's return status of the solve this gait came from (None: no solve)
    solver_status: str | None = None
    #: the IPOPT iteration whose iterate the simulator polished into this gait (None: the
    #: solve's answer, or its best feasible iterate when it stopped short)
    polished_from: int | None = None
    #: the steps of the periodic map: 1 (the step) or 2 (the stride)
    steps: int = 1
    #: the largest accepted spectral radius per step
    max_radius: float = FitOptions.max_radius
    #: a stride's per-leg report (:func:`~pdw_casadi.gait.stride.stride_report`, with its
    #: curves); None for one step
    report: dict | None = None
    #: the NLP's solution with its multipliers and row names, when this gait is IPOPT's
    #: converged answer (:class:`~pdw_casadi.fit.driver.WarmStart`): a stride fit starts
    #: from the symmetric fit's with them (:attr:`FitOptions.stride_warm_start`)
    warm: object | None = field(default=None, repr=False)

    @property
    def certified(self) -> bool:
        """True: IPOPT's converged answer (or no solve); False: the best feasible iterate of
        a solve that stopped short, or an iterate polished on the simulator (checked the same
        way, not shown to be the NLP's optimum)."""
        if self.solver_status is None:
            return True
        return succeeded(self.solver_status) and self.polished_from is None

    @property
    def per_step_radius(self) -> float:
        """The spectral radius per step: rho^(1/steps) of the ``steps``-step map's rho."""
        rho = self.fixed_point.spectral_radius
        return step_radius(rho, self.steps)

    @property
    def stable(self) -> bool:
        """Asymptotically stable (rho < 1) with a per-step radius of at most ``max_radius``.
        Compared as rho <= max_radius^steps: the same verdict as :attr:`per_step_radius`
        <= ``max_radius``, without the rounding of the root."""
        return self.fixed_point.stable and \
            self.fixed_point.spectral_radius <= self.max_radius ** self.steps

    @property
    def valid(self) -> bool:
        return self.fixed_point.valid and self.resimulation_deviation < self.resim_tol

    @property
    def good(self) -> bool:
        """An answer: stable (per-step rho <= ``max_radius``), valid, re-simulated."""
        return self.stable and self.valid

    def mean_score(self, targets) -> float:
        """Mean R^2 of ``targets`` ("knee", "hip", "thigh"), over both legs for a stride:
        what fits rank by."""
        if self.steps == 1:
            return float(np.mean([self.scores[f"r2_{t}"] for t in targets]))
        return float(np.mean([self.scores[s][f"r2_{t}"] for s in SIDES for t in targets]))


@dataclass
class FitResult:
    """The best fit (the good candidate with the highest mean R^2; None if none), every
    start's (or round's) candidate, the IPOPT solves and the wall time (s). The per-leg fit
    on the stride also gives its symmetric ``start`` (label, state, parameters, its R^2 and
    curves per leg) and its ``free`` parameter names (None for a one-step fit)."""

    problem: object
    best: Candidate | None
    candidates: list[Candidate]
    solves: list[Solve]
    options: FitOptions
    wall_time_s: float
    targets: tuple[str, ...]
    notes: list[str] = field(default_factory=list)
    start: dict | None = None
    free: tuple[str, ...] | None = None

    def starts_frame(self) -> pd.DataFrame:
        """One row per start of a one-step fit (``stable``: rho < 1)."""
        rows = []
        for c in self.candidates:
            rows.append({"start": c.start, **c.scores, "objective": c.objective,
                         "spectral_radius": c.fixed_point.spectral_radius,
                         "stable": c.fixed_point.stable, "valid": c.valid,
                         "resimulation_deviation": c.resimulation_deviation,
                         "certified": c.certified, "failure": c.fixed_point.failure})
        return pd.DataFrame(rows)


def mean_score(c: Candidate, targets) -> float:
    """Mean R^2 of ``targets`` of a candidate (:meth:`Candidate.mean_score`)."""
    return c.mean_score(targets)


def evaluate_gait(problem, x, p, human, sim: Simulator | None = None,
                  resim_steps: int = FitOptions.resim_steps,
                  resim_tol: float = FitOptions.resim_tol,
                  max_radius: float = FitOptions.max_radius) -> Candidate | None:
    """Checks of a gait (x: section state, p: parameters): fixed point, stability (rho <=
    ``max_radius``), margins, ``resim_steps``-step re-simulation deviation of x itself,
    curves and R^2 against ``human``. None when the simulator finds no fixed point there."""
    sim = sim or Simulator(problem)
    dev = PoincareMap(problem, sim.hs).resimulation_deviation([x], p, resim_steps)
    fp = find_fixed_point(problem, x, p, max_iter=15, fallback=False)
    if not fp.converged:
        return None
    curves = cycle_curves(sim, fp.state, fp.parameters)
    if curves is None:
        return None
    return Candidate(-1, fp.state, fp.parameters, fp, fit_scores(curves, human), curves, dev,
                     float("nan"), resim_tol, max_radius=max_radius)


def reference_gait(problem, human) -> dict:
    """Fixed point of a problem's own parameters near its initial state, its curves and R^2."""
    fp = own_fixed_point(problem)
    out = {"problem": problem.name, "converged": fp.converged,
           "spectral_radius": fp.spectral_radius, "stable": fp.stable, "valid": fp.valid,
           "failure": fp.failure, "curves": None}
    if not fp.converged:
        return out
    sim = Simulator(problem)
    one = sim.run(fp.state, fp.parameters, steps=1, record=True)
    if one.failure is not None:
        out["failure"] = one.failure.reason
        return out
    curves = gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase)
    out.update(fit_scores(curves, human), curves=curves, step_time_s=fp.step_time_s,
               step_length_m=fp.step_length_m, timing=timing_or_none(
                   lambda: step_timing(problem.family, one.steps[0])))
    return out


