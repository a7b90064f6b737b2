"""The ankle-extended 6-link walker with a forefoot rocker: heel off in single support.

The walker of :mod:`pdw_casadi.model.walkers.humanlike_6link_ankle` (same chain, passive ankle
elements, knee rule, impacts and section) with the forefoot rocker of
:mod:`pdw_casadi.model.feet.rocker` on both legs: the centre of pressure reaching the stance
toe in single support lifts the heel (guard ``heel_off``, no impact) and the stance foot
pivots on its toe in phase ``II_toe`` until the swing heel strikes.

Heel off needs a plantarflexing stance-ankle torque of about N l_ft (the body weight times
the toe-to-ankle length, tens of N m): human-range quasi-stiffness ``k_ankle`` with its
``ankle_rest``, or the clutch spring. A gait whose heel never lifts is the three-phase gait
of the ankle walker, so its gaits are valid starts here. Everything stays passive: no
element or transition adds energy (heel off is smooth, the impacts are inelastic).
"""

from __future__ import annotations

from pdw_casadi.model.feet.rocker import ROCKER

from . import humanlike_6link as base
from . import humanlike_6link_ankle as ankle

__all__ = ["build"]

build = base.register_six_link(
    "humanlike_6link_heeloff",
    "The humanlike 6-link walker with passive ankle extensions and a forefoot rocker (heel "
    "off in single support).",
    foot=ROCKER, ext=ankle.EXTENSION, nonnegative_compliance=ankle.EXTRA_NONNEGATIVE)
