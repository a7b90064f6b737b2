"""Feet of the 6-link walker, one module each, on the interface of :mod:`.base`.

- :mod:`.flat`: the paper's flat foot (toe and heel points);
- :mod:`.arc`: rolling toe and heel arcs;
- :mod:`.rocker`: the flat foot whose heel lifts in single support (forefoot rocker).

A new foot is a new module here (or anywhere: a test file may define one) implementing
:class:`.base.Foot` and :class:`.base.FootLeg`.
"""

from __future__ import annotations

from pdw_casadi.model.feet.base import FlatReading, Foot, FootLeg, Ground, Hold, Pivot, Stage

__all__ = ["FlatReading", "Foot", "FootLeg", "Ground", "Hold", "Pivot", "Stage"]
