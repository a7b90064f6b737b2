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
    from .problem import ProblemError

    if problem.asymmetric:
        # this walker has one set of values for both legs: silently using it would drop the
        # per-leg ones
        raise ProblemError(f"{problem.name}: its legs differ ([compliance.left/right] or "
                           f"[anthropometry.left/right]); this command works on the stride "
                           f"map only (pdw-simulate, pdw-fixed-point; pdw_casadi.stride)")
    key = (problem.family, tuple(sorted(problem.anthropometry.items())), problem.g)
    if key not in _CACHE:
        model = get_family(problem.family).build(problem)
        _CACHE[key] = HybridSystem(model)
    return _CACHE[key]
