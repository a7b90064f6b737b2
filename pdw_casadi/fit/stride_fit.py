"""Fit each leg to its own side's human curves on the stride (two steps, legs may differ).

The per-leg fit (:func:`~pdw_casadi.fit.fit_gait` with per-side curves:
:func:`~pdw_casadi.fit.core.fit_sides`, its rounds those of every fit,
:func:`~pdw_casadi.fit.rounds.fit_rounds`, with :class:`SidesFit`) solves the stride
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
(deviation < ``resim_tol``), the stride fixed point, its exact-AD spectral radius (per step
<= ``max_radius``, so the stride's <= ``max_radius``^2) and validity. R^2 is that of the
re-simulated gait, per leg (:func:`pdw_casadi.gait.stride.stride_report`). Its settings are
those of every fit (:class:`~pdw_casadi.fit.FitOptions`, with ``side`` and ``start``), its
answer a two-step :class:`~pdw_casadi.fit.result.Candidate` in a
:class:`~pdw_casadi.fit.result.FitResult`.
"""

from __future__ import annotations

import numpy as np

from pdw_casadi.engine.errors import CurveError, PoincareError
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.objective import check_targets
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Candidate
from pdw_casadi.fit.stride_objective import side_targets, stride_curve_errors
from pdw_casadi.gait.curves import fit_scores
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.stride import (
    find_stride_fixed_point,
    stride_report,
)
from pdw_casadi.model.gait_data import SIDES
from pdw_casadi.nlp.shooting import ShootingNLP


def evaluate_stride(smap: PoincareMap, xs_steps, parameters, sides,
                    resim_steps: int = FitOptions.resim_steps,
                    resim_tol: float = FitOptions.resim_tol,
                    max_radius: float = FitOptions.max_radius) -> Candidate | None:
    """Checks of a stride (``xs_steps``: the section state at the start of each of its two
    steps; ``parameters``: the physical legs' parameters): the re-simulation deviation over
    ``resim_steps`` steps with the legs' parameters alternating, the stride fixed point
    (stable: per-step radius <= ``max_radius``) and its report, R^2 per leg against
    ``sides``: a two-step :class:`~pdw_casadi.fit.result.Candidate`. None when the simulator
    finds no stride fixed point there."""
    x = np.asarray(xs_steps[0], float)
    theta = np.asarray(parameters, float)
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
    return Candidate(-1, fp.state, fp.parameters, fp, scores, rep["curves"], dev,
                     resim_tol=resim_tol, steps=2, max_radius=max_radius, report=rep)


def check_stride_targets(problem, sides, opts: FitOptions) -> None:
    """Raise :class:`CurveError` (or ValueError for bad options) before any work."""
    if opts.timing_weight > 0:
        raise CurveError("the timing target is a one-step fit's (a stride fit has none)")
    if opts.start not in ("fit", "atlas"):
        raise ValueError(f"start must be 'fit' or 'atlas', got {opts.start!r}")
    opts.free_sides()
    for s in SIDES:
        check_targets(problem, sides.side(s), opts)


def stride_free_names(problem, opts: FitOptions) -> tuple[str, ...]:
    """The stride NLP's unknown parameters: each free side's compliance (``opts.free``, by
    default all of the problem's) as ``<side>.<name>``, and ``slope`` with ``free_slope``."""
    base = tuple(opts.free or problem.compliance_names)
    return tuple(f"{s}.{k}" for s in opts.free_sides() for k in base) + (
        ("slope",) if opts.free_slope else ())


class SidesFit:
    """The per-leg fit's part of :func:`~pdw_casadi.fit.rounds.fit_rounds` on the stride:
    the stride's shooting NLP (:meth:`~pdw_casadi.nlp.shooting.ShootingNLP.stride`) with the
    free names of :func:`stride_free_names`, each leg's curve rows against its side
    (:func:`~pdw_casadi.fit.stride_objective.stride_curve_errors`), the stability row
    bounded by the per-step bound squared (:meth:`FitOptions.radius_bound`), the checks of
    :func:`evaluate_stride`."""

    steps = 2
    start = -1

    def __init__(self, problem, sides, opts: FitOptions, label: str, log=print):
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
                         radius_bound=self.opts.radius_bound(self.steps))

    def check(self, nlp, out: dict) -> Candidate | None:
        u = nlp.unpack(out["w"])
        opts = self.opts
        return evaluate_stride(nlp.stride_map, u["xs_steps"], u["p"], self.sides,
                               opts.resim_steps, opts.resim_tol, opts.max_radius)

    def polish(self, nlp, w) -> Candidate | None:
        cand = self.check(nlp, {"w": w})
        if cand is not None:
            # the gait is the simulator's stride fixed point, not the iterate: re-simulate it
            cand.resimulation_deviation = nlp.stride_map.resimulation_deviation(
                [cand.state], cand.parameters, self.opts.resim_steps)
            cand.objective = sum(1 - cand.scores[k.split(".")[0]][f"r2_{k.split('.')[1]}"]
                                 for k in self.keys)
        return cand

    def gap(self, cand: Candidate) -> float:
        return abs(cand.objective - sum(1 - cand.scores[k.split(".")[0]][
            f"r2_{k.split('.')[1]}"] for k in self.keys))

    def restart(self, cand: Candidate):
        return cand.state, cand.parameters

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


__all__ = ["SidesFit", "check_stride_targets", "evaluate_stride", "stride_free_names"]
