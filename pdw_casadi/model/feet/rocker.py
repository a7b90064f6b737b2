"""The forefoot rocker: the flat foot whose heel lifts in single support.

The flat foot (:mod:`pdw_casadi.model.feet.flat`) in which the centre of pressure reaching
the stance toe in single support (phase II) is no longer a failure but a guard, ``heel_off``:
the flat-foot couple passes through zero there, so the heel lifts without an impact and the
stance foot pivots on its toe point (Perry's third, "forefoot" rocker) in the new stage
``II_toe`` (contact: the stance toe only; swing leg free). ``II_toe`` ends at the swing
heel's strike (transition ``heel_strike_toe``: the impact of phase II's heel strike, onto
phase III); its failures are the stance toe's normal force reaching zero (``toe1_lift``),
the stance heel coming back down (``heel1_down``, once it has risen :data:`HEEL_DOWN_ARM`),
and the walker's common events. In phase II only the centre of pressure's distance from
the heel (``copmargin_heel_foot1``) is a validity margin. In double support (phase I) the
foot is the flat foot.
"""

from __future__ import annotations

from pdw_casadi.model.feet.base import FlatReading, Stage
from pdw_casadi.model.feet.flat import (
    INSTANT_LABELS,
    PHASE_CONTACTS,
    PHASE_DESCRIPTIONS,
    FlatFoot,
    FlatFootLeg,
)
from pdw_casadi.model.hybrid import FAILURE, GUARD, Event

#: m, the height the stance heel must have risen in the toe-rocker stage before its coming
#: back down counts (it leaves the ground at rest, so its height starts at 0 with rate 0)
HEEL_DOWN_ARM = 1e-6


class RockerFootLeg(FlatFootLeg):
    """The flat foot whose heel lifts when the centre of pressure reaches its toe in single
    support (module doc)."""

    def flat_reading(self, lam, single_support):
        reading = super().flat_reading(lam, single_support)
        if not single_support:
            return reading
        i, outs = self.leg, dict(reading.outputs)
        # the centre of pressure reaching the toe is the heel-off guard, not a broken
        # assumption: only its distance from the heel is a validity margin
        del outs[f"copmargin_foot{i}"]
        outs[f"copmargin_heel_foot{i}"] = self.a["l_f"] - outs[f"cop_foot{i}_from_toe"]
        lift, at_toe, at_heel = reading.events
        heel_off = Event("heel_off", at_toe.expr, -1, GUARD,
                         "centre of pressure reaches the stance toe: the stance heel lifts")
        return FlatReading(outs, [lift, heel_off, at_heel])


class RockerFoot(FlatFoot):
    """The forefoot rocker (module doc)."""

    name = "rocker"
    phase_descriptions = {**PHASE_DESCRIPTIONS,
                          "II_toe": "single stance on the stance toe (heel off), swing"}
    phase_contacts = {**PHASE_CONTACTS, "II_toe": ("toe", None)}
    #: instants of the limit-cycle figure: the paper's a/b/c, heel strike from either stance
    instant_labels = {**INSTANT_LABELS, "heel_strike_toe": "c", "heel_off": "heel off"}
    leg_class = RockerFootLeg

    def stages(self, stance, swing, ground):
        """``II_toe``: the stance foot on its toe point after heel off (module doc)."""
        i = stance.leg
        heel_down = Event(f"heel{i}_down", ground.height(stance.heel), -1, FAILURE,
                          "stance heel comes back down onto the ground",
                          arm_above=HEEL_DOWN_ARM)
        return [Stage("II_toe", stance.pivot("toe"), entry_guard="heel_off", entry="heel_off",
                      heel_strike="heel_strike_toe", events=[heel_down],
                      description=self.phase_descriptions["II_toe"])]


#: the forefoot rocker of the humanlike_6link_heeloff walker
ROCKER = RockerFoot()
