"""The 6-link walker with passive ankle extensions for humanlike gait-phase timing.

The paper's walker (:mod:`pdw_casadi.model.walkers.humanlike_6link`: same chain, phases, impacts,
knee rule, section state) with three passive ankle elements, each off at zero (a problem
file switches one on by its value and bounds):

- ``c_ankle_load`` (N m s/rad): a loading-response damper on the leading ankle from heel
  strike to foot flat (phase III), which resists the foot slapping down as the tibialis
  anterior does (mode flag ``load2``, set at heel strike, cleared at foot strike);
- ``ankle_rest`` (rad): the rest angle of the always-on ankle spring, measured from the
  foot perpendicular to the shank (positive: dorsiflexed); with a human-range ``k_ankle``
  this is the ankle's quasi-stiffness;
- ``k_clutch`` (N m/rad) with ``phi_clutch`` (rad, ankle angle foot-to-shank): a clutch
  spring as in unpowered ankle exoskeletons. It is armed at foot flat (foot strike) and
  engages when the stance ankle dorsiflexes through ``phi_clutch`` (event
  ``clutch1_engage``: the spring is at rest there, so engaging stores nothing); it stores
  energy as the shank rotates over the foot, pushes the trailing toe down in the next
  step's phase I and releases at toe-off (the energy still stored is lost and counted as a
  spring loss, like the knee spring's at disengagement). A stance leg whose clutch has not
  engaged by foot strike breaks the gait pattern (failure ``clutch_not_engaged``).

Everything stays passive: the simulator's energy balance (potential energy lost = damper
work + impact losses + spring losses) closes for every step.
"""

from __future__ import annotations

from dataclasses import dataclass

from pdw_casadi.model.hybrid import SWITCH, Event
from pdw_casadi.model.mechanics.torques import JointTorque, engageable_spring_damper

from . import humanlike_6link as base

ANTHROPOMETRY_KEYS = base.ANTHROPOMETRY_KEYS
EXTRA_COMPLIANCE = ("c_ankle_load", "ankle_rest", "k_clutch", "phi_clutch")
COMPLIANCE_KEYS = base.COMPLIANCE_KEYS + EXTRA_COMPLIANCE
#: the extension's compliance values that must be >= 0
EXTRA_NONNEGATIVE = ("c_ankle_load", "k_clutch")
NONNEGATIVE_COMPLIANCE = base.NONNEGATIVE_COMPLIANCE + EXTRA_NONNEGATIVE
EXTRA_MODES = ("load2", "clutch1", "clutch2", "armc1")


@dataclass(frozen=True)
class AnkleExtension:
    """The hooks :func:`pdw_casadi.model.walkers.humanlike_6link.build` calls (module doc)."""

    compliance_keys: tuple[str, ...] = EXTRA_COMPLIANCE
    mode_keys: tuple[str, ...] = EXTRA_MODES
    #: at the section (just after foot strike): the trailing ankle's clutch is engaged (it
    #: engaged in the previous stance), the leading one armed, no loading damper
    initial_mode = {"load2": 0.0, "clutch1": 0.0, "clutch2": 1.0, "armc1": 1.0}

    def elements(self, c1, c2, md, ankles) -> list[JointTorque]:
        """The loading damper on ankle 2 and the clutch springs on both ankles, each with
        the compliance of its leg (``c1``: leg 1, the stance role; ``c2``: leg 2)."""
        (qf1, q1), (qf2, q4) = ankles["ankle1"], ankles["ankle2"]
        return [
            JointTorque("clutch1", qf1, q1, engageable_spring_damper(
                md["clutch1"], c1["k_clutch"], c1["phi_clutch"], 0.0)),
            JointTorque("clutch2", qf2, q4, engageable_spring_damper(
                md["clutch2"], c2["k_clutch"], c2["phi_clutch"],
                md["load2"] * c2["c_ankle_load"])),
        ]

    def events(self, c, angles) -> list[Event]:
        return [Event("clutch1_engage", angles["ankle1"] - c["phi_clutch"], 1, SWITCH,
                      "armed stance-ankle clutch spring engages at its rest angle",
                      when=lambda md_: md_["armc1"] == 1 and md_["clutch1"] == 0,
                      effect=lambda md_, s: {**md_, "clutch1": 1.0, "armc1": 0.0})]

    def mode_rule(self, name, rule):
        """The base rule of transition ``name`` followed by the extension's flags."""

        def after(md_):
            new = rule(md_) if rule else dict(md_)
            if isinstance(new, str):
                return new
            if name.startswith("toe_off"):  # the trailing toe leaves: its clutch releases
                return {**new, "clutch2": 0.0}
            if name.startswith("heel_strike"):  # loading response begins (from any stance)
                return {**new, "load2": 1.0}
            if name != "foot_strike":  # heel off: the stance ankle's elements carry on
                return new
            # foot strike, legs swap: the old stance leg (its clutch engaged) trails
            if md_["clutch1"] != 1:
                return "clutch_not_engaged"
            return {**new, "load2": 0.0, "clutch2": 1.0, "clutch1": 0.0, "armc1": 1.0}

        return after


EXTENSION = AnkleExtension()


build = base.register_six_link(
    "humanlike_6link_ankle",
    "The humanlike 6-link walker with passive ankle extensions (loading damper, spring "
    "rest angle, clutch spring).",
    ext=EXTENSION, nonnegative_compliance=EXTRA_NONNEGATIVE)
