"""Walker families: one small module each, describing a walker symbolically.

A family module decorates its ``build(problem) -> WalkerModel`` with
:func:`~pdw_casadi.model.walkers.registry.register`, naming the problem-file keys it needs
(anthropometry, compliance, section state), an anthropometry check and the names its plots
use (:class:`~pdw_casadi.model.walkers.registry.Family`). Everything numerical (simulation,
Poincare map, fixed points, fits, sweeps) is generic over the model it builds. A new family:
a module here with a registered ``build``, imported below.
"""

from __future__ import annotations

from pdw_casadi.model.walkers.registry import FAMILIES, Family, get_family, register

from . import (  # noqa: F401 (registers)
    humanlike_6link,
    humanlike_6link_ankle,
    humanlike_6link_arc,
    humanlike_6link_heeloff,
    humanlike_toes,
    point_foot,
)

__all__ = ["FAMILIES", "Family", "get_family", "register"]
