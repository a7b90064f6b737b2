"""The scaling workflow: everything ``pdw-scale`` computes, returned as data for the report.

:func:`run_scale` carries a reference walker to a subject's body (:func:`subject_of`: a
bundled subject, or mass, height and sex) and returns a :class:`ScaleRun`: the scaled walker
with its gait as initial state, the gait's spectral radius, how far the continuation got and
how the gait was found. ``--body uniform`` scales the reference's gait by the exact law;
``--body deleva`` reaches the de Leva 1996 body by continuation and then the nearest stable
gait (:func:`~pdw_casadi.studies.scaling.stable_subject_walker`). The report layer
(:mod:`pdw_casadi.report.scale_report`) only renders it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from pdw_casadi.engine.errors import NoGait, ProblemError
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import Problem
from pdw_casadi.studies.scaling import (
    BODY_MAX_RADIUS,
    reference_height,
    reference_mass,
    scale_problem,
    scaled_state,
    stable_subject_walker,
    subject_row,
)

#: the bodies a walker is scaled to: de Leva 1996 (by continuation) or the uniform law
BODIES = ("deleva", "uniform")


@dataclass
class ScaleRun:
    """A walker scaled to a subject and what its report shows (:func:`run_scale`)."""

    #: the reference walker scaled
    reference: Problem
    #: the subject: mass_kg (kg), height_m (m), sex
    subject: dict
    #: one of :data:`BODIES`
    body: str
    #: the scaled walker, its gait as initial state
    problem: Problem
    #: the gait's spectral radius per step (-)
    spectral_radius: float
    #: the continuation's last homotopy parameter lambda (-; 1: the subject reached)
    reached: float
    #: how the gait was found (one line for the problem file's header)
    note: str
    #: wall time of the scaling, s
    wall_time_s: float


def subject_of(subject: str | None, mass_kg: float | None, height_m: float | None,
               sex: str) -> dict:
    """The subject to scale to: the bundled ``subject`` (an ID of
    data/anthropometry/subjects.csv) or ``mass_kg`` (kg), ``height_m`` (m) and ``sex``;
    raises :class:`~pdw_casadi.engine.errors.ProblemError` unless exactly one is given."""
    if subject:
        if mass_kg is not None or height_m is not None:
            raise ProblemError("give either --subject or --mass and --height")
        return subject_row(subject)
    if mass_kg is None or height_m is None:
        raise ProblemError("give --mass and --height (or --subject ID)")
    return {"mass_kg": mass_kg, "height_m": height_m, "sex": sex}


def _uniform(ref: Problem, who: dict, name: str) -> tuple[Problem, float]:
    """The reference's own gait carried to the subject by the exact scaling law."""
    fp0 = find_fixed_point(ref)
    if not fp0.converged:
        raise NoGait(f"no fixed point of {ref.name} near its initial state")
    s = who["height_m"] / reference_height(ref, who["sex"])
    m = who["mass_kg"] / reference_mass(ref)
    pb = scale_problem(ref, s, m, name=name).with_state(scaled_state(ref, fp0.state, s))
    return pb, fp0.spectral_radius


def _deleva_note(res, who: dict, max_radius: float) -> str:
    """How the de Leva body's gait was found."""
    cont = res.continued
    if cont is None:
        return (f"the shipped stable {who['sex']} de Leva body's gait carried by the "
                f"scaling law (exact); stable, valid")
    held = ", ".join(f"{k} held at {v:.4g} from lambda {lam_:g}"
                     for k, (lam_, v) in cont.held.items()) or "none held"
    stab = (f"; then the nearest gait with rho <= {max_radius:g} (the fit's "
            f"stability row on the walker's own curves; the continued gait had rho "
            f"{res.rho_continued:.4f})" if res.stabilised else "")
    return (f"continuation in the body from the uniformly scaled reference ({cont.start}"
            f" gait), {len(cont.path)} points, compliance adapted; validity margins: "
            f"{held}{stab}; stable, valid")


def run_scale(ref: Problem, who: dict, body: str, name: str,
              max_radius: float = BODY_MAX_RADIUS,
              log: Callable[[str], None] | None = None) -> ScaleRun:
    """Scale ``ref`` to the subject ``who`` (:func:`subject_of`) on ``body`` (one of
    :data:`BODIES`), the scaled walker named ``name``; a de Leva body's gait has a spectral
    radius <= ``max_radius`` (-). ``log`` receives the continuation's progress lines.
    Raises :class:`~pdw_casadi.engine.errors.NoGait` when no gait is found."""
    t0 = time.perf_counter()
    if body == "uniform":
        pb, rho = _uniform(ref, who, name)
        lam, note = 1.0, "uniform scaling law (exact)"
    elif body == "deleva":
        res = stable_subject_walker(who["mass_kg"], who["height_m"], who["sex"], ref,
                                    max_radius=max_radius, log=log)
        lam = res.continued.path[-1][0] if res.continued is not None else 1.0
        if res.problem is None:
            raise NoGait(f"{res.reason} (best of {ref.name}'s reference gaits; nothing "
                         f"written)")
        pb, rho = res.problem.replace(name=name), res.spectral_radius
        note = _deleva_note(res, who, max_radius)
    else:
        raise ProblemError(f"unknown body {body!r}: use {' or '.join(BODIES)}")
    return ScaleRun(reference=ref, subject=who, body=body, problem=pb, spectral_radius=rho,
                    reached=lam, note=note, wall_time_s=time.perf_counter() - t0)
