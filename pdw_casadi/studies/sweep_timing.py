"""The gait timing of every converged point of a parameter sweep (``pdw-sweep --timing``).

:func:`sweep_timing` simulates one step from each converged row of a sweep table (the
table of :class:`~pdw_casadi.gait.sweep.SweepResult`: the row's section state and its
parameters ``param:<name>``) and returns per row a :class:`PointTiming`: the swept value,
valid, stable, the spectral radius and the timing of the periodic gait
(:func:`~pdw_casadi.gait.timing.fixed_point_timing`: double support per period and stance
in % of the gait cycle, phase durations in s). :func:`check_sweep_timing` refuses, before
any work, a walker whose gait cannot be timed so. The lines ``pdw-sweep`` prints are
rendered by :mod:`pdw_casadi.report.sweep_timing_report`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd

from pdw_casadi.engine.errors import ProblemError, TimingError
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import GaitTiming, fixed_point_timing, phase_contacts
from pdw_casadi.model.problem import Problem


@dataclass(frozen=True)
class PointTiming:
    """The timing of one sweep point (:func:`sweep_timing`).

    ``value``: the swept parameter's value (its unit); ``converged``, ``valid``, ``stable``
    and ``spectral_radius`` (-) as in the sweep table, ``failure`` its reason when the
    point did not converge; ``timing``: the gait timing of the periodic gait (None when it
    did not converge or its step fails).
    """

    value: float
    converged: bool
    failure: str
    valid: bool
    stable: bool
    spectral_radius: float
    timing: GaitTiming | None


def check_sweep_timing(problem: Problem) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless the step of
    ``problem``'s gait can be timed: its legs carry the same values (a stride's legs are
    timed by ``pdw-fixed-point --stride``) and its family declares the contacts of its
    phases (:func:`~pdw_casadi.gait.timing.phase_contacts`)."""
    if problem.asymmetric:
        raise ProblemError(f"{problem.name}: its legs differ; the timing per point times one "
                           f"step of a walker with one set of values for both legs "
                           f"(pdw-fixed-point --stride times each leg of a stride)")
    try:
        phase_contacts(problem.family)
    except TimingError as exc:
        raise ProblemError(f"{problem.name}: its gait cannot be timed: {exc}") from None


def sweep_timing(problem: Problem, table: pd.DataFrame,
                 sim: Simulator | None = None) -> list[PointTiming]:
    """The timing of every row of the sweep ``table`` of ``problem``, in the table's order.

    ``table``: a sweep table as :func:`~pdw_casadi.gait.sweep.point_row` builds it (the swept
    parameter first, the section state under the problem's state names in rad and rad/s,
    the parameters as ``param:<name>``); ``sim``: the walker's simulator (default: a new
    one). A row that did not converge gets no timing; neither does one whose step from its
    section state fails.
    """
    sim = sim or Simulator(problem)
    swept = table.columns[0]
    params = [f"param:{n}" for n in problem.parameter_names]
    out = []
    for _, row in table.iterrows():
        converged = bool(row["converged"])
        timing = None
        if converged:
            timing = fixed_point_timing(problem, row[list(problem.state_names)].to_numpy(float),
                                        row[params].to_numpy(float), sim)
        out.append(PointTiming(
            value=float(row[swept]), converged=converged, failure=_text(row.get("failure")),
            valid=bool(row["valid"]), stable=bool(row["stable"]),
            spectral_radius=float(row["spectral_radius"]), timing=timing))
    return out


def _text(value) -> str:
    """A table cell as text ('' for an empty one)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value)
