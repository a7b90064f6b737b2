"""The NLP rounds of one fit start, on the periodic map of one step or of a stride.

:func:`fit_rounds` is the loop every fit runs from a start (x, p): build the shooting NLP at
(x, p), solve it (:class:`~pdw_casadi.fit.driver.FitSolver`), check the answer on the
simulator, and build and solve once more at the answer while the NLP objective and the
re-simulated 1 - R^2 differ by more than ``consistency_tol`` or the answer's re-simulation
deviation is at least ``resim_tol`` (at most ``rounds`` solves).
What depends on the map is a :class:`MapFit`: the one-step fit's
(:class:`~pdw_casadi.fit.core.StepFit`) or the per-leg fit's on the stride
(:class:`~pdw_casadi.fit.stride_fit.StrideFit`).
"""

from __future__ import annotations

import math
from typing import Protocol

from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Solve

#: the objective's floor in the relative consistency test (a near-perfect fit's objective
#: ~0 would otherwise ask for an absolute gap of ~0)
OBJECTIVE_FLOOR = 1e-6


class MapFit(Protocol):
    """What a fit on a periodic map of ``steps`` steps supplies to :func:`fit_rounds`."""

    steps: int
    #: the start's index in the fit's solves (-1: the fit's only start)
    start: int

    def nlp(self, x, p):
        """The shooting NLP at section state ``x``, parameters ``p`` (ValueError: none)."""

    def solver(self, nlp) -> FitSolver:
        """The fit's IPOPT solver of ``nlp`` (curve rows, stability row)."""

    def check(self, nlp, out: dict):
        """The checked candidate of a successful solve ``out`` (None: no fixed point)."""

    def gap(self, cand) -> float:
        """|NLP objective - sum of 1 - R^2 of the re-simulated gait| of ``cand``."""

    def restart(self, cand) -> tuple:
        """(x, p) of the next round's NLP from ``cand``."""

    def describe(self, nlp, rnd: int) -> str:
        """The progress line before round ``rnd``'s solve."""

    def outcome(self, rnd: int, out: dict, rho: float, cand) -> str:
        """The progress line after round ``rnd``'s solve (``rho``: the simulator's radius)."""

    def where(self, rnd: int) -> str:
        """The name of round ``rnd`` in notes (e.g. "start 0 round 1")."""


def fit_rounds(fit: MapFit, x, p, opts: FitOptions, log=print):
    """The rounds of one start (x: section state, p: the map's parameters): (every round's
    checked candidate, the IPOPT solves, notes). A round whose NLP cannot be built, whose
    solve fails or whose answer has no fixed point of the simulator ends the rounds. A solve
    that stops short of convergence but passed through iterates that held every row
    (``FitOptions.keep_best_feasible``) gives the best of them, checked like an answer and
    marked not certified; it ends the rounds too."""
    rounds, solves, notes = [], [], []
    period = "" if fit.steps == 1 else "stride "
    for rnd in range(opts.rounds):
        try:
            nlp = fit.nlp(x, p)
        except ValueError as exc:
            notes.append(f"{fit.where(rnd)}: {exc}")
            log(notes[-1])
            break
        log(fit.describe(nlp, rnd))
        out = fit.solver(nlp).solve(nlp.w0)
        fallback = out.get("fallback_iteration")
        usable = out["success"] or fallback is not None
        cand = fit.check(nlp, out) if usable else None
        rho = cand.fixed_point.spectral_radius if cand else math.nan
        hist = out["history"]
        at = hist[fallback] if fallback is not None else (hist[-1] if hist else None)
        solves.append(Solve(fit.start, rnd, out["status"], out["iterations"],
                            out["wall_time_s"], out["objective"], rho,
                            at.spectral_bound if at else math.nan, fallback))
        log(fit.outcome(rnd, out, rho, cand))
        if fallback is not None:
            notes.append(f"{fit.where(rnd)}: {out['status']}; its best feasible iterate "
                         f"(iteration {fallback}, objective {out['objective']:.5f}) "
                         + ("checked on the simulator, not certified optimal" if cand else
                            f"has no {period}fixed point of the simulator"))
            log(notes[-1])
        if cand is None:
            if fallback is None:
                notes.append(f"{fit.where(rnd)}: {out['status']}"
                             + (f"; no {period}fixed point of the simulator there"
                                if out["success"] else ""))
            break
        cand.objective = out["objective"]
        cand.solver_status = out["status"]
        rounds.append(cand)
        if not out["success"]:
            break
        # one more round, built at the answer, when the objective's sample brackets moved or
        # when the durations moved so far that the NLP's RK4 grid (set from the start's
        # durations) no longer reproduces the simulator's map
        if fit.gap(cand) <= opts.consistency_tol * max(cand.objective, OBJECTIVE_FLOOR) \
                and cand.resimulation_deviation < opts.resim_tol:
            break
        x, p = fit.restart(cand)
    return rounds, solves, notes


__all__ = ["OBJECTIVE_FLOOR", "MapFit", "fit_rounds"]
