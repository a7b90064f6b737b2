"""The CasADi functions of a problem's walker, built once per walker and cached.

Parameters (compliance, slope) are function inputs, so changing them never rebuilds a
graph; only a different family, anthropometry or gravity does. The per-leg walker (every
body and compliance value a runtime parameter, per leg role) is built once per family and
gravity.
"""

from __future__ import annotations

from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.walkers import get_family

_CACHE: dict[tuple, HybridSystem] = {}
_PER_LEG: dict[tuple, HybridSystem] = {}


def hybrid_system(problem) -> HybridSystem:
    """The :class:`HybridSystem` of ``problem``'s walker (cached across calls)."""
    from pdw_casadi.model.problem import ProblemError

    if problem.asymmetric:
        # this walker has one set of values for both legs: silently using it would drop the
        # per-leg ones
        raise ProblemError(f"{problem.name}: its legs differ ([compliance.left/right] or "
                           f"[anthropometry.left/right]); this command works on the stride "
                           f"map only (pdw-simulate, pdw-fixed-point, pdw-sweep; "
                           f"pdw_casadi.gait.stride)")
    key = (problem.family, tuple(sorted(problem.anthropometry.items())), problem.g)
    if key not in _CACHE:
        model = get_family(problem.family).build(problem)
        _CACHE[key] = HybridSystem(model)
    return _CACHE[key]


def per_leg_system(problem) -> HybridSystem | None:
    """The per-leg :class:`HybridSystem` of ``problem``'s walker family (cached; one per
    family and g: the body is a runtime parameter), or None if the family has none."""
    fam = get_family(problem.family)
    if fam.build_per_leg is None:
        return None
    key = (problem.family, problem.g)
    if key not in _PER_LEG:
        _PER_LEG[key] = HybridSystem(fam.build_per_leg(problem.family + "_per_leg", problem.g))
    return _PER_LEG[key]


def gait_system(problem) -> HybridSystem:
    """The system whose periodic gaits ``problem`` has: its walker (:func:`hybrid_system`)
    when both legs carry the same values, else the per-leg walker of the stride map. Both
    declare the same validity margins (a stride's keys carry the stance leg in front)."""
    if problem.asymmetric:
        hs = per_leg_system(problem)
        if hs is not None:
            return hs
    return hybrid_system(problem)
