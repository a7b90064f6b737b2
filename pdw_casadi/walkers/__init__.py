"""Walker families: one small module each, describing a walker symbolically.

A family module defines the problem-file keys it needs (``ANTHROPOMETRY_KEYS``,
``COMPLIANCE_KEYS``, ``STATE_KEYS``, ``POSITIVE_KEYS``, ``NONNEGATIVE_COMPLIANCE``), a
``check_anthropometry(values, where)`` hook and ``build(problem) -> WalkerModel``. Everything
numerical (simulation, Poincare map, fixed points, fits, sweeps) is generic over that model.
"""

from __future__ import annotations

import importlib
from types import ModuleType

FAMILIES = ("humanlike_6link", "humanlike_6link_ankle", "compass_gait", "kneed_walker")


def get_family(name: str) -> ModuleType:
    """The module of a walker family (``"humanlike_6link"``, ``"compass_gait"``, ...)."""
    if name not in FAMILIES:
        raise KeyError(f"unknown walker family {name!r}; known: {', '.join(FAMILIES)}")
    module = "point_foot" if name in ("compass_gait", "kneed_walker") else name
    mod = importlib.import_module(f"{__name__}.{module}")
    return getattr(mod, "FAMILY_" + name.upper(), mod)
