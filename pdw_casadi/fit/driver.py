"""The fit's NLP on the shared IPOPT driver (:mod:`pdw_casadi.nlp.driver`): the curve
errors as extra unknowns, the optional timing term and the stability row."""

from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt
from pdw_casadi.fit.objective import curve_errors
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.gait.timing import human_timing, phase_contacts
from pdw_casadi.nlp.driver import Progress, ipopt_settings, nlp_functions, succeeded
from pdw_casadi.nlp.stability import StabilityRow


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
    """IPOPT on one :class:`~pdw_casadi.nlp.shooting.ShootingNLP` with the curve objective.

    The curve errors at the 101 cycle points are extra unknowns E (E - err(w) = 0), so the
    objective sum E^2 / SS_tot has a trivial gradient and each error row depends on few
    unknowns (cheap colouring). With ``stability_constraint`` the last row is the stability
    bound rho_32 <= max_radius - radius_margin (:class:`StabilityRow`).
    """

    def __init__(self, nlp, human, opts: FitOptions, log=print, extra=None, errors=None,
                 radius_bound: float | None = None, knee_floor: float | None = None):
        """``extra(nlp) -> MX``: a further objective term of the caller's (e.g. the heel-off
        margin of scripts/heeloff_seed.py); like the timing term it is left out of the
        reported objective, which stays the curve part. ``errors``: the curve error rows
        (key -> (err, SS_tot)) instead of :func:`curve_errors` of ``human`` (the stride fit's
        per-leg rows, :mod:`.stride_objective`). ``radius_bound``: the stability row's upper
        bound (default ``max_radius - radius_margin``; a stride's is that squared).
        ``knee_floor``: a row knee R^2 >= this value (:attr:`FitOptions.knee_floor`)."""
        self.nlp, self.opts, self.log = nlp, opts, log
        if opts.jacobian not in ("structured", "casadi"):
            raise ValueError(f"jacobian must be 'structured' or 'casadi', got {opts.jacobian!r}")
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
        floor_rows, floor_ub = [], []
        if knee_floor is not None and "knee" in self.E:
            # 1 - R^2_knee <= 1 - floor: the knee never traded for the hip below the floor
            floor_rows.append(ca.sumsqr(self.E["knee"]) / self.ss["knee"])
            floor_ub.append(1.0 - knee_floor)
        self.n_w = nlp.w.shape[0]
        self.x = ca.vertcat(nlp.w, self.e)
        self.row = StabilityRow(nlp, bound=opts.stability_bound, power=opts.stability_power) \
            if opts.stability_constraint and nlp.free else None
        self.cap = [None]  # set per solve (FitOptions.iterate_radius_slack)
        self.nlp_fun, self.jac_g, self._keep = nlp_functions(
            self.x, obj, ca.vertcat(nlp.g, *rows, *floor_rows), self.row, self.n_w,
            nlp if opts.jacobian == "structured" else None, self.cap, opts.threads)
        self.lo, self.hi = nlp.bounds(opts.slope_bounds)
        ne = self.e.shape[0]
        self.lbg = np.r_[nlp.lbg, np.zeros(ne), np.full(len(floor_ub), -np.inf)]
        self.ubg = np.r_[nlp.ubg, np.zeros(ne), floor_ub]
        if self.row is not None:
            self.lbg = np.r_[self.lbg, -np.inf]
            bound = opts.max_radius - opts.radius_margin if radius_bound is None \
                else radius_bound
            self.ubg = np.r_[self.ubg, bound]
            # a stride's row is the per-step bound squared: so is its iterates' cap
            self.per_step = radius_bound is not None
            self.bound = bound
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
        extra = {} if opts.mu_max is None else {"mu_max": opts.mu_max}
        ipopt = ipopt_settings(opts.hessian, opts.max_iter, opts.tol, {**extra, **opts.ipopt},
                               opts.log_file)
        progress = Progress(self.x.shape[0], self.lbg.size, self.lbg, self.ubg, self.lbx,
                             self.ubx, self.r2_of, self.row is not None,
                             self.log if opts.verbose else None,
                            feasible_tol=opts.tol if opts.keep_best_feasible else None)
        solver = ca.nlpsol("pdw_fit", "ipopt", self.nlp_fun,
                           {"ipopt": ipopt, "print_time": False, "iteration_callback": progress,
                            "jac_g": self.jac_g,
                            # a NaN stability row is a deliberate step cut-back, not news
                            "show_eval_warnings": False})
        w0 = np.clip(w0, self.lo, self.hi)
        e0 = self.err(w0).full().ravel()
        self.cap[0] = None
        if self.row is not None and opts.iterate_radius_slack is not None:
            # per-step units; the start's own radius if that is higher (a start above the
            # bound must still be able to move)
            def root(v):
                return math.sqrt(v) if self.per_step else v
            r0 = self.row.value(w0)
            top = max(root(self.bound), root(r0) if np.isfinite(r0) else 0.0)
            cap = top + opts.iterate_radius_slack
            self.cap[0] = cap ** 2 if self.per_step else cap
        t0 = time.perf_counter()
        sol = solver(x0=np.r_[w0, e0], lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg)
        interrupt.check()  # Ctrl-C inside IPOPT ends the solve, not the run: re-raise it
        st = solver.stats()
        success = succeeded(st["return_status"])
        x = np.asarray(sol["x"]).ravel()
        best = progress.best_feasible
        fallback = None if success or best is None else best.iteration
        if fallback is not None:
            # a solve stopped short of convergence (iteration limit, restoration failure):
            # its best iterate that holds every row, for the simulator to check
            x = best.x
        # IPOPT relaxes bounds by about 1e-8 of their size: a compliance value at its lower
        # bound 0 may come back as -2e-10, which is not a walker (the problem file refuses it)
        x = np.clip(x, self.lbx, self.ubx)
        f = best.objective if fallback is not None else float(sol["f"])
        if self.timing is not None:
            # the curve part: what the re-simulated R^2 is checked against
            f -= float(self.timing(x[: self.n_w]))
        if self.extra is not None:
            f -= float(self.extra(x[: self.n_w]))
        return {"w": x[: self.n_w], "objective": f,
                "status": st["return_status"],
                # IPOPT leaves iter_count unset when it never iterated (an invalid option)
                "iterations": int(st["iter_count"]) if progress.history else 0,
                "wall_time_s": time.perf_counter() - t0,
                "success": success,
                #: the iteration whose iterate ``w`` is when the solve did not succeed (None:
                #: ``w`` is IPOPT's answer, or there was no feasible iterate)
                "fallback_iteration": fallback,
                "history": progress.history}
