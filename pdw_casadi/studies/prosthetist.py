"""A prosthetist's study: a subject's sound leg fitted to its side, the prosthetic leg made
lighter step by step with its compliance designed for a symmetric, stable gait.

:func:`prosthetist_study` runs, for one subject's per-side curves
(:class:`~pdw_casadi.model.gait_data.SideCurves`):

1. the one-step fit of the symmetric walker to the **sound side's** curves
   (:func:`~pdw_casadi.fit.fit_gait`): both legs are then the sound leg, fitted;
2. one prosthesis design from that walker
   (:func:`~pdw_casadi.studies.prosthesis.design_prosthesis_nlp`, the right leg lighter,
   the sound leg's compliance adapting as an amputee's gait does) whose mass homotopy
   stops at each of ``levels``
   (:attr:`~pdw_casadi.studies.prosthesis.DesignNLPOptions.stops`);
3. at the fitted walker and at each level: the stride fixed point re-solved on the
   simulator, its radius, validity and asymmetries, the designed compliance of both legs,
   and the R^2 of each leg's knee and hip curves against the sound side's human curves
   (how much of the sound leg's fit the prosthesis costs, and how close the prosthetic
   leg moves to it).

The design's sound leg is the left one (:func:`~pdw_casadi.studies.prosthesis.sound_problem`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from pdw_casadi.engine.errors import NoGait
from pdw_casadi.fit import FitOptions, fit_gait
from pdw_casadi.gait.curves import fit_scores
from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL
from pdw_casadi.gait.stability import step_radius
from pdw_casadi.gait.stride import find_stride_fixed_point, stride_map, stride_report
from pdw_casadi.model.gait_data import SideCurves
from pdw_casadi.model.problem import Problem
from pdw_casadi.model.system import physical_parameter_names
from pdw_casadi.studies.prosthesis import (
    NLP_FREE,
    DesignNLPOptions,
    ProsthesisResult,
    design_prosthesis_nlp,
)

#: the design's sound and prosthetic legs (prosthesis.py designs the right leg)
SOUND, PROSTHETIC = "left", "right"


def study_design_options() -> DesignNLPOptions:
    """The design settings of the study: the shipped 30 % design's (the sound leg's eight
    compliance values adapting, a homotopy step accepted when the simulator verifies it,
    step asymmetries up to 0.9 %, at most 30 solves; docs/results/prosthesis.md)."""
    return DesignNLPOptions(max_solves=30, free_sound=tuple(NLP_FREE), accept_verified=True,
                            symmetry_tol_pct=0.9)


@dataclass
class StudyOptions:
    """Settings of :func:`prosthetist_study`: the mass reductions ``levels`` (fractions of
    the prosthetic leg's shank and foot mass, ascending), the fit of the sound leg
    (:class:`~pdw_casadi.fit.FitOptions`) and the design (:func:`study_design_options`;
    its ``stops`` are set from ``levels``)."""

    levels: tuple = (0.1, 0.2, 0.3)
    fit: FitOptions = field(default_factory=lambda: FitOptions(verbose=False))
    design: DesignNLPOptions = field(default_factory=study_design_options)


@dataclass
class ProsthetistStudy:
    """The study's outcome: the ``fitted`` symmetric walker (the sound leg on both sides)
    and its section state ``state``, the ``design`` run, and ``table``: one row per level
    (0 = the fitted walker) with the stride's verdict, asymmetries, R^2 per leg against the
    sound side's curves and both legs' compliance (``lighter_pct`` and the asymmetries in
    %, ``speed_m_s`` in m/s, the compliance ``<leg>.<key>`` in the problem file's SI units:
    N m/rad, N m s/rad, rad); ``wall_time_s`` (s)."""

    sides: SideCurves
    fitted: Problem
    state: np.ndarray
    design: ProsthesisResult
    table: pd.DataFrame
    wall_time_s: float


def study_row(walker: Problem, x, sides: SideCurves, lighter: float) -> dict:
    """One row of the study's table: the stride fixed point of ``walker`` near section state
    ``x`` at ``lighter`` (-) and what a prosthetist reads off it (see :class:`ProsthetistStudy`)."""
    smap = stride_map(walker)
    fp = find_stride_fixed_point(walker, x0=np.asarray(x, float), tol=FIXED_POINT_TOL,
                                 fallback=False, smap=smap)
    row: dict = {"lighter_pct": 100.0 * lighter, "converged": bool(fp.converged)}
    if not fp.converged:
        return row
    rep = stride_report(smap, fp.state, fp.parameters)
    human = sides.side(SOUND)
    row.update(stride_radius=fp.spectral_radius,
               step_radius=step_radius(fp.spectral_radius, 2),
               valid=bool(fp.valid),
               step_length_asymmetry_pct=rep["step_length_asymmetry_pct"],
               step_time_asymmetry_pct=rep["step_time_asymmetry_pct"],
               speed_m_s=rep["speed_m_s"])
    names = list(physical_parameter_names(walker))
    for leg in (SOUND, PROSTHETIC):
        scores = fit_scores(rep["curves"][leg], human)
        row[f"r2_knee_{leg}"] = scores.get("r2_knee", math.nan)
        row[f"r2_hip_{leg}"] = scores.get("r2_hip", math.nan)
        for key in NLP_FREE:
            row[f"{leg}.{key}"] = float(fp.parameters[names.index(f"{leg}.{key}")])
    return row


def prosthetist_study(problem: Problem, sides: SideCurves, options: StudyOptions | None = None,
                      log=print) -> ProsthetistStudy:
    """The study of the module docstring for ``problem`` (a symmetric walker) and one
    subject's per-side curves ``sides``. Raises :class:`~pdw_casadi.engine.errors.NoGait`
    when the sound side's fit finds no stable, valid gait."""
    t0 = time.perf_counter()
    opts = options or StudyOptions()
    levels = tuple(sorted(float(v) for v in opts.levels))
    if not levels or levels[0] <= 0 or levels[-1] >= 1:
        raise ValueError(f"levels must lie in (0, 1), got {opts.levels}")
    log(f"the sound ({SOUND}) side's fit: {sides.name}")
    fit = fit_gait(problem, sides.side(SOUND), opts.fit, log=log)
    if fit.best is None:
        raise NoGait(f"{sides.name}: the fit to the {SOUND} side found no stable, valid gait")
    best = fit.best
    fitted = problem.with_parameters(best.parameters).with_state(best.state).replace(
        name=f"{problem.name}_{SOUND}_fit")
    design_opts = dataclasses.replace(opts.design, stops=levels[:-1])
    log(f"the design: the {PROSTHETIC} leg {', '.join(f'{100 * v:g}' for v in levels)} % "
        "lighter")
    design = design_prosthesis_nlp(fitted, lighter=levels[-1], options=design_opts, log=log)
    rows = [study_row(fitted, best.state, sides, 0.0)]
    for level in levels:
        try:
            walker, x = design.design_at(level)
        except KeyError:  # the homotopy did not get there
            rows.append({"lighter_pct": 100.0 * level, "converged": False})
            continue
        rows.append(study_row(walker, x, sides, level))
    return ProsthetistStudy(sides, fitted, np.asarray(best.state, float), design,
                            pd.DataFrame(rows), time.perf_counter() - t0)
