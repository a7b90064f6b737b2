"""One IPOPT driver for every NLP of the toolkit (the fit, the stride fit, the designs).

The NLP's rows are the multiple-shooting constraints and the caller's rows (sparse, each
depending on a few unknowns: CasADi colours their Jacobian into a few dozen sweeps) plus an
optional stability row, which depends on every node. Left to CasADi, that one dense row would
force one forward sweep per unknown, so the NLP is handed to IPOPT with its own
constraint-Jacobian function (nlpsol's ``jac_g``): the sparse Jacobian of the other rows
(assembled from the shooting structure, :mod:`pdw_casadi.nlp.jacobian`, or CasADi's) stacked
on the stability row's exact gradient from its own reverse sweep
(:mod:`pdw_casadi.nlp.stability`).

- :func:`nlp_functions`: the (x, p) -> (f, g) function and the assembled Jacobian;
- :func:`ipopt_settings`: IPOPT's options from the caller's settings, in one place;
- :func:`succeeded`: the one success test of an IPOPT return status;
- :class:`Progress`: the iteration callback that logs one :class:`Iterate` per iteration.
"""

from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt
from pdw_casadi.engine.callback import NumericFunction
from pdw_casadi.nlp.jacobian import StructuredJacobian
from pdw_casadi.nlp.stability import StabilityRow

#: IPOPT's convergence tolerance (its ``tol``, on the scaled NLP error; dimensionless) of
#: every NLP of the toolkit (``FitOptions.tol``, ``DesignNLPOptions.tol``): a row or bound
#: held to it counts as held (the fit's best feasible iterate) and one within it of its
#: bound as binding (the design's diagnosis)
IPOPT_TOL = 1e-6
#: IPOPT's barrier and bound pushes for a solve that starts without multipliers at a point
#: that is nearly feasible and nearly optimal (a homotopy step started at the last answer):
#: IPOPT's own (``mu_init`` 0.1, pushes 1e-2 of each bound's size) move such a start deep
#: into the interior, away from the answer it is next to (measured on the 30 % prosthesis
#: design, docs/results/prosthesis.md, "Where the 30 % design's time goes")
NEAR_START_IPOPT = {"mu_init": 1e-4, "bound_push": 1e-6, "bound_frac": 1e-6,
                    "slack_bound_push": 1e-6, "slack_bound_frac": 1e-6}
#: IPOPT return statuses that count as a solved NLP
SUCCESS_STATUSES = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def succeeded(status: str) -> bool:
    """Whether an IPOPT return status is a solved NLP."""
    return status in SUCCESS_STATUSES


def ipopt_settings(hessian: str, max_iter: int, tol: float, extra: dict | None = None,
                   log_file: str | None = None, history: int | None = None) -> dict:
    """IPOPT's options: ``hessian`` ("limited-memory" or "exact"), ``max_iter``, ``tol``
    (acceptable: 100 tol over 10 iterations), adaptive barrier, silent; ``log_file``: IPOPT's
    own log (print level 5, appended); ``history``: the L-BFGS pairs kept (IPOPT's
    ``limited_memory_max_history``; None: IPOPT's 6); ``extra`` overrides any of them."""
    ipopt = {"hessian_approximation": hessian, "max_iter": max_iter,
             "tol": tol, "acceptable_tol": 100 * tol, "acceptable_iter": 10,
             "print_level": 0, "sb": "yes", "mu_strategy": "adaptive"}
    if history is not None and hessian == "limited-memory":
        ipopt["limited_memory_max_history"] = int(history)
    if log_file:
        ipopt.update({"output_file": str(log_file), "file_print_level": 5,
                      "file_append": "yes"})
    ipopt.update(extra or {})
    return ipopt


@dataclass
class Iterate:
    """One IPOPT iteration as the progress line shows it (R^2 from the NLP's error rows)."""

    iteration: int
    objective: float
    infeasibility: float
    r2: dict
    spectral_bound: float
    elapsed_s: float

    def line(self) -> str:
        r2 = "  ".join(f"{k} {v:.4f}" for k, v in self.r2.items())
        rho = "" if np.isnan(self.spectral_bound) else f"  stability row {self.spectral_bound:.4f}"
        return (f"iter {self.iteration:4d}  objective {self.objective:.5f}  "
                f"inf {self.infeasibility:.1e}  {r2}{rho}  {self.elapsed_s:6.1f} s")


def nlp_functions(x, f, g_base, row: StabilityRow | None, n_w: int, nlp=None,
                  cap: list | None = None, threads: int | None = None,
                  params: ca.MX | None = None):
    """The NLP's (x, p) -> (f, g) and the assembled (x, p) -> (g, jac_g_x) for IPOPT.

    With the :class:`~pdw_casadi.nlp.shooting.ShootingNLP` ``nlp`` whose unknowns start
    ``x``, the Jacobian of ``g_base`` is assembled from its structure
    (:mod:`pdw_casadi.nlp.jacobian`), else CasADi differentiates the MX graph. ``cap``
    ([value] or [None], read at every evaluation): a stability row above the value is NaN,
    which IPOPT treats as an evaluation error and answers by cutting its step back, so that
    no iterate lies above it. ``threads``: threads of the assembled Jacobian (None: one
    per core). ``params``: the NLP's parameters p (a symbol column; the values are given to
    the solver), on which ``f`` and ``g_base`` may depend (default: none)."""
    P = ca.MX.sym("p", 0, 1) if params is None else params
    dense = ca.Sparsity.dense
    if nlp is not None and row is not None:
        return _overlapped(x, f, g_base, row, n_w,
                           StructuredJacobian(nlp, g_base, x, threads, P), cap, P)
    if nlp is not None:
        structured = StructuredJacobian(nlp, g_base, x, threads, P).function("fit_jac_base")
        g, J = g_base, structured(x, P)
    else:
        structured = None
        g, J = g_base, ca.Function("fit_jac_base", [x, P], [ca.jacobian(g_base, x)])(x, P)
    if row is not None:
        n = x.shape[0]

        def gradient(a):
            return [ca.DM(row.gradient(np.asarray(a[0]).ravel()[:n_w])).T]

        grad = NumericFunction("stability_gradient", [dense(n, 1)], [dense(1, n_w)], gradient)
        value = _row_value(row, n, n_w, cap, gradient)
        g = ca.vertcat(g_base, value(x))
        J = ca.vertcat(J, ca.horzcat(grad(x), ca.MX(1, n - n_w)))
        keep = (grad, value, structured)  # CasADi does not hold Python callbacks alive
    else:
        keep = (structured,)
    nlp = ca.Function("pdw_fit_nlp", [x, P], [f, g], ["x", "p"], ["f", "g"])
    jac_g = ca.Function("pdw_fit_jac_g", [x, P], [g, J], ["x", "p"], ["g", "jac_g_x"])
    return nlp, jac_g, keep


def _row_value(row: StabilityRow, n: int, n_w: int, cap: list | None,
               gradient) -> NumericFunction:
    """The stability row as a CasADi function of the NLP unknowns (NaN above ``cap``); its
    own Jacobian serves CasADi's derived functions (the Lagrangian gradient at the answer),
    while IPOPT's constraint Jacobian comes from ``jac_g``."""
    dense = ca.Sparsity.dense

    def into(args, outs):  # CasADi's own buffers (see NumericFunction)
        outs[0][0] = capped(row.value(args[0][:n_w]), cap)

    return NumericFunction(
        "stability_row", [dense(n, 1)], [dense(1, 1)], None,
        lambda name: NumericFunction(
            name, [dense(n, 1), dense(1, 1)], [dense(1, n)],
            lambda a: [ca.horzcat(gradient(a)[0], ca.DM(1, n - n_w))]), buffers=into)


def _overlapped(x, f, g_base, row: StabilityRow, n_w: int, structured: StructuredJacobian,
                cap: list | None, P):
    """:func:`nlp_functions` with the assembled Jacobian: the stability row's reverse sweep
    runs on its own thread while the shooting intervals are evaluated (the row's sweep is
    one sequential chain through every interval, as long as the rest of the Jacobian; both
    spend their time in compiled code). The values do not depend on the overlap."""
    n = x.shape[0]
    dense = ca.Sparsity.dense
    row_sp = ca.horzcat(dense(1, n_w), ca.Sparsity(1, n - n_w))
    sp = ca.vertcat(structured.sparsity, row_sp)
    # where each nonzero of the stacked pattern comes from in [base nonzeros, row gradient]
    # (column by column: a column's base nonzeros, then the row's): one DM per evaluation
    # instead of two and a vertcat of ~10^5 nonzeros
    n_base = structured.sparsity.nnz()
    source = ca.vertcat(ca.DM(structured.sparsity, np.arange(n_base, dtype=float)),
                        ca.DM(row_sp, n_base + np.arange(row_sp.nnz(), dtype=float)))
    order = np.asarray(source.nonzeros(), float).astype(np.int64)
    side = ThreadPoolExecutor(1, thread_name_prefix="stability_row")

    def gradient(a):
        return [ca.DM(row.gradient(np.asarray(a[0]).ravel()[:n_w])).T]

    def into(args, outs):  # CasADi's own buffers: no DM of the ~10^5 nonzeros (10 ms)
        xv, pv = args
        pending = side.submit(row.gradient, xv[:n_w])
        base = np.asarray(structured.values(xv, pv), float).ravel()
        outs[0][:] = np.concatenate([base, pending.result()])[order]

    jac = NumericFunction("fit_jac", [dense(n, 1), dense(P.shape[0], 1)], [sp], None,
                          buffers=into)
    value = _row_value(row, n, n_w, cap, gradient)
    g = ca.vertcat(g_base, value(x))
    nlp = ca.Function("pdw_fit_nlp", [x, P], [f, g], ["x", "p"], ["f", "g"])
    jac_g = ca.Function("pdw_fit_jac_g", [x, P], [g, jac(x, P)], ["x", "p"], ["g", "jac_g_x"])
    return nlp, jac_g, (jac, value, structured, side)


def capped(v: float, cap: list | None) -> float:
    """``v``, or NaN when it lies above ``cap[0]`` (see :func:`nlp_functions`)."""
    return math.nan if cap and cap[0] is not None and v > cap[0] else v


@dataclass
class FeasibleIterate:
    """An IPOPT iterate kept for later: its iteration, objective, largest row or bound
    violation (in the rows' own units) and unknowns."""

    iteration: int
    objective: float
    x: np.ndarray
    infeasibility: float = 0.0
    #: IPOPT's multipliers there (bounds, rows): what a warm restart from it starts with
    lam_x: np.ndarray | None = None
    lam_g: np.ndarray | None = None


@dataclass(frozen=True)
class Stall:
    """When a solve counts as stalled (:class:`Progress` then asks IPOPT to stop). Two
    forms, each over the last ``window`` iterations:

    - wandering: the objective moved by at most ``rtol`` of its size, and the least
      infeasibility among them is above ``min_infeasibility`` and no lower than
      ``progress`` times the least one before them (IPOPT is wandering, not converging);
    - zig-zag on a bound (with ``plateau_infeasibility``): the best objective among the
      nearly feasible iterates (largest violation at most ``plateau_infeasibility``) fell by
      at most ``rtol`` of its size, while an iterate of the window strayed to an
      infeasibility of ``wander`` or more and a nearly feasible one came after it (looked
      for after two windows of iterations). IPOPT
      then crosses the stability bound back and forth: the infeasible iterates' lower
      objective hides the plateau from the first form, and a converging tail (every
      iterate feasible) never shows the stray.
    """

    window: int
    rtol: float
    min_infeasibility: float
    progress: float = 0.5
    plateau_infeasibility: float | None = None
    wander: float = 1e-3

    def stalled(self, history: list) -> bool:
        """Whether the iterates ``history`` (:class:`Iterate`, oldest first) end in a stall."""
        if len(history) <= self.window:
            return False
        return self.wandering(history) or self.zigzag(history)

    def wandering(self, history: list) -> bool:
        """The first form (see the class)."""
        last, before = history[-self.window:], history[:-self.window]
        f = [h.objective for h in last]
        scale = max(abs(f[-1]), 1e-12)
        least = min(h.infeasibility for h in last)
        least_before = min(h.infeasibility for h in before)
        return (max(f) - min(f) <= self.rtol * scale and least > self.min_infeasibility
                and least >= self.progress * least_before)

    def zigzag(self, history: list) -> bool:
        """The second form (see the class); False without ``plateau_infeasibility``."""
        # two windows at least: in the first one the only feasible iterate before the
        # window is the start, and a solve's first excursion (infeasible, then back a
        # little better) would read as a plateau (one corpus file stopped at 30 iterations
        # with knee R^2 0.827 where IPOPT converges at 55 with 0.846)
        if self.plateau_infeasibility is None or len(history) <= 2 * self.window:
            return False
        last, before = history[-self.window:], history[:-self.window]
        near = [h.objective for h in last if h.infeasibility <= self.plateau_infeasibility]
        near_before = [h.objective for h in before
                       if h.infeasibility <= self.plateau_infeasibility]
        if not near or not near_before:
            return False
        strays = [i for i, h in enumerate(last) if h.infeasibility >= self.wander]
        # back and forth: a nearly feasible iterate after a stray (a solve that left the
        # feasible region once and has not come back is wandering, not zig-zagging)
        if not strays or all(h.infeasibility > self.plateau_infeasibility
                             for h in last[strays[0] + 1:]):
            return False
        best = min(near)
        return min(near_before) - best <= self.rtol * max(abs(best), 1e-12)


class Progress(ca.Callback):
    """IPOPT iteration callback: one :class:`Iterate` per iteration to ``log``; asks IPOPT
    to stop (``User_Requested_Stop``) once Ctrl-C or SIGTERM is pending, so the solve ends
    within an iteration and the caller's :func:`pdw_casadi.engine.interrupt.check` raises.
    With ``feasible_tol`` it keeps :attr:`best_feasible`, the lowest-objective iterate whose
    largest row or bound violation (in the rows' own units) is at most ``feasible_tol``: what
    a solve that stops short of convergence still has to offer.

    ``ratchet`` ((cap, lowered), with the stability row last): once an iterate's stability
    row is at or below ``lowered``, the cap (:func:`nlp_functions`, read at every evaluation)
    comes down to ``lowered`` for the rest of the solve: a start above the bound may move
    freely until it first reaches the stable region, and from then on no step leaves it.

    ``near_tol``, ``near_keep``: it also keeps :attr:`near`, the ``near_keep``
    lowest-objective iterates whose violation is at most ``near_tol`` (nearly feasible: the
    simulator can polish them into a periodic gait). ``stall`` (:class:`Stall`): it asks
    IPOPT to stop (``User_Requested_Stop``, :attr:`stalled` True) once the solve stalls."""

    def __init__(self, n, m, lbg, ubg, lbx, ubx, r2_of, has_row: bool, log,
                 feasible_tol: float | None = None, ratchet: tuple | None = None,
                 near_tol: float | None = None, near_keep: int = 0,
                 stall: Stall | None = None):
        ca.Callback.__init__(self)
        self.n, self.m = n, m
        self.lbg, self.ubg, self.lbx, self.ubx = lbg, ubg, lbx, ubx
        self.r2_of, self.has_row, self.log = r2_of, has_row, log
        self.feasible_tol = feasible_tol
        self.ratchet = ratchet
        self.best_feasible: FeasibleIterate | None = None
        self.near_tol, self.near_keep, self.stall = near_tol, near_keep, stall
        self.near: list[FeasibleIterate] = []
        self.stalled = False
        #: the stall was the zig-zag on a bound (:meth:`Stall.zigzag`), not wandering
        self.zigzag = False
        self.t0 = time.perf_counter()
        self.iter = 0
        self.history: list[Iterate] = []
        self.construct("pdw_fit_progress", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.n)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.m)
        if n == "f":
            return ca.Sparsity.dense(1)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        if interrupt.requested():
            return [1]  # nonzero: IPOPT stops at once (the signal is re-raised after the solve)
        d = dict(zip(ca.nlpsol_out(), arg, strict=False))
        x, g = np.asarray(d["x"]).ravel(), np.asarray(d["g"]).ravel()
        inf = max(float(np.max(self.lbg - g, initial=0)), float(np.max(g - self.ubg, initial=0)),
                  float(np.max(self.lbx - x, initial=0)), float(np.max(x - self.ubx, initial=0)))
        it = Iterate(self.iter, float(d["f"]), inf, self.r2_of(x),
                     float(g[-1]) if self.has_row else float("nan"),
                     time.perf_counter() - self.t0)
        self.history.append(it)
        if self.ratchet is not None and self.has_row:
            cap, lowered = self.ratchet
            if cap[0] is not None and lowered < cap[0] and g[-1] <= lowered:
                cap[0] = lowered
        # NaN (a capped stability row) is never feasible: the comparison is False
        if self.feasible_tol is not None and inf <= self.feasible_tol and np.isfinite(g).all() and (
                self.best_feasible is None or it.objective < self.best_feasible.objective):
            # with its multipliers: a caller answering with it answers with its duals too
            self.best_feasible = FeasibleIterate(
                self.iter, it.objective, x.copy(), inf,
                np.asarray(d["lam_x"], float).ravel().copy(),
                np.asarray(d["lam_g"], float).ravel().copy())
        if self.near_tol is not None and self.near_keep > 0 and inf <= self.near_tol and \
                np.isfinite(g).all():
            self.near.append(FeasibleIterate(
                self.iter, it.objective, x.copy(), inf,
                np.asarray(d["lam_x"], float).ravel().copy(),
                np.asarray(d["lam_g"], float).ravel().copy()))
            self.near = sorted(self.near, key=lambda k: k.objective)[: self.near_keep]
        self.iter += 1
        if self.log is not None:
            self.log(it.line())
        if self.stall is not None and self.stall.stalled(self.history):
            self.stalled = True
            self.zigzag = self.stall.zigzag(self.history)
            if self.log is not None:
                why = ("the best nearly feasible objective fell by at most "
                       f"{self.stall.rtol:g} of its size while iterates strayed across a bound"
                       if self.zigzag else
                       f"the objective moved by at most {self.stall.rtol:g} of its size and "
                       "the infeasibility did not fall")
                self.log(f"stalled: {why} over the last {self.stall.window} iterations; "
                         f"stopping")
            return [1]
        return [0]
