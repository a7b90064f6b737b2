"""Fit each leg to its own side's human curves on the stride (two steps, legs may differ).

The per-leg fit (:func:`~pdw_casadi.fit.fit_gait` with per-side curves:
:func:`~pdw_casadi.fit.core.fit_sides`, its rounds those of every fit,
:func:`~pdw_casadi.fit.rounds.fit_rounds`, with :class:`StrideFit`) solves the stride
multiple-shooting NLP
(:meth:`~pdw_casadi.nlp.shooting.ShootingNLP.stride`: step 0 with the left leg in stance,
step 1 with the right) for a periodic stride and each leg's free compliance (``left.k_ankle``,
``right.k_ankle``, ...), minimising the sum over legs and curves of 1 - R^2 of each leg's gait
cycle against its side's curves (:mod:`.stride_objective`), with the stability row on the
stride's Jacobian J_2 J_1 bounded by (``max_radius`` - ``radius_margin``)^2: a stride is two
steps, so the per-step bound squared. It starts from the symmetric fit to the mean of both
sides (:func:`~pdw_casadi.fit.fit_gait`; with ``start="atlas"``, from the atlas gait that
fits that mean best), repeated twice, and checks the answer on the stride map as
the step fit does: ``resim_steps``-step re-simulation with the legs' parameters alternating
(deviation < ``resim_tol``), the stride fixed point, its exact-AD spectral radius
(<= ``max_radius``^2) and validity. R^2 is that of the re-simulated gait, per leg
(:func:`pdw_casadi.gait.stride.stride_report`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pdw_casadi.engine.errors import CurveError, PoincareError
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.objective import check_targets
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Solve
from pdw_casadi.fit.stride_objective import side_targets, stride_curve_errors
from pdw_casadi.gait.curves import fit_scores
from pdw_casadi.gait.fixed_point import FixedPointResult
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import (
    find_stride_fixed_point,
    stride_report,
)
from pdw_casadi.model.gait_data import SIDES
from pdw_casadi.nlp.driver import succeeded
from pdw_casadi.nlp.shooting import ShootingNLP


@dataclass
class StrideFitOptions(FitOptions):
    """Settings of the per-leg fit (:func:`~pdw_casadi.fit.core.fit_sides`): those of
    :class:`~pdw_casadi.fit.FitOptions` (the symmetric start fit uses them as they are) and

    ``side``: whose compliance is free, "both" (each leg its own), "left" or "right" (the
    other leg keeps the start's); ``start``: "fit" (the symmetric step fit to the mean of
    both sides first, then repeated twice) or "atlas" (the atlas or problem gait that fits
    that mean best, as the step fit picks it, repeated twice; no extra solve). "fit" is the
    default: the meaningful comparison (what per-leg compliance adds to the best symmetric
    fit), and the better answer where both were measured (``docs/results/per-leg-fit.md``).
    ``max_radius`` stays the per-step value: the stride's verdict is ``max_radius``^2, its
    NLP bound (``max_radius`` - ``radius_margin``)^2.
    """

    side: str = "both"
    start: str = "fit"

    @property
    def stride_max_radius(self) -> float:
        return self.max_radius ** 2

    @property
    def stride_radius_bound(self) -> float:
        return (self.max_radius - self.radius_margin) ** 2

    def free_sides(self) -> tuple[str, ...]:
        if self.side == "both":
            return SIDES
        if self.side not in SIDES:
            raise ValueError(f"side must be 'both', 'left' or 'right', got {self.side!r}")
        return (self.side,)


@dataclass
class StrideCandidate:
    """A fitted stride with its checks: the stride fixed point (stability, validity), the
    per-leg report (:func:`~pdw_casadi.gait.stride.stride_report`, with curves), R^2 per leg
    (``scores[side]``), the re-simulation deviation (rad, rad/s) of the NLP's section states
    over ``resim_steps`` steps, and the NLP objective (sum of 1 - R^2 over legs and curves)."""

    state: np.ndarray
    theta: np.ndarray
    fixed_point: FixedPointResult
    report: dict
    scores: dict
    resimulation_deviation: float
    objective: float = math.nan
    resim_tol: float = FitOptions.resim_tol
    max_radius: float = FitOptions.max_radius ** 2
    #: IPOPT's return status of the solve this stride came from (None: no solve)
    solver_status: str | None = None
    #: the IPOPT iteration whose iterate the simulator polished into this gait (None: the
    #: solve's answer, or its best feasible iterate when it stopped short)
    polished_from: int | None = None

    @property
    def certified(self) -> bool:
        """True: IPOPT's converged answer (or no solve); False: the best feasible iterate of
        a solve that stopped short, or an iterate polished on the simulator (checked the same
        way, not shown to be the NLP's optimum)."""
        if self.solver_status is None:
            return True
        return succeeded(self.solver_status) and self.polished_from is None

    @property
    def stable(self) -> bool:
        return self.fixed_point.stable and self.fixed_point.spectral_radius <= self.max_radius

    @property
    def valid(self) -> bool:
        return self.fixed_point.valid and self.resimulation_deviation < self.resim_tol

    @property
    def good(self) -> bool:
        return self.stable and self.valid

    def mean_score(self, targets) -> float:
        """Mean R^2 over both legs and ``targets``."""
        return float(np.mean([self.scores[s][f"r2_{t}"] for s in SIDES for t in targets]))


@dataclass
class StrideFitResult:
    """The stride fit: its ``best`` stable valid candidate (None if none), every round's
    candidate, the symmetric start (``start``: label, state, parameters, its R^2 per leg),
    the IPOPT solves (the start fit's first) and the wall time (s)."""

    problem: object
    best: StrideCandidate | None
    candidates: list[StrideCandidate]
    start: dict
    solves: list[Solve]
    options: StrideFitOptions
    wall_time_s: float
    targets: tuple[str, ...]
    free: tuple[str, ...]
    notes: list[str] = field(default_factory=list)


def evaluate_stride(smap: PoincareMap, xs_steps, theta, sides,
                    resim_steps: int = FitOptions.resim_steps,
                    resim_tol: float = FitOptions.resim_tol,
                    max_radius: float = FitOptions.max_radius ** 2) -> StrideCandidate | None:
    """Checks of a stride (``xs_steps``: the section state at the start of each of its two
    steps; ``theta``: physical parameters): the re-simulation deviation over ``resim_steps``
    steps with the legs' parameters alternating, the stride fixed point and its report, R^2
    per leg against ``sides``. None when the simulator finds no stride fixed point there."""
    x = np.asarray(xs_steps[0], float)
    theta = np.asarray(theta, float)
    dev = smap.resimulation_deviation(xs_steps, theta, resim_steps)
    fp = find_stride_fixed_point(smap.problem, x0=x, theta=theta, max_iter=15,
                                 fallback=False, smap=smap)
    if not fp.converged:
        return None
    try:
        rep = stride_report(smap, fp.state, fp.parameters)
    except PoincareError:
        return None
    scores = {s: fit_scores(rep["curves"][s], sides.side(s)) for s in SIDES}
    return StrideCandidate(fp.state, fp.parameters, fp, rep, scores, dev,
                           resim_tol=resim_tol, max_radius=max_radius)


def check_stride_targets(problem, sides, opts: StrideFitOptions) -> None:
    """Raise :class:`CurveError` (or ValueError for bad options) before any work."""
    if opts.timing_weight > 0:
        raise CurveError("the timing target is a one-step fit's (a stride fit has none)")
    if opts.start not in ("fit", "atlas"):
        raise ValueError(f"start must be 'fit' or 'atlas', got {opts.start!r}")
    opts.free_sides()
    for s in SIDES:
        check_targets(problem, sides.side(s), opts)


def stride_free_names(problem, opts: StrideFitOptions) -> tuple[str, ...]:
    """The stride NLP's unknown parameters: each free side's compliance (``opts.free``, by
    default all of the problem's) as ``<side>.<name>``, and ``slope`` with ``free_slope``."""
    base = tuple(opts.free or problem.compliance_names)
    return tuple(f"{s}.{k}" for s in opts.free_sides() for k in base) + (
        ("slope",) if opts.free_slope else ())


class StrideFit:
    """The per-leg fit's part of :func:`~pdw_casadi.fit.rounds.fit_rounds` on the stride:
    the stride's shooting NLP (:meth:`~pdw_casadi.nlp.shooting.ShootingNLP.stride`) with the
    free names of :func:`stride_free_names`, each leg's curve rows against its side
    (:func:`~pdw_casadi.fit.stride_objective.stride_curve_errors`), the stability row
    bounded by the per-step bound squared, the checks of :func:`evaluate_stride`."""

    steps = 2
    start = -1

    def __init__(self, problem, sides, opts: StrideFitOptions, label: str, log=print):
        self.problem, self.sides, self.opts, self.label, self.log = (problem, sides, opts,
                                                                      label, log)
        self.targets = opts.targets()
        self.keys = side_targets(self.targets)
        self.free = stride_free_names(problem, opts)

    def nlp(self, x, theta):
        return ShootingNLP.stride(self.problem, x, theta, free=self.free,
                                  sample_stride=self.opts.sample_stride,
                                  headroom_s=self.opts.segment_headroom_s)

    def solver(self, nlp) -> FitSolver:
        errs = stride_curve_errors(nlp, self.sides, self.targets)
        return FitSolver(nlp, None, self.opts, log=self.log, errors=errs,
                         radius_bound=self.opts.stride_radius_bound)

    def check(self, nlp, out: dict) -> StrideCandidate | None:
        u = nlp.unpack(out["w"])
        opts = self.opts
        return evaluate_stride(nlp.stride_map, u["xs_steps"], u["p"], self.sides,
                               opts.resim_steps, opts.resim_tol, opts.stride_max_radius)

    def polish(self, nlp, w) -> StrideCandidate | None:
        cand = self.check(nlp, {"w": w})
        if cand is not None:
            # the gait is the simulator's stride fixed point, not the iterate: re-simulate it
            cand.resimulation_deviation = nlp.stride_map.resimulation_deviation(
                [cand.state], cand.theta, self.opts.resim_steps)
            cand.objective = sum(1 - cand.scores[k.split(".")[0]][f"r2_{k.split('.')[1]}"]
                                 for k in self.keys)
        return cand

    def accepts(self, cand: StrideCandidate) -> bool:
        return cand.good

    def rank(self, cand: StrideCandidate) -> float:
        return cand.mean_score(self.opts.targets())

    def gap(self, cand: StrideCandidate) -> float:
        return abs(cand.objective - sum(1 - cand.scores[k.split(".")[0]][
            f"r2_{k.split('.')[1]}"] for k in self.keys))

    def restart(self, cand: StrideCandidate):
        return cand.state, cand.theta

    def describe(self, nlp, rnd: int) -> str:
        return (f"stride round {rnd} from {self.label}: {len(nlp.specs)} segments, "
                f"{nlp.w.shape[0]} unknowns, {nlp.g.shape[0]} constraints, "
                f"{len(self.free)} free")

    def outcome(self, rnd: int, out: dict, rho: float, cand) -> str:
        return (f"stride round {rnd}: {out['status']} after {out['iterations']} iterations "
                f"({out['wall_time_s']:.1f} s), objective {out['objective']:.4f}, stride "
                f"radius {rho:.4f}")

    def where(self, rnd: int) -> str:
        return f"stride round {rnd}"


__all__ = ["StrideCandidate", "StrideFit", "StrideFitOptions", "StrideFitResult",
           "check_stride_targets", "evaluate_stride", "stride_free_names"]
