"""The humanlike 6-link walker of the paper (flat feet, compliant ankles, engageable knees).

Conventions follow docs/model.md of the repository: absolute angles from the vertical with link
direction d(q) = (sin q, -cos q); q = [q1, q2, q3, q4, qf1, qf2, x_t1, y_t1]; three phases
per step (I: leading foot flat + trailing toe pivot; II: single stance on the flat foot;
III: trailing toe + leading heel pivots), heel strike and foot strike impacts, then a leg
swap. Modes: ``eng1``/``eng2`` knee springs engaged, ``flex1``/``flex2`` disengaged knee
flexing (selects flexion or extension damping), ``armed2`` swing-knee spring armed.
"""

from __future__ import annotations

import math

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.hybrid import (
    FAILURE,
    GUARD,
    SWITCH,
    Event,
    WalkerModel,
    make_phase,
    make_transition,
)
from pdw_casadi.model.margins import IMPULSE, IMPULSE_COP
from pdw_casadi.model.mechanics.planar import Body, ContactSet, PlanarSystem, direction
from pdw_casadi.model.mechanics.rolling import RollingArc
from pdw_casadi.model.mechanics.torques import (
    JointTorque,
    engageable_spring_damper,
    spring_damper,
    total_torque,
)
from pdw_casadi.model.walkers.registry import register

ANTHROPOMETRY_KEYS = ("l_s", "l_t", "l_f", "l_sc", "l_tc", "l_fc", "l_ft", "l_fh",
                      "m_h", "m_t", "m_s", "m_f", "J_t", "J_s", "J_f")
COMPLIANCE_KEYS = ("k_ankle", "c_ankle", "c_knee_flex", "c_knee_ext", "k_knee",
                   "c_knee_stance", "theta_eq", "theta_dis")
STATE_KEYS = ("q1", "q2", "q3", "qf2", "dq1", "dq2", "dq3")
POSITIVE_KEYS = tuple(k for k in ANTHROPOMETRY_KEYS if k != "l_fc")
NONNEGATIVE_COMPLIANCE = ("k_ankle", "c_ankle", "c_knee_flex", "c_knee_ext", "k_knee",
                          "c_knee_stance")
MODE_KEYS = ("eng1", "eng2", "flex1", "flex2", "armed2")
#: the anthropometry of one physical leg (everything but the lumped hip mass)
LEG_ANTHROPOMETRY_KEYS = tuple(k for k in ANTHROPOMETRY_KEYS if k != "m_h")
#: keys a problem may set per physical leg ([compliance.left], [anthropometry.right], ...)
LEG_KEYS = {"compliance": COMPLIANCE_KEYS, "anthropometry": LEG_ANTHROPOMETRY_KEYS}
Q_NAMES = ("q1", "q2", "q3", "q4", "qf1", "qf2", "x_t1", "y_t1")
#: the swap of legs at the Poincare section: new coordinate i is old coordinate SWAP[i]
SWAP = (3, 2, 1, 0, 5, 4)
#: m, the height the stance heel must have risen in the toe-rocker phase before its coming
#: back down counts (it leaves the ground at rest, so its height starts at 0 with rate 0)
HEEL_DOWN_ARM = 1e-6

# -- faces of the walker for plots and reports (see pdw_casadi.model.faces) ---------------------
PHASE_DESCRIPTIONS = {"I": "leading foot flat + trailing toe pivot",
                      "II": "single stance on the flat foot, swing",
                      "III": "trailing toe + leading heel pivots"}
#: (shank, thigh) of one physical leg: leg 1 (stance) in step 0, leg 2 (swing) in step 1
LIMIT_CYCLE_LEGS = (("q1", "q2"), ("q4", "q3"))
LEG_SEGMENTS = ("shank", "thigh")
CURVE_JOINTS = ("knee", "hip")
#: the phases with rolling feet (toe and heel arcs): see humanlike_6link_arc
ARC_PHASE_DESCRIPTIONS = {"I": "leading foot flat + trailing toe arc rolling",
                          "II": PHASE_DESCRIPTIONS["II"],
                          "III": "trailing toe arc + leading heel arc rolling"}
#: what touches the ground in each phase, (leg 1, leg 2): see pdw_casadi.gait.timing
PHASE_CONTACTS = {"I": ("flat", "toe"), "II": ("flat", None), "III": ("toe", "heel")}
#: instants of the paper's Fig. 4: a (foot strike), b (toe-off), c (heel strike)
INSTANT_LABELS = {"foot_strike": "a", "toe_off": "b", "heel_strike": "c"}
#: the paper's comparison walker [48] (point feet, locked stance knee), this anthropometry
COMPARISON_PROBLEM = "comparison_kneed_6link"
#: R^2 of the paper's own fit (its four subjects), shown beside a fit for comparison
PAPER_REPORTED_R2 = {"r2_knee": 0.891, "r2_hip": 0.899}


def check_anthropometry(a, where) -> None:
    """Foot geometry must close: heel-to-ankle + ankle-to-toe = foot length."""
    if abs(a["l_ft"] + a["l_fh"] - a["l_f"]) > 1e-9:
        raise ProblemError(f"{where}: 'anthropometry.l_ft' + 'anthropometry.l_fh' must equal "
                           f"'anthropometry.l_f' ({a['l_ft']} + {a['l_fh']} != {a['l_f']})")
    for com, length in (("l_sc", "l_s"), ("l_tc", "l_t")):
        if not a[com] < a[length]:
            raise ProblemError(f"{where}: 'anthropometry.{com}' must be shorter than "
                               f"'anthropometry.{length}'")


def _height(point, n):
    return ca.dot(point, n)


#: rad, the trailing foot's contact angle on its toe arc must have exceeded this in phase
#: III (it starts flat, at 0) before its coming back to 0 counts
ARC_FLAT_ARM = 1e-6


def _arc_outputs(arc: RollingArc, tag: str) -> dict:
    """The contact on a rolling arc: its angle from the tangent point (deg), its arc
    length from there (m) and the span margin (rad, a validity margin: the contact stays on
    the arc)."""
    return {f"arc_{tag}_deg": arc.contact_angle * 180 / math.pi,
            f"arc_{tag}_m": arc.contact_length, f"arcmargin_{tag}": arc.span_margin}


def _arc_events(arc: RollingArc, tag: str, arm_first: bool) -> list[Event]:
    """A toe arc's contact angle falling back to 0: the foot is flat again, its heel
    reaching the ground (a broken gait pattern: the flat sole would sink). ``arm_first``:
    the event counts only once the contact angle has exceeded ARC_FLAT_ARM in the phase
    (a phase that starts with the foot flat on its toe arc's tangent point)."""
    return [Event(f"{tag}_arc_flat", arc.contact_angle, -1, FAILURE,
                  "rolling foot comes back flat onto the ground (contact leaves its toe arc)",
                  arm_above=ARC_FLAT_ARM if arm_first else 0.0)]


@register(
    "humanlike_6link",
    description="The humanlike 6-link walker: flat feet, compliant ankles, engageable knees.",
    anthropometry_keys=ANTHROPOMETRY_KEYS, compliance_keys=COMPLIANCE_KEYS,
    state_keys=STATE_KEYS, positive_keys=POSITIVE_KEYS,
    nonnegative_compliance=NONNEGATIVE_COMPLIANCE, check_anthropometry=check_anthropometry,
    phase_descriptions=PHASE_DESCRIPTIONS, limit_cycle_legs=LIMIT_CYCLE_LEGS,
    leg_segments=LEG_SEGMENTS, curve_joints=CURVE_JOINTS, instant_labels=INSTANT_LABELS,
    comparison_problem=COMPARISON_PROBLEM, paper_reported_r2=PAPER_REPORTED_R2,
    leg_keys=LEG_KEYS, build_per_leg=lambda name, g: build_per_leg(name, g),
    phase_contacts=PHASE_CONTACTS)
def build(problem, ext=None) -> WalkerModel:
    """The symbolic model of the walker with ``problem``'s anthropometry (numbers baked in).

    ``ext``: an extension of the passive elements (extra compliance keys, mode flags,
    torque elements, events and mode rules at the transitions), e.g.
    :data:`pdw_casadi.model.walkers.humanlike_6link_ankle.EXTENSION`; None: the paper's walker.
    An extension whose ``forefoot_rocker`` is true adds the toe-rocker phase ``II_toe``
    (:mod:`pdw_casadi.model.walkers.humanlike_6link_heeloff`); one whose ``rolling_feet`` is true
    gives the feet toe and heel arcs (compliance keys ``r_toe``, ``r_heel``, m) that roll
    without slip wherever the walker pivots on a toe or heel
    (:mod:`pdw_casadi.model.walkers.humanlike_6link_arc`).
    """
    a = dict(problem.anthropometry)
    comp_keys = COMPLIANCE_KEYS + (ext.compliance_keys if ext else ())
    p = ca.SX.sym("p", len(comp_keys) + 1)
    c = {k: p[i] for i, k in enumerate(comp_keys)}
    return _assemble(problem.name, problem.g, a, a, a["m_h"], c, c, p, p[-1],
                     (*comp_keys, "slope"), ext)


def per_leg_parameter_names(compliance_keys: tuple[str, ...] = COMPLIANCE_KEYS
                             ) -> tuple[str, ...]:
    """Parameter names of :func:`build_per_leg`: leg 1's (stance role) compliance and
    anthropometry, leg 2's (swing role), then ``m_h`` and ``slope`` (``compliance_keys``:
    the family's, an extension's included)."""
    return (*(f"{k}@1" for k in compliance_keys), *(f"{k}@2" for k in compliance_keys),
            *(f"{k}@1" for k in LEG_ANTHROPOMETRY_KEYS),
            *(f"{k}@2" for k in LEG_ANTHROPOMETRY_KEYS), "m_h", "slope")


def build_per_leg(name: str, g: float, ext=None) -> WalkerModel:
    """The walker with every body and compliance value a runtime parameter, per leg role.

    p = [compliance of leg 1 (the stance leg of the step), compliance of leg 2 (swing),
    leg-1 anthropometry, leg-2 anthropometry, m_h, slope] (:func:`per_leg_parameter_names`;
    rad, m, kg, kg m^2, N m/rad, N m s/rad). Each joint element and link uses the values of
    the leg it belongs to, so a caller that swaps the two leg blocks after every step makes
    the parameters follow the physical leg through the leg swap. One compiled walker serves
    every body: changing the anthropometry needs no recompilation. ``ext``: an extension
    as in :func:`build` (its compliance keys per leg too).
    """
    comp_keys = COMPLIANCE_KEYS + (ext.compliance_keys if ext else ())
    names = per_leg_parameter_names(comp_keys)
    p = ca.SX.sym("p", len(names))
    sym = {n: p[i] for i, n in enumerate(names)}
    c1 = {k: sym[f"{k}@1"] for k in comp_keys}
    c2 = {k: sym[f"{k}@2"] for k in comp_keys}
    a1 = {k: sym[f"{k}@1"] for k in LEG_ANTHROPOMETRY_KEYS}
    a2 = {k: sym[f"{k}@2"] for k in LEG_ANTHROPOMETRY_KEYS}
    return _assemble(name, g, a1, a2, sym["m_h"], c1, c2, p, sym["slope"], names, ext)


def _assemble(name, g, a1, a2, m_h, c1, c2, p, gamma, parameter_names,
              ext=None) -> WalkerModel:
    """The model from leg 1's (stance role) and leg 2's (swing role) anthropometry ``a1``,
    ``a2`` and compliance ``c1``, ``c2`` (numbers or SX entries of ``p``); ``ext``: see
    :func:`build` (its elements read the compliance of the leg they act on)."""
    q = ca.SX.sym("q", 8)
    qd = ca.SX.sym("qd", 8)
    q1, q2, q3, q4, qf1, qf2, xt, yt = (q[i] for i in range(8))
    mode_keys = MODE_KEYS + (ext.mode_keys if ext else ())
    m = ca.SX.sym("m", len(mode_keys))
    md = {k: m[i] for i, k in enumerate(mode_keys)}
    n = ca.vertcat(ca.sin(gamma), ca.cos(gamma))
    t_slope = ca.vertcat(ca.cos(gamma), -ca.sin(gamma))  # downhill along the ground

    toe1 = ca.vertcat(xt, yt)
    ankle1 = toe1 - a1["l_ft"] * direction(qf1)
    knee1 = ankle1 - a1["l_s"] * direction(q1)
    hip = knee1 - a1["l_t"] * direction(q2)
    knee2 = hip + a2["l_t"] * direction(q3)
    ankle2 = knee2 + a2["l_s"] * direction(q4)
    toe2 = ankle2 + a2["l_ft"] * direction(qf2)
    heel1 = ankle1 - a1["l_fh"] * direction(qf1)
    heel2 = ankle2 - a2["l_fh"] * direction(qf2)
    points = {"toe1": toe1, "heel1": heel1, "ankle1": ankle1, "knee1": knee1, "hip": hip,
              "knee2": knee2, "ankle2": ankle2, "heel2": heel2, "toe2": toe2}
    links = [("toe1", "heel1"), ("ankle1", "knee1"), ("knee1", "hip"), ("hip", "knee2"),
             ("knee2", "ankle2"), ("heel2", "toe2")]

    bodies = [  # order of eq. (1)
        Body("shank1", a1["m_s"], a1["J_s"], ankle1 - a1["l_sc"] * direction(q1), q1),
        Body("thigh1", a1["m_t"], a1["J_t"], knee1 - a1["l_tc"] * direction(q2), q2),
        Body("thigh2", a2["m_t"], a2["J_t"], knee2 - a2["l_tc"] * direction(q3), q3),
        Body("shank2", a2["m_s"], a2["J_s"], ankle2 - a2["l_sc"] * direction(q4), q4),
        Body("hip", m_h, 0.0, hip),
        Body("foot1", a1["m_f"], a1["J_f"], ankle1 + a1["l_fc"] * direction(qf1), qf1),
        Body("foot2", a2["m_f"], a2["J_f"], ankle2 + a2["l_fc"] * direction(qf2), qf2),
    ]
    sysm = PlanarSystem(q, qd, bodies, g)
    legc = {1: c1, 2: c2}

    def knee_damping(i):
        c = legc[i]
        free = md[f"flex{i}"] * c["c_knee_flex"] + (1 - md[f"flex{i}"]) * c["c_knee_ext"]
        return md[f"eng{i}"] * c["c_knee_stance"] + (1 - md[f"eng{i}"]) * free

    # each joint element uses the compliance of the leg it belongs to; an extension may
    # shift the ankle spring's rest angle (foot perpendicular to the shank)
    elements = [
        JointTorque("ankle1", qf1, q1, spring_damper(
            c1["k_ankle"], math.pi / 2 + c1.get("ankle_rest", 0.0), c1["c_ankle"])),
        JointTorque("ankle2", qf2, q4, spring_damper(
            c2["k_ankle"], math.pi / 2 + c2.get("ankle_rest", 0.0), c2["c_ankle"])),
        JointTorque("knee1", q2, q1, engageable_spring_damper(
            md["eng1"], c1["k_knee"], c1["theta_eq"], knee_damping(1))),
        JointTorque("knee2", q3, q4, engageable_spring_damper(
            md["eng2"], c2["k_knee"], c2["theta_eq"], knee_damping(2))),
    ]
    if ext:
        elements += ext.elements(c1, c2, md, {"ankle1": (qf1, q1), "ankle2": (qf2, q4)})
    F_torque, spring_energy, damping_power = total_torque(sysm, elements, qd)
    F_q = sysm.F_gravity + sysm.F_velocity + F_torque

    lf, lf2 = a1["l_f"], a2["l_f"]
    flat1 = lf * ca.cos(qf1)
    # the pivots of phases I and III and of the impacts: points, or (rolling feet) arcs at
    # the toe and heel that roll without slip (rows: the arc's rolling point, see RollingArc)
    arcs = bool(getattr(ext, "rolling_feet", False))
    if arcs and getattr(ext, "forefoot_rocker", False):
        raise ValueError("rolling feet with the forefoot rocker: phase II_toe pivots on the "
                         "toe point (not built)")
    if arcs:
        span = ext.arc_span
        toe1_arc = RollingArc(toe1, qf1, c1["r_toe"], n, t_slope, gamma, span, toe=True)
        toe2_arc = RollingArc(toe2, qf2, c2["r_toe"], n, t_slope, gamma, span, toe=True)
        heel2_arc = RollingArc(heel2, qf2, c2["r_heel"], n, t_slope, gamma, span, toe=False)
        toe1_pivot, toe2_pivot, heel2_pivot = toe1_arc.rows, toe2_arc.rows, heel2_arc.rows
        toe2_low, heel2_low = toe2_arc.lowest_height, heel2_arc.lowest_height
    else:
        toe1_pivot, toe2_pivot, heel2_pivot = ca.vertcat(xt, yt), toe2, heel2
        toe2_low, heel2_low = _height(toe2, n), _height(heel2, n)
    contact_I = ContactSet("I", ca.vertcat(toe2_pivot, xt, yt, flat1),
                           ("toe2_x", "toe2_y", "toe1_x", "toe1_y", "flat1"))
    contact_II = ContactSet("II", ca.vertcat(xt, yt, flat1), ("toe1_x", "toe1_y", "flat1"))
    contact_toe_rocker = ContactSet("II_toe", ca.vertcat(xt, yt), ("toe1_x", "toe1_y"))
    contact_III = ContactSet("III", ca.vertcat(toe1_pivot, heel2_pivot),
                             ("toe1_x", "toe1_y", "heel2_x", "heel2_y"))
    contact_foot_strike = ContactSet("foot_strike",
                                     ca.vertcat(toe1_pivot, toe2, lf2 * ca.cos(qf2)),
                                     ("toe1_x", "toe1_y", "toe2_x", "toe2_y", "flat2"))

    theta1, theta2 = q2 - q1, q3 - q4
    dtheta1, dtheta2 = qd[1] - qd[0], qd[2] - qd[3]
    hip_h = _height(hip, n)
    leg = a1["l_s"] + a1["l_t"]

    def flat_foot(lam_fx, lam_fy, lam_couple, qf, tag):
        """Normal force (N), couple (N m) and centre-of-pressure margins (N m) of a flat foot.

        The couple row l_f cos(qf) gives a torque -l_f sin(qf) lambda on the foot; the
        centre of pressure lies s = -tau/N behind the toe, so s N and (l_f - s) N are the
        smooth margins (positive while N > 0 and the CoP is inside the foot).
        """
        force = ca.vertcat(lam_fx, lam_fy)
        normal = ca.dot(force, n)
        tau = -lf * ca.sin(qf) * lam_couple
        cop = -tau / normal
        outs = {f"N_{tag}": normal, f"cop_{tag}_from_toe": cop,
                f"copmargin_{tag}": ca.fmin(cop, lf - cop),
                f"F_{tag}_x": lam_fx, f"F_{tag}_y": lam_fy}
        return normal, -tau, lf * normal + tau, outs

    def knee_events(i, theta, dtheta):
        evs = [Event(f"knee{i}_rate", dtheta, 0, SWITCH,
                     "disengaged knee changes between flexion and extension damping",
                     when=lambda md_, i=i: md_[f"eng{i}"] == 0, indicator=f"flex{i}")]
        if i == 1:
            evs.append(Event("knee1_disengage", theta - c1["theta_dis"], -1, SWITCH,
                             "stance knee spring disengages while extending through theta_dis",
                             when=lambda md_: md_["eng1"] == 1,
                             effect=lambda md_, s: {**md_, "eng1": 0.0}))
        else:
            evs.append(Event("knee2_engage", theta - c2["theta_eq"], 0, SWITCH,
                             "armed swing knee spring engages at its equilibrium angle",
                             when=lambda md_: md_["armed2"] == 1 and md_["eng2"] == 0,
                             effect=lambda md_, s: {**md_, "eng2": 1.0, "armed2": 0.0}))
        return evs

    fall = Event("fall", hip_h - 0.5 * leg, -1, FAILURE, "hip below half the leg length")
    common_events = [*knee_events(1, theta1, dtheta1), *knee_events(2, theta2, dtheta2), fall]
    if ext:
        common_events += ext.events(c1, {"ankle1": qf1 - q1, "ankle2": qf2 - q4})

    # Phase I: leading foot flat, trailing toe pivot
    ph1 = make_phase(sysm, F_q, "I", contact_I)
    lam = ph1.lam
    N_toe2 = ca.dot(lam[0:2], n)
    N1, m1a, m1b, outs1 = flat_foot(lam[2], lam[3], lam[4], qf1, "foot1")
    # the trailing toe's force is the releasing contact (it is the guard, zero at toe-off),
    # so it is reported but is not a validity margin
    ph1.outputs = {**outs1, "release_N_toe2": N_toe2, "F_toe2_x": lam[0], "F_toe2_y": lam[1]}
    ph1.events = [
        Event("toe_off", N_toe2, -1, GUARD, "normal reaction at the trailing toe reaches zero"),
        Event("foot1_lift", N1, -1, FAILURE, "stance foot normal force reaches zero"),
        Event("cop1_at_toe", m1a, -1, FAILURE, "centre of pressure reaches the stance toe"),
        Event("cop1_at_heel", m1b, -1, FAILURE, "centre of pressure reaches the stance heel"),
        *(_arc_events(toe2_arc, "toe2", arm_first=False) if arcs else ()),
        *common_events,
    ]
    # Phase II: single stance on the flat foot, swing leg free
    ph2 = make_phase(sysm, F_q, "II", contact_II)
    lam = ph2.lam
    N1, m1a, m1b, outs2 = flat_foot(lam[0], lam[1], lam[2], qf1, "foot1")
    ph2.outputs = {**outs2, "clearance_toe2": toe2_low}
    rocker = bool(getattr(ext, "forefoot_rocker", False))
    if rocker:
        # the centre of pressure reaching the toe is the heel-off guard, not a broken
        # assumption: only its distance from the heel is a validity margin
        del ph2.outputs["copmargin_foot1"]
        ph2.outputs["copmargin_heel_foot1"] = lf - outs2["cop_foot1_from_toe"]
    heel_strike_event = Event(
        "heel_strike", heel2_low, -1, GUARD, "swing heel reaches the ground",
        require=ca.dot(heel2 - heel1, t_slope), require_reason="heel_strike_behind")
    scuff_event = Event("toe_scuff", toe2_low, -1, FAILURE, "swing toe hits the ground",
                        arm_above=1e-4)
    # with the forefoot rocker the centre of pressure reaching the stance toe lifts the heel
    # (the flat-foot couple passes through zero: no impact) instead of breaking the gait
    cop_toe = (Event("heel_off", m1a, -1, GUARD, "centre of pressure reaches the stance toe: "
                     "the stance heel lifts") if rocker else
               Event("cop1_at_toe", m1a, -1, FAILURE,
                     "centre of pressure reaches the stance toe"))
    ph2.events = [
        heel_strike_event,
        scuff_event,
        Event("foot1_lift", N1, -1, FAILURE, "stance foot normal force reaches zero"),
        cop_toe,
        Event("cop1_at_heel", m1b, -1, FAILURE, "centre of pressure reaches the stance heel"),
        *common_events,
    ]
    phases = [ph1, ph2]
    if rocker:
        # Phase II_toe (forefoot rocker): single stance on the stance toe, heel off, swing
        ph2t = make_phase(sysm, F_q, "II_toe", contact_toe_rocker)
        lam = ph2t.lam
        N_toe1 = ca.dot(lam[0:2], n)
        heel1_h = _height(heel1, n)
        ph2t.outputs = {"N_toe1": N_toe1, "F_toe1_x": lam[0], "F_toe1_y": lam[1],
                        "clearance_toe2": toe2_low}
        ph2t.events = [
            heel_strike_event,
            scuff_event,
            Event("toe1_lift", N_toe1, -1, FAILURE, "stance toe normal force reaches zero"),
            # the heel leaves the ground at rest (height 0, rate 0): it counts as coming back
            # down only once it has risen HEEL_DOWN_ARM (m)
            Event("heel1_down", heel1_h, -1, FAILURE, "stance heel comes back down onto "
                  "the ground", arm_above=HEEL_DOWN_ARM),
            *common_events,
        ]
        phases.append(ph2t)
    # Phase III: trailing toe and leading heel pivots
    ph3 = make_phase(sysm, F_q, "III", contact_III)
    lam = ph3.lam
    N_toe1 = ca.dot(lam[0:2], n)
    N_heel2 = ca.dot(lam[2:4], n)
    ph3.outputs = {"N_toe1": N_toe1, "N_heel2": N_heel2, "F_toe1_x": lam[0],
                   "F_toe1_y": lam[1], "F_heel2_x": lam[2], "F_heel2_y": lam[3]}
    if arcs:
        ph1.outputs.update(_arc_outputs(toe2_arc, "toe2"))
        ph3.outputs.update({**_arc_outputs(toe1_arc, "toe1"), **_arc_outputs(heel2_arc, "heel2")})
    ph3.events = [
        Event("foot_strike", qf2 - (ca.pi / 2 - gamma), -1, GUARD,
              "leading foot rotates flat onto the ground"),
        Event("toe1_lift", N_toe1, -1, FAILURE, "trailing toe normal force reaches zero"),
        Event("heel2_lift", N_heel2, -1, FAILURE, "leading heel normal force reaches zero"),
        # the trailing foot leaves flat at heel strike (contact angle 0): armed first
        *(_arc_events(toe1_arc, "toe1", arm_first=True) if arcs else ()),
        *common_events,
    ]

    # transitions: toe-off (no impact, arms the swing knee), heel strike, foot strike + swap
    toe_off = make_transition(sysm, "toe_off", "I", "II", None,
                              mode_after=lambda md_: {**md_, "armed2": 1.0})
    heel = make_transition(sysm, "heel_strike", "II", "III", contact_III,
                           guard="heel_strike" if rocker else None)
    qdp = heel.qd_plus
    heel.checks = {
        "impulse_toe1": ca.dot(heel.impulse[0:2], n),
        "impulse_heel2": ca.dot(heel.impulse[2:4], n),
        "heel1_rise_speed": ca.dot(ca.jtimes(heel1, q, qdp), n),
    }
    transitions = [toe_off, heel]
    if rocker:
        # heel off: the couple of the flat foot is zero there, so no impact; heel strike
        # from the toe rocker: the same impact as from phase II (trailing toe and leading
        # heel on the ground after it), the trailing heel already up
        transitions.append(make_transition(sysm, "heel_off", "II", "II_toe", None,
                                           guard="heel_off"))
        heel_t = make_transition(sysm, "heel_strike_toe", "II_toe", "III", contact_III,
                                 guard="heel_strike")
        heel_t.checks = {"impulse_toe1": ca.dot(heel_t.impulse[0:2], n),
                         "impulse_heel2": ca.dot(heel_t.impulse[2:4], n)}
        transitions.append(heel_t)
    foot = make_transition(sysm, "foot_strike", "III", "I", contact_foot_strike, ends_step=True)
    imp = foot.impulse
    N_imp = ca.dot(imp[2:4], n)
    tau_imp = -lf2 * ca.sin(qf2) * imp[4]
    foot.checks = {
        "impulse_toe1": ca.dot(imp[0:2], n),
        "impulse_foot2": N_imp,
        "impulse_cop2_from_toe": -tau_imp / N_imp,
        "impulse_cop2_from_heel": lf2 + tau_imp / N_imp,
    }
    foot.margins = {"impulse_toe1": IMPULSE, "impulse_foot2": IMPULSE,
                    "impulse_cop2_from_toe": IMPULSE_COP, "impulse_cop2_from_heel": IMPULSE_COP}
    swap = list(SWAP)
    q_new = ca.vertcat(*[q[i] for i in swap], 0, 0)
    qd_new = ca.vertcat(*[qd[i] for i in swap], 0, 0)
    foot.relabel = (q_new, qd_new)

    def after_foot_strike(md_):
        if md_["eng2"] != 1:
            return "swing_knee_not_engaged"
        return {"eng1": 1.0, "eng2": 0.0, "flex1": md_["flex2"], "flex2": md_["flex1"],
                "armed2": 0.0}

    foot.mode_after = after_foot_strike
    transitions.append(foot)
    if ext:
        for tr in transitions:
            tr.mode_after = ext.mode_rule(tr.name, tr.mode_after)

    # section state <-> full state
    xs = ca.SX.sym("xs", len(STATE_KEYS))
    s_q1, s_q2, s_q3, s_qf2, s_d1, s_d2, s_d3 = (xs[i] for i in range(7))
    s_qf1 = ca.pi / 2 - gamma
    knee2_s = ca.substitute(knee2, ca.vertcat(q1, q2, q3, qf1, xt, yt),
                            ca.vertcat(s_q1, s_q2, s_q3, s_qf1, 0, 0))
    # toe2 height = 0: l_s cos(q4 + gamma) = knee2.n + l_ft d(qf2).n, d(a).n = -cos(a + gamma)
    rhs_c = (_height(knee2_s, n) - a2["l_ft"] * ca.cos(s_qf2 + gamma)) / a2["l_s"]
    if arcs:
        # rolling feet: the toe arc's centre is r_toe above the ground instead,
        # C.n = toe2.n + r_toe u(qf2).n with u(a).n = sin(a + gamma)
        rhs_c = rhs_c + c2["r_toe"] * (ca.sin(s_qf2 + gamma) - 1) / a2["l_s"]
    root = ca.acos(ca.fmin(ca.fmax(rhs_c, -1), 1))
    r_plus, r_minus = -gamma + root, -gamma - root
    s_q4 = ca.if_else(ca.fabs(r_plus - s_q3) < ca.fabs(r_minus - s_q3), r_plus, r_minus)
    q_s = ca.vertcat(s_q1, s_q2, s_q3, s_q4, s_qf1, s_qf2, 0, 0)
    # trailing toe at rest (rolling feet: its arc rolls, not slips): solve for (dq4, dqf2)
    v_toe2 = ca.jacobian(toe2_pivot, q)
    Jt = ca.substitute(v_toe2, q, q_s)
    A = ca.horzcat(Jt[:, 3], Jt[:, 5])
    b = -(Jt[:, 0] * s_d1 + Jt[:, 1] * s_d2 + Jt[:, 2] * s_d3)
    sol = ca.solve(A, b)
    qd_s = ca.vertcat(s_d1, s_d2, s_d3, sol[0], 0, sol[1], 0, 0)
    section_to_full = ca.Function("section_to_full", [xs, p], [ca.vertcat(q_s, qd_s, 0)],
                                  ["xs", "p"], ["x"])
    xf = ca.SX.sym("x", 17)
    full_to_section = ca.Function(
        "full_to_section", [xf], [ca.vertcat(xf[0], xf[1], xf[2], xf[5], xf[8], xf[9], xf[10])],
        ["x"], ["xs"])

    common = {
        "knee1_deg": theta1 * 180 / math.pi, "knee2_deg": theta2 * 180 / math.pi,
        "hip1_deg": (q2 + gamma) * 180 / math.pi, "hip2_deg": (q3 + gamma) * 180 / math.pi,
        "thigh1_deg": q2 * 180 / math.pi, "thigh2_deg": q3 * 180 / math.pi,
        "ankle1_deg": (qf1 - q1) * 180 / math.pi, "ankle2_deg": (qf2 - q4) * 180 / math.pi,
        "kinetic_J": sysm.kinetic, "potential_J": sysm.potential, "spring_J": spring_energy,
        "hip_height_m": hip_h, "toe2_height_m": _height(toe2, n),
        "heel2_height_m": _height(heel2, n), "heel1_height_m": _height(heel1, n),
    }
    return WalkerModel(
        name=name, system=sysm, p=p, m=m, mode_keys=mode_keys,
        initial_mode={"eng1": 1.0, "eng2": 0.0, "flex1": 0.0, "flex2": 0.0, "armed2": 0.0,
                      **(ext.initial_mode if ext else {})},
        F_q=F_q, spring_energy=spring_energy, damping_power=damping_power,
        phases=[*phases, ph3], transitions=transitions,
        section_to_full=section_to_full, full_to_section=full_to_section,
        state_names=STATE_KEYS, parameter_names=tuple(parameter_names),
        step_length=ca.dot(toe2 - toe1, t_slope), common_outputs=common, points=points,
        links=links, ground_normal=n, q_names=Q_NAMES, heel_strike_phase="III",
    )

