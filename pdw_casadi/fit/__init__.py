"""Fitting a walker's compliance and stable periodic gait to human curves.

- :mod:`.options`: :class:`FitOptions`, every setting;
- :mod:`.objective`: 1 - R^2 on the multiple-shooting grid;
- :mod:`.driver`: the fit's NLP on the shared IPOPT driver (:mod:`pdw_casadi.nlp.driver`),
  with the stability row of :mod:`pdw_casadi.nlp.stability` (spectral-radius bound of the NLP
  step, exact gradient) and its progress lines;
- :mod:`.starts`: the gait atlas and the choice of starts;
- :mod:`.atlas`: building a walker's gait atlas (``pdw-atlas``);
- :mod:`.result`: solves, candidates (a periodic gait of one step or of a stride), checks;
- :mod:`.rounds`: the NLP rounds of a start, on the step or on the stride;
- :mod:`.core`: :func:`fit_gait` (per-side curves: the per-leg fit :func:`fit_sides`);
- :mod:`.stride_objective`, :mod:`.stride_fit`: the per-leg fit's parts, each leg to its
  own side's curves on the stride.
"""

from pdw_casadi.fit.core import (
    RefitCorrector,
    check_targets,
    fit_gait,
    fit_libraries,
    fit_sides,
)
from pdw_casadi.fit.objective import CurveError
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import (
           Candidate,
           FitResult,
           Solve,
           evaluate_gait,
           mean_score,
           reference_gait,
)
from pdw_casadi.nlp.stability import RADIUS_NORM, StabilityRow, smooth_radius

__all__ = ["Candidate", "CurveError", "FitOptions", "FitResult", "RADIUS_NORM",
           "RefitCorrector", "Solve", "StabilityRow", "check_targets", "evaluate_gait",
           "fit_gait", "fit_libraries", "fit_sides", "mean_score",
           "reference_gait", "smooth_radius"]
