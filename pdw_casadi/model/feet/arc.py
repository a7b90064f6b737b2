"""Rolling feet: the flat foot with a toe arc and a heel arc (a rollover shape).

As the roller feet of Whittington & Thelen (J. Biomech. Eng. 131, 2009): a toe arc of radius
``r_toe`` tangent to the sole line at the toe point and a heel arc of radius ``r_heel``
tangent at the heel point (centre = the point + r times the sole's normal into the foot).
Wherever the walker pivots on a toe or heel point (the trailing toe in phases I and III, the
leading heel in phase III, the heel-strike and foot-strike impacts, the section's trailing
toe on the ground at rest) this foot instead rolls without slip on that arc
(:class:`pdw_casadi.model.mechanics.rolling.RollingArc`: rows C . n - r = 0 and
C . t + r qf = const, as the world-frame rolling point). The flat sole still runs from heel
point to toe point and its rows are the flat foot's. Heel strike is the heel arc's lowest
point reaching the ground, foot strike the foot reaching flat (the heel arc's tangent point).

Outputs per rolling contact: the contact angle from the arc's tangent point
(``arc_toe2_deg``, ...), its arc length (``arc_toe2_m``) and the span margin
``arcmargin_*`` (rad, a validity margin: the contact stays within the arc's span). A toe
arc's contact angle falling back to zero (the heel coming down) is the failure
``toe1_arc_flat`` / ``toe2_arc_flat``. ``r_toe = r_heel = 0`` is the flat foot. Rolling
without slip does no work: the energy balance closes as for the point pivots.
"""

from __future__ import annotations

import math

import casadi as ca

from pdw_casadi.model.feet.base import Pivot
from pdw_casadi.model.feet.flat import PHASE_CONTACTS, FlatFoot, FlatFootLeg
from pdw_casadi.model.hybrid import FAILURE, Event
from pdw_casadi.model.mechanics.rolling import RollingArc

#: rad, the angular extent of each arc from its tangent point (a declared bound: a contact
#: beyond it has rolled off the rounded end)
ARC_SPAN = math.radians(60.0)
#: rad, a toe arc's contact angle must have exceeded this in a phase that starts with the
#: foot flat on its arc's tangent point before its coming back to 0 counts
ARC_FLAT_ARM = 1e-6
PHASE_DESCRIPTIONS = {"I": "leading foot flat + trailing toe arc rolling",
                      "II": "single stance on the flat foot, swing",
                      "III": "trailing toe arc + leading heel arc rolling"}


class ArcFootLeg(FlatFootLeg):
    """The rolling foot on one leg (module doc); radii ``r_toe``, ``r_heel`` (m) from the
    leg's compliance values, span ``span`` (rad)."""

    span = ARC_SPAN

    def arc(self, end) -> RollingArc:
        g = self.ground
        r = self.c["r_toe"] if end == "toe" else self.c["r_heel"]
        return RollingArc(self.end_point(end), self.angle, r, g.n, g.t, g.gamma, self.span,
                          toe=end == "toe")

    def pivot(self, end, arm_first=False):
        tag = f"{end}{self.leg}"
        arc = self.arc(end)
        extras = {f"arc_{tag}_deg": arc.contact_angle * 180 / math.pi,
                  f"arc_{tag}_m": arc.contact_length, f"arcmargin_{tag}": arc.span_margin}
        events = []
        if end == "toe":
            # the foot is flat again, its heel reaching the ground: a broken gait pattern
            # (the flat sole would sink)
            events.append(Event(f"{tag}_arc_flat", arc.contact_angle, -1, FAILURE,
                                "rolling foot comes back flat onto the ground (contact "
                                "leaves its toe arc)", arm_above=ARC_FLAT_ARM if arm_first
                                else 0.0))
        return Pivot(tag, arc.rows, (f"{tag}_x", f"{tag}_y"), extras, events)

    def lowest(self, end):
        return self.arc(end).lowest_height

    def resting_shank_cosine(self, knee_height, angle, shank_length):
        # the toe arc's centre is r_toe above the ground instead of the toe point on it:
        # C.n = toe.n + r_toe u(qf).n with u(a).n = sin(a + gamma)
        flat = super().resting_shank_cosine(knee_height, angle, shank_length)
        return flat + self.c["r_toe"] * (ca.sin(angle + self.ground.gamma) - 1) / shank_length


class ArcFoot(FlatFoot):
    """The rolling foot (module doc): compliance keys ``r_toe``, ``r_heel`` (m, >= 0)."""

    name = "arc"
    compliance_keys = ("r_toe", "r_heel")
    nonnegative_compliance = ("r_toe", "r_heel")
    phase_descriptions = PHASE_DESCRIPTIONS
    phase_contacts = PHASE_CONTACTS
    leg_class = ArcFootLeg


#: the rolling foot of the humanlike_6link_arc walker
ARC = ArcFoot()
