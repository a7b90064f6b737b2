"""The walker-family registry: a :class:`Family` per walker, registered by its module.

A family module decorates its ``build(problem) -> WalkerModel`` with :func:`register`,
giving the problem-file keys it needs, its anthropometry check and the names its plots and
reports use; :func:`get_family` then finds it by the problem file's ``walker.family``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType


def _no_check(values, where) -> None:
    """No anthropometry rule beyond positivity."""


@dataclass(frozen=True)
class Family:
    """A walker family: how to build it and what its problem files hold.

    ``anthropometry_keys`` / ``compliance_keys`` / ``state_keys``: the keys of the problem
    file's sections (in order; compliance and state order is the parameter and section
    vector order); ``positive_keys``: anthropometry that must be > 0;
    ``nonnegative_compliance``: compliance that must be >= 0; ``check_anthropometry(values,
    where)``: further rules (raises ProblemError). The faces (see :mod:`pdw_casadi.model.faces`):
    ``phase_descriptions``, ``limit_cycle_legs`` (per step, the coordinates of one physical
    leg's segments), ``leg_segments``, ``curve_joints``, ``instant_labels``,
    ``comparison_problem`` (a bundled problem the fit report compares with),
    ``paper_reported_r2`` and ``phase_contacts`` (the gait timing); ``leg_keys`` and
    ``build_per_leg`` for walkers whose legs may differ.
    """

    name: str
    description: str
    build: Callable
    anthropometry_keys: tuple[str, ...]
    compliance_keys: tuple[str, ...]
    state_keys: tuple[str, ...]
    positive_keys: tuple[str, ...]
    nonnegative_compliance: tuple[str, ...] = ()
    check_anthropometry: Callable = _no_check
    phase_descriptions: Mapping[str, str] = field(default_factory=dict)
    limit_cycle_legs: tuple[tuple[str, ...], ...] = ()
    leg_segments: tuple[str, ...] = ()
    curve_joints: tuple[str, ...] = ("knee", "hip")
    instant_labels: Mapping[str, str] = field(default_factory=dict)
    comparison_problem: str | None = None
    paper_reported_r2: Mapping[str, float] | None = None
    #: phase -> (what leg 1 touches, what leg 2 touches): "flat", "heel", "toe", "point" or
    #: None (in the air); the gait timing reads it (:mod:`pdw_casadi.gait.timing`)
    phase_contacts: Mapping[str, tuple[str | None, str | None]] = field(default_factory=dict)
    #: per physical leg (pdw_casadi.gait.stride): the keys a problem may set per leg
    #: ({"compliance": ..., "anthropometry": ...}) and ``build_per_leg(name, g)``, the
    #: walker with every body and compliance value a runtime parameter, leg by leg
    leg_keys: Mapping[str, tuple[str, ...]] | None = None
    build_per_leg: Callable | None = None


_REGISTRY: dict[str, Family] = {}
#: the registered families by name (read-only view, in registration order)
FAMILIES: Mapping[str, Family] = MappingProxyType(_REGISTRY)


def register(name: str, **spec) -> Callable[[Callable], Callable]:
    """Decorator of a family's ``build`` function: registers ``Family(name, build=...,
    **spec)`` (``description`` defaults to the build function's first docstring line)."""

    def deco(build: Callable) -> Callable:
        if name in _REGISTRY:
            raise ValueError(f"walker family {name!r} is registered twice")
        spec.setdefault("description", (build.__doc__ or name).strip().splitlines()[0])
        _REGISTRY[name] = Family(name=name, build=build, **spec)
        return build

    return deco


def get_family(name: str) -> Family:
    """The registered :class:`Family` called ``name`` (``"humanlike_6link"``, ...)."""
    if name not in _REGISTRY:
        raise KeyError(f"unknown walker family {name!r}; known: {', '.join(_REGISTRY)}")
    return _REGISTRY[name]
