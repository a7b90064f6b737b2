"""The design workflow: everything ``pdw-design`` computes, returned as data for the report.

:func:`run_design` designs the prosthetic leg of a walker as a :class:`DesignRequest` asks
(:mod:`pdw_casadi.studies.prosthesis`: the stride NLP with the stability row,
:func:`~pdw_casadi.studies.prosthesis.design_prosthesis_nlp`, or the min-norm Newton
continuation, :func:`~pdw_casadi.studies.prosthesis.design_prosthesis`) and returns a
:class:`DesignRun`: the designed walker, its stride gait, how far the mass homotopy got and
the wall time. The report layer (:mod:`pdw_casadi.report.design_report`) only renders it.

The rules a request obeys that its walker decides (:func:`check_compliance_keys`,
:func:`check_mass_distribution`) are checked here, once, and raise
:class:`~pdw_casadi.engine.errors.ProblemError` before any solve: a command calls them while
it validates its arguments and names its own flag in the message.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.problem import Problem
from pdw_casadi.studies.prosthesis import (
    NLP_FREE,
    DesignNLPOptions,
    ProsthesisResult,
    design_prosthesis,
    design_prosthesis_nlp,
    lighter_mass,
)

#: the design methods: the stride NLP with the stability row (the default), or the min-norm
#: Newton continuation (symmetry without a stability condition)
METHODS = ("nlp", "continuation")


@dataclass(frozen=True)
class DesignRequest:
    """What :func:`run_design` designs.

    ``lighter``: the fraction (-) by which the right (prosthetic) leg's shank and foot mass
    and inertia are reduced; ``method``: one of :data:`METHODS`. The NLP design's
    ``free`` compliance keys of the prosthetic leg and its ``options``
    (:class:`~pdw_casadi.studies.prosthesis.DesignNLPOptions`: homotopy steps, IPOPT,
    symmetry tolerance in %, shortest segment in s, the mass distribution, the sound leg's
    adapting keys); the continuation's ``hold_first_phase`` (hold the duration of the
    walker's first phase, s, at its start value) and its own free keys
    (:data:`~pdw_casadi.studies.prosthesis.FREE`).
    """

    lighter: float = 0.3
    method: str = "nlp"
    free: tuple[str, ...] = NLP_FREE
    hold_first_phase: bool = True
    options: DesignNLPOptions = field(default_factory=DesignNLPOptions)


@dataclass
class DesignRun:
    """A prosthetic-leg design and what its report shows (:func:`run_design`)."""

    #: the walker the design started from (an atlas entry's gait, or a problem file)
    start: Problem
    request: DesignRequest
    #: the design itself: the designed walker, its stride fixed point and stride report
    #: (None: no fixed point at the last answer), the compliance found, the homotopy path
    #: and, for the NLP, its solves
    result: ProsthesisResult
    #: how much lighter the designed walker's right shank + foot are than the left's, as a
    #: fraction of the left's mass (-)
    lighter_reached: float
    #: wall time of the design, s
    wall_time_s: float

    @property
    def has_gait(self) -> bool:
        """The designed walker has a stride fixed point (so a stride report to show)."""
        return self.result.report is not None

    @property
    def stable(self) -> bool:
        """The designed gait's stride spectral radius (-) lies within the verdict's
        ``max_stride_radius`` (:class:`~pdw_casadi.studies.prosthesis.DesignNLPOptions`)."""
        return self.result.fixed_point.spectral_radius <= self.request.options.max_stride_radius


def check_compliance_keys(problem: Problem, keys: Sequence[str], required: bool = True) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless every one of ``keys`` is
    a compliance key of ``problem``'s walker (and, when ``required``, at least one is
    given): the keys a design frees on a leg."""
    unknown = [k for k in keys if k not in problem.compliance]
    if unknown or (required and not keys):
        raise ProblemError(f"{', '.join(unknown) or 'no key given'}; the {problem.family} "
                           f"walker's compliance keys: {', '.join(problem.compliance)}")


def check_mass_distribution(keys: Sequence[str], options: DesignNLPOptions | None = None) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless every one of ``keys`` is
    a body value the NLP design can place (a key of ``mass_distribution_bounds``:
    l_sc and l_fc in m, J_s and J_f in kg m^2)."""
    bounds = (options or DesignNLPOptions()).mass_distribution_bounds
    unknown = [k for k in keys if k not in bounds]
    if unknown:
        raise ProblemError(f"{', '.join(unknown)} not among {', '.join(bounds)}")


def run_design(start: Problem, request: DesignRequest, *,
               nlp: Callable[..., ProsthesisResult] = design_prosthesis_nlp,
               continuation: Callable[..., ProsthesisResult] = design_prosthesis) -> DesignRun:
    """Design the prosthetic leg of ``start`` (a symmetric walker at a stable gait, or a
    walker written by an earlier design, which the NLP continues) as ``request`` asks.

    ``nlp`` and ``continuation`` are the two design functions (default those of
    :mod:`pdw_casadi.studies.prosthesis`; a caller passes the ones it holds, so that a test
    can stand in for a solve). The NLP design logs one line per solve on stdout. Returns
    the :class:`DesignRun`, whether or not the design reached its target (``reached`` of
    its result) or ends at a stride fixed point (:attr:`DesignRun.has_gait`).
    """
    began = time.perf_counter()
    if request.method == "nlp":
        result = nlp(start, lighter=request.lighter, free=request.free, options=request.options)
    elif request.method == "continuation":
        result = continuation(start, lighter=request.lighter,
                              hold_first_phase=request.hold_first_phase)
    else:
        raise ProblemError(f"unknown design method {request.method!r}: use "
                           f"{' or '.join(METHODS)}")
    took = time.perf_counter() - began
    return DesignRun(start=start, request=request, result=result,
                     lighter_reached=1 - lighter_mass(result.problem), wall_time_s=took)
