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

import math
import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np

from pdw_casadi.engine.compile import HOT, INTERPRETED, PLAIN, Lazy, LazyGroup
from pdw_casadi.engine.errors import PoincareError, ProblemError
from pdw_casadi.engine.rk4 import rk4_sensitivities
from pdw_casadi.gait.simulate import Segment, SimulationResult, Simulator, StepRecord
from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.margins import check_key, leg_key, phase_key
from pdw_casadi.model.problem import LEG_SIDES, Problem, load_problem
from pdw_casadi.model.system import (
    gait_system,
    hybrid_system,
    leg_layout,
    per_leg_system,
    physical_parameter_names,
    physical_parameter_vector,
)

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
    #: a map of several steps: each step's own result and its parameters in the step's roles
    #: (empty for a one-step map)
    steps: tuple = ()
    step_parameters: tuple = ()


class _Sensitivities:
    """CasADi functions propagating S = dx/dz through RK4 steps, built once per walker."""

    def __init__(self, hs: HybridSystem):
        model = hs.model
        ns = len(model.state_names)
        nx, npar, nm = hs.nx, hs.np, hs.nm
        nz = ns + npar
        self.ns, self.nz = ns, nz
        p = model.p
        xs = ca.SX.sym("xs", ns)
        x0 = model.section_to_full(xs, p)
        #: every compiled library of the sensitivities (see ``build_libraries``)
        self.libraries: list = []
        self.section = self._lazy(ca.Function("section_jac", [xs, p], [
            x0, ca.horzcat(ca.jacobian(x0, xs), ca.jacobian(x0, p))])).np
        xf = ca.SX.sym("xf", nx)
        self.section_out = self._lazy(ca.Function("section_out_jac", [xf], [
            ca.jacobian(model.full_to_section(xf), xf)])).np
        Sp = ca.DM(ca.horzcat(ca.DM.zeros(npar, ns), ca.DM.eye(npar)))
        self.Sp = np.asarray(Sp)
        self.chunks, self.partial = {}, {}
        for name in hs.rhs:
            jac = hs.rhs_jacobian(name)
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
            # the Poincare Jacobian's hot loop
            lazy = LazyGroup(group, HOT)
            self.libraries.append(lazy)
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
            self.margin_jac[name] = self._lazy(ca.Function(
                f"margin_jac_{name}", [xm, pm, mm],
                [o, ca.jacobian(o, xm), ca.jacobian(o, pm)])).np
        self.check_rows, self.check_jac = {}, {}
        for name, rows in hs.check_margins.items():
            if not rows:
                continue
            chk = hs.impact[name](xm, pm)[2]
            o = ca.vertcat(*[chk[r] for r, _, _ in rows])
            self.check_rows[name] = rows
            self.check_jac[name] = self._lazy(ca.Function(
                f"check_jac_{name}", [xm, pm], [o, ca.jacobian(o, xm), ca.jacobian(o, pm)]),
                INTERPRETED).np


    def _lazy(self, fun: ca.Function, flags=PLAIN) -> Lazy:
        lazy = Lazy(fun, flags)
        self.libraries.append(lazy)
        return lazy


def sensitivity_libraries(hs: HybridSystem) -> list:
    """The compiled libraries of the Poincare map's exact sensitivities of walker ``hs``
    (for :func:`~pdw_casadi.engine.compile.build_libraries`)."""
    return list(_sens(hs).libraries)


def fixed_point_libraries(problem) -> list:
    """Every compiled function a fixed point of ``problem`` with its stability calls: its
    walker (per-leg when its legs differ) and the Poincare map's sensitivities."""
    hs = gait_system(problem)
    return [*hs.libraries(), *sensitivity_libraries(hs)]


#: one set of sensitivity functions per hybrid system, kept only while the system lives
_SENS: weakref.WeakKeyDictionary[HybridSystem, _Sensitivities] = weakref.WeakKeyDictionary()


def _sens(hs: HybridSystem) -> _Sensitivities:
    if hs not in _SENS:
        _SENS[hs] = _Sensitivities(hs)
    return _SENS[hs]


class PoincareMap:
    """The periodic map of ``steps`` steps of a problem's walker: value, exact Jacobians,
    and a CasADi-function view.

    ``steps=1``: the step map P(x, p), p the problem's parameters (compliance, slope) on
    its walker ``hs`` (default: :func:`~pdw_casadi.model.system.hybrid_system`).
    ``steps=n``: the composition of n steps, the parameters following the physical legs
    through the leg swaps: theta (:func:`~pdw_casadi.model.system.physical_parameter_names`)
    on the per-leg walker where the family has one, step k with the left leg in stance for
    even k and the right for odd k (p_k = theta[perms[k]]); a family without a per-leg
    build composes its step map with the same p (equal legs only). n = 2 is the stride
    (:mod:`pdw_casadi.gait.stride`). The Jacobians follow by the chain rule:
    dP^n/dx = P_n,x ... P_1,x, dP^n/dtheta = sum_k P_n,x ... P_k+1,x P_k,p Pi_k.
    """

    def __init__(self, problem, hs: HybridSystem | None = None, steps: int = 1):
        if not isinstance(problem, Problem):
            problem = load_problem(problem)
        if steps < 1:
            raise ValueError(f"a periodic map has at least one step, got {steps}")
        self.problem, self.steps = problem, int(steps)
        self.per_leg = False
        self._theta0 = None  # the default parameters: the problem's (None) or theta
        if steps > 1 and hs is None:
            hs = per_leg_system(problem)
            if hs is None and problem.asymmetric:
                raise ProblemError(f"{problem.name}: the {problem.family} walker has no "
                                   f"per-leg build, so its legs cannot differ")
            self.per_leg = hs is not None
        # hs: another build of the walker (e.g. the per-leg one)
        self.hs = hs or hybrid_system(problem)
        self.sim = Simulator(problem, self.hs)
        self.state_names = self.hs.model.state_names
        self.parameter_names = self.hs.model.parameter_names
        if self.steps > 1:  # theta: each physical leg's values (the problem's p otherwise)
            self.parameter_names = physical_parameter_names(problem)
        n = len(self.parameter_names)
        swap = np.arange(n)
        if self.per_leg:
            self._theta0 = physical_parameter_vector(problem)
            comp, leg, _ = leg_layout(problem)
            nc, nl = len(comp), len(leg)
            # theta -> role vector of a right-stance step: the right leg's blocks come first
            idx = np.arange(n)
            swap = np.r_[idx[nc:2 * nc], idx[:nc], idx[2 * nc + nl:2 * nc + 2 * nl],
                         idx[2 * nc:2 * nc + nl], idx[2 * nc + 2 * nl:]]
        #: per step, theta -> that step's role parameters (the left leg in stance first)
        self.perms = tuple(np.arange(n) if k % 2 == 0 else swap for k in range(self.steps))
        self.Pi = tuple(np.eye(n)[q] for q in self.perms)  # p_k = Pi[k] @ theta
        self._ell = None

    def default_parameters(self) -> np.ndarray:
        """The map's parameters of the problem: its parameter vector (a one-step map) or
        theta (a map of several steps on the per-leg walker); SI units."""
        if self._theta0 is not None:
            return self._theta0.copy()
        return self.problem.parameter_vector()

    def step_parameters(self, theta) -> tuple[np.ndarray, ...]:
        """Each step's parameters in its roles from the map's parameters ``theta``."""
        theta = np.asarray(theta, float).ravel()
        return tuple(theta.copy() if k == 0 else theta[q] for k, q in enumerate(self.perms))

    def __call__(self, x, p=None) -> np.ndarray:
        """The section state after the map's steps (rad, rad/s)."""
        return self.evaluate(x, p, jacobian=False).x_next

    def evaluate(self, x, p=None, jacobian: bool = True, record: bool = False,
                 margins: bool = False, margin_gradients: bool = False) -> MapResult:
        """Simulate the map's steps from section state ``x`` with parameters ``p`` (default:
        :meth:`default_parameters`); with ``jacobian`` also d/dx, d/dp.

        ``record``: keep the trajectory (and margins) in ``sim``; ``margins``: margins only.
        ``margin_gradients`` (with ``jacobian``, one-step maps): also each validity margin's
        smallest sample with its exact gradient (``margin_grads``; the sensitivities are
        then carried one RK4 step at a time through phases that have margins, a few times
        slower). Several steps: ``steps`` holds each step's result, ``sim`` one record of
        them all (margin names prefixed with the stance leg).
        """
        if self.steps == 1:
            return self.evaluate_step(x, p, jacobian, record, margins, margin_gradients)
        theta = self.default_parameters() if p is None else np.asarray(p, float).ravel()
        ps = self.step_parameters(theta)
        rs, xk = [], np.asarray(x, float).ravel()
        for k, pk in enumerate(ps):
            rs.append(self.evaluate_step(xk, pk, jacobian, record, margins,
                                         p_next=ps[(k + 1) % len(ps)]))
            xk = rs[-1].x_next
        sim = _merged([r.sim for r in rs])
        T = rs[0].step_time
        for r in rs[1:]:
            T = T + r.step_time
        if not jacobian:
            return MapResult(xk, None, None, T, None, None, sim, steps=tuple(rs),
                             step_parameters=ps)
        r0 = rs[0]
        dx, dp, dT_dx, dT_dp = r0.dx, r0.dp, r0.dT_dx, r0.dT_dp
        for r, Pi in zip(rs[1:], self.Pi[1:], strict=True):
            dT_dx, dT_dp = dT_dx + r.dT_dx @ dx, dT_dp + r.dT_dx @ dp + r.dT_dp @ Pi
            dx, dp = r.dx @ dx, r.dx @ dp + r.dp @ Pi
        return MapResult(xk, dx, dp, T, dT_dx, dT_dp, sim, steps=tuple(rs),
                         step_parameters=ps)

    def evaluate_step(self, x, p=None, jacobian: bool = True, record: bool = False,
                      margins: bool = False, margin_gradients: bool = False,
                      p_next=None) -> MapResult:
        """One step of the walker from section state ``x`` with the step's role parameters
        ``p`` (default: the problem's); the arguments as :meth:`evaluate`. ``p_next``: the
        next step's parameters (default ``p``), with which the guards of the phase that the
        step's last impact enters are checked."""
        p = self.problem.parameter_vector() if p is None else np.asarray(p, float).ravel()
        x = np.asarray(x, float).ravel()
        if margin_gradients and p_next is not None and not np.array_equal(p_next, p):
            raise ValueError("margin gradients are those of a one-step map (p_next = p)")
        res = self.sim.run(x, p, steps=1, record=record, margins=margins, p_after=p_next)
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
                if mins is not None and item.mode_after is not None:
                    self._guards_ahead(item, x, S, p, sens, mins)
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

    def _guards_ahead(self, item, x, S, p, sens, mins):
        """The guard margins of the phase that transition ``item`` enters, at its first state
        ``x`` (sensitivity ``S``), with their gradients (see ``Simulator._guards_ahead``)."""
        hs = self.hs
        ahead = hs.guards_ahead[item.name]
        if not ahead:
            return
        mv = list(item.mode_after)
        mode = dict(zip(hs.mode_keys, mv, strict=True))
        g, gx, gp = hs.event_jac[hs.transition_target[item.name]].np(x, p, mv)
        g = np.ravel(g)
        for i, ev, key in ahead:
            if ev.enabled(mode):
                d = -ev.direction
                mins[key] = (float(d * g[i]), d * (gx[i] @ S + gp[i] @ sens.Sp))

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

    def resimulation_deviation(self, xs_steps, p=None, steps: int = 20) -> float:
        """The largest deviation (rad, rad/s) over ``steps`` simulated steps from
        ``xs_steps[0]`` of each step's section state from the one given for it
        (``xs_steps``: one state per step of the map, e.g. an NLP's nodes; the map's steps
        repeat), with the map's parameters ``p``; inf when the walker fails on the way."""
        xs = [np.asarray(v, float).ravel() for v in xs_steps]
        p = self.default_parameters() if p is None else p
        if self.steps == 1:
            run = self.sim.run(xs[0], p, steps=steps, record=False)
        else:
            run = self.sim.run(xs[0], None, steps=steps, record=False,
                               p_steps=list(self.step_parameters(p)))
        if run.failure is not None:
            return math.inf
        ps = run.poincare_states
        return float(max(np.abs(ps[k::self.steps] - x).max() for k, x in enumerate(xs)))

    def step_length(self, x_end, p_next) -> tuple[float, np.ndarray, np.ndarray]:
        """Length (m) of the step that ended in section state ``x_end`` (read from the
        section geometry with the next step's role parameters ``p_next``), with its exact
        gradients with respect to ``x_end`` and ``p_next``."""
        if self._ell is None:
            self._ell = _section_step_length(self.hs)
        if self._ell is False:
            raise ValueError(f"{self.problem.family}: no toe points for the section step "
                             f"length")
        v, gx, gp = (np.asarray(a, float).ravel() for a in self._ell(x_end, p_next))
        return float(v[0]), gx, gp

    def jacobian(self, x, p=None):
        """(P(x, p), dP/dx, dP/dp) with exact AD derivatives."""
        r = self.evaluate(x, p)
        return r.x_next, r.dx, r.dp

    def as_casadi(self) -> ca.Function:
        """P as a CasADi function of (x, p) with exact Jacobian (for NLPs and rootfinders)."""
        return _PoincareCallback("poincare_map", self)


def _section_step_length(hs: HybridSystem):
    """CasADi function (xs, p) -> (step length, d/dxs, d/dp) of walkers with toe points
    (False for the others): after the swap the new leading toe sits at the origin and the
    trailing toe where the old leading toe was, so the step length is -(trailing toe .
    downhill direction)."""
    if "toe2" not in hs.point_names:
        return False
    model = hs.model
    xs = ca.SX.sym("xs", len(model.state_names))
    p = model.p
    # the walker's own step length (leading minus trailing toe along the slope), read
    # with the legs' roles after the swap
    ell = -hs.step_length.fun(model.section_to_full(xs, p), p)
    return ca.Function("section_step_length", [xs, p],
                       [ell, ca.jacobian(ell, xs), ca.jacobian(ell, p)])


def _merged(sims: list[SimulationResult]) -> SimulationResult:
    """One record for several steps (phases, lengths, losses, margins of every step; margin
    names prefixed with the stance leg, the smallest value per leg) so that fixed-point
    reports read the whole period."""
    recs = [s.steps[0] for s in sims]
    a, b = recs[0], recs[-1]
    margins: dict = {}
    for k, r in enumerate(recs):
        for key, v in r.margins.items():
            name = leg_key(LEG_SIDES[k % 2], key)
            margins[name] = v if name not in margins else min(margins[name], v)

    def total(attr):
        out = getattr(a, attr)
        for r in recs[1:]:
            out = out + getattr(r, attr)
        return out

    rec = StepRecord(0, a.t_start, [ph for r in recs for ph in r.phases], a.x_section_start,
                     b.x_section_end, total("step_length"), total("dissipated_damping_J"),
                     total("impact_loss_J"), total("spring_loss_J"), a.energy_start_J,
                     b.energy_end_J, margins)
    return SimulationResult(None, [], [rec], None, sims[-1].state_names,
                            sims[-1].final_state, sims[-1].final_mode)


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


def poincare_map(problem, steps: int = 1) -> PoincareMap:
    """The periodic map of ``steps`` steps of ``problem``'s walker (see :class:`PoincareMap`)."""
    return PoincareMap(problem, steps=steps)
