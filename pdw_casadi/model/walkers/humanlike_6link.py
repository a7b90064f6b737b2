"""The humanlike 6-link walker of the paper, assembled from its parts.

Conventions follow docs/model.md of the repository: absolute angles from the vertical with link
direction d(q) = (sin q, -cos q); q = [q1, q2, q3, q4, qf1, qf2, x_t1, y_t1]; three phases
per step (I: leading foot flat + trailing toe pivot; II: single stance on the flat foot;
III: trailing toe + leading heel pivots), heel strike and foot strike impacts, then a leg
swap. Modes: ``eng1``/``eng2`` knee springs engaged, ``flex1``/``flex2`` disengaged knee
flexing (selects flexion or extension damping), ``armed2`` swing-knee spring armed.

The parts: the leg chain (:mod:`pdw_casadi.model.sixlink.chain`), the knees
(:mod:`pdw_casadi.model.sixlink.knees`), the section (:mod:`pdw_casadi.model.sixlink.section`)
and a foot on each leg (:mod:`pdw_casadi.model.feet`: the paper's flat foot by default, the
rolling arcs, the forefoot rocker). This module composes them into phases and transitions:
what each leg touches in a phase comes from the foot (its flat contact, its toe and heel
pivots, single-support stages it adds after phase II); the gait's order of contacts, the
impacts and the leg swap are the walker's. :func:`register_six_link` registers a walker
family of this chain with a given foot and extension.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.feet.base import FlatReading, Foot, FootLeg, Ground, Hold, Pivot
from pdw_casadi.model.feet.flat import FLAT
from pdw_casadi.model.hybrid import (
    FAILURE,
    GUARD,
    Event,
    Phase,
    Transition,
    WalkerModel,
    make_phase,
    make_transition,
)
from pdw_casadi.model.margins import IMPULSE, output_margin
from pdw_casadi.model.mechanics.planar import ContactSet, PlanarSystem
from pdw_casadi.model.mechanics.torques import total_torque
from pdw_casadi.model.sixlink.chain import ANTHROPOMETRY_KEYS, ankle_elements, leg_chain
from pdw_casadi.model.sixlink.knees import COMPLIANCE_KEYS as KNEE_COMPLIANCE
from pdw_casadi.model.sixlink.knees import (
    INITIAL_MODE,
    MODE_KEYS,
    after_foot_strike,
    arm_swing_knee,
    knee_elements,
    knee_events,
)
from pdw_casadi.model.sixlink.section import STATE_KEYS, SWAP, section_maps, swap
from pdw_casadi.model.walkers.registry import register

COMPLIANCE_KEYS = ("k_ankle", "c_ankle", *KNEE_COMPLIANCE)
POSITIVE_KEYS = tuple(k for k in ANTHROPOMETRY_KEYS if k != "l_fc")
NONNEGATIVE_COMPLIANCE = ("k_ankle", "c_ankle", "c_knee_flex", "c_knee_ext", "k_knee",
                          "c_knee_stance")
#: the anthropometry of one physical leg (everything but the lumped hip mass)
LEG_ANTHROPOMETRY_KEYS = tuple(k for k in ANTHROPOMETRY_KEYS if k != "m_h")
#: keys a problem may set per physical leg ([compliance.left], [anthropometry.right], ...)
LEG_KEYS = {"compliance": COMPLIANCE_KEYS, "anthropometry": LEG_ANTHROPOMETRY_KEYS}
Q_NAMES = ("q1", "q2", "q3", "q4", "qf1", "qf2", "x_t1", "y_t1")
__all__ = ["ANTHROPOMETRY_KEYS", "COMPLIANCE_KEYS", "MODE_KEYS", "Q_NAMES", "STATE_KEYS",
           "SWAP", "build", "build_per_leg", "register_six_link"]

# -- faces of the walker for plots and reports (see pdw_casadi.model.faces) ---------------------
PHASE_DESCRIPTIONS = FLAT.phase_descriptions
#: (shank, thigh) of one physical leg: leg 1 (stance) in step 0, leg 2 (swing) in step 1
LIMIT_CYCLE_LEGS = (("q1", "q2"), ("q4", "q3"))
LEG_SEGMENTS = ("shank", "thigh")
CURVE_JOINTS = ("knee", "hip")
#: what touches the ground in each phase, (leg 1, leg 2): see pdw_casadi.gait.timing
PHASE_CONTACTS = FLAT.phase_contacts
#: instants of the paper's Fig. 4: a (foot strike), b (toe-off), c (heel strike)
INSTANT_LABELS = FLAT.instant_labels
#: the paper's comparison walker [48] (point feet, locked stance knee), this anthropometry
COMPARISON_PROBLEM = "comparison_kneed_6link"
#: R^2 of the paper's own fit (its four subjects), shown beside a fit for comparison
PAPER_REPORTED_R2 = {"r2_knee": 0.891, "r2_hip": 0.899}


def check_chain(a, where) -> None:
    """The chain's centres of mass lie on their links (shorter than the link)."""
    for com, length in (("l_sc", "l_s"), ("l_tc", "l_t")):
        if not a[com] < a[length]:
            raise ProblemError(f"{where}: 'anthropometry.{com}' must be shorter than "
                               f"'anthropometry.{length}'")


def anthropometry_check(foot: Foot):
    """The anthropometry rules of the walker with ``foot``: the foot's, then the chain's."""

    def check(a, where) -> None:
        foot.check_anthropometry(a, where)
        check_chain(a, where)

    return check


#: the rules of the paper's walker (flat feet)
check_anthropometry = anthropometry_check(FLAT)


def compliance_keys(ext=None, foot: Foot = FLAT) -> tuple[str, ...]:
    """The walker's compliance keys (per leg): its own, an extension's, the foot's."""
    return COMPLIANCE_KEYS + (ext.compliance_keys if ext else ()) + foot.compliance_keys


def build(problem, ext=None, foot: Foot = FLAT) -> WalkerModel:
    """The symbolic model of the walker with ``problem``'s anthropometry (numbers baked in).

    ``ext``: an extension of the passive elements (extra compliance keys, mode flags,
    torque elements, events and mode rules at the transitions), e.g.
    :data:`pdw_casadi.model.walkers.humanlike_6link_ankle.EXTENSION`; None: the paper's
    elements. ``foot``: the foot on both legs (:mod:`pdw_casadi.model.feet`; its compliance
    keys follow the extension's).
    """
    a = dict(problem.anthropometry)
    comp_keys = compliance_keys(ext, foot)
    p = ca.SX.sym("p", len(comp_keys) + 1)
    c = {k: p[i] for i, k in enumerate(comp_keys)}
    return _assemble(problem.name, problem.g, a, a, a["m_h"], c, c, p, p[-1],
                     (*comp_keys, "slope"), ext, foot)


def per_leg_parameter_names(compliance_keys: tuple[str, ...] = COMPLIANCE_KEYS,
                            leg_anthropometry: tuple[str, ...] = LEG_ANTHROPOMETRY_KEYS
                            ) -> tuple[str, ...]:
    """Parameter names of :func:`build_per_leg`: leg 1's (stance role) compliance and
    anthropometry, leg 2's (swing role), then ``m_h`` and ``slope`` (``compliance_keys``:
    the family's, an extension's and the foot's included)."""
    return (*(f"{k}@1" for k in compliance_keys), *(f"{k}@2" for k in compliance_keys),
            *(f"{k}@1" for k in leg_anthropometry),
            *(f"{k}@2" for k in leg_anthropometry), "m_h", "slope")


def build_per_leg(name: str, g: float, ext=None, foot: Foot = FLAT) -> WalkerModel:
    """The walker with every body and compliance value a runtime parameter, per leg role.

    p = [compliance of leg 1 (the stance leg of the step), compliance of leg 2 (swing),
    leg-1 anthropometry, leg-2 anthropometry, m_h, slope] (:func:`per_leg_parameter_names`;
    rad, m, kg, kg m^2, N m/rad, N m s/rad). Each joint element and link uses the values of
    the leg it belongs to, so a caller that swaps the two leg blocks after every step makes
    the parameters follow the physical leg through the leg swap. One compiled walker serves
    every body: changing the anthropometry needs no recompilation. ``ext``, ``foot``: as in
    :func:`build` (their compliance keys per leg too).
    """
    comp_keys = compliance_keys(ext, foot)
    leg_anth = LEG_ANTHROPOMETRY_KEYS + foot.anthropometry_keys
    names = per_leg_parameter_names(comp_keys, leg_anth)
    p = ca.SX.sym("p", len(names))
    sym = {n: p[i] for i, n in enumerate(names)}
    c1 = {k: sym[f"{k}@1"] for k in comp_keys}
    c2 = {k: sym[f"{k}@2"] for k in comp_keys}
    a1 = {k: sym[f"{k}@1"] for k in leg_anth}
    a2 = {k: sym[f"{k}@2"] for k in leg_anth}
    return _assemble(name, g, a1, a2, sym["m_h"], c1, c2, p, sym["slope"], names, ext, foot)


@dataclass
class _Contacts:
    """The contacts of a step (rows in m or rad; their multipliers in N and N m): the
    trailing foot's toe ``toe2`` (phase I, the section), the stance foot's toe ``toe1``
    (phase III, the impacts), the leading foot's heel ``heel2``, the rows holding the stance
    foot flat, the rows the swing foot closes in single support and holds until it lands
    (``hold``: its :class:`~pdw_casadi.model.feet.base.Hold`, None when its foot has none;
    the rows empty then), and the contact sets of phases I, II, III and of the foot strike."""

    toe1: Pivot
    toe2: Pivot
    heel2: Pivot
    flat1_rows: ca.SX
    flat1_labels: tuple[str, ...]
    hold: Hold | None
    hold_rows: ca.SX
    hold_labels: tuple[str, ...]
    contact_I: ContactSet
    contact_II: ContactSet
    contact_III: ContactSet
    contact_foot_strike: ContactSet


@dataclass
class _Parts:
    """What every phase and transition of the walker is made from: its planar system and
    generalised forces (N, N m; eq. 12), the ground, the feet on leg 1 (stance role) and leg
    2 (swing role), the contacts of the step and the events of every phase (the knees', the
    fall, an extension's)."""

    sysm: PlanarSystem
    F_q: ca.SX
    ground: Ground
    foot1: FootLeg
    foot2: FootLeg
    contacts: _Contacts
    common_events: list[Event]


class _Swing(NamedTuple):
    """The swing foot's events in single support: its heel striking the ground (the guard),
    its toe scuffing it (a failure), and the toe's clearance (m) they are read with."""

    heel_strike: Event
    scuff: Event
    clearance: ca.SX


def _assemble(name, g, a1, a2, m_h, c1, c2, p, gamma, parameter_names, ext=None,
              foot: Foot = FLAT) -> WalkerModel:
    """The model from leg 1's (stance role) and leg 2's (swing role) anthropometry ``a1``,
    ``a2`` (m, kg, kg m^2) and compliance ``c1``, ``c2`` (N m/rad, N m s/rad, rad; numbers
    or SX entries of ``p``), the hip mass ``m_h`` (kg), gravity ``g`` (m/s^2) and the slope
    ``gamma`` (rad); ``ext``, ``foot``: see :func:`build` (each part reads the values of the
    leg it belongs to)."""
    ne = len(foot.extra_coordinates)
    q = ca.SX.sym("q", 8 + 2 * ne)
    qd = ca.SX.sym("qd", 8 + 2 * ne)
    q1, q2, q3, q4, qf1, qf2, xt, yt = (q[i] for i in range(8))
    # a foot's extra coordinates (leg 1's, then leg 2's) are passed to it on attach
    extra1 = {"extra": q[8:8 + ne]} if ne else {}
    extra2 = {"extra": q[8 + ne:]} if ne else {}
    mode_keys = MODE_KEYS + (ext.mode_keys if ext else ())
    m = ca.SX.sym("m", len(mode_keys))
    md = {k: m[i] for i, k in enumerate(mode_keys)}
    n = ca.vertcat(ca.sin(gamma), ca.cos(gamma))
    t_slope = ca.vertcat(ca.cos(gamma), -ca.sin(gamma))  # downhill along the ground
    ground = Ground(n, t_slope, gamma)

    # the chain hangs from the stance foot's ground anchor (x_t1, y_t1); the swing foot
    # hangs from the chain's swing ankle
    foot1 = foot.attach(1, qf1, a1, c1, ground, root=ca.vertcat(xt, yt), **extra1)
    chain = leg_chain(q1, q2, q3, q4, foot1.ankle, a1, a2, m_h)
    foot2 = foot.attach(2, qf2, a2, c2, ground, ankle=chain.ankle2, **extra2)
    points = {**foot1.points, "ankle1": foot1.ankle, "knee1": chain.knee1, "hip": chain.hip,
              "knee2": chain.knee2, "ankle2": chain.ankle2, **foot2.points}
    links = [*foot1.links, ("ankle1", "knee1"), ("knee1", "hip"), ("hip", "knee2"),
             ("knee2", "ankle2"), *foot2.links]
    sysm = PlanarSystem(q, qd, [*chain.bodies, *foot1.bodies, *foot2.bodies], g)
    F_q, spring_energy, damping_power = _forces(sysm, q, md, foot1, foot2, c1, c2, ext)
    contacts = _contacts(foot1, foot2)

    common_events, knees, hip_h = _common_events(q, qd, ground, chain.hip, a1, c1, c2, ext)
    w = _Parts(sysm, F_q, ground, foot1, foot2, contacts, common_events)

    ph1 = _double_support(w, "I", contacts.toe2, contacts.contact_I)
    trailing_phases, trailing_transitions = _trailing_stages(w, foot)
    ph2, swing = _single_support(w)
    phases = [ph1, *trailing_phases, ph2]
    # the swing foot's hold closes in phase II (an impact) into the phase held; the single
    # support after it is that phase's
    hold_transitions = []
    first_single = "II"
    if contacts.hold:
        held, close = _held_support(w, ph2, swing)
        phases.append(held)
        hold_transitions.append(close)
        first_single = held.name
    stage_phases, stage_transitions = _stages(w, foot, swing, first_single)
    phases += stage_phases
    ph3 = _phase_III(w)

    toe_off = make_transition(sysm, "toe_off", "I", "II", None, mode_after=arm_swing_knee,
                              guard="toe_off")
    heel = _heel_strike(w, "heel_strike", first_single, stance_heel_down=True)
    foot_strike = _foot_strike(w, q, qd, ne)
    transitions = [toe_off, *trailing_transitions, *hold_transitions, heel,
                   *stage_transitions, foot_strike]
    if ext:
        for tr in transitions:
            tr.mode_after = ext.mode_rule(tr.name, tr.mode_after)
    phases = _unfollowed_guards_fail([*phases, ph3], transitions)

    section_to_full, full_to_section = section_maps(q, chain.knee2, foot2, a2["l_s"],
                                                    ground, p, leading=foot1)
    common = _common_outputs(q, knees, hip_h, spring_energy, w)
    return WalkerModel(
        name=name, system=sysm, p=p, m=m, mode_keys=mode_keys,
        initial_mode={**INITIAL_MODE, **(ext.initial_mode if ext else {})},
        F_q=F_q, spring_energy=spring_energy, damping_power=damping_power,
        phases=phases, transitions=transitions,
        section_to_full=section_to_full, full_to_section=full_to_section,
        state_names=STATE_KEYS, parameter_names=tuple(parameter_names),
        step_length=ca.dot(foot2.end_point("toe") - foot1.end_point("toe"), t_slope),
        common_outputs=common,
        points=points, links=links, ground_normal=n,
        q_names=Q_NAMES + tuple(f"{e}{i}" for i in (1, 2) for e in foot.extra_coordinates),
        heel_strike_phase="III",
    )


def _forces(sysm: PlanarSystem, q, md, foot1: FootLeg, foot2: FootLeg, c1, c2, ext):
    """(F_q, spring energy, damping power): the generalised forces of eq. (12) (N, N m:
    gravity, velocity terms and the joint elements' torques), the elements' stored energy
    (J) and the power their dampers dissipate (W); ``md``: the mode flags by name (SX)."""
    q1, q2, q3, q4, qf1, qf2 = (q[i] for i in range(6))
    # each joint element uses the compliance of the leg it belongs to; an extension may
    # shift the ankle spring's rest angle (foot perpendicular to the shank)
    elements = [*ankle_elements(qf1, q1, qf2, q4, c1, c2),
                *knee_elements(md, q1, q2, q3, q4, c1, c2)]
    if ext:
        elements += ext.elements(c1, c2, md, {"ankle1": (qf1, q1), "ankle2": (qf2, q4)})
    elements += [*foot1.elements(), *foot2.elements()]
    F_torque, spring_energy, damping_power = total_torque(sysm, elements, sysm.qd)
    return sysm.F_gravity + sysm.F_velocity + F_torque, spring_energy, damping_power


def _common_events(q, qd, ground: Ground, hip, a1, c1, c2, ext
                   ) -> tuple[list[Event], tuple, ca.SX]:
    """The events of every phase: the knees' (damping switches, springs engaging and
    disengaging), the fall (the ``hip`` point below half of leg 1's length above the
    ground) and an extension's; with the knee angles (thigh - shank, rad) and the hip's
    height (m), which the common outputs report (the same expressions)."""
    q1, q2, q3, q4, qf1, qf2 = (q[i] for i in range(6))
    theta1, theta2 = q2 - q1, q3 - q4
    dtheta1, dtheta2 = qd[1] - qd[0], qd[2] - qd[3]
    hip_h = ground.height(hip)
    leg = a1["l_s"] + a1["l_t"]
    fall = Event("fall", hip_h - 0.5 * leg, -1, FAILURE, "hip below half the leg length")
    events = [*knee_events(1, theta1, dtheta1, c1), *knee_events(2, theta2, dtheta2, c2), fall]
    if ext:
        events += ext.events(c1, {"ankle1": qf1 - q1, "ankle2": qf2 - q4})
    return events, (theta1, theta2), hip_h


def _common_outputs(q, knees, hip_h, spring_energy, w: _Parts) -> dict[str, ca.SX]:
    """The outputs of every phase: joint and segment angles (deg; hips from the slope's
    normal), energies (J), the hip's and the feet ends' heights above the ground (m);
    ``knees``, ``hip_h``: as ``_common_events`` gives them."""
    q1, q2, q3, q4, qf1, qf2 = (q[i] for i in range(6))
    theta1, theta2 = knees
    gamma, ground, sysm = w.ground.gamma, w.ground, w.sysm
    heel1_point = w.foot1.end_point("heel")
    toe2_point, heel2_point = w.foot2.end_point("toe"), w.foot2.end_point("heel")
    return {
        "knee1_deg": theta1 * 180 / math.pi, "knee2_deg": theta2 * 180 / math.pi,
        "hip1_deg": (q2 + gamma) * 180 / math.pi, "hip2_deg": (q3 + gamma) * 180 / math.pi,
        "thigh1_deg": q2 * 180 / math.pi, "thigh2_deg": q3 * 180 / math.pi,
        "ankle1_deg": (qf1 - q1) * 180 / math.pi, "ankle2_deg": (qf2 - q4) * 180 / math.pi,
        "kinetic_J": sysm.kinetic, "potential_J": sysm.potential, "spring_J": spring_energy,
        "hip_height_m": hip_h, "toe2_height_m": ground.height(toe2_point),
        "heel2_height_m": ground.height(heel2_point),
        "heel1_height_m": ground.height(heel1_point),
    }


def _contacts(foot1: FootLeg, foot2: FootLeg) -> _Contacts:
    """The contacts of the step from the feet on leg 1 (stance) and leg 2 (swing)."""
    toe2 = foot2.pivot("toe")
    # the stance foot starts the step flat: its toe's own events must see it leave first
    toe1 = foot1.pivot("toe", arm_first=True)
    heel2 = foot2.pivot("heel")
    flat1_rows, flat1_labels = foot1.flat_rows()
    flat2_rows, flat2_labels = foot2.flat_rows()
    contact_I = ContactSet("I", ca.vertcat(toe2.rows, flat1_rows), toe2.labels + flat1_labels)
    contact_II = ContactSet("II", flat1_rows, flat1_labels)
    # the held rows stay closed in every later contact of the step (its stages, phase III,
    # the heel-strike impacts) until the swing foot lands
    hold = foot2.swing_hold()
    hold_rows, hold_labels = (hold.rows, hold.labels) if hold else (ca.SX(0, 1), ())
    contact_III = ContactSet("III", ca.vertcat(toe1.rows, heel2.rows, hold_rows),
                             toe1.labels + heel2.labels + hold_labels)
    contact_foot_strike = ContactSet("foot_strike", ca.vertcat(toe1.rows, flat2_rows),
                                     toe1.labels + flat2_labels)
    return _Contacts(toe1, toe2, heel2, flat1_rows, flat1_labels, hold, hold_rows,
                     hold_labels, contact_I, contact_II, contact_III, contact_foot_strike)


def _double_support(w: _Parts, name: str, pivot: Pivot, contact: ContactSet,
                    stage_events=(), closes_hold: bool = False) -> Phase:
    """Phase ``name`` of double support before toe off: the stance foot flat, the trailing
    foot on ``pivot``, whose normal force (N) reaching zero is the guard (toe off);
    ``contact``: the pivot's rows, the flat stance foot's, then the swing foot's held rows
    if the stage ``closes_hold``; ``stage_events``: a foot stage's own events."""
    ph = make_phase(w.sysm, w.F_q, name, contact)
    kp, nf = pivot.rows.shape[0], w.contacts.flat1_rows.shape[0]
    N = ca.dot(ph.lam[0:2], w.ground.n)
    flat = w.foot1.flat_reading(ph.lam[kp:kp + nf], single_support=False)
    piv_read = _releasing(pivot.read(ph.lam[:kp]))
    held = w.contacts.hold.reading(ph.lam[kp + nf:]) if closes_hold else _NOTHING
    # the trailing contact's force is the releasing one (zero at toe off, the guard), so it
    # is reported but is not a validity margin
    ph.outputs = {**flat.outputs, f"release_N_{pivot.tag}": N, f"F_{pivot.tag}_x": ph.lam[0],
                  f"F_{pivot.tag}_y": ph.lam[1], **pivot.extras, **piv_read.outputs,
                  **held.outputs}
    ph.events = [
        Event("toe_off", N, -1, GUARD, "normal reaction at the trailing toe reaches zero"),
        *flat.events, *stage_events, *pivot.events, *piv_read.events, *held.events,
        *w.common_events,
    ]
    return ph


def _trailing_stages(w: _Parts, foot: Foot) -> tuple[list[Phase], list[Transition]]:
    """The foot's double-support stages after phase I (the trailing foot's contact changing)
    and their transitions: each is entered from the one before and left at toe off into
    phase II; a stage that closes the swing foot's hold is entered through that impact and
    left into the held phase."""
    c = w.contacts
    phases, transitions = [], []
    previous = "I"
    for st in foot.trailing_stages(w.foot1, w.foot2, w.ground):
        piv = st.pivot
        kp, nf = piv.rows.shape[0], c.flat1_rows.shape[0]
        extra_rows, extra_labels = (c.hold_rows, c.hold_labels) if st.closes_hold else (
            ca.SX(0, 1), ())
        contact = ContactSet(st.name, ca.vertcat(piv.rows, c.flat1_rows, extra_rows),
                             piv.labels + c.flat1_labels + extra_labels)
        phases.append(_double_support(w, st.name, piv, contact, st.events, st.closes_hold))
        entry = make_transition(w.sysm, st.entry, previous, st.name,
                                contact if st.closes_hold else None, guard=st.entry_guard)
        if st.closes_hold:
            entry.checks = _hold_impulse_checks(c.hold, entry.impulse, kp + nf)
        transitions += [
            entry, make_transition(w.sysm, st.toe_off, st.name,
                                   c.hold.phase if st.closes_hold else "II", None,
                                   guard="toe_off", mode_after=arm_swing_knee)]
        previous = st.name
    return phases, transitions


def _single_support(w: _Parts) -> tuple[Phase, _Swing]:
    """Phase II: single stance on the flat foot, the swing leg free until its heel strikes
    the ground (the guard; it must land ahead of the stance heel)."""
    ph2 = make_phase(w.sysm, w.F_q, "II", w.contacts.contact_II)
    foot1, foot2 = w.foot1, w.foot2
    flat = foot1.flat_reading(ph2.lam, single_support=True)
    toe2_low = foot2.lowest("toe")
    ph2.outputs = {**flat.outputs, "clearance_toe2": toe2_low}
    heel_strike = Event(
        "heel_strike", foot2.lowest("heel"), -1, GUARD, "swing heel reaches the ground",
        require=ca.dot(foot2.end_point("heel") - foot1.end_point("heel"), w.ground.t),
        require_reason="heel_strike_behind")
    # the swing toe leaves the ground at toe off: it must rise before touching counts
    scuff = Event("toe_scuff", toe2_low, -1, FAILURE, "swing toe hits the ground",
                  arm_above=1e-4)
    ph2.events = [heel_strike, scuff, *flat.events, *w.common_events]
    return ph2, _Swing(heel_strike, scuff, toe2_low)


def _held_support(w: _Parts, ph2: Phase, swing: _Swing) -> tuple[Phase, Transition]:
    """The held phase (phase II with the swing foot's hold rows closed) and the impact
    that closes them, from phase II at the hold's guard (adds that guard and the free
    swing's failures to ``ph2``)."""
    c = w.contacts
    hold = c.hold
    ph2.events += [hold.guard, *hold.events]
    contact_held = ContactSet(hold.phase, ca.vertcat(c.flat1_rows, c.hold_rows),
                              c.flat1_labels + c.hold_labels)
    phh = make_phase(w.sysm, w.F_q, hold.phase, contact_held)
    nf = c.flat1_rows.shape[0]
    flat = w.foot1.flat_reading(phh.lam[:nf], single_support=True)
    held = hold.reading(phh.lam[nf:])
    phh.outputs = {**flat.outputs, "clearance_toe2": swing.clearance, **held.outputs}
    phh.events = [swing.heel_strike, swing.scuff, *flat.events, *held.events,
                  *w.common_events]
    close = make_transition(w.sysm, hold.transition, "II", hold.phase, contact_held,
                            guard=hold.guard.name)
    close.checks = _hold_impulse_checks(hold, close.impulse, nf)
    return phh, close


def _stages(w: _Parts, foot: Foot, swing: _Swing, previous: str
            ) -> tuple[list[Phase], list[Transition]]:
    """The foot's single-support stages after phase II (e.g. heel off onto the toe), the
    first entered from phase ``previous``: each ends at the swing heel's strike (an impact
    into phase III) or in the next stage."""
    c = w.contacts
    hold = c.hold
    phases, transitions = [], []
    for st in foot.stages(w.foot1, w.foot2, w.ground):
        piv = st.pivot
        kp = piv.rows.shape[0]
        ph = make_phase(w.sysm, w.F_q, st.name,
                        ContactSet(st.name, ca.vertcat(piv.rows, c.hold_rows),
                                   piv.labels + c.hold_labels))
        N = ca.dot(ph.lam[0:2], w.ground.n)
        piv_read = piv.read(ph.lam[:kp])
        held = hold.reading(ph.lam[kp:]) if hold else piv.read(ca.SX(0, 1))
        ph.outputs = {f"N_{piv.tag}": N, f"F_{piv.tag}_x": ph.lam[0],
                      f"F_{piv.tag}_y": ph.lam[1], **piv.extras,
                      "clearance_toe2": swing.clearance, **piv_read.outputs, **held.outputs}
        ph.events = [
            swing.heel_strike, swing.scuff,
            Event(f"{piv.tag}_lift", N, -1, FAILURE, "stance toe normal force reaches zero"),
            *st.events, *piv.events, *piv_read.events, *held.events, *w.common_events,
        ]
        phases.append(ph)
        # entering the stage is smooth (its contact already carries the load); the heel
        # strike from it is the impact of phase II's, its stance heel already up
        transitions.append(make_transition(w.sysm, st.entry, previous, st.name, None,
                                           guard=st.entry_guard))
        transitions.append(_heel_strike(w, st.heel_strike, st.name, stance_heel_down=False))
        previous = st.name
    return phases, transitions


def _phase_III(w: _Parts) -> Phase:
    """Phase III: double support on the trailing toe and the leading heel pivots, until the
    leading foot rotates flat (the guard: foot strike); either normal force (N) reaching
    zero is a failure."""
    c = w.contacts
    toe1, heel2, n = c.toe1, c.heel2, w.ground.n
    ph3 = make_phase(w.sysm, w.F_q, "III", c.contact_III)
    lam = ph3.lam
    k1 = toe1.rows.shape[0]
    N_toe1 = ca.dot(lam[0:2], n)
    N_heel2 = ca.dot(lam[k1:k1 + 2], n)
    kh = k1 + heel2.rows.shape[0]
    toe1_read = toe1.read(lam[:k1])
    held = c.hold.reading(lam[kh:]) if c.hold else toe1.read(ca.SX(0, 1))
    ph3.outputs = {f"N_{toe1.tag}": N_toe1, f"N_{heel2.tag}": N_heel2,
                   f"F_{toe1.tag}_x": lam[0], f"F_{toe1.tag}_y": lam[1],
                   f"F_{heel2.tag}_x": lam[k1], f"F_{heel2.tag}_y": lam[k1 + 1],
                   **toe1.extras, **heel2.extras, **toe1_read.outputs, **held.outputs}
    ph3.events = [
        Event("foot_strike", w.foot2.flat_guard(), -1, GUARD,
              "leading foot rotates flat onto the ground"),
        Event(f"{toe1.tag}_lift", N_toe1, -1, FAILURE, "trailing toe normal force reaches zero"),
        Event(f"{heel2.tag}_lift", N_heel2, -1, FAILURE,
              "leading heel normal force reaches zero"),
        *toe1.events, *heel2.events, *toe1_read.events, *held.events, *w.common_events,
    ]
    return ph3


def _heel_strike(w: _Parts, name: str, source: str, stance_heel_down: bool) -> Transition:
    """The heel-strike impact ``name`` from single-support phase ``source`` into phase III:
    its checks are the trailing toe's and leading heel's normal impulses (N s) and, when
    the stance heel is still down (``stance_heel_down``), its rise speed after the impact
    (m/s; a heel pushed into the ground breaks the gait pattern)."""
    c, n = w.contacts, w.ground.n
    k1 = c.toe1.rows.shape[0]
    heel = make_transition(w.sysm, name, source, "III", c.contact_III, guard="heel_strike")
    heel.checks = {f"impulse_{c.toe1.tag}": ca.dot(heel.impulse[0:2], n),
                   f"impulse_{c.heel2.tag}": ca.dot(heel.impulse[k1:k1 + 2], n)}
    if stance_heel_down:
        heel.checks["heel1_rise_speed"] = ca.dot(
            ca.jtimes(w.foot1.end_point("heel"), w.sysm.q, heel.qd_plus), n)
    return heel


def _foot_strike(w: _Parts, q, qd, ne: int) -> Transition:
    """The foot-strike impact from phase III (the leading foot landing flat), then the leg
    swap into phase I of the next step (the Poincare section; ``ne``: the foot's extra
    coordinates per leg); its checks are the trailing toe's normal impulse (N s) and the
    foot's flat-impact checks."""
    c, n = w.contacts, w.ground.n
    foot_strike = make_transition(w.sysm, "foot_strike", "III", "I", c.contact_foot_strike,
                                  ends_step=True, guard="foot_strike")
    imp = foot_strike.impulse
    k = c.toe1.rows.shape[0]
    checks, margins = w.foot2.flat_impulse_checks(imp[k:])
    foot_strike.checks = {f"impulse_{c.toe1.tag}": ca.dot(imp[0:2], n), **checks}
    foot_strike.margins = {f"impulse_{c.toe1.tag}": IMPULSE, **margins}
    order = swap(ne)
    q_new = ca.vertcat(*[q[i] for i in order[:6]], 0, 0, *[q[i] for i in order[8:]])
    qd_new = ca.vertcat(*[qd[i] for i in order[:6]], 0, 0, *[qd[i] for i in order[8:]])
    foot_strike.relabel = (q_new, qd_new)
    foot_strike.mode_after = after_foot_strike
    return foot_strike


def _hold_impulse_checks(hold: Hold, impulse, offset: int) -> dict[str, ca.SX]:
    """The impulses (N m s) of the swing foot's held rows, at ``offset`` in ``impulse``: an
    impact closing them must push the joint onto its stop."""
    return {f"impulse_{hold.labels[j]}": impulse[offset + j] for j in range(len(hold.labels))}


#: the reading of no rows
_NOTHING = FlatReading({}, [])


def _releasing(reading):
    """A trailing contact's reading with its validity margins renamed ``release_*``: the
    contact is releasing (its normal force falls to zero at toe off, the guard), so they are
    reported, not required (its failures still end the step)."""
    outs = {(f"release_{k}" if output_margin(k) else k): v for k, v in reading.outputs.items()}
    return dataclasses.replace(reading, outputs=outs)


def _unfollowed_guards_fail(phases, transitions):
    """The phases with every guard that no transition follows made a failure (a contact
    change the walker has no phase for, e.g. the stance heel lifting before a swing foot's
    hold has closed): the walker's gait pattern is broken there."""
    followed = {(tr.source, tr.guard) for tr in transitions}
    only = {tr.source for tr in transitions if tr.guard is None}
    for ph in phases:
        if ph.name in only:
            continue
        ph.events = [dataclasses.replace(e, name=f"{e.name}_in_{ph.name}", kind=FAILURE)
                     if e.kind == GUARD and (ph.name, e.name) not in followed else e
                     for e in ph.events]
    return phases


def register_six_link(name: str, description: str, foot: Foot = FLAT, ext=None,
                      nonnegative_compliance: tuple[str, ...] = (), **faces):
    """Register the walker family ``name``: this walker with ``foot`` on both legs and the
    extension ``ext`` (see :func:`build`); returns its ``build(problem)``.

    ``nonnegative_compliance``: the extension's compliance keys that must be >= 0 (the
    walker's and the foot's are added); ``faces``: overrides of the family's faces
    (:class:`~pdw_casadi.model.walkers.registry.Family`), which default to the foot's
    phases, contacts and instant labels and to the paper walker's legs and joints.
    """
    comp_keys = compliance_keys(ext, foot)
    spec = dict(
        description=description,
        anthropometry_keys=ANTHROPOMETRY_KEYS + foot.anthropometry_keys,
        compliance_keys=comp_keys, state_keys=STATE_KEYS,
        positive_keys=POSITIVE_KEYS + foot.anthropometry_keys,
        nonnegative_compliance=(NONNEGATIVE_COMPLIANCE + tuple(nonnegative_compliance)
                                + foot.nonnegative_compliance),
        check_anthropometry=anthropometry_check(foot),
        phase_descriptions=foot.phase_descriptions, limit_cycle_legs=LIMIT_CYCLE_LEGS,
        leg_segments=LEG_SEGMENTS, curve_joints=CURVE_JOINTS,
        instant_labels=foot.instant_labels, comparison_problem=COMPARISON_PROBLEM,
        phase_contacts=foot.phase_contacts,
        leg_keys={"compliance": comp_keys,
                  "anthropometry": LEG_ANTHROPOMETRY_KEYS + foot.anthropometry_keys},
        build_per_leg=lambda family, g: build_per_leg(family, g, ext, foot))
    spec.update(faces)

    def build_family(problem) -> WalkerModel:
        return build(problem, ext, foot)

    build_family.__doc__ = (f"The symbolic model of the {name} walker (see "
                            f":func:`pdw_casadi.model.walkers.humanlike_6link.build`).")
    return register(name, **spec)(build_family)


register_six_link(
    "humanlike_6link",
    "The humanlike 6-link walker: flat feet, compliant ankles, engageable knees.",
    paper_reported_r2=PAPER_REPORTED_R2)
