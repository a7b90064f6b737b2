"""The fit workflow: everything ``pdw-fit`` computes, returned as data for the report.

:func:`run_fit` checks the curves against the fit's targets, compiles what it needs, runs
the references, the fit (:func:`~pdw_casadi.fit.fit_gait`) and picks its answer, then
computes what the report shows of it: the gait timing and the two steps of the limit cycle.
The report layer (:mod:`pdw_casadi.report.fit_report`,
:mod:`pdw_casadi.report.fit_stride_report`) only renders the result.

Beside the fit, references are computed with the same curve code on the same data: the
problem file's own compliance (for the 6-link walker the paper's Table 3) re-run on this
walker, and, when the walker's family names one (``COMPARISON_PROBLEM``, see
:mod:`pdw_casadi.model.faces`), its comparison walker: for the 6-link walker the paper's [48]
(point feet, knees locked in stance) with this anthropometry
(``problems/comparison_kneed_6link.toml``). Other walkers have no comparison row.

With per-side curves (:class:`~pdw_casadi.model.gait_data.SideCurves`) the fit is the
per-leg fit on the stride (:func:`~pdw_casadi.fit.fit_sides`) and the result a
:class:`FitSidesRun`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from pdw_casadi.engine.clock import Stopwatch
from pdw_casadi.engine.compile import build_libraries
from pdw_casadi.fit import (
    Candidate,
    FitOptions,
    FitResult,
    check_targets,
    fit_gait,
    fit_libraries,
    reference_gait,
)
from pdw_casadi.fit.stride_fit import check_stride_targets
from pdw_casadi.gait.poincare import fixed_point_libraries
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stride import stride_map
from pdw_casadi.gait.timing import GaitTiming, fixed_point_timing, human_timing
from pdw_casadi.model.faces import WalkerFaces, walker_faces
from pdw_casadi.model.gait_data import SIDES, GaitCurves, SideCurves
from pdw_casadi.model.problem import Problem, load_problem
from pdw_casadi.model.system import HybridSystem, hybrid_system


@dataclass
class FitRun:
    """A one-step fit and what its report shows (:func:`run_fit` on one curve set)."""

    problem: Problem
    human: GaitCurves
    options: FitOptions
    #: the fit itself (every start's candidate, the IPOPT solves, the notes)
    result: FitResult
    #: the reported candidate: the best stable valid one, else the best at all (None: none)
    candidate: Candidate | None
    #: the candidate is the fit's best (stable with rho <= max_radius, valid)
    accepted: bool
    #: the problem file's own compliance re-run on these curves
    #: (:func:`~pdw_casadi.fit.reference_gait`; for the 6-link walker the paper's Table 3)
    reference: dict
    #: the comparison walker's reference gait (None: the family names no comparison walker)
    comparison: dict | None
    #: the comparison walker's problem name (None: none)
    comparison_problem: str | None
    #: the R^2 the paper reports for this walker family (None: none)
    paper_reported: dict | None
    #: the timing of the candidate's gait (None: no candidate, or its step failed)
    fit_timing: GaitTiming | None
    #: the human timing values to compare with, and where they come from
    human_timing: dict[str, float]
    human_timing_source: str
    #: the candidate's gait simulated over two steps (None: no candidate)
    limit_cycle: pd.DataFrame | None
    #: the walker's faces (phases, legs, comparison walker) for the figures
    faces: WalkerFaces
    #: the walker's hybrid system (the units of the summary)
    system: HybridSystem
    #: wall time (s) of each part of the run (:class:`~pdw_casadi.engine.clock.Stopwatch`)
    times: Stopwatch | None = None


@dataclass
class FitSidesRun:
    """A per-leg (stride) fit and what its report shows (:func:`run_fit` on per-side
    curves)."""

    problem: Problem
    sides: SideCurves
    options: FitOptions
    #: the stride fit itself (its candidates, the symmetric start, the IPOPT solves)
    result: FitResult
    #: the reported two-step candidate: the best stable valid one, else the best at all
    #: (None: none)
    candidate: Candidate | None
    #: the candidate is the fit's best (stable with per-step rho <= max_radius, valid)
    accepted: bool
    #: each leg's compliance {side: {name: value}} at the symmetric start
    start_compliance: dict
    #: each leg's compliance at the candidate (None: no candidate)
    compliance: dict | None
    #: the candidate's slope (rad; None: no candidate)
    slope: float | None
    #: the stride map's hybrid system (the units of the summary)
    system: HybridSystem


def leg_compliance(problem, parameters) -> dict:
    """Each leg's compliance {side: {name: value}} from the physical legs' ``parameters``."""
    names = list(stride_map(problem).parameter_names)
    return {s: {k: float(parameters[names.index(f"{s}.{k}")])
                for k in problem.compliance_names} for s in SIDES}


def _pick(res: FitResult) -> tuple[Candidate | None, bool]:
    """The best stable valid candidate, else the best candidate at all (flagged)."""
    if res.best is not None:
        return res.best, True
    if not res.candidates:
        return None, False
    return max(res.candidates, key=lambda c: c.mean_score(res.targets)), False


def run_fit(problem, human, opts: FitOptions | None = None, workers: int = 1, log=print,
            scheduler: str | None = None,
            before_work: Callable[[], object] | None = None) -> FitRun | FitSidesRun:
    """Fit ``problem``'s walker to ``human`` and compute what the report shows.

    One curve set (:class:`~pdw_casadi.model.gait_data.GaitCurves`): the references, the
    multistart fit (``workers`` processes or a Dask ``scheduler``), the chosen candidate's
    timing and two steps of its limit cycle: a :class:`FitRun`. Per-side curves
    (:class:`~pdw_casadi.model.gait_data.SideCurves`): the per-leg fit on the stride
    (``opts`` with its ``side`` and ``start``): a :class:`FitSidesRun`.

    The curves are checked against the targets first (:func:`~pdw_casadi.fit.check_targets`,
    per side :func:`~pdw_casadi.fit.stride_fit.check_stride_targets`): bad input raises
    before any log line or compilation. ``before_work`` is then called, before anything
    else (a command creates its output folder there, once its input is known good).
    """
    if isinstance(human, SideCurves):
        return _run_sides(problem, human, opts or FitOptions(), log, before_work)
    opts = opts or FitOptions()
    check_targets(problem, human, opts)  # before the reference solves
    if before_work is not None:
        before_work()
    watch = Stopwatch()
    faces = walker_faces(problem)
    comparison_name = faces.comparison_problem
    with watch.part("compiled functions"):
        # everything the references and the fit call, compiled side by side on a first run
        build_libraries([*fit_libraries(problem, opts),
                         *(fixed_point_libraries(load_problem(comparison_name))
                           if comparison_name else ())], log=log)
    with watch.part("references"):
        log("reference: the problem's own compliance on the same data")
        table3 = reference_gait(problem, human)
        paper = dict(faces.paper_reported) if faces.paper_reported else None
        comparison = None
        if comparison_name is not None:
            log(f"reference: the comparison walker {comparison_name}")
            comparison = reference_gait(load_problem(comparison_name), human)
    with watch.part("fit"):
        res = fit_gait(problem, human, opts, log=log, workers=workers, scheduler=scheduler)
    ipopt = sum(s.wall_time_s for s in res.solves)
    watch.parts["fit"] -= ipopt
    watch.parts["fit (starts, NLP building, checks)"] = watch.parts.pop("fit")
    watch.add(f"IPOPT ({sum(s.iterations for s in res.solves)} iterations)", ipopt)
    cand, ok = _pick(res)
    fit_timing = None
    limit_cycle = None
    with watch.part("timing and limit cycle"):
        if cand is not None:
            fit_timing = fixed_point_timing(problem, cand.state, cand.parameters)
            two = Simulator(problem).run(cand.state, cand.parameters, steps=2, record=True)
            limit_cycle = two.trajectory
    norms, norms_source = human_timing(human)
    return FitRun(problem=problem, human=human, options=opts, result=res, candidate=cand,
                  accepted=ok, reference=table3, comparison=comparison,
                  comparison_problem=comparison_name, paper_reported=paper,
                  fit_timing=fit_timing, human_timing=norms, human_timing_source=norms_source,
                  limit_cycle=limit_cycle, faces=faces, system=hybrid_system(problem),
                  times=watch)


def _run_sides(problem, sides: SideCurves, opts: FitOptions, log,
               before_work: Callable[[], object] | None) -> FitSidesRun:
    """The per-leg fit of :func:`run_fit`."""
    check_stride_targets(problem, sides, opts)
    if before_work is not None:
        before_work()
    res = fit_gait(problem, sides, opts, log=log)
    cand, ok = _pick(res)
    start_comp = leg_compliance(problem, np.asarray(res.start["parameters"]))
    comp = slope = None
    if cand is not None:
        comp = leg_compliance(problem, cand.parameters)
        names = list(stride_map(problem).parameter_names)
        slope = float(cand.parameters[names.index("slope")])
    return FitSidesRun(problem=problem, sides=sides, options=opts, result=res,
                       candidate=cand, accepted=ok, start_compliance=start_comp,
                       compliance=comp, slope=slope, system=stride_map(problem).hs)
