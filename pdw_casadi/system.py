"""The CasADi functions of a problem's walker, built once per walker and cached.

Parameters (compliance, slope) are function inputs, so changing them never rebuilds a
graph; only a different family, anthropometry or gravity does.
"""

from __future__ import annotations

from .hybrid import HybridSystem
from .walkers import get_family

_CACHE: dict[tuple, HybridSystem] = {}


def hybrid_system(problem) -> HybridSystem:
    """The :class:`HybridSystem` of ``problem``'s walker (cached across calls)."""
    key = (problem.family, tuple(sorted(problem.anthropometry.items())), problem.g)
    if key not in _CACHE:
        model = get_family(problem.family).build(problem)
        _CACHE[key] = HybridSystem(model)
    return _CACHE[key]
