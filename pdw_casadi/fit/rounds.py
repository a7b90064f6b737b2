"""The NLP rounds of one fit start, on the periodic map of one step or of a stride.

:func:`fit_rounds` is the loop every fit runs from a start (x, p): build the shooting NLP at
(x, p), solve it (:class:`~pdw_casadi.fit.driver.FitSolver`), check the answer on the
simulator, and build and solve once more at the answer while the NLP objective and the
re-simulated 1 - R^2 differ by more than ``consistency_tol`` or the answer's re-simulation
deviation is at least ``resim_tol`` (at most ``rounds`` solves).
What depends on the map is a :class:`MapFit`: the one-step fit's
(:class:`~pdw_casadi.fit.core.StepFit`) or the per-leg fit's on the stride
(:class:`~pdw_casadi.fit.stride_fit.SidesFit`). Either checks its answers into a
:class:`~pdw_casadi.fit.result.Candidate` of its ``steps``.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Solve
from pdw_casadi.nlp.driver import FeasibleIterate

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

    def polish(self, nlp, w):
        """The simulator's periodic gait polished from ``nlp``'s unknowns ``w`` (Newton on
        the map at their parameters from their section state), checked like an answer and
        re-simulated from its own fixed point (None: no fixed point there)."""

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


def polish_iterates(fit: MapFit, nlp, solver: FitSolver, out: dict, targets, log=print):
    """The best accepted gait the simulator polishes from the nearly feasible iterates a
    solve kept (``out["near"]``, :attr:`FitOptions.polish_infeasibility`), or None: each is
    polished (:meth:`MapFit.polish`) and the accepted one with the highest mean R^2 of
    ``targets`` is returned,
    marked with the iteration it came from (not certified)."""
    best = None
    for k in out.get("near", ()):
        cand = fit.polish(nlp, solver.unknowns(k))
        if cand is None or not cand.good:
            continue
        cand.polished_from = k.iteration
        if best is None or cand.mean_score(targets) > best.mean_score(targets):
            best = cand
    if best is not None:
        log(f"polished iteration {best.polished_from}'s iterate on the simulator: a stable, "
            f"valid gait")
    return best


def relax_stability(fit: MapFit, nlp, solver: FitSolver, solves: list, log=print):
    """The continuation from an unstable start (:meth:`FitSolver.relaxed_bounds`): a
    solve per relaxed bound of the stability row, loosest first
    (``FitOptions.radius_stage_iter`` iterations each, at most ``max_iter``), recorded in
    ``solves``. Each solve
    goes on from the iterate the one before ended at, with its multipliers
    (``FitOptions.warm_ipopt``): its answer, else its best iterate that held every row,
    else its least infeasible nearly feasible one (``FitOptions.polish_infeasibility``),
    which the next solve makes feasible. A solve that keeps none ends the continuation.
    Returns the last iterate kept, for the fit's own solve
    (:class:`~pdw_casadi.nlp.driver.FeasibleIterate`; None: no relaxed solve, or none
    kept an iterate)."""
    point = None
    for bound in solver.relaxed_bounds(nlp.w0):
        out = solver.solve(nlp.w0, warm=point, bound=bound,
                           max_iter=min(solver.opts.radius_stage_iter, solver.opts.max_iter))
        near, last = out.get("near") or [], point
        if out["success"]:
            x = np.r_[out["w"], solver.err(out["w"]).full().ravel()]
            point = FeasibleIterate(out["iterations"], out["objective"], x, 0.0,
                                    out["lam_x"], out["lam_g"])
        elif out.get("best") is not None:
            point = out["best"]
        elif near:
            point = min(near, key=lambda k: k.infeasibility)
        else:
            point = None
        hist = out["history"]
        at = None if point is None else min(point.iteration, len(hist) - 1)
        row = hist[at].spectral_bound if at is not None and at >= 0 else math.nan
        solves.append(Solve(fit.start, 0, out["status"], out["iterations"],
                            out["wall_time_s"], out["objective"], math.nan, row,
                            out.get("fallback_iteration"), stage_bound=bound))
        log(f"{fit.where(0)}: the stability row relaxed to {bound:.4g}: {out['status']} "
            f"after {out['iterations']} iterations; "
            + (f"on from iteration {point.iteration} (row {row:.4g}, infeasibility "
               f"{point.infeasibility:.1e})" if point is not None else
               "no nearly feasible iterate; the fit goes on from where the solve before "
               "ended" if last is not None else "no nearly feasible iterate"))
        if point is None:
            return last
    return point


def fit_rounds(fit: MapFit, x, p, opts: FitOptions, log=print, warm=None):
    """The rounds of one start (x: section state, p: the map's parameters): (every round's
    checked candidate, the IPOPT solves, notes). A round whose NLP cannot be built, whose
    solve fails or whose answer has no fixed point of the simulator ends the rounds. A solve
    that stops short of convergence but passed through iterates that held every row
    (``FitOptions.keep_best_feasible``) gives the best of them, checked like an answer and
    marked not certified; it ends the rounds too. When a solve gives no accepted gait that
    way, or stops short of convergence, its nearly feasible iterates are polished on the
    simulator (:func:`polish_iterates`) and the better gait (mean R^2) is its answer.
    A solve stalled wandering (``FitOptions.stall_window``) is followed by a warm restart of
    the same NLP from the least infeasible of its kept iterates, with that iterate's
    multipliers (``stall_restarts`` per start); one stalled zig-zagging on a bound
    (``FitOptions.stall_plateau_infeasibility``) ends the rounds with its best iterate.
    ``warm``: a stored solution of the NLP built at (x, p)
    (:class:`~pdw_casadi.fit.driver.WarmStart`, e.g. an atlas entry's): the first solve
    starts from it with its multipliers when the NLP has its shape."""
    rounds, solves, notes = [], [], []
    period = "" if fit.steps == 1 else "stride "
    restarts, rnd = 0, 0
    restart_from = None  # (nlp, solver, kept iterate) of a stalled solve
    while rnd < opts.rounds + restarts:
        if restart_from is None:
            try:
                nlp = fit.nlp(x, p)
            except ValueError as exc:
                notes.append(f"{fit.where(rnd)}: {exc}")
                log(notes[-1])
                break
            log(fit.describe(nlp, rnd))
            solver = fit.solver(nlp)
            point = solver.warm_point(warm) if warm is not None and rnd == 0 else None
            if point is not None:
                log(f"{fit.where(rnd)}: warm start from the "
                    + ("stored solution at the start, with its multipliers" if fit.steps == 1
                       else f"symmetric fit's solution, with its multipliers on "
                            f"{solver.mapped} of {solver.n_shooting} shooting rows"))
            if point is None and rnd == 0:
                # an unstable start (a walker's first gait) brought down by continuation
                point = relax_stability(fit, nlp, solver, solves, log)
            out = solver.solve(nlp.w0, warm=point)
        else:
            nlp, solver, k = restart_from
            restart_from = None
            log(f"{fit.where(rnd)}: warm restart from iteration {k.iteration} (objective "
                f"{k.objective:.5f}, infeasibility {k.infeasibility:.1e}) with its multipliers")
            out = solver.solve(nlp.w0, warm=k)
        fallback = out.get("fallback_iteration")
        usable = out["success"] or fallback is not None
        cand = fit.check(nlp, out) if usable else None
        if cand is not None:
            cand.objective = out["objective"]
        # a solve that stopped short (its limit, a stall) also polishes its nearly feasible
        # iterates: its best feasible iterate can lie far behind them (a stride solve
        # zig-zagging on the bound had its last feasible one at iteration 4 of 202)
        if out.get("near") and (cand is None or not cand.good or not out["success"]):
            targets = opts.targets()
            shined = polish_iterates(fit, nlp, solver, out, targets, log=log)
            if shined is not None and (cand is None or not cand.good or
                                       shined.mean_score(targets) > cand.mean_score(targets)):
                cand, fallback = shined, shined.polished_from
        rho = cand.fixed_point.spectral_radius if cand else math.nan
        hist = out["history"]
        at = hist[fallback] if fallback is not None else (hist[-1] if hist else None)
        solves.append(Solve(fit.start, rnd, out["status"], out["iterations"],
                            out["wall_time_s"], out["objective"], rho,
                            at.spectral_bound if at else math.nan, fallback))
        log(fit.outcome(rnd, out, rho, cand))
        stalled = bool(out.get("stalled"))
        if stalled:
            notes.append(f"{fit.where(rnd)}: stalled after {out['iterations']} iterations "
                         f"(FitOptions.stall_window)")
            log(notes[-1])
        polished = cand is not None and cand.polished_from is not None
        if fallback is not None:
            notes.append(f"{fit.where(rnd)}: {out['status']}; its "
                         + ("nearly feasible iterate (iteration " if polished else
                            "best feasible iterate (iteration ") + f"{fallback}) "
                         + (("polished" if polished else "checked") +
                            " on the simulator, not certified optimal" if cand else
                            f"has no {period}fixed point of the simulator"))
            log(notes[-1])
        if cand is not None:
            cand.solver_status = out["status"]
            if out["success"] and fallback is None:
                cand.warm = solver.warm_start_of(out)
            rounds.append(cand)
        rnd += 1
        # a restart helps a solve wandering infeasible; one zig-zagging on a bound already
        # passed its best nearly feasible gait, and a restart zig-zags again (one corpus
        # file: 33 more iterations, the same answer)
        if stalled and not out.get("zigzag") and restarts < opts.stall_restarts \
                and out["near"]:
            restarts += 1
            restart_from = (nlp, solver, min(out["near"], key=lambda k: k.infeasibility))
            continue
        if cand is None:
            if fallback is None:
                notes.append(f"{fit.where(rnd - 1)}: {out['status']}"
                             + (f"; no {period}fixed point of the simulator there"
                                if out["success"] else ""))
            break
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


__all__ = ["OBJECTIVE_FLOOR", "MapFit", "fit_rounds", "polish_iterates", "relax_stability"]
