"""The IPOPT driver of the fit: one NLP function with an assembled constraint Jacobian.

The NLP's rows are the multiple-shooting constraints and curve-error rows (sparse, each
depending on a few unknowns: CasADi colours their Jacobian into a few dozen sweeps) plus the
stability row, which depends on every node. Left to CasADi, that one dense row would force
one forward sweep per unknown (measured: 2.65 s per Jacobian instead of 0.19 s), so the NLP
handed to IPOPT with its own constraint-Jacobian function (nlpsol's ``jac_g``): CasADi's
sparse Jacobian of the shooting rows stacked on the stability row's exact gradient from its
own reverse sweep (:mod:`pdw_casadi.fit.stability`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..callback import NumericFunction
from ..timing import human_timing, phase_contacts
from .objective import curve_errors
from .options import FitOptions
from .stability import StabilityRow


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
        rho = "" if np.isnan(self.spectral_bound) else f"  rho32 {self.spectral_bound:.4f}"
        return (f"iter {self.iteration:4d}  objective {self.objective:.5f}  "
                f"inf {self.infeasibility:.1e}  {r2}{rho}  {self.elapsed_s:6.1f} s")


def _nlp_functions(x, f, g_base, row: StabilityRow | None, n_w: int):
    """The NLP's (x, p) -> (f, g) and the assembled (x, p) -> (g, jac_g_x) for IPOPT."""
    P = ca.MX.sym("p", 0, 1)
    dense = ca.Sparsity.dense
    jac_base = ca.Function("fit_jac_base", [x], [ca.jacobian(g_base, x)])
    g, J = g_base, jac_base(x)
    if row is not None:
        n = x.shape[0]

        def gradient(a):
            return [ca.DM(row.gradient(np.asarray(a[0]).ravel()[:n_w])).T]

        grad = NumericFunction("stability_gradient", [dense(n, 1)], [dense(1, n_w)], gradient)
        # the row's own Jacobian serves CasADi's derived functions (the Lagrangian gradient
        # at the answer); IPOPT's constraint Jacobian comes from ``jac_g`` below
        value = NumericFunction(
            "stability_row", [dense(n, 1)], [dense(1, 1)],
            lambda a: [row.value(np.asarray(a[0]).ravel()[:n_w])],
            lambda name: NumericFunction(
                name, [dense(n, 1), dense(1, 1)], [dense(1, n)],
                lambda a: [ca.horzcat(gradient(a)[0], ca.DM(1, n - n_w))]))
        g = ca.vertcat(g_base, value(x))
        J = ca.vertcat(J, ca.horzcat(grad(x), ca.MX(1, n - n_w)))
        keep = (grad, value)  # CasADi does not hold Python callbacks alive
    else:
        keep = ()
    nlp = ca.Function("pdw_fit_nlp", [x, P], [f, g], ["x", "p"], ["f", "g"])
    jac_g = ca.Function("pdw_fit_jac_g", [x, P], [g, J], ["x", "p"], ["g", "jac_g_x"])
    return nlp, jac_g, keep


class _Progress(ca.Callback):
    """IPOPT iteration callback: one :class:`Iterate` per iteration to ``log``."""

    def __init__(self, n, m, lbg, ubg, lbx, ubx, r2_of, has_row: bool, log):
        ca.Callback.__init__(self)
        self.n, self.m = n, m
        self.lbg, self.ubg, self.lbx, self.ubx = lbg, ubg, lbx, ubx
        self.r2_of, self.has_row, self.log = r2_of, has_row, log
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
        d = dict(zip(ca.nlpsol_out(), arg, strict=False))
        x, g = np.asarray(d["x"]).ravel(), np.asarray(d["g"]).ravel()
        inf = max(float(np.max(self.lbg - g, initial=0)), float(np.max(g - self.ubg, initial=0)),
                  float(np.max(self.lbx - x, initial=0)), float(np.max(x - self.ubx, initial=0)))
        it = Iterate(self.iter, float(d["f"]), inf, self.r2_of(x),
                     float(g[-1]) if self.has_row else float("nan"),
                     time.perf_counter() - self.t0)
        self.history.append(it)
        self.iter += 1
        if self.log is not None:
            self.log(it.line())
        return [0]


def stance_pct_expr(nlp) -> ca.MX:
    """The stance (= toe off) in % of the gait cycle of the NLP's step, from its segment
    durations and the walker's phase_contacts (symmetric gait: a cycle is two steps)."""
    contacts = phase_contacts(nlp.problem.family)
    down = 0
    for k, s in enumerate(nlp.specs):
        legs = sum(c is not None for c in contacts[s.phase])
        down = down + legs * nlp.T[k]
    return 100.0 * down / (2.0 * nlp.step_time)


class FitSolver:
    """IPOPT on one :class:`~pdw_casadi.shooting.ShootingNLP` with the curve objective.

    The curve errors at the 101 cycle points are extra unknowns E (E - err(w) = 0), so the
    objective sum E^2 / SS_tot has a trivial gradient and each error row depends on few
    unknowns (cheap colouring). With ``stability_constraint`` the last row is the stability
    bound rho_32 <= max_radius - radius_margin (:class:`StabilityRow`).
    """

    def __init__(self, nlp, human, opts: FitOptions, log=print, extra=None, errors=None,
                 radius_bound: float | None = None):
        """``extra(nlp) -> MX``: a further objective term of the caller's (e.g. the heel-off
        margin of scripts/heeloff_seed.py); like the timing term it is left out of the
        reported objective, which stays the curve part. ``errors``: the curve error rows
        (key -> (err, SS_tot)) instead of :func:`curve_errors` of ``human`` (the stride fit's
        per-leg rows, :mod:`.stride_objective`). ``radius_bound``: the stability row's upper
        bound (default ``max_radius - radius_margin``; a stride's is that squared)."""
        self.nlp, self.opts, self.log = nlp, opts, log
        errs = errors if errors is not None else curve_errors(nlp, human, opts.targets())
        rows, obj, self.E, self.ss = [], 0, {}, {}
        for target, (err, ss_tot) in errs.items():
            E = ca.MX.sym(f"E_{target}", 1, err.shape[1])
            self.E[target], self.ss[target] = E, ss_tot
            rows.append(ca.vec(E - err))
            obj = obj + ca.sumsqr(E) / ss_tot
        self.timing = None
        if opts.timing_weight > 0:
            stance = stance_pct_expr(nlp)
            target = human_timing(human)[0]["toe_off_pct"]
            term = opts.timing_weight * ((stance - target) / 10.0) ** 2
            obj = obj + term
            self.timing = ca.Function("timing_term", [nlp.w], [term])
        self.extra = None
        if extra is not None:
            term = extra(nlp)
            obj = obj + term
            self.extra = ca.Function("extra_term", [nlp.w], [term])
        self.e = ca.vertcat(*[ca.vec(E) for E in self.E.values()])
        self.err = ca.Function("err", [nlp.w], [ca.vertcat(*[ca.vec(e) for e, _ in
                                                             errs.values()])])
        self.n_w = nlp.w.shape[0]
        self.x = ca.vertcat(nlp.w, self.e)
        self.row = StabilityRow(nlp, bound=opts.stability_bound, power=opts.stability_power) \
            if opts.stability_constraint and nlp.free else None
        self.nlp_fun, self.jac_g, self._keep = _nlp_functions(
            self.x, obj, ca.vertcat(nlp.g, *rows), self.row, self.n_w)
        self.lo, self.hi = nlp.bounds(opts.slope_bounds)
        ne = self.e.shape[0]
        self.lbg = np.r_[nlp.lbg, np.zeros(ne)]
        self.ubg = np.r_[nlp.ubg, np.zeros(ne)]
        if self.row is not None:
            self.lbg = np.r_[self.lbg, -np.inf]
            bound = opts.max_radius - opts.radius_margin if radius_bound is None \
                else radius_bound
            self.ubg = np.r_[self.ubg, bound]
        self.lbx = np.r_[self.lo, np.full(ne, -np.inf)]
        self.ubx = np.r_[self.hi, np.full(ne, np.inf)]

    def r2_of(self, x) -> dict:
        """Per target, 1 - sum E^2 / SS_tot at the NLP unknowns ``x`` (w, E)."""
        out, o = {}, self.n_w
        for target, E in self.E.items():
            e = x[o: o + E.shape[1]]
            o += E.shape[1]
            out[target] = 1.0 - float(e @ e) / self.ss[target]
        return out

    def solve(self, w0) -> dict:
        """Solve from ``w0`` (ShootingNLP unknowns): the answer, IPOPT status, iterations."""
        opts = self.opts
        ipopt = {"hessian_approximation": opts.hessian, "max_iter": opts.max_iter,
                 "tol": opts.tol, "acceptable_tol": 100 * opts.tol, "acceptable_iter": 10,
                 "print_level": 0, "sb": "yes", "mu_strategy": "adaptive"}
        if opts.log_file:
            ipopt.update({"output_file": str(opts.log_file), "file_print_level": 5,
                          "file_append": "yes"})
        ipopt.update(opts.ipopt)
        progress = _Progress(self.x.shape[0], self.lbg.size, self.lbg, self.ubg, self.lbx,
                             self.ubx, self.r2_of, self.row is not None,
                             self.log if opts.verbose else None)
        solver = ca.nlpsol("pdw_fit", "ipopt", self.nlp_fun,
                           {"ipopt": ipopt, "print_time": False, "iteration_callback": progress,
                            "jac_g": self.jac_g,
                            # a NaN stability row is a deliberate step cut-back, not news
                            "show_eval_warnings": False})
        w0 = np.clip(w0, self.lo, self.hi)
        e0 = self.err(w0).full().ravel()
        t0 = time.perf_counter()
        sol = solver(x0=np.r_[w0, e0], lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        st = solver.stats()
        x = sol["x"].full().ravel()
        f = float(sol["f"])
        if self.timing is not None:
            # the curve part: what the re-simulated R^2 is checked against
            f -= float(self.timing(x[: self.n_w]))
        if self.extra is not None:
            f -= float(self.extra(x[: self.n_w]))
        return {"w": x[: self.n_w], "objective": f,
                "status": st["return_status"],
                "iterations": int(st["iter_count"]), "wall_time_s": time.perf_counter() - t0,
                "success": st["return_status"] in ("Solve_Succeeded",
                                                   "Solved_To_Acceptable_Level"),
                "history": progress.history}
