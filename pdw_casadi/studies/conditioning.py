"""How well conditioned is the fixed point at a fit's answer? The simulator's view of the NLP
(``pdw-fixed-point --conditioning``).

:func:`run_conditioning` runs the fit's first start on a walker and curve file (the
:class:`~pdw_casadi.fit.FitOptions` given, one round) and takes the NLP's answer, or, when
the solve stops short, its best feasible iterate (``FitOptions.keep_best_feasible``). At
that section state x (rad, rad/s) and parameters p it measures what decides whether the
simulator finds the same gait (:func:`conditioning`):

- the simulator's residual |P(x) - x| (the NLP's RK4 grid against the event-driven map);
- the exact-AD Jacobian J = dP/dx: its spectral radius, the smallest singular value of
  I - J and ||(I - J)^-1|| (how far one Newton step moves x per unit residual), the largest
  entry of J and Henrici's departure from normality (||J||_F^2 - sum |l_i|^2)^(1/2) /
  ||J||_F (0: normal; near 1: eigenvalues say little about a step's growth);
- along the Newton step x + t d, d = (I - J)^-1 (P(x) - x), t in [0, 1]: the spectral
  radius, the change of J per step in t and whether the simulator's event plan stays the
  same;
- Newton on the simulator's map from x (the fixed point the fit's check looks for).

A well-conditioned answer moves by about the residual times ||(I - J)^-1|| and keeps its
radius; an ill-conditioned one (I - J nearly singular, J strongly non-normal) turns a
discretisation difference of 1e-7 into a different verdict. The report
(:mod:`pdw_casadi.report.conditioning_report`) renders a :class:`ConditioningRun`.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pdw_casadi.engine.errors import NoGait, PoincareError, ProblemError
from pdw_casadi.fit.core import StepFit
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.starts import select_starts
from pdw_casadi.gait.fixed_point import FixedPointResult, find_fixed_point, stability
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Segment
from pdw_casadi.model.gait_data import GaitCurves
from pdw_casadi.model.problem import Problem

#: the fit's settings of the measurement: no progress lines, the best feasible iterate when
#: the solve stops short, one NLP round (the answer of the first solve is what is measured)
BASE_OPTIONS = {"verbose": False, "keep_best_feasible": True, "rounds": 1}
#: Newton iterations on the simulator's map: at the fit's start, and from the NLP's answer
START_NEWTON, ANSWER_NEWTON = 30, 15


def fit_option_values(items: Sequence[str]) -> dict:
    """``KEY=VALUE`` settings of :class:`~pdw_casadi.fit.FitOptions` fields as a dict (VALUE
    parsed as JSON, else taken as a string; a JSON list becomes a tuple). Raises
    :class:`~pdw_casadi.engine.errors.ProblemError` for a malformed item, an unknown field or
    a value of a kind the field does not take (its annotation: a number for ``int`` or
    ``float``, true or false for ``bool``, null where it may be None, ...)."""
    kinds = {f.name: f.type for f in dataclasses.fields(FitOptions)}
    out = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ProblemError(f"{item!r}: expected KEY=VALUE (a FitOptions field)")
        if key not in kinds:
            raise ProblemError(f"FitOptions has no field {key!r}")
        try:
            value = json.loads(text)
        except ValueError:
            value = text
        if isinstance(value, list):
            value = tuple(value)
        if not _fits(value, str(kinds[key])):
            raise ProblemError(f"FitOptions.{key} = {text}: not a value of its kind "
                               f"({kinds[key]})")
        out[key] = value
    return out


#: the Python types a field's annotation names (a float field takes an integer too)
_KINDS = {"bool": (bool,), "int": (int,), "float": (int, float), "str": (str,),
          "tuple": (tuple,), "dict": (dict,), "None": (type(None),)}


def _fits(value, annotation: str) -> bool:
    """Whether ``value`` is of a kind the annotation (``"int | None"``, ``"tuple[float,
    float]"``) names; an annotation of other kinds takes anything."""
    bases = {part.strip().split("[")[0] for part in annotation.split("|")}
    if not bases <= set(_KINDS):
        return True
    if isinstance(value, bool):  # a bool is an int to Python, not to a setting
        return "bool" in bases
    return isinstance(value, tuple(t for b in bases for t in _KINDS[b]))


def measurement_options(overrides: dict | None = None) -> FitOptions:
    """The fit's settings of the measurement (:data:`BASE_OPTIONS`) with ``overrides``."""
    return FitOptions(**{**BASE_OPTIONS, **(overrides or {})})


def plan_of(res) -> tuple:
    """The simulator's event plan of one step: its segments' phases, knee modes and RK4
    step counts, and its transitions, in order."""
    return tuple((it.phase, it.mode, it.n) if isinstance(it, Segment) else it.name
                 for it in res.sim.steps[0].plan.items)


def henrici(J: np.ndarray, eigenvalues: np.ndarray) -> float:
    """Henrici's relative departure from normality of J (-; 0: normal), from its
    ``eigenvalues``."""
    fro2 = float(np.sum(J * J))
    lam2 = float(np.sum(np.abs(eigenvalues) ** 2))
    return float(np.sqrt(max(fro2 - lam2, 0.0) / fro2))


def conditioning(pmap: PoincareMap, x, p, samples: int = 10) -> dict:
    """The conditioning figures of the module docstring at section state ``x`` (rad,
    rad/s), parameters ``p``: ``residual`` |P(x) - x|, ``rho``, ``sigma_min_I_minus_J``,
    ``inv_norm``, ``max_entry``, ``henrici``, ``newton_step`` |d| (max norms of section-state
    differences, rad and rad/s mixed; the rest dimensionless) and ``path``: per point
    t = k / ``samples`` of the Newton step its ``rho``, ``dJ`` (max change of J since the
    previous point), ``same_plan`` and ``residual`` |P(x + t d) - x - t d|, or the
    simulator's ``failure`` there (the path ends at it)."""
    r = pmap.evaluate(x, p)
    J = r.dx
    n = J.shape[0]
    res = r.x_next - x
    A = np.eye(n) - J
    sv = np.linalg.svd(A, compute_uv=False)
    d = np.linalg.solve(A, res)
    st = stability(J)  # one eigen-decomposition for the radius and Henrici's number
    out = {"residual": float(np.max(np.abs(res))), "rho": st.spectral_radius,
           "sigma_min_I_minus_J": float(sv[-1]), "inv_norm": float(1.0 / sv[-1]),
           "max_entry": float(np.max(np.abs(J))), "henrici": henrici(J, st.eigenvalues),
           "newton_step": float(np.max(np.abs(d))), "path": []}
    plan0, J_prev = plan_of(r), J
    for k in range(1, samples + 1):
        t = k / samples
        try:
            rk = pmap.evaluate(x + t * d, p)
        except PoincareError as e:
            out["path"].append({"t": t, "failure": str(e)})
            break
        out["path"].append({"t": t, "rho": stability(rk.dx).spectral_radius,
                            "dJ": float(np.max(np.abs(rk.dx - J_prev))),
                            "same_plan": plan_of(rk) == plan0,
                            "residual": float(np.max(np.abs(rk.x_next - x - t * d)))})
        J_prev = rk.dx
    return out


@dataclass
class ConditioningRun:
    """What :func:`run_conditioning` measured.

    ``start``: the label of the fit's start; ``status``, ``iterations``, ``wall_time_s``
    (s) and ``objective`` of IPOPT's solve; ``fallback_iteration``: the iteration of the
    best feasible iterate taken when the solve stopped short (None: IPOPT's answer);
    ``state`` x (rad, rad/s) and ``parameters`` p (compliance in its units, slope in rad)
    of the answer, in the problem's order; ``figures``: :func:`conditioning` at (x, p);
    ``newton``: Newton on the simulator's map from x.
    """

    problem: Problem
    start: str
    status: str
    iterations: int
    wall_time_s: float
    objective: float
    fallback_iteration: int | None
    state: np.ndarray
    parameters: np.ndarray
    figures: dict
    newton: FixedPointResult

    @property
    def which(self) -> str:
        """Which point was measured: IPOPT's answer or its best feasible iterate."""
        return ("IPOPT's answer" if self.fallback_iteration is None else
                f"best feasible iterate (iteration {self.fallback_iteration})")


def run_conditioning(problem: Problem, human: GaitCurves, options: FitOptions,
                     samples: int = 10) -> ConditioningRun:
    """Run the fit's first start of ``problem`` on the curves ``human`` with ``options``
    (:func:`measurement_options`) and measure the conditioning of the simulator's step map
    at the NLP's answer (the module docstring), ``samples`` points along the Newton step.
    Raises :class:`~pdw_casadi.engine.errors.NoGait` when the start has no fixed point."""
    start = select_starts(problem, human, options)[0]
    fp0 = find_fixed_point(problem, start.state, start.parameters, max_iter=START_NEWTON,
                           fallback=False)
    if not fp0.converged:
        raise NoGait(f"the start {start.label} of {problem.name} has no fixed point")
    fit = StepFit(problem, human, options, 0, start.label, fp0.spectral_radius,
                  log=lambda m: None)
    nlp = fit.nlp(fp0.state, fp0.parameters)
    out = fit.solver(nlp).solve(nlp.w0)
    u = nlp.unpack(out["w"])
    x, p = np.asarray(u["xs"], float).ravel(), np.asarray(u["p"], float).ravel()
    figures = conditioning(PoincareMap(problem), x, p, samples)
    newton = find_fixed_point(problem, x, p, max_iter=ANSWER_NEWTON, fallback=False)
    return ConditioningRun(problem=problem, start=start.label, status=out["status"],
                           iterations=int(out["iterations"]),
                           wall_time_s=float(out["wall_time_s"]),
                           objective=float(out["objective"]),
                           fallback_iteration=out["fallback_iteration"], state=x,
                           parameters=p, figures=figures, newton=newton)
