"""The CasADi functions of a problem's walker, built once per walker and cached.

Parameters (compliance, slope) are function inputs, so changing them never rebuilds a
graph; only a different family, anthropometry or gravity does. The per-leg walker (every
body and compliance value a runtime parameter, per leg role) is built once per family and
gravity.
"""

from __future__ import annotations

import numpy as np

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.problem import LEG_SIDES
from pdw_casadi.model.walkers import get_family

_CACHE: dict[tuple, HybridSystem] = {}
_PER_LEG: dict[tuple, HybridSystem] = {}


def hybrid_system(problem) -> HybridSystem:
    """The :class:`HybridSystem` of ``problem``'s walker (cached across calls)."""
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


def leg_layout(problem) -> tuple[tuple[str, ...], ...]:
    """(compliance keys, leg anthropometry keys, shared anthropometry keys) of the family
    of ``problem``'s walker: the blocks of the per-leg parameters theta."""
    fam = get_family(problem.family)
    comp = tuple(fam.compliance_keys)
    leg = tuple(fam.leg_keys["anthropometry"])
    shared = tuple(k for k in fam.anthropometry_keys if k not in leg)
    return comp, leg, shared


def physical_parameter_names(problem) -> tuple[str, ...]:
    """Names of theta: ``left.k_ankle``, ..., ``right.J_f``, shared body keys, ``slope``."""
    if per_leg_system(problem) is None:
        return (*problem.compliance, "slope")
    comp, leg, shared = leg_layout(problem)
    return (*(f"{s}.{k}" for s in LEG_SIDES for k in comp),
            *(f"{s}.{k}" for s in LEG_SIDES for k in leg), *shared, "slope")


def physical_parameter_vector(problem) -> np.ndarray:
    """theta of ``problem`` (order of :func:`physical_parameter_names`; SI units)."""
    if per_leg_system(problem) is None:
        return problem.parameter_vector()
    comp, leg, shared = leg_layout(problem)
    vals = {s: problem.leg_values(s) for s in LEG_SIDES}
    return np.array([*(vals[s][0][k] for s in LEG_SIDES for k in comp),
                     *(vals[s][1][k] for s in LEG_SIDES for k in leg),
                     *(problem.anthropometry[k] for k in shared), problem.slope], float)


def with_physical_parameters(problem, theta):
    """A copy of ``problem`` whose legs carry the values of theta (per-leg walkers)."""
    theta = np.asarray(theta, float).ravel()
    names = physical_parameter_names(problem)
    if theta.size != len(names):
        raise ProblemError(f"{problem.name}: theta has {theta.size} values, expected "
                           f"{len(names)}")
    if per_leg_system(problem) is None:
        return problem.with_parameters(theta)
    d = dict(zip(names, map(float, theta), strict=True))
    comp, leg, shared = leg_layout(problem)
    base_c = {k: d[f"left.{k}"] for k in comp}
    base_a = {**problem.anthropometry, **{k: d[f"left.{k}"] for k in leg},
              **{k: d[k] for k in shared}}
    right_c = {k: d[f"right.{k}"] for k in comp if d[f"right.{k}"] != base_c[k]}
    right_a = {k: d[f"right.{k}"] for k in leg if d[f"right.{k}"] != base_a[k]}
    legs = {}
    if right_c or right_a:
        legs["right"] = {"compliance": right_c, "anthropometry": right_a}
    return problem.replace(compliance=base_c, anthropometry=base_a, slope=d["slope"],
                           legs=legs)
