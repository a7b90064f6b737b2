"""The ankle-extended 6-link walker with rolling feet: toe and heel arcs (a rollover shape).

The walker of :mod:`pdw_casadi.model.walkers.humanlike_6link_ankle` (same chain, passive ankle
elements, knee rule, phases and section) whose feet have rounded ends, as the roller feet
of Whittington & Thelen (J. Biomech. Eng. 131, 2009): a toe arc of radius ``r_toe`` tangent
to the sole line at the toe point and a heel arc of radius ``r_heel`` tangent at the heel
point (centre = the point + r times the sole's normal into the foot). Wherever the 6-link
walker pivots on a toe or heel point (the trailing toe in phases I and III, the leading
heel in phase III, the heel-strike and foot-strike impacts, the section's trailing toe on
the ground at rest) the foot instead rolls without slip on that arc
(:class:`pdw_casadi.model.mechanics.rolling.RollingArc`: rows C . n - r = 0 and
C . t + r qf = const, as the world-frame rolling point). The flat sole still runs from heel
point to toe point, and its rows are unchanged. Heel strike is the heel arc's lowest point
reaching the ground, foot strike the leading foot reaching flat (the heel arc's tangent
point) as before.

Outputs per rolling contact: the contact angle from the arc's tangent point
(``arc_toe2_deg``, ...), its arc length (``arc_toe2_m``) and the span margin
``arcmargin_*`` (rad, a validity margin: the contact stays within :data:`ARC_SPAN`). A toe
arc's contact angle falling back to zero (the heel coming down) is the failure
``toe1_arc_flat`` / ``toe2_arc_flat``. ``r_toe = r_heel = 0`` is the ankle walker. Rolling
without slip does no work: the energy balance closes as for the point pivots.
"""

from __future__ import annotations

import math
from dataclasses import replace

from pdw_casadi.model.walkers.registry import register

from . import humanlike_6link as base
from . import humanlike_6link_ankle as ankle

#: rad, the angular extent of each arc from its tangent point (a declared bound: a contact
#: beyond it has rolled off the rounded end)
ARC_SPAN = math.radians(60.0)
EXTRA_COMPLIANCE = ("r_toe", "r_heel")
COMPLIANCE_KEYS = ankle.COMPLIANCE_KEYS + EXTRA_COMPLIANCE
NONNEGATIVE_COMPLIANCE = ankle.NONNEGATIVE_COMPLIANCE + EXTRA_COMPLIANCE
PHASE_DESCRIPTIONS = base.ARC_PHASE_DESCRIPTIONS
EXTENSION = replace(ankle.EXTENSION, compliance_keys=ankle.EXTRA_COMPLIANCE + EXTRA_COMPLIANCE,
                    rolling_feet=True, arc_span=ARC_SPAN)


@register(
    "humanlike_6link_arc",
    description="The humanlike 6-link walker with passive ankle extensions and rolling "
                "feet (toe and heel arcs, a rollover shape).",
    anthropometry_keys=ankle.ANTHROPOMETRY_KEYS, compliance_keys=COMPLIANCE_KEYS,
    state_keys=ankle.STATE_KEYS, positive_keys=ankle.POSITIVE_KEYS,
    nonnegative_compliance=NONNEGATIVE_COMPLIANCE,
    check_anthropometry=ankle.check_anthropometry, phase_descriptions=PHASE_DESCRIPTIONS,
    limit_cycle_legs=ankle.LIMIT_CYCLE_LEGS, leg_segments=ankle.LEG_SEGMENTS,
    curve_joints=ankle.CURVE_JOINTS, instant_labels=ankle.INSTANT_LABELS,
    comparison_problem=ankle.COMPARISON_PROBLEM, phase_contacts=ankle.PHASE_CONTACTS,
    leg_keys={**ankle.LEG_KEYS, "compliance": COMPLIANCE_KEYS},
    build_per_leg=lambda name, g: base.build_per_leg(name, g, EXTENSION))
def build(problem):
    """The symbolic model (see :func:`pdw_casadi.model.walkers.humanlike_6link.build`)."""
    return base.build(problem, EXTENSION)
