"""The 6-link walker's knees: engageable springs, mode-dependent damping and the knee rule.

Mode flags (docs/model.md): ``eng1``/``eng2`` knee spring engaged, ``flex1``/``flex2`` a
disengaged knee flexing (selects flexion or extension damping, an indicator of the knee
rate's sign), ``armed2`` the swing knee's spring armed (set at toe-off). The stance knee's
spring disengages while extending through ``theta_dis``; the armed swing knee's engages at
its equilibrium ``theta_eq``; at foot strike the swing knee must be engaged, and the legs'
flags swap.
"""

from __future__ import annotations

from pdw_casadi.model.hybrid import SWITCH, Event
from pdw_casadi.model.mechanics.torques import JointTorque, engageable_spring_damper

COMPLIANCE_KEYS = ("c_knee_flex", "c_knee_ext", "k_knee", "c_knee_stance", "theta_eq",
                   "theta_dis")
MODE_KEYS = ("eng1", "eng2", "flex1", "flex2", "armed2")
#: at the section (just after foot strike): stance knee locked by its spring, swing free
INITIAL_MODE = {"eng1": 1.0, "eng2": 0.0, "flex1": 0.0, "flex2": 0.0, "armed2": 0.0}


def knee_damping(md, c, i):
    """Damping (N m s/rad) of knee ``i`` in mode ``md`` with its leg's compliance ``c``."""
    free = md[f"flex{i}"] * c["c_knee_flex"] + (1 - md[f"flex{i}"]) * c["c_knee_ext"]
    return md[f"eng{i}"] * c["c_knee_stance"] + (1 - md[f"eng{i}"]) * free


def knee_elements(md, q1, q2, q3, q4, c1, c2) -> list[JointTorque]:
    """The two knees' engageable springs (``k_knee`` N m/rad at ``theta_eq``) and dampers,
    each with the compliance of its leg."""
    return [
        JointTorque("knee1", q2, q1, engageable_spring_damper(
            md["eng1"], c1["k_knee"], c1["theta_eq"], knee_damping(md, c1, 1))),
        JointTorque("knee2", q3, q4, engageable_spring_damper(
            md["eng2"], c2["k_knee"], c2["theta_eq"], knee_damping(md, c2, 2))),
    ]


def knee_events(i, theta, dtheta, c) -> list[Event]:
    """The events of knee ``i`` (angle ``theta`` = thigh - shank, rad, and its rate): the
    flexion/extension indicator, and the stance knee's disengagement (i = 1) or the armed
    swing knee's engagement (i = 2)."""
    evs = [Event(f"knee{i}_rate", dtheta, 0, SWITCH,
                 "disengaged knee changes between flexion and extension damping",
                 when=lambda md_, i=i: md_[f"eng{i}"] == 0, indicator=f"flex{i}")]
    if i == 1:
        evs.append(Event("knee1_disengage", theta - c["theta_dis"], -1, SWITCH,
                         "stance knee spring disengages while extending through theta_dis",
                         when=lambda md_: md_["eng1"] == 1,
                         effect=lambda md_, s: {**md_, "eng1": 0.0}))
    else:
        evs.append(Event("knee2_engage", theta - c["theta_eq"], 0, SWITCH,
                         "armed swing knee spring engages at its equilibrium angle",
                         when=lambda md_: md_["armed2"] == 1 and md_["eng2"] == 0,
                         effect=lambda md_, s: {**md_, "eng2": 1.0, "armed2": 0.0}))
    return evs


def arm_swing_knee(md_):
    """At toe-off: the swing knee's spring is armed."""
    return {**md_, "armed2": 1.0}


def after_foot_strike(md_):
    """At foot strike (legs swap): the swing knee must be engaged (else the failure
    ``swing_knee_not_engaged``); the new stance knee starts engaged, the new swing free."""
    if md_["eng2"] != 1:
        return "swing_knee_not_engaged"
    return {"eng1": 1.0, "eng2": 0.0, "flex1": md_["flex2"], "flex2": md_["flex1"],
            "armed2": 0.0}
