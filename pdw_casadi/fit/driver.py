"""The fit's NLP on the shared IPOPT driver (:mod:`pdw_casadi.nlp.driver`): the curve
errors as extra unknowns, the optional timing term and the stability row."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt
from pdw_casadi.fit.objective import curve_errors
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.gait.stability import map_radius, step_radius
from pdw_casadi.gait.timing import human_timing, phase_contacts
from pdw_casadi.nlp.driver import (
    FeasibleIterate,
    Progress,
    ipopt_settings,
    nlp_functions,
    succeeded,
)
from pdw_casadi.nlp.multipliers import bound_multipliers, map_multipliers
from pdw_casadi.nlp.stability import StabilityRow


@dataclass
class WarmStart:
    """A stored solution of a fit's NLP to start another fit's NLP of the same shape from
    (:meth:`FitSolver.warm_point`): the shooting unknowns ``w``, their bound multipliers
    ``lam_w``, the multipliers of the shooting rows ``lam_shooting`` and of the stability
    row ``lam_row`` (None: no row). The curve rows' multipliers are not stored: they follow
    from the new fit's curves."""

    w: np.ndarray
    lam_w: np.ndarray
    lam_shooting: np.ndarray
    lam_row: float | None
    #: the names of the shooting rows (``ShootingNLP.g_names``) and of the free parameters
    #: (``ShootingNLP.free``) of the NLP it solved, and its stability row's value there:
    #: what maps it onto a stride's NLP
    #: (:func:`~pdw_casadi.nlp.multipliers.map_multipliers`; None: not kept)
    rows: tuple[str, ...] | None = None
    free: tuple[str, ...] | None = None
    row_value: float | None = None
    #: the free parameters' scales (``ShootingNLP.p_scale``: the unknowns are p / scale)
    #: and the phases of the segments, in order
    scale: tuple[float, ...] | None = None
    phases: tuple[str, ...] | None = None


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
        margin of pdw-seed heeloff); like the timing term it is left out of the
        reported objective, which stays the curve part. ``errors``: the curve error rows
        (key -> :class:`~pdw_casadi.fit.objective.CurveRows`) instead of
        :func:`curve_errors` of ``human`` (the stride fit's per-leg rows,
        :mod:`.stride_objective`). ``radius_bound``: the stability row's upper
        bound (default :meth:`FitOptions.radius_bound`, ``max_radius - radius_margin``; a
        stride's is that squared).
        ``knee_floor``: a row knee R^2 >= this value (:attr:`FitOptions.knee_floor`)."""
        self.nlp, self.opts, self.log = nlp, opts, log
        if opts.jacobian not in ("structured", "casadi"):
            raise ValueError(f"jacobian must be 'structured' or 'casadi', got {opts.jacobian!r}")
        errs = errors if errors is not None else curve_errors(nlp, human, opts.targets())
        rows, obj, self.E, self.ss = [], 0, {}, {}
        # the gait file enters the rows only as the NLP's parameters (the human angles and
        # the knee floor's SS_tot), never as constants: the rows' Jacobian, built once
        # and stored per start gait (nlp.jacobian), then serves every gait file
        data, values = [], []
        for target, r in errs.items():
            E = ca.MX.sym(f"E_{target}", 1, r.err.shape[1])
            H = ca.MX.sym(f"H_{target}", 1, r.err.shape[1])
            self.E[target], self.ss[target] = E, r.ss_tot
            rows.append(ca.vec(E - (r.model - H)))
            obj = obj + ca.sumsqr(E) / r.ss_tot
            data.append(ca.vec(H))
            values.append(np.asarray(r.values, float).ravel())
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
        self.err = ca.Function("err", [nlp.w], [ca.vertcat(*[ca.vec(r.err)
                                                             for r in errs.values()])])
        floor_rows, floor_ub = [], []
        if knee_floor is not None and "knee" in self.E:
            # 1 - R^2_knee <= 1 - floor: the knee never traded for the hip below the floor
            ss = ca.MX.sym("ss_tot_knee")
            floor_rows.append(ca.sumsqr(self.E["knee"]) / ss)
            floor_ub.append(1.0 - knee_floor - opts.knee_floor_margin)
            data.append(ss)
            values.append([self.ss["knee"]])
        #: the NLP's parameter values: the human curves (deg) and the knee's SS_tot (deg^2)
        self.p = np.concatenate(values) if values else np.zeros(0)
        self.n_w = nlp.w.shape[0]
        self.x = ca.vertcat(nlp.w, self.e)
        #: the steps of the row's map: 2 for a stride (its row is the per-step bound
        #: squared, map_radius), else 1
        self.row_steps = nlp.n_steps
        self.row = StabilityRow(nlp, bound=opts.stability_bound,
                                power=opts.row_power(self.row_steps)) \
            if opts.stability_constraint and nlp.free else None
        self.cap = [None]  # set per solve (FitOptions.iterate_radius_slack)
        self.nlp_fun, self.jac_g, self._keep = nlp_functions(
            self.x, obj, ca.vertcat(nlp.g, *rows, *floor_rows), self.row, self.n_w,
            nlp if opts.jacobian == "structured" else None, self.cap, opts.threads,
            params=ca.vertcat(*data) if data else None)
        self.lo, self.hi = nlp.bounds(opts.slope_bounds)
        ne = self.e.shape[0]
        self.lbg = np.r_[nlp.lbg, np.zeros(ne), np.full(len(floor_ub), -np.inf)]
        self.ubg = np.r_[nlp.ubg, np.zeros(ne), floor_ub]
        if self.row is not None:
            self.lbg = np.r_[self.lbg, -np.inf]
            bound = opts.radius_bound() if radius_bound is None else radius_bound
            self.ubg = np.r_[self.ubg, bound]
            self.bound = bound
        self.lbx = np.r_[self.lo, np.full(ne, -np.inf)]
        self.ubx = np.r_[self.hi, np.full(ne, np.inf)]
        #: shooting rows that the last :meth:`stride_point` gave a multiplier
        self.mapped = 0

    @property
    def n_shooting(self) -> int:
        """The shooting NLP's own rows (the first rows of g)."""
        return int(self.nlp.g.shape[0])

    def warm_point(self, warm: WarmStart) -> FeasibleIterate | None:
        """The full IPOPT point (unknowns and multipliers) of a stored solution ``warm`` of
        an NLP of the same shape; for a stride, of the one-step NLP of its start gait
        (:meth:`stride_point`); None: neither. The curve errors
        and their rows' multipliers are this fit's own: at E = err(w) the objective's
        stationarity in E gives lam_E = -2 E / SS_tot exactly; a knee-floor row starts at 0."""
        if warm.w.size != self.n_w or warm.lam_shooting.size != self.n_shooting or \
                (self.row is None) != (warm.lam_row is None):
            return self.stride_point(warm)
        w = np.clip(warm.w, self.lo, self.hi)
        e = self.err(w).full().ravel()
        lam_e = self.curve_multipliers(e)
        n_floor = self.lbg.size - self.n_shooting - e.size - (self.row is not None)
        lam_g = np.r_[warm.lam_shooting, lam_e, np.zeros(n_floor),
                      [] if self.row is None else [warm.lam_row]]
        return FeasibleIterate(-1, math.nan, np.r_[w, e], math.nan,
                               np.r_[warm.lam_w, np.zeros(e.size)], lam_g)

    def warm_start_of(self, out: dict) -> WarmStart:
        """What :meth:`warm_point` needs of a solve ``out`` of this solver, to store."""
        lam_g = out["lam_g"]
        # the stability row at the answer, as the last progress line read it
        last = out["history"][-1] if out.get("history") else None
        row_value = None if self.row is None or last is None or \
            not np.isfinite(last.spectral_bound) else float(last.spectral_bound)
        return WarmStart(out["w"].copy(), out["lam_x"][: self.n_w].copy(),
                         lam_g[: self.n_shooting].copy(),
                         None if self.row is None else float(lam_g[-1]),
                         rows=tuple(self.nlp.g_names), free=tuple(self.nlp.free),
                         row_value=row_value, scale=tuple(float(v) for v in self.nlp.p_scale),
                         phases=tuple(s.phase for s in self.nlp.specs))

    def curve_multipliers(self, e: np.ndarray) -> np.ndarray:
        """The curve rows' multipliers at the errors ``e`` (E = err(w)): the objective's
        stationarity in E gives lam_E = -2 E / SS_tot exactly."""
        lam, o = [], 0
        for target, E in self.E.items():
            lam.append(-2.0 * e[o: o + E.shape[1]] / self.ss[target])
            o += E.shape[1]
        return np.concatenate(lam)

    def stride_point(self, warm: WarmStart) -> FeasibleIterate | None:
        """This stride NLP's start (its own ``w0``, built by simulating the start gait)
        with multipliers mapped from a one-step solution ``warm`` of the same symmetric
        gait (:func:`~pdw_casadi.nlp.multipliers.map_multipliers`): the shooting rows by
        name, each leg's compliance bound and each step's durations as the one step's, the
        curve rows exactly (:meth:`curve_multipliers`), the stability row's as the one
        step's divided by
        the one step's row value when the stride's row is at its bound at the start
        (along a symmetric change the stride's row moves 2 rho times the step's; the
        stride's objective, two gait cycles, moves twice the step's), else 0. None: not a
        stride, or ``warm`` kept no names, or each step's segments are not the one step's
        phases in order. :attr:`mapped` holds how many shooting rows got a multiplier."""
        nlp = self.nlp
        if nlp.n_steps != 2 or warm.rows is None or warm.free is None or \
                warm.scale is None or warm.phases is None:
            return None
        phases = tuple(s.phase for s in nlp.specs)
        if phases != warm.phases * 2:
            return None
        n_seg = len(warm.phases)
        lam_s, self.mapped = map_multipliers(warm.rows, warm.lam_shooting, nlp.g_names,
                                             nlp.hs.nx)
        w = np.clip(np.asarray(nlp.w0, float).ravel(), self.lo, self.hi)
        e = self.err(w).full().ravel()
        lam_e = self.curve_multipliers(e)
        # a leg's compliance acts on its own leg (half the symmetric value's reach, in a
        # stride objective of twice the step's); the slope on both steps
        lam_w = bound_multipliers(warm.lam_w, warm.free, warm.scale, n_seg, nlp,
                                  source=lambda name: name.rsplit(".", 1)[-1],
                                  weight=lambda name: 2.0 if name == "slope" else 1.0)
        n_floor = self.lbg.size - self.n_shooting - e.size - (self.row is not None)
        lam_row = []
        if self.row is not None:
            lam_row = [0.0]
            v = self.row.value(w)
            if warm.lam_row is not None and warm.row_value is not None and \
                    np.isfinite(warm.row_value) and warm.row_value > 0 and \
                    np.isfinite(v) and v >= self.bound - self.opts.tol:
                lam_row = [warm.lam_row / warm.row_value]
        lam_g = np.r_[lam_s, lam_e, np.zeros(n_floor), lam_row]
        return FeasibleIterate(-1, math.nan, np.r_[w, e], math.nan,
                               np.r_[lam_w, np.zeros(e.size)], lam_g)

    def r2_of(self, x) -> dict:
        """Per target, 1 - sum E^2 / SS_tot at the NLP unknowns ``x`` (w, E)."""
        out, o = {}, self.n_w
        for target, E in self.E.items():
            e = x[o: o + E.shape[1]]
            o += E.shape[1]
            out[target] = 1.0 - float(e @ e) / self.ss[target]
        return out

    def unknowns(self, k: FeasibleIterate) -> np.ndarray:
        """The ShootingNLP unknowns of a kept iterate, within their bounds."""
        return np.clip(k.x[: self.n_w], self.lo, self.hi)

    def _per_step(self, v: float) -> float:
        """A stability row value in per-step units (a stride's row is the per-step value
        squared)."""
        return step_radius(v, self.row_steps)

    def relaxed_bounds(self, w0) -> list[float]:
        """The stability row's relaxed bounds of the continuation from the start ``w0``
        (ShootingNLP unknowns) when its row lies above ``FitOptions.radius_stage_ratio`` x
        the bound, in the row's units, loosest first; [] when it does not (or without a
        row): the per-step bound x ratio^k, k = n - 1, ..., 1, with n the fewest stages
        in which no solve asks more than a factor ``ratio`` of its start (the fit's own
        bound is the last, its own solve)."""
        ratio = self.opts.radius_stage_ratio
        if self.row is None or ratio is None:
            return []
        r0 = self.row.value(np.clip(w0, self.lo, self.hi))
        bound = self._per_step(self.bound)
        if not np.isfinite(r0) or self._per_step(r0) <= ratio * bound:
            return []
        n = math.ceil(math.log(self._per_step(r0) / bound) / math.log(ratio))
        return [map_radius(bound * ratio ** k, self.row_steps) for k in range(n - 1, 0, -1)]

    def solve(self, w0, warm: FeasibleIterate | None = None, bound: float | None = None,
              max_iter: int | None = None) -> dict:
        """Solve from ``w0`` (ShootingNLP unknowns), or warm from the kept iterate ``warm``
        with its multipliers (:attr:`FitOptions.warm_ipopt`). ``bound``: the stability
        row's bound of this solve (default the fit's; :meth:`relaxed_bounds`), ``max_iter``:
        IPOPT's iterations (default ``FitOptions.max_iter``). The answer, IPOPT status,
        iterations, the nearly feasible iterates kept (``near``), whether it stalled (and
        whether on a bound's zig-zag, ``zigzag``)."""
        opts = self.opts
        extra = {} if opts.mu_max is None else {"mu_max": opts.mu_max}
        if warm is not None:
            extra.update(opts.warm_ipopt)
        ipopt = ipopt_settings(opts.hessian, opts.max_iter if max_iter is None else max_iter,
                               opts.tol, {**extra, **opts.ipopt}, opts.log_file,
                               history=opts.stride_lbfgs_history if self.row_steps > 1
                               else opts.lbfgs_history)
        if warm is not None:
            w0 = self.unknowns(warm)
        w0 = np.clip(w0, self.lo, self.hi)
        e0 = self.err(w0).full().ravel() if warm is None else warm.x[self.n_w:]
        ubg = self.ubg.copy()
        if self.row is not None:
            bound = self.bound if bound is None else bound
            ubg[-1] = bound
        self.cap[0] = None
        ratchet = None
        if self.row is not None and opts.iterate_radius_slack is not None:
            # per-step units; the start's own radius if that is higher (a start above the
            # bound must still be able to move)
            root = self._per_step
            r0 = self.row.value(w0)
            top = max(root(bound), root(r0) if np.isfinite(r0) else 0.0)
            cap = top + opts.iterate_radius_slack
            self.cap[0] = map_radius(cap, self.row_steps)
            if opts.ratchet_cap:
                low = root(bound) + opts.iterate_radius_slack
                ratchet = (self.cap, map_radius(low, self.row_steps))
        progress = Progress(self.x.shape[0], self.lbg.size, self.lbg, ubg, self.lbx,
                            self.ubx, self.r2_of, self.row is not None,
                            self.log if opts.verbose else None,
                            feasible_tol=opts.tol if opts.keep_best_feasible else None,
                            ratchet=ratchet, near_tol=opts.polish_infeasibility,
                            near_keep=opts.polish_keep,
                            stall=opts.stall_rule())
        solver = ca.nlpsol("pdw_fit", "ipopt", self.nlp_fun,
                           {"ipopt": ipopt, "print_time": False, "iteration_callback": progress,
                            "jac_g": self.jac_g,
                            # a NaN stability row is a deliberate step cut-back, not news
                            "show_eval_warnings": False})
        t0 = time.perf_counter()
        args = {"x0": np.r_[w0, e0], "lbx": self.lbx, "ubx": self.ubx, "lbg": self.lbg,
                "ubg": ubg, "p": self.p}
        if warm is not None and warm.lam_x is not None:
            args.update(lam_x0=warm.lam_x, lam_g0=warm.lam_g)
        sol = solver(**args)
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
                # IPOPT's multipliers at its answer (a stored warm start, :meth:`warm_start_of`)
                "lam_x": np.asarray(sol["lam_x"], float).ravel(),
                "lam_g": np.asarray(sol["lam_g"], float).ravel(),
                "status": st["return_status"],
                # IPOPT leaves iter_count unset when it never iterated (an invalid option)
                "iterations": int(st["iter_count"]) if progress.history else 0,
                "wall_time_s": time.perf_counter() - t0,
                "success": success,
                #: the iteration whose iterate ``w`` is when the solve did not succeed (None:
                #: ``w`` is IPOPT's answer, or there was no feasible iterate)
                "fallback_iteration": fallback,
                #: nearly feasible iterates for the simulator to polish (FitOptions.polish_*)
                "near": progress.near,
                #: the lowest-objective iterate that held every row, with its multipliers
                "best": best,
                "stalled": progress.stalled, "zigzag": progress.zigzag,
                "history": progress.history}
