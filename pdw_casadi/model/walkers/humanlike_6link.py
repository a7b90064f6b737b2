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

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.feet.base import FlatReading, Foot, Ground
from pdw_casadi.model.feet.flat import FLAT
from pdw_casadi.model.hybrid import (
    FAILURE,
    GUARD,
    Event,
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


def _assemble(name, g, a1, a2, m_h, c1, c2, p, gamma, parameter_names, ext=None,
              foot: Foot = FLAT) -> WalkerModel:
    """The model from leg 1's (stance role) and leg 2's (swing role) anthropometry ``a1``,
    ``a2`` and compliance ``c1``, ``c2`` (numbers or SX entries of ``p``); ``ext``,
    ``foot``: see :func:`build` (each part reads the values of the leg it belongs to)."""
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

    # each joint element uses the compliance of the leg it belongs to; an extension may
    # shift the ankle spring's rest angle (foot perpendicular to the shank)
    elements = [*ankle_elements(qf1, q1, qf2, q4, c1, c2),
                *knee_elements(md, q1, q2, q3, q4, c1, c2)]
    if ext:
        elements += ext.elements(c1, c2, md, {"ankle1": (qf1, q1), "ankle2": (qf2, q4)})
    elements += [*foot1.elements(), *foot2.elements()]
    F_torque, spring_energy, damping_power = total_torque(sysm, elements, qd)
    F_q = sysm.F_gravity + sysm.F_velocity + F_torque

    # the contacts of the step: the trailing foot's toe (phase I, section), the stance
    # foot's toe (phase III, impacts: it starts flat, so its own events arm first), the
    # leading foot's heel; the feet flat
    toe2 = foot2.pivot("toe")
    toe1 = foot1.pivot("toe", arm_first=True)
    heel2 = foot2.pivot("heel")
    k1 = toe1.rows.shape[0]
    flat1_rows, flat1_labels = foot1.flat_rows()
    flat2_rows, flat2_labels = foot2.flat_rows()
    contact_I = ContactSet("I", ca.vertcat(toe2.rows, flat1_rows), toe2.labels + flat1_labels)
    contact_II = ContactSet("II", flat1_rows, flat1_labels)
    # rows the swing foot closes in single support and holds until it lands (a stop of
    # one of its joints), in every later contact of the step
    hold = foot2.swing_hold()
    hold_rows, hold_labels = (hold.rows, hold.labels) if hold else (ca.SX(0, 1), ())
    contact_III = ContactSet("III", ca.vertcat(toe1.rows, heel2.rows, hold_rows),
                             toe1.labels + heel2.labels + hold_labels)
    contact_foot_strike = ContactSet("foot_strike", ca.vertcat(toe1.rows, flat2_rows),
                                     toe1.labels + flat2_labels)

    theta1, theta2 = q2 - q1, q3 - q4
    dtheta1, dtheta2 = qd[1] - qd[0], qd[2] - qd[3]
    hip_h = ground.height(chain.hip)
    leg = a1["l_s"] + a1["l_t"]
    fall = Event("fall", hip_h - 0.5 * leg, -1, FAILURE, "hip below half the leg length")
    common_events = [*knee_events(1, theta1, dtheta1, c1), *knee_events(2, theta2, dtheta2, c2),
                     fall]
    if ext:
        common_events += ext.events(c1, {"ankle1": qf1 - q1, "ankle2": qf2 - q4})

    # Phase I: leading foot flat, trailing toe pivot
    ph1 = make_phase(sysm, F_q, "I", contact_I)
    lam = ph1.lam
    k = toe2.rows.shape[0]
    N_toe2 = ca.dot(lam[0:2], n)
    flat = foot1.flat_reading(lam[k:], single_support=False)
    toe2_read = _releasing(toe2.read(lam[:k]))
    # the trailing toe's force is the releasing contact (it is the guard, zero at toe-off),
    # so it is reported but is not a validity margin
    ph1.outputs = {**flat.outputs, f"release_N_{toe2.tag}": N_toe2,
                   f"F_{toe2.tag}_x": lam[0], f"F_{toe2.tag}_y": lam[1], **toe2.extras,
                   **toe2_read.outputs}
    ph1.events = [
        Event("toe_off", N_toe2, -1, GUARD, "normal reaction at the trailing toe reaches zero"),
        *flat.events, *toe2.events, *toe2_read.events, *common_events,
    ]
    # the foot's double-support stages after I (the trailing foot's contact changing),
    # each left at toe off into II or entered by the next; a stage that closes the swing
    # foot's hold is entered through its impact and left into the held phase
    trailing_transitions = []
    trailing_phases = []
    previous = "I"
    for st in foot.trailing_stages(foot1, foot2, ground):
        piv = st.pivot
        kp, nf = piv.rows.shape[0], flat1_rows.shape[0]
        extra_rows, extra_labels = (hold_rows, hold_labels) if st.closes_hold else (
            ca.SX(0, 1), ())
        contact = ContactSet(st.name, ca.vertcat(piv.rows, flat1_rows, extra_rows),
                             piv.labels + flat1_labels + extra_labels)
        ph = make_phase(sysm, F_q, st.name, contact)
        N = ca.dot(ph.lam[0:2], n)
        flat = foot1.flat_reading(ph.lam[kp:kp + nf], single_support=False)
        piv_read = _releasing(piv.read(ph.lam[:kp]))
        held = (hold.reading(ph.lam[kp + nf:]) if st.closes_hold
                else _NOTHING)
        ph.outputs = {**flat.outputs, f"release_N_{piv.tag}": N, f"F_{piv.tag}_x": ph.lam[0],
                      f"F_{piv.tag}_y": ph.lam[1], **piv.extras, **piv_read.outputs,
                      **held.outputs}
        ph.events = [
            Event("toe_off", N, -1, GUARD, "normal reaction at the trailing toe reaches zero"),
            *flat.events, *st.events, *piv.events, *piv_read.events, *held.events,
            *common_events,
        ]
        trailing_phases.append(ph)
        entry = make_transition(sysm, st.entry, previous, st.name,
                                contact if st.closes_hold else None, guard=st.entry_guard)
        if st.closes_hold:
            entry.checks = {f"impulse_{hold.labels[j]}": entry.impulse[kp + nf + j]
                            for j in range(len(hold.labels))}
        trailing_transitions += [
            entry, make_transition(sysm, st.toe_off, st.name,
                                   hold.phase if st.closes_hold else "II", None,
                                   guard="toe_off", mode_after=arm_swing_knee)]
        previous = st.name

    # Phase II: single stance on the flat foot, swing leg free
    ph2 = make_phase(sysm, F_q, "II", contact_II)
    flat = foot1.flat_reading(ph2.lam, single_support=True)
    toe2_low = foot2.lowest("toe")
    ph2.outputs = {**flat.outputs, "clearance_toe2": toe2_low}
    heel_strike_event = Event(
        "heel_strike", foot2.lowest("heel"), -1, GUARD, "swing heel reaches the ground",
        require=ca.dot(foot2.end_point("heel") - foot1.end_point("heel"), t_slope),
        require_reason="heel_strike_behind")
    scuff_event = Event("toe_scuff", toe2_low, -1, FAILURE, "swing toe hits the ground",
                        arm_above=1e-4)
    ph2.events = [heel_strike_event, scuff_event, *flat.events, *common_events]
    phases = [ph1, *trailing_phases, ph2]

    # the swing foot's hold closes in phase II (an impact) into the phase held, which is
    # phase II with the hold's rows; the single support after it is that phase's
    hold_transitions = []
    previous = "II"
    if hold:
        ph2.events += [hold.guard, *hold.events]
        contact_held = ContactSet(hold.phase, ca.vertcat(flat1_rows, hold_rows),
                                  flat1_labels + hold_labels)
        phh = make_phase(sysm, F_q, hold.phase, contact_held)
        nf = flat1_rows.shape[0]
        flat = foot1.flat_reading(phh.lam[:nf], single_support=True)
        held = hold.reading(phh.lam[nf:])
        phh.outputs = {**flat.outputs, "clearance_toe2": toe2_low, **held.outputs}
        phh.events = [heel_strike_event, scuff_event, *flat.events, *held.events,
                      *common_events]
        phases.append(phh)
        close = make_transition(sysm, hold.transition, "II", hold.phase, contact_held,
                                guard=hold.guard.name)
        close.checks = {f"impulse_{hold.labels[j]}": close.impulse[nf + j]
                        for j in range(len(hold.labels))}
        hold_transitions.append(close)
        previous = hold.phase
    first_single = previous

    # the foot's single-support stages after II (e.g. heel off onto the toe), each ending
    # at the swing heel's strike or in the next stage
    stages = foot.stages(foot1, foot2, ground)
    stage_transitions = []
    for st in stages:
        piv = st.pivot
        kp = piv.rows.shape[0]
        ph = make_phase(sysm, F_q, st.name, ContactSet(st.name, ca.vertcat(piv.rows, hold_rows),
                                                       piv.labels + hold_labels))
        N = ca.dot(ph.lam[0:2], n)
        piv_read = piv.read(ph.lam[:kp])
        held = hold.reading(ph.lam[kp:]) if hold else piv.read(ca.SX(0, 1))
        ph.outputs = {f"N_{piv.tag}": N, f"F_{piv.tag}_x": ph.lam[0],
                      f"F_{piv.tag}_y": ph.lam[1], **piv.extras, "clearance_toe2": toe2_low,
                      **piv_read.outputs, **held.outputs}
        ph.events = [
            heel_strike_event, scuff_event,
            Event(f"{piv.tag}_lift", N, -1, FAILURE, "stance toe normal force reaches zero"),
            *st.events, *piv.events, *piv_read.events, *held.events, *common_events,
        ]
        phases.append(ph)
        # entering the stage is smooth (its contact already carries the load); the heel
        # strike from it is the impact of phase II's, its stance heel already up
        stage_transitions.append(make_transition(sysm, st.entry, previous, st.name, None,
                                                 guard=st.entry_guard))
        heel_st = make_transition(sysm, st.heel_strike, st.name, "III", contact_III,
                                  guard="heel_strike")
        heel_st.checks = {f"impulse_{toe1.tag}": ca.dot(heel_st.impulse[0:2], n),
                          f"impulse_{heel2.tag}": ca.dot(heel_st.impulse[k1:k1 + 2], n)}
        stage_transitions.append(heel_st)
        previous = st.name

    # Phase III: trailing toe and leading heel pivots
    ph3 = make_phase(sysm, F_q, "III", contact_III)
    lam = ph3.lam
    N_toe1 = ca.dot(lam[0:2], n)
    N_heel2 = ca.dot(lam[k1:k1 + 2], n)
    kh = k1 + heel2.rows.shape[0]
    toe1_read = toe1.read(lam[:k1])
    held = hold.reading(lam[kh:]) if hold else toe1.read(ca.SX(0, 1))
    ph3.outputs = {f"N_{toe1.tag}": N_toe1, f"N_{heel2.tag}": N_heel2,
                   f"F_{toe1.tag}_x": lam[0], f"F_{toe1.tag}_y": lam[1],
                   f"F_{heel2.tag}_x": lam[k1], f"F_{heel2.tag}_y": lam[k1 + 1],
                   **toe1.extras, **heel2.extras, **toe1_read.outputs, **held.outputs}
    ph3.events = [
        Event("foot_strike", foot2.flat_guard(), -1, GUARD,
              "leading foot rotates flat onto the ground"),
        Event(f"{toe1.tag}_lift", N_toe1, -1, FAILURE, "trailing toe normal force reaches zero"),
        Event(f"{heel2.tag}_lift", N_heel2, -1, FAILURE,
              "leading heel normal force reaches zero"),
        *toe1.events, *heel2.events, *toe1_read.events, *held.events, *common_events,
    ]

    # transitions: toe-off (no impact, arms the swing knee), heel strike, foot strike + swap
    toe_off = make_transition(sysm, "toe_off", "I", "II", None, mode_after=arm_swing_knee,
                              guard="toe_off")
    heel = make_transition(sysm, "heel_strike", first_single, "III", contact_III,
                           guard="heel_strike")
    heel.checks = {
        f"impulse_{toe1.tag}": ca.dot(heel.impulse[0:2], n),
        f"impulse_{heel2.tag}": ca.dot(heel.impulse[k1:k1 + 2], n),
        "heel1_rise_speed": ca.dot(ca.jtimes(foot1.end_point("heel"), q, heel.qd_plus), n),
    }
    foot_strike = make_transition(sysm, "foot_strike", "III", "I", contact_foot_strike,
                                  ends_step=True, guard="foot_strike")
    imp = foot_strike.impulse
    k = toe1.rows.shape[0]
    checks, margins = foot2.flat_impulse_checks(imp[k:])
    foot_strike.checks = {f"impulse_{toe1.tag}": ca.dot(imp[0:2], n), **checks}
    foot_strike.margins = {f"impulse_{toe1.tag}": IMPULSE, **margins}
    order = swap(ne)
    q_new = ca.vertcat(*[q[i] for i in order[:6]], 0, 0, *[q[i] for i in order[8:]])
    qd_new = ca.vertcat(*[qd[i] for i in order[:6]], 0, 0, *[qd[i] for i in order[8:]])
    foot_strike.relabel = (q_new, qd_new)
    foot_strike.mode_after = after_foot_strike
    transitions = [toe_off, *trailing_transitions, *hold_transitions, heel,
                   *stage_transitions, foot_strike]
    if ext:
        for tr in transitions:
            tr.mode_after = ext.mode_rule(tr.name, tr.mode_after)
    phases = _unfollowed_guards_fail([*phases, ph3], transitions)

    section_to_full, full_to_section = section_maps(q, chain.knee2, foot2, a2["l_s"],
                                                    ground, p, leading=foot1)
    toe1_point, heel1_point = foot1.end_point("toe"), foot1.end_point("heel")
    toe2_point, heel2_point = foot2.end_point("toe"), foot2.end_point("heel")
    common = {
        "knee1_deg": theta1 * 180 / math.pi, "knee2_deg": theta2 * 180 / math.pi,
        "hip1_deg": (q2 + gamma) * 180 / math.pi, "hip2_deg": (q3 + gamma) * 180 / math.pi,
        "thigh1_deg": q2 * 180 / math.pi, "thigh2_deg": q3 * 180 / math.pi,
        "ankle1_deg": (qf1 - q1) * 180 / math.pi, "ankle2_deg": (qf2 - q4) * 180 / math.pi,
        "kinetic_J": sysm.kinetic, "potential_J": sysm.potential, "spring_J": spring_energy,
        "hip_height_m": hip_h, "toe2_height_m": ground.height(toe2_point),
        "heel2_height_m": ground.height(heel2_point),
        "heel1_height_m": ground.height(heel1_point),
    }
    return WalkerModel(
        name=name, system=sysm, p=p, m=m, mode_keys=mode_keys,
        initial_mode={**INITIAL_MODE, **(ext.initial_mode if ext else {})},
        F_q=F_q, spring_energy=spring_energy, damping_power=damping_power,
        phases=phases, transitions=transitions,
        section_to_full=section_to_full, full_to_section=full_to_section,
        state_names=STATE_KEYS, parameter_names=tuple(parameter_names),
        step_length=ca.dot(toe2_point - toe1_point, t_slope), common_outputs=common,
        points=points, links=links, ground_normal=n,
        q_names=Q_NAMES + tuple(f"{e}{i}" for i in (1, 2) for e in foot.extra_coordinates),
        heel_strike_phase="III",
    )


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
