"""Phases, guards and transitions of a hybrid walker, as CasADi functions built once.

A walker module (see :mod:`pdw_casadi.model.walkers`) describes its model symbolically: the
planar system, its phases (contact set + events + named outputs) and transitions (impact
contact set + post-impact relabelling). :class:`HybridSystem` turns that description into
CasADi functions of the integrated state x = [q; qd; W] (W: energy dissipated by dampers, J),
the parameters p (compliance..., slope) and the mode weights m (0/1 switches such as "knee
spring engaged"), built once per walker and reused by every simulation, Poincare map and fit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import NamedTuple

import casadi as ca

from pdw_casadi.engine.compile import HOT, INTERPRETED, Lazy, cse_function
from pdw_casadi.engine.rk4 import rk4
from pdw_casadi.model.margins import (
    GUARD_AHEAD,
    Margin,
    ahead_name,
    check_key,
    check_margin,
    output_margin,
    phase_key,
)
from pdw_casadi.model.mechanics.planar import ContactSet, PlanarSystem


class EventKind(StrEnum):
    """What crossing an event does: end the phase, switch the mode, end the simulation."""

    GUARD = "guard"
    SWITCH = "switch"
    FAILURE = "failure"


GUARD, SWITCH, FAILURE = EventKind.GUARD, EventKind.SWITCH, EventKind.FAILURE

Mode = dict[str, float]


@dataclass(frozen=True)
class Event:
    """A switching surface g(q, qd, p, m) = 0 crossed in ``direction`` (-1 down, +1 up, 0 any).

    ``kind``: GUARD ends the phase, SWITCH changes the walker's mode, FAILURE ends the
    simulation with this event's name as the reason. ``when(mode)`` enables the event;
    ``effect(mode, sign)`` returns the new mode (sign = direction of the crossing).
    ``indicator``: the name of a mode flag that is 1 while g > 0 (re-read from the state at
    every phase start). ``require``: an expression that must be > 0 when a GUARD is reached,
    else the step fails with reason ``require_reason``. ``arm_above`` > 0: the event only
    counts once g has exceeded this value in the phase (a swing toe leaving the ground at
    toe-off starts at g = 0 and must rise before touching down counts as scuffing).
    """

    name: str
    expr: ca.SX
    direction: int
    kind: EventKind
    description: str = ""
    when: Callable[[Mode], bool] | None = None
    effect: Callable[[Mode, int], Mode] | None = None
    indicator: str | None = None
    require: ca.SX | None = None
    require_reason: str = ""
    arm_above: float = 0.0

    def enabled(self, mode: Mode) -> bool:
        return True if self.when is None else bool(self.when(mode))

    @property
    def directional_guard(self) -> bool:
        """Whether the event ends its phase at a crossing in one direction, counted from
        the phase's start (a phase must begin on its near side: ``GUARD_AHEAD``)."""
        return self.kind == GUARD and self.direction != 0 and self.arm_above <= 0


@dataclass
class Phase:
    """One continuous phase: contact set, its dynamics (qdd, multipliers), events, outputs."""

    name: str
    contact: ContactSet
    qdd: ca.SX
    lam: ca.SX
    events: list[Event] = field(default_factory=list)
    outputs: dict[str, ca.SX] = field(default_factory=dict)
    #: validity margins among the outputs (name -> spec); None: by the naming rule of
    #: :mod:`pdw_casadi.model.margins`
    margins: dict[str, Margin] | None = None


def make_phase(system: PlanarSystem, F_q, name: str, contact: ContactSet) -> Phase:
    """A phase with its constrained dynamics (eq. 12) solved; add events and outputs after."""
    qdd, lam = system.constrained_dynamics(contact, F_q)
    return Phase(name=name, contact=contact, qdd=qdd, lam=lam)


@dataclass
class Transition:
    """An instantaneous transition at the end of phase ``source`` (impact if ``impact``),
    taken when the phase ends on its guard event ``guard`` (None: the phase's only guard),
    so that a phase with several guards may end in different transitions.

    ``qd_plus``/``impulse`` come from :meth:`PlanarSystem.impact`; ``checks`` are named
    margins in (q, qd, qd_plus) that must be > 0 for the assumed gait pattern; ``relabel`` =
    (q_new, qd_new) in terms of (q, qd) maps the post-impact state to the next phase's
    coordinates (leg swap); ``ends_step`` marks the Poincare section; ``mode_after`` maps
    the walker's mode across the transition and may return a failure reason instead.
    """

    name: str
    source: str
    target: str
    qd_plus: ca.SX
    impulse: ca.SX
    checks: dict[str, ca.SX] = field(default_factory=dict)
    relabel: tuple[ca.SX, ca.SX] | None = None
    ends_step: bool = False
    mode_after: Callable[[Mode], Mode | str] | None = None
    guard: str | None = None
    #: validity margins among the checks (name -> spec); None: by the naming rule of
    #: :mod:`pdw_casadi.model.margins`
    margins: dict[str, Margin] | None = None
    #: the contact set the impact closes (None: no impact)
    contact: ContactSet | None = None


def make_transition(system: PlanarSystem, name: str, source: str, target: str,
                    impact: ContactSet | None, **kw) -> Transition:
    """A transition; with ``impact`` the post-impact velocities and impulses are solved."""
    if impact is None:
        return Transition(name, source, target, system.qd, ca.SX(0, 1), **kw)
    qd_plus, impulse = system.impact(impact)
    return Transition(name, source, target, qd_plus, impulse, contact=impact, **kw)


@dataclass
class WalkerModel:
    """Symbolic description of one walker, produced by a walker module's ``build``.

    ``section_to_full(xs, p) -> x`` and ``full_to_section(x) -> xs`` map the Poincare
    section state to the integrated state x = [q; qd; W] at the start of the first phase.
    ``initial_mode`` is the mode at the section; ``mode_keys`` orders the mode vector m.
    ``step_length`` (q, p) is the distance (m) covered by one step, evaluated just before
    the section transition.
    """

    name: str
    system: PlanarSystem
    p: ca.SX
    m: ca.SX
    mode_keys: tuple[str, ...]
    initial_mode: Mode
    F_q: ca.SX  # generalized forces of eq. (12) (gravity, velocity terms, joint torques)
    spring_energy: ca.SX
    damping_power: ca.SX
    phases: list[Phase]
    transitions: list[Transition]
    section_to_full: ca.Function
    full_to_section: ca.Function
    state_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    step_length: ca.SX
    common_outputs: dict[str, ca.SX] = field(default_factory=dict)
    points: dict[str, ca.SX] = field(default_factory=dict)
    links: list[tuple[str, str]] = field(default_factory=list)
    ground_normal: ca.SX | None = None
    q_names: tuple[str, ...] = ()
    #: the phase that begins at the swing leg's heel strike (gait-cycle start, docs/model.md);
    #: None: the step itself begins at leg 1's heel strike (point feet)
    heel_strike_phase: str | None = None


class Impact(NamedTuple):
    """The outputs of a transition's map (numpy arrays or CasADi expressions): the state
    after it in the next phase's coordinates, the impulses (N s), the checks, and the
    post-impact state before relabelling (same frame as the state before, for energies)."""

    x_plus: object
    impulse: object
    checks: object
    x_post: object


class Energy(NamedTuple):
    """Kinetic, potential and spring energy of a state (J)."""

    kinetic: float
    potential: float
    spring: float


class HybridSystem:
    """CasADi functions of a walker's phases and transitions, built once and reused."""

    def __init__(self, model: WalkerModel, chunk_size: int = 32):
        self.model = model
        sysm = model.system
        q, p, m = sysm.q, model.p, model.m
        self.nq = q.shape[0]
        self.nx = 2 * self.nq + 1
        self.np = p.shape[0]
        self.nm = m.shape[0]
        self.mode_keys = model.mode_keys
        self._rhs_jac: dict[str, ca.Function] = {}  # rhs_jacobian, built on first use
        x = ca.SX.sym("x", self.nx)
        h = ca.SX.sym("h")
        self.chunk_size = chunk_size
        self.phase_names = [ph.name for ph in model.phases]
        self.phases = {ph.name: ph for ph in model.phases}
        self.rhs, self.step, self.events, self.chunk, self.locate = {}, {}, {}, {}, {}
        self.outputs, self.output_names, self.event_list = {}, {}, {}
        self.event_jac, self.require = {}, {}
        #: per phase / transition: (row, output or check name, Margin) of its validity
        #: margins; ``margin_specs``: margins-table key -> Margin (see pdw_casadi.model.margins)
        self.phase_margins: dict[str, list[tuple[int, str, Margin]]] = {}
        self.check_margins: dict[str, list[tuple[int, str, Margin]]] = {}
        self.margin_specs: dict[str, Margin] = {}
        self.x_sym = x
        for ph in model.phases:
            self._add_phase(ph, h)
        self.impact, self.impact_jac = {}, {}
        #: (phase, guard event name) -> the transition taken there
        self.transitions: dict[tuple[str, str], Transition] = self._guard_transitions()
        for tr in model.transitions:
            self._add_impact(tr)
        self.check_names = {tr.name: list(tr.checks) for tr in model.transitions}
        self._add_transition_margins()
        self._add_walker_functions()

    def subs_x(self, expr):
        """``expr`` in (q, qd) as an expression of the state symbol ``x_sym``."""
        sysm = self.model.system
        return ca.substitute(expr, ca.vertcat(sysm.q, sysm.qd), self.x_sym[: 2 * self.nq])

    # -- one phase -------------------------------------------------------------------------
    def _add_phase(self, ph: Phase, h) -> None:
        """The functions of phase ``ph`` in (x, p, m): its right-hand side and RK4 step of
        size ``h`` (s), its events, their requirements and location within a step, its
        outputs and validity margins, the simulator's chunk of steps, and the exact
        derivatives of its events."""
        x, p, m = self.x_sym, self.model.p, self.model.m
        rhs, step = self._phase_step(ph, h)
        g, events, locate = self._phase_events(ph, step)
        outputs = self._phase_outputs(ph)
        chunk = self._phase_chunk(ph, rhs, h)
        # exact derivatives of the event functions (for the Poincare map)
        event_jac = ca.Function(
            f"event_jac_{ph.name}", [x, p, m], [g, ca.jacobian(g, x), ca.jacobian(g, p)])
        self.chunk[ph.name] = Lazy(chunk, HOT)
        self.outputs[ph.name] = Lazy(outputs)
        self.event_jac[ph.name] = Lazy(event_jac)
        self.rhs[ph.name], self.step[ph.name] = rhs, Lazy(step)
        self.events[ph.name] = Lazy(events)
        self.locate[ph.name] = Lazy(locate)
        self.event_list[ph.name] = ph.events

    def _phase_step(self, ph: Phase, h) -> tuple[ca.Function, ca.Function]:
        """The phase's right-hand side xdot(x, p, m) (eq. 12 with the damping power, W) and
        its RK4 step of size ``h`` (s)."""
        model = self.model
        x, p, m = self.x_sym, model.p, model.m
        xdot = self.subs_x(ca.vertcat(model.system.qd, ph.qdd, model.damping_power))
        # cse: the expression graph repeats subexpressions (sin/cos of the same angles,
        # products in M_q); merging them saves ~12 % of the operations, same values
        rhs = cse_function(f"rhs_{ph.name}", [x, p, m], [xdot], ["x", "p", "m"], ["xdot"])
        x_next = rk4(lambda y: rhs(y, p, m), x, h)
        step = cse_function(f"step_{ph.name}", [x, h, p, m], [x_next],
                            ["x", "h", "p", "m"], ["xf"])
        return rhs, step

    def _phase_events(self, ph: Phase, step: ca.Function
                      ) -> tuple[ca.SX, ca.Function, ca.Function]:
        """The phase's event functions g (their expression in x and ``events``), their
        requirements at a guard (registered in ``self.require``), and ``locate``: g, dg/dtau
        and the state a partial step tau (s) after x (the Newton location of a crossing)."""
        x, p, m = self.x_sym, self.model.p, self.model.m
        g = self.subs_x(ca.vertcat(*[e.expr for e in ph.events]))
        events = cse_function(f"events_{ph.name}", [x, p, m], [g], ["x", "p", "m"], ["g"])
        req = self.subs_x(ca.vertcat(*[e.require if e.require is not None else ca.SX(1.0)
                                       for e in ph.events]))
        self.require[ph.name] = Lazy(ca.Function(f"require_{ph.name}", [x, p, m], [req]))
        tau = ca.SX.sym("tau")
        x_tau = step(x, tau, p, m)
        g_tau = events(x_tau, p, m)
        locate = cse_function(f"locate_{ph.name}", [x, tau, p, m],
                              [g_tau, ca.jacobian(g_tau, tau), x_tau])
        return g, events, locate

    def _phase_outputs(self, ph: Phase) -> ca.Function:
        """The phase's named outputs (the walker's common ones, then the phase's: N, m, deg,
        J, ...) as one function of (x, p, m); registers their names and validity margins."""
        model = self.model
        outs = {**model.common_outputs, **ph.outputs}
        out_vec = self.subs_x(ca.vertcat(*outs.values()))
        outputs = ca.Function(f"outputs_{ph.name}", [self.x_sym, model.p, model.m], [out_vec])
        self.output_names[ph.name] = list(outs)
        self.phase_margins[ph.name] = _declared(list(outs), ph.margins, output_margin)
        self.margin_specs.update({phase_key(ph.name, name): mg
                                  for _, name, mg in self.phase_margins[ph.name]})
        return outputs

    def _phase_chunk(self, ph: Phase, rhs: ca.Function, h) -> ca.Function:
        """``chunk_size`` RK4 steps of size ``h`` (s) in one call: the states after each
        step (columns) and the event functions there."""
        model = self.model
        x, p, m = self.x_sym, model.p, model.m
        # the simulator's hot loop calls this, not the single step. The events are needed
        # at every step's end point, whose right-hand side is the next step's first stage:
        # one fused function gives both (shared subexpressions, the multipliers), and the
        # chunk carries k1 along ("first same as last"), so a step costs four right-hand
        # sides instead of four plus the events. Same arithmetic as ``step``, so the states
        # are the same.
        xg = self.subs_x(ca.vertcat(model.system.qd, ph.qdd, model.damping_power,
                                    *[e.expr for e in ph.events]))
        fg = cse_function(f"rhs_events_{ph.name}", [x, p, m], [xg[: self.nx], xg[self.nx:]])
        z = ca.SX.sym("z", 2 * self.nx)
        xz, k1 = z[: self.nx], z[self.nx:]
        xn = rk4(lambda y: rhs(y, p, m), xz, h, k1=k1)
        k1n, gn = fg(xn, p, m)
        fsal = cse_function(f"fsal_{ph.name}", [z, h, p, m], [ca.vertcat(xn, k1n), gn])
        acc = fsal.mapaccum(f"acc_{ph.name}", self.chunk_size, [0], [0])
        X0 = ca.MX.sym("x0", self.nx)
        hh, pp, mm = ca.MX.sym("h"), ca.MX.sym("p", self.np), ca.MX.sym("m", self.nm)
        Z, G = acc(ca.vertcat(X0, fg(X0, pp, mm)[0]), hh, pp, mm)
        return ca.Function(f"chunk_{ph.name}", [X0, hh, pp, mm], [Z[: self.nx, :], G])

    # -- transitions -----------------------------------------------------------------------
    def _guard_transitions(self) -> dict[tuple[str, str], Transition]:
        """(phase, guard event name) -> the transition taken there (at most one each)."""
        transitions: dict[tuple[str, str], Transition] = {}
        for tr in self.model.transitions:
            key = (tr.source, tr.guard or _only_guard(self.phases[tr.source]))
            if key in transitions:
                raise ValueError(f"two transitions leave phase {key[0]!r} at guard {key[1]!r}")
            transitions[key] = tr
        return transitions

    def _add_impact(self, tr: Transition) -> None:
        """The map of transition ``tr`` in (x, p): the state after it in the next phase's
        coordinates (the damping work W, J, carried over), the impulses (N s), the checks
        and the post-impact state before relabelling; and its Jacobians in x and p."""
        q, qd = self.model.system.q, self.model.system.qd
        x, p = self.x_sym, self.model.p
        chk = ca.vertcat(*tr.checks.values()) if tr.checks else ca.SX(0, 1)
        q_new, qd_new = q, tr.qd_plus
        if tr.relabel is not None:
            q_new = tr.relabel[0]
            qd_new = ca.substitute(tr.relabel[1], qd, tr.qd_plus)
        x_plus = self.subs_x(ca.vertcat(q_new, qd_new, 0)) + ca.vertcat(
            ca.SX(2 * self.nq, 1), x[-1])
        # x_post: post-impact state before relabelling (same frame, for energy balances)
        x_post = self.subs_x(ca.vertcat(q, tr.qd_plus))
        x_post = ca.vertcat(x_post, x[-1])
        self.impact[tr.name] = Lazy(ca.Function(
            f"impact_{tr.name}", [x, p],
            [x_plus, self.subs_x(tr.impulse), self.subs_x(chk), x_post],
            ["x", "p"], ["x_plus", "impulse", "checks", "x_post"]), INTERPRETED)
        self.impact_jac[tr.name] = Lazy(ca.Function(
            f"impact_jac_{tr.name}", [x, p],
            [x_plus, ca.jacobian(x_plus, x), ca.jacobian(x_plus, p)]), INTERPRETED)

    def _add_transition_margins(self) -> None:
        """The validity margins of the transitions: their checks' (N s, m/s, m) and, for
        the phase each enters, how far each of its directional guards is from crossing."""
        transitions = self.model.transitions
        for tr in transitions:
            self.check_margins[tr.name] = _declared(list(tr.checks), tr.margins, check_margin)
            self.margin_specs.update({check_key(tr.name, name): mg
                                      for _, name, mg in self.check_margins[tr.name]})
        #: per transition: (index, event, margins-table key) of each guard of the phase it
        #: enters that must not be crossed yet when that phase begins (directional guards
        #: without arming; see :data:`~pdw_casadi.model.margins.GUARD_AHEAD`)
        self.guards_ahead: dict[str, list[tuple[int, Event, str]]] = {}
        #: transition name -> the phase it enters
        self.transition_target = {tr.name: tr.target for tr in transitions}
        for tr in transitions:
            ahead = [(i, ev, check_key(tr.name, ahead_name(ev.name)))
                     for i, ev in enumerate(self.event_list[tr.target])
                     if ev.directional_guard]
            self.guards_ahead[tr.name] = ahead
            self.margin_specs.update({key: GUARD_AHEAD for _, _, key in ahead})

    # -- the whole walker ------------------------------------------------------------------
    def _add_walker_functions(self) -> None:
        """Functions of the walker in any phase: its energies (J), the step length (m), the
        Poincare section maps and its drawn points (m)."""
        model, sysm = self.model, self.model.system
        x, p, m = self.x_sym, model.p, model.m
        e = self.subs_x(ca.vertcat(sysm.kinetic, sysm.potential, model.spring_energy))
        # Lazy: called a few times per step by the simulator (``.np``); ``(...)`` gives DMs
        self.energy = Lazy(ca.Function("energy", [x, p, m], [e], ["x", "p", "m"], ["E"]))
        self.step_length = Lazy(ca.Function("step_length", [x, p],
                                            [self.subs_x(model.step_length)]))
        self.section_to_full = Lazy(model.section_to_full)
        self.full_to_section = Lazy(model.full_to_section)
        self.points = ca.Function(
            "points", [x, p], [self.subs_x(ca.horzcat(*model.points.values()))])
        self.point_names = list(model.points)

    def libraries(self) -> list[Lazy]:
        """Every compiled function of the walker: phases, impacts, energies and section
        maps, with the exact derivatives of its events and impacts (for
        :func:`~pdw_casadi.engine.compile.build_libraries`)."""
        tables = (self.chunk, self.step, self.events, self.locate, self.require, self.outputs,
                  self.event_jac, self.impact, self.impact_jac)
        return [*(f for t in tables for f in t.values()), self.energy, self.step_length,
                self.section_to_full, self.full_to_section]

    def rhs_jacobian(self, phase: str) -> ca.Function:
        """(xdot, dxdot/dx, dxdot/dp) of a phase as one SX function of (x, p, m) (the
        sensitivities of the Poincare map and of the shooting intervals chain it), built
        once per phase (30 ms for the 6-link walker's stance phase)."""
        if phase not in self._rhs_jac:
            x, p, m = ca.SX.sym("x", self.nx), self.model.p, self.model.m
            xdot = self.rhs[phase](x, p, m)
            self._rhs_jac[phase] = cse_function(
                f"rhs_jac_{phase}", [x, p, m], [xdot, ca.jacobian(xdot, x), ca.jacobian(xdot, p)])
        return self._rhs_jac[phase]

    # -- named outputs ---------------------------------------------------------------
    def impact_at(self, transition: str, x, p) -> Impact:
        """The map of ``transition`` at the pre-impact state ``x`` (numpy, flat arrays)."""
        return Impact(*(v.ravel() for v in self.impact[transition].np(x, p)))

    def impact_expr(self, transition: str, x, p) -> Impact:
        """The map of ``transition`` on CasADi expressions (for the NLP)."""
        return Impact(*self.impact[transition](x, p))

    def energy_at(self, x, p, mv) -> Energy:
        """The energies (J) of state ``x`` in mode vector ``mv``."""
        return Energy(*map(float, self.energy.np(x, p, mv).ravel()))

    # -- mode helpers -------------------------------------------------------------------
    def mode_vector(self, mode: Mode) -> list[float]:
        return [float(mode[k]) for k in self.mode_keys]

    def mode_after_switch(self, phase: str, idx: int, sign: float, x, p, mode: Mode) -> Mode:
        """The walker's mode after the switch event ``idx`` of ``phase`` crossed in the
        direction ``sign`` (+1 upwards, -1 downwards) at the state ``x`` (SI): its flag from
        the crossing direction, its effect, the other flags read from the state. One rule
        for the simulator and for a pattern read off a guess (:mod:`pdw_casadi.nlp.pattern`)."""
        ev = self.event_list[phase][idx]
        if ev.indicator:
            mode = {**mode, ev.indicator: 1.0 if sign > 0 else 0.0}
        if ev.effect is not None:
            mode = ev.effect(mode, sign)
        return self.refresh_indicators(phase, x, p, mode, skip=idx)

    def mode_after_transition(self, tr: Transition, x_plus, p, mode: Mode) -> Mode | str:
        """The walker's mode in the phase that the transition ``tr`` enters, at its state
        ``x_plus`` (SI, after the impact) with the parameters ``p`` of that phase: the
        transition's mode rule, then the flags read from the state; or the rule's failure
        reason (a string)."""
        new = tr.mode_after(mode) if tr.mode_after else mode
        if isinstance(new, str):
            return new
        return self.refresh_indicators(tr.target, x_plus, p, new)

    def refresh_indicators(self, phase: str, x, p, mode: Mode, skip: int | None = None) -> Mode:
        """Mode flags that mirror the sign of an event function, read from the state.

        ``skip``: index of an event located at this very state (its value is ~0, so its
        sign is noise; its flag was set from the crossing direction instead).
        """
        evs = self.event_list[phase]
        if not any(e.indicator for e in evs):
            return mode
        g = self.events[phase].np(x, p, self.mode_vector(mode)).ravel()
        mode = dict(mode)
        for i, (e, gi) in enumerate(zip(evs, g, strict=True)):
            if e.indicator and i != skip:
                mode[e.indicator] = 1.0 if gi > 0 else 0.0
        return mode


def _declared(names: list[str], declared: dict[str, Margin] | None,
              rule) -> list[tuple[int, str, Margin]]:
    """(row, name, Margin) of the margins among ``names``: as declared, else by ``rule``."""
    if declared is not None:
        unknown = set(declared) - set(names)
        if unknown:
            raise ValueError(f"margins declared for unknown names {sorted(unknown)}")
        return [(j, n, declared[n]) for j, n in enumerate(names) if n in declared]
    return [(j, n, mg) for j, n in enumerate(names) if (mg := rule(n)) is not None]


def _only_guard(phase: Phase) -> str:
    """The name of the phase's one guard event (a transition that names none needs one)."""
    guards = [e.name for e in phase.events if e.kind == GUARD]
    if len(guards) != 1:
        raise ValueError(f"phase {phase.name!r} has guards {guards}: its transitions must "
                         f"name the guard they follow (Transition.guard)")
    return guards[0]
