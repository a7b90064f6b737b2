"""The Poincare map of a walker and its exact algorithmic-differentiation Jacobian.

P(x, p) maps the section state x (e.g. Table 2's 7 values) to the same state one step later.
It is the discrete map the event-driven simulator computes: RK4 steps of size h, partial
steps tau ending on events, impact maps and the leg swap. Its Jacobian is the exact
derivative of that discrete map: the simulator's plan (the sequence of full and partial
steps) is replayed with forward sensitivities S = dx/d(x0, p) chained through every RK4 stage
(CasADi AD of the right-hand side), and every event time tau(x0, p) is differentiated by the
implicit function theorem on its guard g(x(tau)) = 0, which adds the saltation term
f(tau) dtau/dz. The same chain gives the derivative of the step time.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np

from pdw_casadi.engine.compile import Lazy, LazyGroup
from pdw_casadi.engine.errors import PoincareError
from pdw_casadi.engine.rk4 import rk4_sensitivities
from pdw_casadi.gait.simulate import Segment, SimulationResult, Simulator
from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.margins import check_key, phase_key
from pdw_casadi.model.problem import Problem, load_problem
from pdw_casadi.model.system import hybrid_system

_SENS_CHUNKS = (32, 8, 1)



@dataclass
class MapResult:
    """P(x, p) with exact derivatives: ``x_next``, ``dx`` = dP/dx, ``dp`` = dP/dp,
    ``step_time`` (s) and its gradients ``dT_dx``, ``dT_dp``; ``sim`` the simulation."""

    x_next: np.ndarray
    dx: np.ndarray | None
    dp: np.ndarray | None
    step_time: float
    dT_dx: np.ndarray | None
    dT_dp: np.ndarray | None
    sim: SimulationResult
    #: per phase: (duration s, d/dx, d/dp), the phases' durations with exact gradients
    phase_times: dict | None = None
    #: per validity margin (margins-table key): (value, d/dx, d/dp), its smallest sample
    #: over the step with the exact gradient of that sample (``margin_gradients=True``)
    margin_grads: dict | None = None


class _Sensitivities:
    """CasADi functions propagating S = dx/dz through RK4 steps, built once per walker."""

    def __init__(self, hs: HybridSystem):
        model = hs.model
        ns = len(model.state_names)
        nx, npar, nm = hs.nx, hs.np, hs.nm
        nz = ns + npar
        self.ns, self.nz = ns, nz
        x, p = ca.SX.sym("x", nx), model.p
        xs = ca.SX.sym("xs", ns)
        x0 = model.section_to_full(xs, p)
        self.section = Lazy(ca.Function("section_jac", [xs, p], [
            x0, ca.horzcat(ca.jacobian(x0, xs), ca.jacobian(x0, p))])).np
        xf = ca.SX.sym("xf", nx)
        self.section_out = Lazy(ca.Function("section_out_jac", [xf], [
            ca.jacobian(model.full_to_section(xf), xf)])).np
        Sp = ca.DM(ca.horzcat(ca.DM.zeros(npar, ns), ca.DM.eye(npar)))
        self.Sp = np.asarray(Sp)
        self.chunks, self.partial = {}, {}
        for name in hs.rhs:
            jac = hs.rhs_jacobian(name, x)
            X, S = ca.MX.sym("X", nx), ca.MX.sym("S", nx * nz)
            H, P, M = ca.MX.sym("h"), ca.MX.sym("p", npar), ca.MX.sym("m", nm)
            Sm = ca.reshape(S, nx, nz)

            def f(xx, ss, jac=jac, P=P, M=M):
                k, A, B = jac(xx, P, M)
                return k, ca.mtimes(A, ss) + ca.mtimes(B, Sp)

            Xn, Sn = rk4_sensitivities(f, X, Sm, H)
            one = ca.Function(f"sens_{name}", [X, S, H, P, M],
                              [ca.vertcat(Xn, ca.reshape(Sn, -1, 1))])
            # partial step: also d x_next / d h (the flow at the event, for the saltation term)
            group = {"partial": ca.Function(
                f"sens_partial_{name}", [X, S, H, P, M],
                [Xn, ca.reshape(Sn, -1, 1), ca.jacobian(Xn, H)])}
            Z = ca.MX.sym("Z", nx + nx * nz)
            step1 = ca.Function(f"sens1_{name}", [Z, H, P, M],
                                [one(Z[:nx], Z[nx:], H, P, M)])
            for k in _SENS_CHUNKS:
                acc = step1.mapaccum(f"sens{k}_{name}", k) if k > 1 else step1
                group[k] = ca.Function(
                    f"sensacc{k}_{name}", [Z, H, P, M], [acc(Z, H, P, M)[:, -1]])
            # -O1: with the structured dynamics the group compiles in seconds, and runs
            # about five times faster than at -O0
            lazy = LazyGroup(group, ("-O1",))
            self.partial[name] = lazy.np("partial")
            for k in _SENS_CHUNKS:
                self.chunks[(name, k)] = lazy.np(k)
        # the validity margins' rows of each phase's outputs and of each impact's checks,
        # with their exact derivatives (margin gradients of the step, built on first use)
        xm, pm, mm = ca.SX.sym("x", nx), ca.SX.sym("p", npar), ca.SX.sym("m", nm)
        self.margin_rows, self.margin_jac = {}, {}
        for name, rows in hs.phase_margins.items():
            if not rows:
                continue
            out = hs.outputs[name](xm, pm, mm)
            o = ca.vertcat(*[out[r] for r, _, _ in rows])
            self.margin_rows[name] = rows
            self.margin_jac[name] = Lazy(ca.Function(
                f"margin_jac_{name}", [xm, pm, mm],
                [o, ca.jacobian(o, xm), ca.jacobian(o, pm)])).np
        self.check_rows, self.check_jac = {}, {}
        for name, rows in hs.check_margins.items():
            if not rows:
                continue
            chk = hs.impact[name](xm, pm)[2]
            o = ca.vertcat(*[chk[r] for r, _, _ in rows])
            self.check_rows[name] = rows
            self.check_jac[name] = Lazy(ca.Function(
                f"check_jac_{name}", [xm, pm], [o, ca.jacobian(o, xm), ca.jacobian(o, pm)])).np


#: one set of sensitivity functions per hybrid system, kept only while the system lives
_SENS: weakref.WeakKeyDictionary[HybridSystem, _Sensitivities] = weakref.WeakKeyDictionary()


def _sens(hs: HybridSystem) -> _Sensitivities:
    if hs not in _SENS:
        _SENS[hs] = _Sensitivities(hs)
    return _SENS[hs]


class PoincareMap:
    """P(x, p) of a problem's walker: value, exact Jacobians, and a CasADi-function view."""

    def __init__(self, problem, hs: HybridSystem | None = None):
        self.problem = problem
        # hs: another build of the walker (e.g. the per-leg one of pdw_casadi.gait.stride)
        self.hs = hs or hybrid_system(problem)
        self.sim = Simulator(problem, self.hs)
        self.state_names = self.hs.model.state_names
        self.parameter_names = self.hs.model.parameter_names

    def __call__(self, x, p=None) -> np.ndarray:
        """P(x, p): the section state one step later (rad, rad/s)."""
        return self.evaluate(x, p, jacobian=False).x_next

    def evaluate(self, x, p=None, jacobian: bool = True, record: bool = False,
                 margins: bool = False, margin_gradients: bool = False) -> MapResult:
        """Simulate one step from section state ``x``; with ``jacobian`` also dP/dx, dP/dp.

        ``record``: keep the trajectory (and margins) in ``sim``; ``margins``: margins only.
        ``margin_gradients`` (with ``jacobian``): also each validity margin's smallest
        sample with its exact gradient (``margin_grads``; the sensitivities are then
        carried one RK4 step at a time through phases that have margins, a few times
        slower).
        """
        p = self.problem.parameter_vector() if p is None else np.asarray(p, float).ravel()
        x = np.asarray(x, float).ravel()
        res = self.sim.run(x, p, steps=1, record=record, margins=margins)
        if res.failure is not None:
            raise PoincareError(res.failure)
        sr = res.steps[0]
        if not jacobian:
            return MapResult(sr.x_section_end, None, None, sr.step_time, None, None, res)
        mins = {} if margin_gradients else None
        x_end, S, dT, dT_phase = self._replay(sr.plan, x, p, mins)
        ns = len(x)
        durations = {}
        for ph, d in sr.phases:
            durations[ph] = durations.get(ph, 0.0) + d
        phase_times = {ph: (durations[ph], g[:ns], g[ns:]) for ph, g in dT_phase.items()}
        grads = None if mins is None else {k: (v, g[:ns], g[ns:]) for k, (v, g) in mins.items()}
        return MapResult(x_end, S[:, :ns], S[:, ns:], sr.step_time, dT[:ns], dT[ns:], res,
                         phase_times, grads)

    def _replay(self, plan, xs, p, mins: dict | None = None):
        """Re-run the discrete map of ``plan`` with forward sensitivities (exact AD).

        ``mins`` (a dict to fill, or None): margins-table key -> (smallest sample, its
        gradient in z = (xs, p)), over the samples each margin counts."""
        hs, sens = self.hs, _sens(self.hs)
        nx, nz = hs.nx, sens.nz
        x, S = (np.asarray(v) for v in sens.section(xs, p))
        x = x.ravel()
        dT = np.zeros(nz)
        dT_phase: dict[str, np.ndarray] = {}
        clock = _PhaseClock(plan) if mins is not None else None
        for i, item in enumerate(plan.items):
            if isinstance(item, Segment):
                before = dT
                track = None
                if clock is not None and item.phase in sens.margin_rows:
                    track = (clock.start[i], clock.phase_start[i], clock.duration[i], mins)
                x, S, dT = self._segment(item, x, S, dT, p, sens, nx, nz, track)
                dT_phase[item.phase] = dT_phase.get(item.phase, 0.0) + (dT - before)
            else:  # a TransitionItem
                if mins is not None and item.name in sens.check_jac:
                    v, vx, vp = sens.check_jac[item.name](x, p)
                    g = np.asarray(vx) @ S + np.asarray(vp) @ sens.Sp
                    for j, (_, name, _) in enumerate(sens.check_rows[item.name]):
                        mins[check_key(item.name, name)] = (float(np.ravel(v)[j]), g[j])
                xp, Jx, Jp = hs.impact_jac[item.name].np(x, p)
                S = Jx @ S + Jp @ sens.Sp
                x = xp.ravel()
        J_out = np.asarray(sens.section_out(x))
        return hs.full_to_section.np(x).ravel(), J_out @ S, dT, dT_phase

    def _segment(self, seg: Segment, x, S, dT, p, sens, nx, nz, track=None):
        mv = list(seg.mode)
        z = np.concatenate([x, S.ravel(order="F")])
        n = seg.n
        if track is None:
            for k in _SENS_CHUNKS:
                while n >= k:
                    z = sens.chunks[(seg.phase, k)](z, seg.h, p, mv).ravel()
                    n -= k
        else:  # one step at a time: every sample's margins and their gradients
            t0, phase_t0, phase_dur, mins = track
            for j in range(n + 1):
                if j:
                    z = sens.chunks[(seg.phase, 1)](z, seg.h, p, mv).ravel()
                self._margin_sample(seg.phase, z[:nx], z[nx:].reshape((nx, nz), order="F"),
                                    t0 + j * seg.h, phase_t0, phase_dur, p, mv, sens, mins)
        x, S = z[:nx], z[nx:].reshape((nx, nz), order="F")
        xe, Se, fh = sens.partial[seg.phase](x, S.ravel(order="F"), seg.tau, p, mv)
        xe, Se, fh = xe.ravel(), Se.reshape((nx, nz), order="F"), fh.ravel()
        g, gx, gp = self.hs.event_jac[seg.phase].np(xe, p, mv)
        i = seg.event
        dg = gx[i] @ Se + gp[i] @ sens.Sp
        dtau = -dg / (gx[i] @ fh)
        S_end = Se + np.outer(fh, dtau)
        if track is not None:  # the event sample: its time moves with z
            self._margin_sample(seg.phase, xe, S_end, t0 + seg.n * seg.h + seg.tau,
                                phase_t0, phase_dur, p, mv, sens, mins)
        return xe, S_end, dT + dtau

    @staticmethod
    def _margin_sample(phase, x, S, t, phase_t0, phase_dur, p, mv, sens, mins):
        """Fold one sample (state x, sensitivity S, time t) into the running minima."""
        v, vx, vp = sens.margin_jac[phase](x, p, mv)
        v = np.ravel(v)
        for j, (_, name, spec) in enumerate(sens.margin_rows[phase]):
            if not spec.counted(t, phase_t0, phase_dur):
                continue
            key = phase_key(phase, name)
            if key not in mins or v[j] < mins[key][0]:
                mins[key] = (float(v[j]), vx[j] @ S + vp[j] @ sens.Sp)

    def jacobian(self, x, p=None):
        """(P(x, p), dP/dx, dP/dp) with exact AD derivatives."""
        r = self.evaluate(x, p)
        return r.x_next, r.dx, r.dp

    def as_casadi(self) -> ca.Function:
        """P as a CasADi function of (x, p) with exact Jacobian (for NLPs and rootfinders)."""
        return _PoincareCallback("poincare_map", self)


class _PhaseClock:
    """Start time of each plan segment, and of the phase it belongs to with that phase's
    duration (s, from the step's start): phases end at transitions."""

    def __init__(self, plan):
        self.start, self.phase_start, self.duration = {}, {}, {}
        t, run = 0.0, []
        for i, item in enumerate([*plan.items, None]):
            if isinstance(item, Segment):
                self.start[i] = t
                run.append(i)
                t += item.n * item.h + item.tau
                continue
            if run:  # a transition (or the plan's end) closes the phase of the run
                t0 = self.start[run[0]]
                for k in run:
                    self.phase_start[k], self.duration[k] = t0, t - t0
                run = []


class _PoincareCallback(ca.Callback):
    def __init__(self, name, pmap: PoincareMap):
        ca.Callback.__init__(self)
        self.pmap = pmap
        self.nx = len(pmap.state_names)
        self.np_ = len(pmap.parameter_names)
        self.construct(name, {"enable_fd": False})

    def get_n_in(self):
        return 2

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.nx if i == 0 else self.np_, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(self.nx, 1)

    def eval(self, arg):
        return [self.pmap(np.asarray(arg[0]).ravel(), np.asarray(arg[1]).ravel())]

    def has_jacobian(self):
        return True

    def get_jacobian(self, name, inames, onames, opts):
        outer = self

        class Jac(ca.Callback):
            def __init__(self):
                ca.Callback.__init__(self)
                self.construct(name, opts)

            def get_n_in(self):
                return 3

            def get_n_out(self):
                return 2

            def get_sparsity_in(self, i):
                return [ca.Sparsity.dense(outer.nx, 1), ca.Sparsity.dense(outer.np_, 1),
                        ca.Sparsity.dense(outer.nx, 1)][i]

            def get_sparsity_out(self, i):
                return ca.Sparsity.dense(outer.nx, outer.nx if i == 0 else outer.np_)

            def eval(self, arg):
                _, jx, jp = outer.pmap.jacobian(np.asarray(arg[0]).ravel(),
                                                np.asarray(arg[1]).ravel())
                return [jx, jp]

        self._jac = Jac()
        return self._jac


def poincare_map(problem) -> PoincareMap:
    """The Poincare map of ``problem``'s walker (see :class:`PoincareMap`)."""
    return PoincareMap(problem if isinstance(problem, Problem) else load_problem(problem))
