"""Point-foot walkers: the compass gait and the kneed walker (one module, two families).

``compass_gait`` (Goswami, Thuilot & Espiau 1996): two rigid legs of length l = a + b, a
point mass ``m`` on each leg at ``a`` from the foot (``b`` from the hip) and a hip mass
``m_h``. ``kneed_walker`` (McGeer 1990; Hsu Chen 2007; Tedrake's kneed compass gait): each
leg is a shank (point mass ``m_s`` at ``a1`` from the foot, ``b1`` from the knee, inertia
``J_s`` about it) and a thigh (``m_t`` at ``a2`` from the knee, ``b2`` from the hip, ``J_t``),
plus a hip mass ``m_h``. Both feet are points; no compliance, so p = [slope].

Conventions (docs/model.md): absolute angles from the vertical, link direction
proximal -> distal d(q) = (sin q, -cos q) (hip -> knee -> foot), so q grows counter-clockwise
and the walker walks downhill along +x; the stance foot is at (x_foot, y_foot).

* compass gait: q = [q_st, q_sw, x_foot, y_foot]; one phase ``swing`` (stance foot pinned);
  guard ``heel_strike``; impact on the swing foot (old stance foot leaves), leg swap.
* kneed walker: q = [q1 stance shank, q2 stance thigh, q3 swing thigh, q4 swing shank,
  x_foot, y_foot]; knee angles thigh - shank (flexion positive). Phase ``unlocked`` (stance
  foot pinned, stance knee locked, swing knee free) ends at ``knee_strike`` (swing knee
  extends to 0; inelastic knee lock); phase ``locked`` (both knees locked) ends at
  ``heel_strike`` (impact on the swing foot with both knees locked; old stance foot leaves),
  leg swap, the new swing knee unlocks.

Heel strike is the swing foot reaching the ground *ahead of* the stance foot: with straight
legs of equal length L the swing-foot height is 2 L sin(S/2) sin((q_sw - q_st)/2), S = q_st +
q_sw + 2 slope, and the guard is the factor L sin(S/2) (the foot height divided by the chord
factor, which is positive once the swing leg is ahead). It vanishes exactly when the foot is
on the ground except where the legs pass each other, so the classic mid-stance scuff of the
rigid compass gait is ignored (as in the literature) and cannot end the step; ``arm_above``
(``ARM`` L) skips the zero at the section itself, and ``require`` checks that the swing foot
is ahead.

Section states (just after heel strike, new stance foot at the origin): compass gait
(q_st, q_sw, dq_st, dq_sw); kneed walker (q_st, q_sw, dq_st, dq_sw_thigh, dq_sw_shank) with
both knees straight. These carry the constraint "swing foot on the ground" (and, for the
kneed walker, equal swing thigh and shank rates after the knee-locked impact), so the
monodromy matrix has one (two) extra eigenvalue(s) ~ 0.
"""

from __future__ import annotations

import math

import casadi as ca

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.hybrid import FAILURE, GUARD, Event, WalkerModel, make_phase, make_transition
from pdw_casadi.model.mechanics.planar import Body, ContactSet, PlanarSystem, direction
from pdw_casadi.model.walkers.registry import register

DEG = 180 / math.pi
#: the heel-strike guard L sin(S/2) counts only once it has exceeded ARM * L in the phase
#: (S > ~0.02 rad): the section itself (S = 0) and section states slightly off the ground
#: (Newton iterates, finite differences) must not end the step at once
ARM = 0.01


def _height(point, n):
    return ca.dot(point, n)


def _ground(gamma):
    n = ca.vertcat(ca.sin(gamma), ca.cos(gamma))  # ground normal (up)
    t_slope = ca.vertcat(ca.cos(gamma), -ca.sin(gamma))  # downhill along the ground
    return n, t_slope


def _symbols(nq: int):
    """Coordinates q, rates qd, parameters p = [slope], no modes, the slope and the ground's
    normal and downhill tangent of a point-foot walker with ``nq`` coordinates."""
    q = ca.SX.sym("q", nq)
    qd = ca.SX.sym("qd", nq)
    p = ca.SX.sym("p", 1)
    gamma = p[0]
    m = ca.SX.sym("m", 0)
    n, t_slope = _ground(gamma)
    return q, qd, p, m, gamma, n, t_slope


def _strike_guard(q_st, q_sw, gamma, leg):
    """Heel-strike function L sin(S/2): zero with the swing foot on the ground ahead."""
    return leg * ca.sin((q_st + q_sw + 2 * gamma) / 2)


def _common(sysm, gamma, th1, th2, sh1, sh2, hip, foot2, n):
    return {
        "knee1_deg": (th1 - sh1) * DEG, "knee2_deg": (th2 - sh2) * DEG,
        "hip1_deg": (th1 + gamma) * DEG, "hip2_deg": (th2 + gamma) * DEG,
        "thigh1_deg": th1 * DEG, "thigh2_deg": th2 * DEG,
        "kinetic_J": sysm.kinetic, "potential_J": sysm.potential, "spring_J": ca.SX(0),
        "hip_height_m": _height(hip, n), "foot2_height_m": _height(foot2, n),
    }


# -- compass gait ------------------------------------------------------------------------

CG_ANTHROPOMETRY_KEYS = ("a", "b", "m", "m_h")
CG_STATE_KEYS = ("q_st", "q_sw", "dq_st", "dq_sw")
CG_Q_NAMES = ("q_st", "q_sw", "x_foot", "y_foot")


def check_compass_gait(a, where) -> None:
    """Nothing beyond positivity (a, b, m, m_h > 0)."""


@register(
    "compass_gait",
    description="Compass gait (Goswami et al.): rigid point-foot legs, hip mass.",
    anthropometry_keys=CG_ANTHROPOMETRY_KEYS, compliance_keys=(), state_keys=CG_STATE_KEYS,
    positive_keys=CG_ANTHROPOMETRY_KEYS, check_anthropometry=check_compass_gait,
    phase_descriptions={"swing": "stance foot pinned, swing leg free"},
    limit_cycle_legs=(("q_st",), ("q_sw",)), leg_segments=("leg",),
    curve_joints=("hip",),  # rigid legs: no knee
    phase_contacts={"swing": ("point", None)})
def build_compass_gait(problem) -> WalkerModel:
    """The compass-gait model with ``problem``'s anthropometry (numbers baked in)."""
    a = dict(problem.anthropometry)
    leg = a["a"] + a["b"]
    q, qd, p, m, gamma, n, t_slope = _symbols(4)
    q_st, q_sw, xf, yf = (q[i] for i in range(4))

    foot1 = ca.vertcat(xf, yf)
    hip = foot1 - leg * direction(q_st)
    foot2 = hip + leg * direction(q_sw)
    bodies = [
        Body("leg1", a["m"], 0.0, foot1 - a["a"] * direction(q_st)),
        Body("hip", a["m_h"], 0.0, hip),
        Body("leg2", a["m"], 0.0, hip + a["b"] * direction(q_sw)),
    ]
    sysm = PlanarSystem(q, qd, bodies, problem.g)
    F_q = sysm.F_gravity + sysm.F_velocity

    stance = ContactSet("stance", ca.vertcat(xf, yf), ("foot1_x", "foot1_y"))
    strike = ContactSet("heel_strike", foot2, ("foot2_x", "foot2_y"))

    ph = make_phase(sysm, F_q, "swing", stance)
    N1 = ca.dot(ph.lam[0:2], n)
    ph.outputs = {"N_foot1": N1, "F_foot1_x": ph.lam[0], "F_foot1_y": ph.lam[1]}
    ph.events = [
        Event("heel_strike", _strike_guard(q_st, q_sw, gamma, leg), -1, GUARD,
              "swing foot reaches the ground ahead of the stance foot (mid-stance scuff "
              "ignored)", require=ca.dot(foot2 - foot1, t_slope),
              require_reason="heel_strike_behind", arm_above=ARM * leg),
        Event("fall", _height(hip, n) - 0.5 * leg, -1, FAILURE, "hip below half the leg"),
    ]
    tr = make_transition(sysm, "heel_strike", "swing", "swing", strike, ends_step=True)
    tr.checks = {
        "impulse_foot2": ca.dot(tr.impulse[0:2], n),
        "foot1_rise_speed": ca.dot(ca.jtimes(foot1, q, tr.qd_plus), n),
    }
    tr.relabel = (ca.vertcat(q_sw, q_st, 0, 0), ca.vertcat(qd[1], qd[0], 0, 0))

    xs = ca.SX.sym("xs", 4)
    section_to_full = ca.Function(
        "section_to_full", [xs, p], [ca.vertcat(xs[0], xs[1], 0, 0, xs[2], xs[3], 0, 0, 0)],
        ["xs", "p"], ["x"])
    xf_ = ca.SX.sym("x", 9)
    full_to_section = ca.Function("full_to_section", [xf_],
                                  [ca.vertcat(xf_[0], xf_[1], xf_[4], xf_[5])], ["x"], ["xs"])
    return WalkerModel(
        name=problem.name, system=sysm, p=p, m=m, mode_keys=(), initial_mode={},
        F_q=F_q, spring_energy=ca.SX(0), damping_power=ca.SX(0),
        phases=[ph], transitions=[tr],
        section_to_full=section_to_full, full_to_section=full_to_section,
        state_names=CG_STATE_KEYS, parameter_names=("slope",),
        step_length=ca.dot(foot2 - foot1, t_slope),
        common_outputs=_common(sysm, gamma, q_st, q_sw, q_st, q_sw, hip, foot2, n),
        points={"foot1": foot1, "hip": hip, "foot2": foot2},
        links=[("foot1", "hip"), ("hip", "foot2")], ground_normal=n, q_names=CG_Q_NAMES,
    )


# -- kneed walker ------------------------------------------------------------------------

KW_ANTHROPOMETRY_KEYS = ("a1", "b1", "a2", "b2", "m_s", "m_t", "m_h", "J_s", "J_t")
KW_STATE_KEYS = ("q_st", "q_sw", "dq_st", "dq_sw_thigh", "dq_sw_shank")
KW_Q_NAMES = ("q1", "q2", "q3", "q4", "x_foot", "y_foot")
#: the swap of legs at heel strike: new coordinate i is old coordinate SWAP[i]
KW_SWAP = (3, 2, 1, 0)


def check_kneed_walker(a, where) -> None:
    """Inertias about the point masses must be >= 0 (the other values are positive)."""
    for k in ("J_s", "J_t"):
        if a[k] < 0:
            raise ProblemError(f"{where}: 'anthropometry.{k}' must be >= 0, got {a[k]}")


@register(
    "kneed_walker",
    description="Kneed walker (McGeer; Hsu Chen): point feet, knees that lock at full "
                "extension.",
    anthropometry_keys=KW_ANTHROPOMETRY_KEYS, compliance_keys=(), state_keys=KW_STATE_KEYS,
    positive_keys=tuple(k for k in KW_ANTHROPOMETRY_KEYS if k not in ("J_s", "J_t")),
    check_anthropometry=check_kneed_walker,
    phase_descriptions={"unlocked": "stance knee locked, swing knee free",
                        "locked": "both knees locked"},
    limit_cycle_legs=(("q1", "q2"), ("q4", "q3")), leg_segments=("shank", "thigh"),
    curve_joints=("knee", "hip"),
    phase_contacts={"unlocked": ("point", None), "locked": ("point", None)})
def build_kneed_walker(problem) -> WalkerModel:
    """The kneed-walker model with ``problem``'s anthropometry (numbers baked in)."""
    a = dict(problem.anthropometry)
    l_s, l_t = a["a1"] + a["b1"], a["a2"] + a["b2"]
    leg = l_s + l_t
    q, qd, p, m, gamma, n, t_slope = _symbols(6)
    q1, q2, q3, q4, xf, yf = (q[i] for i in range(6))

    foot1 = ca.vertcat(xf, yf)
    knee1 = foot1 - l_s * direction(q1)
    hip = knee1 - l_t * direction(q2)
    knee2 = hip + l_t * direction(q3)
    foot2 = knee2 + l_s * direction(q4)
    bodies = [
        Body("shank1", a["m_s"], a["J_s"], foot1 - a["a1"] * direction(q1), q1),
        Body("thigh1", a["m_t"], a["J_t"], knee1 - a["a2"] * direction(q2), q2),
        Body("thigh2", a["m_t"], a["J_t"], knee2 - a["a2"] * direction(q3), q3),
        Body("shank2", a["m_s"], a["J_s"], foot2 - a["a1"] * direction(q4), q4),
        Body("hip", a["m_h"], 0.0, hip),
    ]
    sysm = PlanarSystem(q, qd, bodies, problem.g)
    F_q = sysm.F_gravity + sysm.F_velocity

    knee1_lock, knee2_lock = q2 - q1, q3 - q4
    unlocked = ContactSet("unlocked", ca.vertcat(xf, yf, knee1_lock),
                          ("foot1_x", "foot1_y", "knee1"))
    locked = ContactSet("locked", ca.vertcat(xf, yf, knee1_lock, knee2_lock),
                        ("foot1_x", "foot1_y", "knee1", "knee2"))
    strike = ContactSet("heel_strike", ca.vertcat(foot2, knee1_lock, knee2_lock),
                        ("foot2_x", "foot2_y", "knee1", "knee2"))
    fall = Event("fall", _height(hip, n) - 0.5 * leg, -1, FAILURE, "hip below half the leg")

    def stance_outputs(ph):
        # lam along q2 - q1 (q3 - q4): +lam on the thigh, -lam on the shank; > 0: the knee
        # stop resists hyperextension (the lock holds)
        return {"N_foot1": ca.dot(ph.lam[0:2], n), "F_foot1_x": ph.lam[0],
                "F_foot1_y": ph.lam[1], "knee1_lock_Nm": ph.lam[2]}

    ph_u = make_phase(sysm, F_q, "unlocked", unlocked)
    ph_u.outputs = stance_outputs(ph_u)
    ph_u.events = [
        Event("knee_strike", knee2_lock, -1, GUARD, "swing knee extends to straight"),
        fall,
    ]
    ph_l = make_phase(sysm, F_q, "locked", locked)
    ph_l.outputs = {**stance_outputs(ph_l), "knee2_lock_Nm": ph_l.lam[3]}
    ph_l.events = [
        Event("heel_strike", _strike_guard(q1, q3, gamma, leg), -1, GUARD,
              "swing foot reaches the ground ahead of the stance foot",
              require=ca.dot(foot2 - foot1, t_slope), require_reason="heel_strike_behind",
              arm_above=ARM * leg),
        fall,
    ]

    knee = make_transition(sysm, "knee_strike", "unlocked", "locked", locked)
    knee.checks = {"impulse_knee2": knee.impulse[3]}  # > 0: the stop resists hyperextension
    heel = make_transition(sysm, "heel_strike", "locked", "unlocked", strike, ends_step=True)
    heel.checks = {
        "impulse_foot2": ca.dot(heel.impulse[0:2], n),
        "foot1_rise_speed": ca.dot(ca.jtimes(foot1, q, heel.qd_plus), n),
    }
    heel.relabel = (ca.vertcat(*[q[i] for i in KW_SWAP], 0, 0),
                    ca.vertcat(*[qd[i] for i in KW_SWAP], 0, 0))

    xs = ca.SX.sym("xs", 5)
    s_st, s_sw, d_st, d_th, d_sh = (xs[i] for i in range(5))
    section_to_full = ca.Function(
        "section_to_full", [xs, p],
        [ca.vertcat(s_st, s_st, s_sw, s_sw, 0, 0, d_st, d_st, d_th, d_sh, 0, 0, 0)],
        ["xs", "p"], ["x"])
    xf_ = ca.SX.sym("x", 13)
    full_to_section = ca.Function(
        "full_to_section", [xf_], [ca.vertcat(xf_[0], xf_[2], xf_[6], xf_[8], xf_[9])],
        ["x"], ["xs"])
    return WalkerModel(
        name=problem.name, system=sysm, p=p, m=m, mode_keys=(), initial_mode={},
        F_q=F_q, spring_energy=ca.SX(0), damping_power=ca.SX(0),
        phases=[ph_u, ph_l], transitions=[knee, heel],
        section_to_full=section_to_full, full_to_section=full_to_section,
        state_names=KW_STATE_KEYS, parameter_names=("slope",),
        step_length=ca.dot(foot2 - foot1, t_slope),
        common_outputs=_common(sysm, gamma, q2, q3, q1, q4, hip, foot2, n),
        points={"foot1": foot1, "knee1": knee1, "hip": hip, "knee2": knee2, "foot2": foot2},
        links=[("foot1", "knee1"), ("knee1", "hip"), ("hip", "knee2"), ("knee2", "foot2")],
        ground_normal=n, q_names=KW_Q_NAMES,
    )
