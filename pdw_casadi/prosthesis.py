"""Prosthetic-leg design: the compliance of a lighter leg that makes the gait symmetric.

A below-knee prosthesis is lighter than the limb it replaces. On one physical leg (default
the right) the shank and foot masses and inertias are reduced by a fraction; the walker's
gait then becomes asymmetric. :func:`design_prosthesis` finds the prosthetic leg's free
compliance (ankle and knee) for which the stride's periodic gait has equal left and right
step lengths and step times: continuation from the symmetric walker (lambda = 0) to the
lighter leg (lambda = 1), solving at every step the stride fixed point together with the
symmetry conditions and the least relative change of the free compliance
(:mod:`pdw_casadi.design`, exact AD Jacobians through the stride map).

Stability is read from the stride map: its spectral radius rho_S is the product of two
steps, so sqrt(rho_S) is the per-step radius comparable with a symmetric walker's rho.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

from .design import (
    DesignOptions,
    combined,
    continue_design,
    phase_time_conditions,
    symmetry_conditions,
)
from .problem import Problem, ProblemError
from .stride import (
    StrideMap,
    find_stride_fixed_point,
    physical_parameter_names,
    physical_parameter_vector,
    stride_report,
    with_physical_parameters,
)

#: the prosthetic leg's compliance left free by default (the angles stay)
FREE = ("k_ankle", "c_ankle", "k_knee", "c_knee_flex", "c_knee_ext", "c_knee_stance")
#: the body values of a lighter shank and foot
LIGHTER_KEYS = ("m_s", "J_s", "m_f", "J_f")


def prosthetic_problem(problem: Problem, lighter: float = 0.3, side: str = "right") -> Problem:
    """``problem`` with the ``side`` leg's shank and foot mass and inertia x (1 - lighter)
    (segment geometry and COM positions unchanged)."""
    if not 0.0 <= lighter < 1.0:
        raise ProblemError(f"lighter must lie in [0, 1), got {lighter}")
    _, anthro = problem.leg_values(side)
    legs = {s: {k: dict(v) for k, v in d.items()} for s, d in problem.legs.items()}
    over = legs.setdefault(side, {}).setdefault("anthropometry", {})
    for k in LIGHTER_KEYS:
        over[k] = anthro[k] * (1.0 - lighter)
    return problem.replace(legs=legs)


@dataclass
class ProsthesisResult:
    """The designed walker: ``problem`` (prosthetic leg, designed compliance, the gait's
    section state as initial state), its stride ``fixed_point``, the ``report``
    (:func:`pdw_casadi.stride.stride_report`), the compliance found per free key, the
    continuation path, whether it reached the full mass reduction, and the wall time (s)."""

    problem: Problem
    fixed_point: object
    report: dict
    compliance: dict
    path: list
    reached: bool
    wall_time_s: float

    @property
    def step_radius(self) -> float:
        """sqrt of the stride map's spectral radius: the per-step equivalent (-)."""
        return math.sqrt(self.fixed_point.spectral_radius)


def design_prosthesis(problem: Problem, x0=None, lighter: float = 0.3, side: str = "right",
                      free: Sequence[str] = FREE, hold_first_phase: bool = True,
                      options: DesignOptions | None = None) -> ProsthesisResult:
    """Design the prosthetic leg's compliance (see the module docstring).

    ``problem``: the symmetric walker to start from; ``x0``: its periodic gait's section
    state (default: the stride fixed point near the problem's initial state). ``free``: the
    prosthetic leg's compliance keys to design. ``hold_first_phase``: hold the duration of
    the walker's first phase at its start value in both steps (the 6-link walker's phase
    I lasts a few ms: where it shrinks to zero the trailing toe never lifts and the gait is
    lost); False: symmetry conditions only. The result says how far the continuation got
    (``reached``, ``path``): the gait may meet a gait-pattern boundary before the full
    mass reduction.
    """
    t0 = time.perf_counter()
    if problem.asymmetric:
        raise ProblemError(f"{problem.name}: start from a symmetric walker")
    opts = options or DesignOptions()
    smap = StrideMap(problem)
    if x0 is None:
        fp0 = find_stride_fixed_point(problem, smap=smap, tol=opts.tol)
        if not fp0.converged:
            raise ProblemError(f"{problem.name}: no periodic gait near its initial state")
        x0 = fp0.state
    target = prosthetic_problem(problem, lighter, side)
    names = list(physical_parameter_names(problem))
    theta0 = physical_parameter_vector(problem)
    theta1 = physical_parameter_vector(target)
    first = smap.evaluate(x0, theta0, jacobian=False)
    length_scale = first.sim.steps[0].step_length / 2
    time_scale = first.step_time / 2
    extra = symmetry_conditions(smap, length_scale, time_scale)
    if hold_first_phase:  # keep clear of the boundary where that phase vanishes
        phase = smap.hs.phase_names[0]
        held = sum(d for ph, d in first.steps[0].sim.steps[0].phases if ph == phase)
        extra = combined(extra, phase_time_conditions(smap, phase, held, time_scale))
    idx = [[names.index(f"{side}.{k}")] for k in free]
    run = continue_design(smap, x0, theta0, theta1, idx, extra, opts)
    last = run.last
    designed = with_physical_parameters(target, last.theta)
    designed = designed.replace(
        name=f"{problem.name}_prosthesis",
        initial_state=dict(zip(problem.initial_state, last.state, strict=True)))
    smap_d = StrideMap(designed)
    fp = find_stride_fixed_point(designed, x0=last.state, theta=last.theta, tol=opts.tol,
                                 fallback=False, smap=smap_d)
    report = stride_report(smap_d, fp.state, fp.parameters)
    comp = {k: float(last.theta[names.index(f"{side}.{k}")]) for k in free}
    return ProsthesisResult(designed, fp, report, comp,
                            [(lam, st.copy(), th.copy()) for lam, st, th in run.path],
                            run.reached and fp.converged, time.perf_counter() - t0)


def lighter_mass(problem: Problem, side: str = "right") -> float:
    """Shank + foot mass (kg) of the ``side`` leg relative to the other leg's, -."""
    other = "left" if side == "right" else "right"
    a, b = problem.leg_values(side)[1], problem.leg_values(other)[1]
    return float((a["m_s"] + a["m_f"]) / (b["m_s"] + b["m_f"]))


#: the stable gait of the bundled atlas the prosthesis examples start from (rho 0.83)
START_ENTRY = "humanlike_6link-own-rho0.86"


def atlas_problem(label: str = START_ENTRY) -> Problem:
    """The 6-link problem at the compliance and section state of a bundled atlas entry
    (data/atlas/humanlike_6link.json, :mod:`pdw_casadi.fit.atlas`), by its label."""
    import json

    from .problem import load_problem
    from .resources import bundled_dir

    atlas = json.loads((bundled_dir("data") / "atlas" / "humanlike_6link.json").read_text())
    entry = next((e for e in atlas["entries"] if e["label"] == label), None)
    if entry is None:
        raise ProblemError(f"no atlas entry {label!r}; known: "
                           f"{', '.join(e['label'] for e in atlas['entries'])}")
    return load_problem(atlas["problem"]).with_parameters(entry["parameters"]).with_state(
        entry["state"])
