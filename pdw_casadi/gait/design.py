"""Design solves: a periodic gait together with free parameters that meet extra conditions.

The unknowns are the section state x and relative changes u of chosen free parameters
(theta_i = theta0_i (1 + u_k) for every index i bound to free value k, so one free value may
drive the same key on both legs). The equations are the fixed-point condition of a map
(step or stride map, :mod:`pdw_casadi.gait.poincare`, :mod:`pdw_casadi.gait.stride`) and
optional extra
conditions (e.g. equal left and right step lengths and times). With more unknowns than
equations Newton takes minimum-norm steps (least change of x and u), with a backtracking line
search on the residual norm; every Jacobian is exact (AD through the map).

Two uses: the prosthesis design (the prosthetic leg's compliance that makes the gait
symmetric: :func:`solve_design` and :func:`continue_design` with
:func:`symmetry_conditions`, driven by :func:`pdw_casadi.studies.prosthesis.design_prosthesis`)
and carrying a gait onto a new body with the compliance
adapted (:func:`pdw_casadi.studies.scaling.walker_for_subject`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL, validity_slacks
from pdw_casadi.gait.poincare import PoincareError
from pdw_casadi.model.margins import GUARD_AHEAD, spec_of


class PatternLost(RuntimeError):
    """An extra condition cannot be evaluated: the gait left the event pattern it is
    defined on (e.g. an expected event did not occur). Treated like a failed step."""


@dataclass
class DesignOptions:
    """Heuristics of the design Newton solve.

    ``tol``: norm of all residuals to reach (rad, rad/s for the fixed point; the extra
    conditions in their own normalised units); ``max_iter``: Newton iterations;
    ``min_alpha``: smallest line-search step; ``max_rel_change``: largest |u| step per
    iteration (a relative parameter change; keeps the linearisation honest). Continuation
    (:func:`continue_design`): the step in lambda starts at 1/``n_min`` and halves on a
    failed solve down to ``min_step``.
    """

    tol: float = FIXED_POINT_TOL
    max_iter: int = 40
    min_alpha: float = 1e-4
    max_rel_change: float = 0.2
    n_min: int = 10
    min_step: float = 1e-3
    #: keep the gait valid along a continuation: a validity margin that falls below its
    #: requirement is from then on held at requirement + ``margin_headroom`` x its scale
    #: (the requirement, or its value at the path's start for margins required > 0 only),
    #: an extra condition with its exact gradient (step maps; see :func:`continue_design`)
    hold_margins: bool = False
    margin_headroom: float = 0.1
    #: with ``hold_margins``: also hold the guards a phase must begin ahead of
    #: (:data:`~pdw_casadi.model.margins.GUARD_AHEAD`); off, a path may pass through gaits
    #: that break them (the trailing toe pulling at foot strike) and a fit restores them
    #: at its end (:func:`~pdw_casadi.studies.scaling.nearest_stable_gait`)
    hold_guards: bool = False


@dataclass
class DesignResult:
    """The solved gait: ``state`` (section), ``theta`` (all parameters, SI), ``converged``,
    ``residual`` (norm), ``iterations``, ``history`` of residual norms, ``wall_time_s``."""

    state: np.ndarray
    theta: np.ndarray
    converged: bool
    residual: float
    iterations: int
    history: list = field(default_factory=list)
    wall_time_s: float = 0.0


#: extra conditions: (map result r, x, theta) -> (values, d/dx, d/dtheta)
Extra = Callable[[object, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def solve_design(pmap, x0, theta0, free: Sequence[Sequence[int]], extra: Extra | None = None,
                 options: DesignOptions | None = None,
                 margin_gradients: bool = False) -> DesignResult:
    """Solve P(x, theta(u)) = x and ``extra`` = 0 for (x, u) (see the module docstring).

    ``free``: for each free value, the indices of theta it scales (relative change u_k).
    ``margin_gradients``: the map results handed to ``extra`` carry the validity margins
    with their gradients (:func:`margin_conditions`).
    """
    evaluate = _evaluator(pmap, margin_gradients)
    opt = options or DesignOptions()
    t0 = time.perf_counter()
    theta0 = np.asarray(theta0, float).ravel()
    x = np.asarray(x0, float).ravel().copy()
    n, k = x.size, len(free)
    E = np.zeros((theta0.size, k))  # d theta / d u
    for j, idx in enumerate(free):
        for i in idx:
            E[i, j] = theta0[i]
    u = np.zeros(k)

    def theta_of(u_):
        return theta0 + E @ u_

    def residual(x_, u_):
        th = theta_of(u_)
        r = evaluate(x_, th)
        rows = [r.x_next - x_]
        J = np.hstack([r.dx - np.eye(n), r.dp @ E])
        if extra is not None:
            v, vx, vt = extra(r, x_, th)
            rows.append(np.atleast_1d(v))
            J = np.vstack([J, np.hstack([np.atleast_2d(vx), np.atleast_2d(vt) @ E])])
        return np.concatenate(rows), J

    history = []
    converged = False
    it = 0
    try:
        F, J = residual(x, u)
        for it in range(1, opt.max_iter + 1):
            norm = float(np.linalg.norm(F))
            history.append(norm)
            if norm < opt.tol:
                converged, it = True, it - 1
                break
            dz = -np.linalg.lstsq(J, F, rcond=None)[0]
            du = dz[n:]
            big = np.abs(du).max() if k else 0.0
            if big > opt.max_rel_change:
                dz *= opt.max_rel_change / big
            alpha, accepted = 1.0, False
            while alpha >= opt.min_alpha:
                xn, un = x + alpha * dz[:n], u + alpha * dz[n:]
                try:
                    Fn, Jn = residual(xn, un)
                    if np.linalg.norm(Fn) < (1 - 1e-4 * alpha) * norm:
                        accepted = True
                        break
                except (PoincareError, PatternLost):
                    pass
                alpha *= 0.5
            if not accepted:
                break
            x, u, F, J = xn, un, Fn, Jn
        else:
            converged = float(np.linalg.norm(F)) < opt.tol
    except (PoincareError, PatternLost):
        converged = False
    return DesignResult(x, theta_of(u), converged, history[-1] if history else float("nan"),
                        it, history, time.perf_counter() - t0)


def _evaluator(pmap, margin_gradients: bool):
    """(x, theta) -> the map's result with exact Jacobians (and margin gradients)."""
    if margin_gradients:
        return lambda x, th: pmap.evaluate(x, th, jacobian=True, margin_gradients=True)
    return lambda x, th: pmap.evaluate(x, th, jacobian=True)


def margin_conditions(targets: dict[str, float], scales: dict[str, float]) -> Extra:
    """Extra conditions holding validity margins (margins-table keys of a step map) at
    ``targets`` (their units): (margin - target) / scale, with the exact gradients of the
    margins' smallest samples (the map evaluated with ``margin_gradients``)."""
    keys = sorted(targets)

    def extra(r, x, theta):
        if r.margin_grads is None:
            raise ValueError("margin conditions need the map's margin gradients")
        rows = [r.margin_grads[k] for k in keys]
        v = np.array([(val - targets[k]) / scales[k] for k, (val, _, _) in zip(keys, rows,
                                                                                strict=True)])
        vx = np.vstack([gx / scales[k] for k, (_, gx, _) in zip(keys, rows, strict=True)])
        vt = np.vstack([gp / scales[k] for k, (_, _, gp) in zip(keys, rows, strict=True)])
        return v, vx, vt

    return extra


def symmetry_conditions(smap, length_scale: float, time_scale: float) -> Extra:
    """Extra conditions of a symmetric gait on the stride map ``smap``: (left step length -
    right step length) / ``length_scale`` and (left step time - right step time) /
    ``time_scale``, with exact derivatives (the left-stance step is the stride's first)."""

    def extra(r, x, theta):
        r1, r2 = r.steps
        p1, p2 = r.step_parameters
        # step lengths from the section geometry after each step (next step's roles)
        l1, g1x, g1p = smap.step_length(r1.x_next, p2)
        l2, g2x, g2p = smap.step_length(r2.x_next, p1)
        dl1_dx = g1x @ r1.dx
        dl1_dt = g1x @ r1.dp + g1p @ smap.Pi[1]
        dl2_dx = g2x @ r.dx
        dl2_dt = g2x @ r.dp + g2p
        T1, T2 = r1.step_time, r2.step_time
        dT1_dx, dT1_dt = r1.dT_dx, r1.dT_dp
        dT2_dx = r2.dT_dx @ r1.dx
        dT2_dt = r2.dT_dx @ r1.dp + r2.dT_dp @ smap.Pi[1]
        v = np.array([(l1 - l2) / length_scale, (T1 - T2) / time_scale])
        vx = np.vstack([(dl1_dx - dl2_dx) / length_scale, (dT1_dx - dT2_dx) / time_scale])
        vt = np.vstack([(dl1_dt - dl2_dt) / length_scale, (dT1_dt - dT2_dt) / time_scale])
        return v, vx, vt

    return extra


@dataclass
class PathResult:
    """A design continuation: the last solved point, the path [(lambda, state, theta)],
    ``reached`` (lambda = 1 solved), the wall time (s) and the validity margins held on
    the way (key -> (lambda where the hold began, held value))."""

    last: DesignResult
    path: list
    reached: bool
    wall_time_s: float
    held: dict = field(default_factory=dict)


class _MarginHolds:
    """The validity margins a continuation holds (``DesignOptions.hold_margins``): each
    margin that falls below its requirement is held at requirement + headroom x scale."""

    def __init__(self, pmap, x0, theta0, headroom: float, hold_guards: bool = False):
        self.pmap, self.headroom = pmap, headroom
        specs = pmap.hs.margin_specs
        self._slacks = lambda m: {k: v for k, v in validity_slacks(m, pmap.problem,
                                                                   pmap.hs).items()
                                  if hold_guards or spec_of(k, specs) is not GUARD_AHEAD}
        start = self._margins(x0, theta0)
        need = {k: start[k] - s for k, s in self._slacks(start).items()}
        # a margin required > 0 only (an impulse) takes its own size at the start as scale
        self.need = need
        self.scale = {k: (abs(n) if n > 0 else max(abs(start[k]), 1e-12))
                      for k, n in need.items()}
        self.targets: dict[str, float] = {}
        self.held: dict[str, tuple[float, float]] = {}

    def _margins(self, x, theta) -> dict:
        r = self.pmap.evaluate(x, theta, jacobian=False, margins=True)
        return dict(r.sim.steps[0].margins)

    def broken(self, x, theta) -> list[str]:
        """Margins below their requirement at (x, theta) that are not held yet."""
        sl = self._slacks(self._margins(x, theta))
        return [k for k, v in sl.items() if v < 0 and k not in self.targets]

    def extra(self, base: Extra | None) -> Extra | None:
        if not self.targets:
            return base
        held = margin_conditions(self.targets, {k: self.scale[k] for k in self.targets})
        return held if base is None else combined(base, held)

    def hold(self, keys, lam: float) -> None:
        for k in keys:
            self.targets[k] = self.need[k] + self.headroom * self.scale[k]
            self.held[k] = (lam, self.targets[k])

    def release(self, keys) -> None:
        for k in keys:
            self.targets.pop(k, None)
            self.held.pop(k, None)


def next_homotopy_step(tried: float, accepted: bool, max_step: float) -> float:
    """A homotopy's next step (in its own parameter) after a solve at ``tried`` past the last
    accepted point: doubled (at most ``max_step``) when accepted, halved when not. Halving
    the step tried, not a nominal one: near the end the nominal step reaches past it, and
    halving that would repeat the same solve."""
    return min(2 * tried, max_step) if accepted else tried / 2


def continue_design(pmap, x0, theta_start, theta_end, free: Sequence[Sequence[int]],
                    extra: Extra | None = None,
                    options: DesignOptions | None = None) -> PathResult:
    """Move the non-free parameters linearly from ``theta_start`` (lambda = 0, where
    ``x0`` should be a solution) to ``theta_end`` (lambda = 1), solving the design at each
    step (:func:`solve_design`) with the free values carried over from the last solution.

    Each step is predicted along the exact minimum-norm tangent of the design; the step
    starts at 1/``options.n_min``, halves when a solve fails (down to
    ``options.min_step``) and doubles again after a success (up to 1/``n_min``).

    With ``options.hold_margins`` (step maps) the path stays a valid gait: a solved point
    at which a validity margin fell below its requirement is solved again with that margin
    held (:func:`margin_conditions`, an active set that only grows); the point is accepted
    when that solve converges with every margin met, else the step halves.
    """
    t0 = time.perf_counter()
    options = options or DesignOptions()
    n_min, min_step = options.n_min, options.min_step
    theta_start = np.asarray(theta_start, float)
    theta_end = np.asarray(theta_end, float)
    free_idx = sorted({i for idx in free for i in idx})
    first = solve_design(pmap, x0, theta_start, free, extra, options)
    holds = (_MarginHolds(pmap, first.state, first.theta, options.margin_headroom,
                          options.hold_guards)
             if options.hold_margins and first.converged else None)
    grads = False
    path = [(0.0, first.state, first.theta)]
    last, lam, step = first, 0.0, 1.0 / n_min
    direction = theta_end - theta_start
    direction[free_idx] = 0.0
    tangent = None
    now = extra
    while last.converged and lam < 1.0 and step >= min_step:
        new = min(1.0, lam + step)
        if tangent is None:
            tangent = _tangent(pmap, last, free, now, direction, grads)
        dx, du = tangent
        base = theta_start + new * (theta_end - theta_start)
        base[free_idx] = last.theta[free_idx]
        guess = last.state + (new - lam) * dx
        scaled = base.copy()
        for j, idx in enumerate(free):  # the free values' predicted (relative) change
            scaled[idx] = base[idx] * (1.0 + (new - lam) * du[j])
        cand = solve_design(pmap, guess, scaled, free, now, options, grads)
        if cand.converged and holds is not None:
            broken = holds.broken(cand.state, cand.theta)
            if broken:  # hold them and solve again at this lambda, from this point
                holds.hold(broken, new)
                again = solve_design(pmap, cand.state, cand.theta, free, holds.extra(extra),
                                     options, True)
                if again.converged and not holds.broken(again.state, again.theta):
                    cand, now, grads = again, holds.extra(extra), True
                else:
                    holds.release(broken)
                    cand = replace(again, converged=False)
        step = next_homotopy_step(new - lam, cand.converged, 1.0 / n_min)
        if cand.converged:
            lam, last, tangent = new, cand, None
            path.append((lam, cand.state, cand.theta))
    return PathResult(last, path, bool(last.converged and lam == 1.0),
                      time.perf_counter() - t0, dict(holds.held) if holds else {})


def _tangent(pmap, sol: DesignResult, free, extra, direction, margin_gradients=False):
    """Minimum-norm tangent (dx/dlambda, du/dlambda) of the design at a solution, when the
    non-free parameters move along ``direction`` (exact: from the map's AD Jacobians)."""
    x, th = sol.state, sol.theta
    n = x.size
    r = _evaluator(pmap, margin_gradients)(x, th)
    E = np.zeros((th.size, len(free)))
    for j, idx in enumerate(free):
        for i in idx:
            E[i, j] = th[i]
    J = np.hstack([r.dx - np.eye(n), r.dp @ E])
    F_lam = r.dp @ direction
    if extra is not None:
        _, vx, vt = extra(r, x, th)
        J = np.vstack([J, np.hstack([np.atleast_2d(vx), np.atleast_2d(vt) @ E])])
        F_lam = np.concatenate([F_lam, np.atleast_2d(vt) @ direction])
    dz = -np.linalg.lstsq(J, F_lam, rcond=None)[0]
    return dz[:n], dz[n:]


def phase_time_conditions(smap, phase: str, target_s: float, scale_s: float) -> Extra:
    """Extra conditions holding the duration of ``phase`` in every step of the map at
    ``target_s`` (s): (duration - target) / ``scale_s`` per step, exact derivatives; the
    map is a stride map (two steps) or, with ``smap`` None, a step map (one step).

    Used to keep a gait away from a gait-pattern boundary: the 6-link gait's phase I lasts
    only a few ms (the trailing toe lifts soon after foot strike); a path on which it
    shrinks to zero leaves the three-phase pattern (the toe never lifts, the walker falls).
    """

    def extra(r, x, theta):
        if smap is None:
            d, gx, gp = r.phase_times[phase]
            return (np.array([(d - target_s) / scale_s]), np.atleast_2d(gx) / scale_s,
                    np.atleast_2d(gp) / scale_s)
        r1, r2 = r.steps
        d1, g1x, g1p = r1.phase_times[phase]
        d2, g2x, g2p = r2.phase_times[phase]
        v = np.array([(d1 - target_s) / scale_s, (d2 - target_s) / scale_s])
        vx = np.vstack([g1x, g2x @ r1.dx]) / scale_s
        vt = np.vstack([g1p, g2x @ r1.dp + g2p @ smap.Pi[1]]) / scale_s
        return v, vx, vt

    return extra


def combined(*extras: Extra) -> Extra:
    """Several extra conditions stacked into one."""

    def extra(r, x, theta):
        parts = [e(r, x, theta) for e in extras]
        return (np.concatenate([np.atleast_1d(v) for v, _, _ in parts]),
                np.vstack([np.atleast_2d(a) for _, a, _ in parts]),
                np.vstack([np.atleast_2d(b) for _, _, b in parts]))

    return extra
