"""The ankle-extended 6-link walker with a forefoot rocker: heel off in single support.

The walker of :mod:`pdw_casadi.model.walkers.humanlike_6link_ankle` (same chain, passive ankle
elements, knee rule, impacts and section) in which the centre of pressure reaching the stance
toe in single support (phase II) is no longer a failure but a guard, ``heel_off``: the
flat-foot couple passes through zero there, so the heel lifts without an impact and the
stance foot pivots on its toe (Perry's third, "forefoot" rocker) in the new phase ``II_toe``
(contact: the stance toe only; swing leg free). ``II_toe`` ends at the swing heel's strike
(transition ``heel_strike_toe``: the impact of phase II's heel strike, onto phase III); its
failures are the stance toe's normal force reaching zero (``toe1_lift``), the stance heel
coming back down (``heel1_down``, once it has risen 1 micrometre), the swing toe scuffing,
and the common events (knee rules, clutch engagement, fall).

Heel off needs a plantarflexing stance-ankle torque of about N l_ft (the body weight times
the toe-to-ankle length, tens of N m): human-range quasi-stiffness ``k_ankle`` with its
``ankle_rest``, or the clutch spring. A gait whose heel never lifts is the three-phase gait
of the ankle walker, so its gaits are valid starts here. Everything stays passive: no
element or transition adds energy (heel off is smooth, the impacts are inelastic).
"""

from __future__ import annotations

from dataclasses import replace

from pdw_casadi.model.walkers.registry import register

from . import humanlike_6link as base
from . import humanlike_6link_ankle as ankle

PHASE_DESCRIPTIONS = {**base.PHASE_DESCRIPTIONS,
                      "II_toe": "single stance on the stance toe (heel off), swing"}
#: what touches the ground in each phase, (leg 1, leg 2): see pdw_casadi.gait.timing
PHASE_CONTACTS = {**base.PHASE_CONTACTS, "II_toe": ("toe", None)}
#: instants of the limit-cycle figure: the paper's a/b/c, heel strike from either stance
INSTANT_LABELS = {**base.INSTANT_LABELS, "heel_strike_toe": "c", "heel_off": "heel off"}
EXTENSION = replace(ankle.EXTENSION, forefoot_rocker=True)


@register(
    "humanlike_6link_heeloff",
    description="The humanlike 6-link walker with passive ankle extensions and a forefoot "
                "rocker (heel off in single support).",
    anthropometry_keys=ankle.ANTHROPOMETRY_KEYS, compliance_keys=ankle.COMPLIANCE_KEYS,
    state_keys=ankle.STATE_KEYS, positive_keys=ankle.POSITIVE_KEYS,
    nonnegative_compliance=ankle.NONNEGATIVE_COMPLIANCE,
    check_anthropometry=ankle.check_anthropometry, phase_descriptions=PHASE_DESCRIPTIONS,
    limit_cycle_legs=ankle.LIMIT_CYCLE_LEGS, leg_segments=ankle.LEG_SEGMENTS,
    curve_joints=ankle.CURVE_JOINTS, instant_labels=INSTANT_LABELS,
    comparison_problem=ankle.COMPARISON_PROBLEM, phase_contacts=PHASE_CONTACTS,
    leg_keys=ankle.LEG_KEYS, build_per_leg=lambda name, g: base.build_per_leg(name, g, EXTENSION))
def build(problem):
    """The symbolic model (see :func:`pdw_casadi.model.walkers.humanlike_6link.build`)."""
    return base.build(problem, EXTENSION)
