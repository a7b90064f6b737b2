"""Walkers scaled to a subject: anthropometry from mass, height and sex.

Body-segment parameters come from the adjusted Zatsiorsky-Seluyanov table of

    P. de Leva, "Adjustments to Zatsiorsky-Seluyanov's segment inertia parameters",
    J. Biomech. 29(9):1223-1230, 1996, Table 4 (female and male columns):

segment length (mm, at the table's reference stature), mass (% body mass), centre of mass
(% of the length from the proximal end: thigh from the hip joint centre, shank from the knee
joint centre, foot from the heel) and sagittal radius of gyration (% of the length). The
paper's own body (Table 1, an average 60 kg female from the Handbook of Human Motion) is the
*reference*: its compliance, gait and numerics are carried over.

The walker's foot is a rigid flat sole 0.15 m long with the ankle on the sole line, a model
choice and not the anatomical heel-to-toe length (0.228 m in the table): the foot geometry
and inertia are therefore scaled from Table 1 (lengths by the height ratio, inertia with the
foot mass), and only the foot mass comes from the table. The hip mass is the rest of the body
(head, arms, trunk lumped at the hip).

Dimensional analysis gives the exact law used as the start: with lengths x s, masses x m and
g fixed, the walker's gait is the same in dimensionless form: angles equal, rates x 1/sqrt(s),
times x sqrt(s) (also the integrator step, so the *discrete* map scales exactly), inertias x
m s^2, stiffness x m s, damping x m s^1.5, eigenvalues unchanged. A subject whose
proportions differ from Table 1 is then reached by continuation in the body (anthropometry
is a runtime parameter of the per-leg walker, :func:`pdw_casadi.model.system.per_leg_system`, so no
recompilation).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.fit import FitOptions, fit_gait
from pdw_casadi.fit.starts import load_atlas
from pdw_casadi.gait.curves import cycle_curves
from pdw_casadi.gait.design import DesignOptions, continue_design, phase_time_conditions
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stability import RADIUS_BOUND
from pdw_casadi.model.gait_data import GaitCurves
from pdw_casadi.model.problem import (
    DEFAULT_PROBLEM,
    Problem,
    ProblemError,
    load_problem,
)
from pdw_casadi.model.system import (
    per_leg_system,
    physical_parameter_names,
    physical_parameter_vector,
    with_physical_parameters,
)

#: de Leva (1996), Table 4: reference stature (m), body mass (kg) and per segment
#: (length m, mass fraction, COM fraction from the proximal end, sagittal radius of
#: gyration fraction)
DE_LEVA_1996 = {
    "female": {"stature_m": 1.735, "mass_kg": 61.99,
               "thigh": (0.3685, 0.1478, 0.3612, 0.369),
               "shank": (0.4323, 0.0481, 0.4416, 0.271),
               "foot": (0.2283, 0.0129, 0.4014, 0.299)},
    "male": {"stature_m": 1.741, "mass_kg": 73.00,
             "thigh": (0.4222, 0.1416, 0.4095, 0.329),
             "shank": (0.4340, 0.0433, 0.4459, 0.255),
             "foot": (0.2581, 0.0137, 0.4415, 0.257)},
}
SEXES = tuple(DE_LEVA_1996)

#: compliance keys by physical dimension (the others are angles: unchanged by scaling)
_STIFFNESS = ("k_ankle", "k_knee")
_DAMPING = ("c_ankle", "c_knee_flex", "c_knee_ext", "c_knee_stance")
_LENGTHS = ("l_s", "l_t", "l_f", "l_sc", "l_tc", "l_fc", "l_ft", "l_fh")
_MASSES = ("m_h", "m_t", "m_s", "m_f")
_INERTIAS = ("J_t", "J_s", "J_f")
_RATES = ("dq1", "dq2", "dq3")
#: the largest spectral radius of a subject's body gait per step (dimensionless; the stable
#: bound of pdw-scale and of a cohort's subject bodies, which start their fits): the fit's
#: NLP bound, one margin stricter than a fit's own verdict FitOptions.max_radius (0.90
#: against 0.91; why they differ: pdw_casadi.gait.stability.RADIUS_BOUND)
BODY_MAX_RADIUS = RADIUS_BOUND

#: compliance values adapted on the way to a subject's body (the angles stay)
ADAPTED = ("k_ankle", "c_ankle", "c_knee_flex", "c_knee_ext", "k_knee", "c_knee_stance")


def reference_height(problem: Problem, sex: str = "female") -> float:
    """The stature (m) the reference body stands for: the one at which the table's leg
    (thigh + shank) equals the problem's l_t + l_s (Table 1 gives no stature)."""
    t = DE_LEVA_1996[sex]
    leg = (t["thigh"][0] + t["shank"][0]) / t["stature_m"]
    return (problem.anthropometry["l_t"] + problem.anthropometry["l_s"]) / leg


def reference_mass(problem: Problem) -> float:
    """Total body mass (kg) of a walker problem: hip + two legs."""
    a = problem.anthropometry
    return a["m_h"] + 2 * (a["m_t"] + a["m_s"] + a["m_f"])


#: the adult range of de Leva's (1996) table that a subject's body is scaled within
MASS_RANGE_KG = (20.0, 200.0)
HEIGHT_RANGE_M = (1.2, 2.2)


def check_subject_body(mass_kg, height_m, where: str = "subject") -> None:
    """Raise :class:`ProblemError` unless ``mass_kg`` (kg) and ``height_m`` (m) are finite
    numbers within the table's adult range (:data:`MASS_RANGE_KG`, :data:`HEIGHT_RANGE_M`)."""
    (m0, m1), (h0, h1) = MASS_RANGE_KG, HEIGHT_RANGE_M
    try:
        mass, height = float(mass_kg), float(height_m)
    except (TypeError, ValueError):
        raise ProblemError(f"{where}: mass {mass_kg!r} kg / height {height_m!r} m must be "
                           f"numbers") from None
    if not (m0 <= mass <= m1 and h0 <= height <= h1):  # NaN fails both
        raise ProblemError(f"{where}: mass {mass_kg} kg / height {height_m} m outside the "
                           f"adult range of the table ({m0:g}-{m1:g} kg, {h0:g}-{h1:g} m)")


def subject_anthropometry(mass_kg: float, height_m: float, sex: str = "female",
                          reference: Problem | None = None) -> dict[str, float]:
    """The 6-link walker's anthropometry (m, kg, kg m^2) for a subject, from de Leva (1996)
    for thigh and shank (length, mass, COM, inertia) and the foot mass; foot geometry and
    inertia from the reference body (Table 1) scaled to the subject (see module docstring)."""
    if sex not in DE_LEVA_1996:
        raise ProblemError(f"sex must be one of {', '.join(SEXES)}, got {sex!r}")
    check_subject_body(mass_kg, height_m)
    ref = reference or load_problem(DEFAULT_PROBLEM)
    r = ref.anthropometry
    t = DE_LEVA_1996[sex]
    k = height_m / t["stature_m"]
    out: dict[str, float] = {}
    for seg, (L, mf, cm, rg) in (("t", t["thigh"]), ("s", t["shank"])):
        length = L * k
        mass = mf * mass_kg
        out[f"l_{seg}"] = length
        out[f"m_{seg}"] = mass
        # COM measured from the distal joint in the walker (thigh: from the knee; shank:
        # from the ankle); the table measures from the proximal end
        out[f"l_{seg}c"] = (1.0 - cm) * length
        out[f"J_{seg}"] = mass * (rg * length) ** 2
    s = height_m / reference_height(ref, sex)
    out["m_f"] = t["foot"][1] * mass_kg
    for key in ("l_f", "l_fc", "l_ft", "l_fh"):
        out[key] = r[key] * s
    out["J_f"] = r["J_f"] * (out["m_f"] / r["m_f"]) * s**2
    out["m_h"] = mass_kg - 2 * (out["m_t"] + out["m_s"] + out["m_f"])
    return {key: out[key] for key in r}


def scale_problem(problem: Problem, s: float, m: float, name: str | None = None) -> Problem:
    """``problem`` under the uniform scaling law: lengths x s, masses x m (g fixed).

    The initial state and the numerics scale with it (rates x 1/sqrt(s), the integrator
    step and the phase time limit x sqrt(s)), so a fixed point of ``problem`` maps onto a
    fixed point of the result exactly, with the same eigenvalues.
    """
    if not (s > 0 and m > 0):
        raise ProblemError(f"scale factors must be positive, got s = {s}, m = {m}")
    rt = math.sqrt(s)
    law = {**{k: s for k in _LENGTHS}, **{k: m for k in _MASSES},
           **{k: m * s**2 for k in _INERTIAS}, **{k: m * s for k in _STIFFNESS},
           **{k: m * s**1.5 for k in _DAMPING}}

    def scaled(values):
        return {k: v * law.get(k, 1.0) for k, v in values.items()}

    legs = {side: {sec: scaled(vals) for sec, vals in d.items()}
            for side, d in problem.legs.items()}
    bounds = {k: (lo * law.get(k, 1.0), hi * law.get(k, 1.0))
              for k, (lo, hi) in problem.compliance_bounds.items()}
    state = {k: v / rt if k in _RATES else v for k, v in problem.initial_state.items()}
    numerics = {k: v * rt for k, v in problem.numerics.items()}
    validity = dict(problem.validity)
    validity["min_normal_force"] = validity.get("min_normal_force", 0.0) * m
    for k in ("min_clearance", "min_cop_margin"):
        validity[k] = validity.get(k, 0.0) * s
    return problem.replace(name=name or f"{problem.name}_scaled",
                           anthropometry=scaled(problem.anthropometry),
                           compliance=scaled(problem.compliance), compliance_bounds=bounds,
                           legs=legs, initial_state=state, numerics=numerics,
                           validity=validity)


def scaled_state(problem: Problem, x, s: float) -> np.ndarray:
    """A section state of ``problem``'s 6-link walker under the scaling law (rates (rad/s)
    x 1/sqrt(s), angles unchanged)."""
    x = np.asarray(x, float).copy()
    names = list(problem.state_names)
    x[[names.index(k) for k in _RATES]] /= math.sqrt(s)
    return x


@dataclass
class SubjectResult:
    """A subject's walker: the problem (with the fixed point as its initial state), the
    fixed point, the continuation path [(lambda, state, theta)] (lambda 0 = the uniformly
    scaled reference, 1 = the subject), the wall time (s), whether lambda = 1 was
    reached with a fixed point (valid or not: ``fixed_point.valid``), the validity
    margins held on the way (key -> (lambda, held value)) and the label of the reference
    gait it started from."""

    problem: Problem
    fixed_point: object
    path: list = field(default_factory=list)
    wall_time_s: float = 0.0
    reached: bool = False
    held: dict = field(default_factory=dict)
    start: str = "own"


def walker_for_subject(mass_kg: float, height_m: float, sex: str = "female",
                       reference: Problem | None = None, x_ref=None,
                       adapt: Sequence[str] | None = ADAPTED,
                       options=None, hold_first_phase: bool = True) -> SubjectResult:
    """The reference walker moved onto a subject's body, with its periodic gait.

    1. The reference gait (``x_ref``, else the fixed point near the problem's state) is
       carried exactly to the uniformly scaled body (s = height / reference height, m =
       mass / reference mass), compliance scaled by the law.
    2. The body then moves linearly from that one (lambda = 0) to the subject's de Leva body
       (lambda = 1) by continuation (:func:`pdw_casadi.gait.design.continue_design`): at every
       step the fixed point is solved together with the least relative change of the
       ``adapt`` compliance values (both legs alike). The paper's gait is so sensitive to
       the body that at fixed compliance it is lost within a thousandth of that path; the
       compliance is what "adapts the walker to a weight and leg length". ``adapt=None``
       keeps the compliance fixed (plain Newton continuation). ``options``: the solver's
       :class:`~pdw_casadi.gait.design.DesignOptions` (tolerance, continuation steps; by
       default validity margins that would break are held, ``hold_margins``: a longer
       shank leaves the swing toe less clearance). ``hold_first_phase``: hold the
       duration of the walker's first phase at its start value (the 6-link gait's phase I
       lasts a few ms; where it vanishes the trailing toe never lifts and the gait is
       lost).
    """
    t0 = time.perf_counter()
    opts = options or DesignOptions(hold_margins=True)
    tol = opts.tol
    ref = reference or load_problem(DEFAULT_PROBLEM)
    if ref.asymmetric:
        raise ProblemError(f"{ref.name}: the reference body must be symmetric")
    if x_ref is None:
        fp0 = find_fixed_point(ref, tol=tol)
        if not fp0.converged:
            raise ProblemError(f"{ref.name}: no fixed point near its initial state")
        x_ref = fp0.state
    s = height_m / reference_height(ref, sex)
    m = mass_kg / reference_mass(ref)
    uni = scale_problem(ref, s, m, name=f"subject_{sex}_{mass_kg:g}kg_{height_m:g}m")
    target = uni.replace(anthropometry=subject_anthropometry(mass_kg, height_m, sex, ref))
    hs = per_leg_system(uni)
    names = list(physical_parameter_names(uni))
    theta0, theta1 = physical_parameter_vector(uni), physical_parameter_vector(target)
    pmap = PoincareMap(uni, hs)  # symmetric body: the step map of the per-leg walker
    free = [[names.index(f"{side}.{k}") for side in ("left", "right")] for k in (adapt or ())]
    x_uni = scaled_state(ref, x_ref, s)
    extra = None
    if hold_first_phase:
        first = pmap.evaluate(x_uni, theta0)
        phase = hs.phase_names[0]
        extra = phase_time_conditions(None, phase, first.phase_times[phase][0],
                                      first.step_time)
    run = continue_design(pmap, x_uni, theta0, theta1, free, extra, opts)
    last = run.last
    body = with_physical_parameters(uni, last.theta)
    body = body.replace(initial_state=dict(zip(uni.initial_state, last.state, strict=True)))
    fp = find_fixed_point(body, x0=last.state, p=last.theta, tol=tol, fallback=False,
                          pmap=PoincareMap(body, hs))
    return SubjectResult(body, fp, [(lam, st.copy(), th.copy()) for lam, st, th in run.path],
                         time.perf_counter() - t0, run.reached and fp.converged,
                         run.held)


def reference_gaits(reference: Problem) -> list[tuple[str, Problem]]:
    """The reference walker's gaits a subject's walker may start from: its own, then the
    stable gaits of its bundled atlas (:mod:`pdw_casadi.fit.starts`), most stable first,
    as (label, problem at that gait's compliance and state)."""
    entries = sorted(load_atlas(reference), key=lambda e: e.spectral_radius)
    return [("own", reference)] + [
        (e.label, reference.with_parameters(e.parameters).with_state(e.state))
        for e in entries]


def subject_walker(mass_kg: float, height_m: float, sex: str = "female",
                   reference: Problem | None = None, log=None,
                   own_last: bool = False) -> SubjectResult:
    """:func:`walker_for_subject` from each of :func:`reference_gaits` in turn until one
    reaches the subject's body with a valid gait; else the attempt that got furthest.
    ``log``: called with a line per attempt. ``own_last``: try the atlas gaits (the most
    stable first) before the reference's own (the paper's Table 3 gait sits next to a fold;
    for 62.45 kg, 1.695 m its continuation stops at lambda 0.578 after 94 s, the atlas's
    rho 0.86 gait gets there in 62 s, 2 shared cores)."""
    ref = reference or load_problem(DEFAULT_PROBLEM)
    best = None
    t0 = time.perf_counter()
    gaits = reference_gaits(ref)
    if own_last:
        gaits = gaits[1:] + gaits[:1]
    for label, start in gaits:
        fp0 = find_fixed_point(start)
        if not (fp0.converged and fp0.valid):
            continue
        res = walker_for_subject(mass_kg, height_m, sex, start, fp0.state)
        res.start = label
        if log is not None:
            log(f"from the {label} gait: lambda {res.path[-1][0]:.4f}"
                f"{' (reached)' if res.reached else ''}, {res.wall_time_s:.1f} s")
        if best is None or res.path[-1][0] > best.path[-1][0] or res.reached:
            best = res
        if res.reached:
            break
    if best is None:
        raise ProblemError(f"{ref.name}: no valid reference gait to start from")
    best.wall_time_s = time.perf_counter() - t0
    return best


#: the body keys the de Leva scaling sets (:func:`subject_anthropometry`)
SCALED_BODY = ("l_t", "l_s", "l_tc", "l_sc", "m_t", "m_s", "J_t", "J_s", "m_f", "l_f", "l_fc",
               "l_ft", "l_fh", "J_f", "m_h")


def check_scalable(problem: Problem) -> None:
    """Raise :class:`ProblemError` unless ``problem``'s walker can be scaled to a subject:
    the 6-link body (:data:`SCALED_BODY`), both legs alike, a per-leg walker (the body as a
    runtime parameter of the continuation)."""
    missing = [k for k in SCALED_BODY if k not in problem.anthropometry]
    if missing:
        raise ProblemError(f"{problem.name} ({problem.family}) cannot be scaled to a subject: "
                           f"the de Leva scaling needs the 6-link body; no "
                           f"{', '.join(missing)} (e.g. humanlike_6link has it)")
    if problem.asymmetric:
        raise ProblemError(f"{problem.name}: the reference body must be symmetric")
    if per_leg_system(problem) is None:
        raise ProblemError(f"{problem.name} ({problem.family}): no per-leg walker to carry "
                           f"the gait onto a subject's body")


def own_curves(problem: Problem, x, p):
    """The gait-cycle curves of ``problem``'s gait through ``x`` at parameters ``p`` as a
    target (:class:`~pdw_casadi.model.gait_data.GaitCurves`), or None when the step fails."""
    c = cycle_curves(Simulator(problem), x, p)
    if c is None:
        return None
    frame = pd.DataFrame({"cycle_pct": c.cycle_pct, "hip_mean_deg": c.hip_deg,
                          "knee_mean_deg": c.knee_deg, "thigh_mean_deg": c.thigh_deg})
    return GaitCurves(frame, Path(f"<{problem.name} own gait>"), f"{problem.name} own gait")


@dataclass
class StableSubject:
    """A subject's walker with a stable gait, or why there is none.

    ``problem``: the walker on the subject's body with the stable gait as its initial state
    (None when ``status`` is "failed", ``reason`` then says why); ``spectral_radius`` of that
    gait; ``continued``: the :class:`SubjectResult` of the continuation; ``rho_continued``:
    the spectral radius where the continuation ended; ``stabilised``: whether the nearest
    stable gait had to be fitted (:func:`nearest_stable_gait`); wall times (s)."""

    problem: Problem | None
    status: str
    reason: str = ""
    spectral_radius: float = math.nan
    valid: bool = False
    continued: SubjectResult | None = None
    rho_continued: float = math.nan
    stabilised: bool = False
    continuation_s: float = 0.0
    stabilise_s: float = 0.0

    def record(self) -> dict:
        """The JSON-ready facts (no problem)."""
        c = self.continued
        return {"status": self.status, "reason": self.reason,
                "spectral_radius": self.spectral_radius, "valid": self.valid,
                "continuation_start": None if c is None else c.start,
                "continuation_lambda": None if c is None or not c.path else c.path[-1][0],
                "continuation_points": None if c is None else len(c.path),
                "rho_continued": self.rho_continued, "stabilised": self.stabilised,
                "continuation_s": self.continuation_s, "stabilise_s": self.stabilise_s}


def nearest_stable_gait(problem: Problem, max_radius: float = BODY_MAX_RADIUS, options=None):
    """The stable (rho <= ``max_radius``), valid gait of ``problem``'s walker whose knee and
    hip curves are closest (R^2) to those of its gait through its initial state: the fit
    (:func:`~pdw_casadi.fit.fit_gait`, its stability row) with the walker's own curves as
    the target, from that gait, compliance free. Returns the fit's best
    :class:`~pdw_casadi.fit.Candidate` (None when it found none)."""
    fp = find_fixed_point(problem, fallback=False)
    if not fp.converged:
        raise ProblemError(f"{problem.name}: no fixed point near its initial state")
    target = own_curves(problem, fp.state, fp.parameters)
    if target is None:
        raise ProblemError(f"{problem.name}: its gait's step fails")
    opts = options or FitOptions(max_radius=max_radius, atlas="", verbose=False,
                                 knee_floor=None)
    return fit_gait(problem, target, opts, log=lambda m: None).best


#: the walker the shipped de Leva bodies (data/bodies/deleva_<sex>.toml) were built from
SHIPPED_BODY_REFERENCE = "humanlike_6link"


def shipped_body(sex: str) -> Problem | None:
    """The shipped stable gait on de Leva's body of ``sex`` (data/bodies), or None."""
    path = bundled_dir("data") / "bodies" / f"deleva_{sex}.toml"
    return load_problem(path) if path.is_file() else None


def scaled_shipped_body(mass_kg: float, height_m: float, sex: str, reference: Problem,
                        max_radius: float = BODY_MAX_RADIUS) -> StableSubject | None:
    """The subject's de Leva body with a stable gait by the scaling law from the shipped
    body of that sex: de Leva's segment lengths and masses are fractions of height and
    mass, so every body of one sex is the same walker in dimensionless form, and the shipped
    gait scaled (lengths x s, masses x m, times x sqrt(s)) is a gait of the subject's body
    with the same spectral radius. None when no body of that sex is shipped, the reference
    is not the walker it was built from (same family and name, same compliance keys), or
    the scaled gait is not a stable (rho <= ``max_radius``), valid fixed point."""
    body = shipped_body(sex)
    if body is None or reference.name != SHIPPED_BODY_REFERENCE or \
            reference.family != body.family or \
            set(reference.compliance) != set(body.compliance):
        return None
    fp0 = find_fixed_point(body, fallback=False)
    if not fp0.converged:
        return None
    s = height_m / reference_height(body, sex)
    m = mass_kg / reference_mass(body)
    pb = scale_problem(body, s, m, name=f"subject_{sex}_{mass_kg:g}kg_{height_m:g}m")
    pb = pb.with_state(scaled_state(body, fp0.state, s))
    fp = find_fixed_point(pb, fallback=False)
    if not (fp.converged and fp.stable and fp.valid and fp.spectral_radius <= max_radius):
        return None
    return StableSubject(pb.with_state(fp.state), "accepted", spectral_radius=fp.spectral_radius,
                         valid=True, rho_continued=fp.spectral_radius)


def stable_subject_walker(mass_kg: float, height_m: float, sex: str = "female",
                          reference: Problem | None = None, max_radius: float = BODY_MAX_RADIUS,
                          log=None) -> StableSubject:
    """The reference walker on a subject's de Leva body with a stable, valid gait.

    0. :func:`scaled_shipped_body`: when a stable body of the subject's sex is shipped for
       this reference, its gait carried exactly by the scaling law (no continuation, no NLP).
    1. :func:`subject_walker`: the reference's gaits, each carried exactly to the uniformly
       scaled body by the scaling law, then by continuation to the subject's proportions
       (compliance adapted), until one gets there with a valid gait. The gait it ends on
       is a fixed point but may be unstable (rho 1.013 for 62.45 kg, 1.695 m).
    2. If its spectral radius exceeds ``max_radius``: :func:`nearest_stable_gait`, the
       fit's stability row pulling the gait inside the stable region at the least change
       of its curves.
    Never raises for a subject without a stable gait: ``status`` "failed" and ``reason``.
    """
    ref = reference or load_problem(DEFAULT_PROBLEM)
    check_scalable(ref)
    t0 = time.perf_counter()
    shipped = scaled_shipped_body(mass_kg, height_m, sex, ref, max_radius)
    if shipped is not None:
        if log is not None:
            log(f"from the shipped stable {sex} de Leva body, by the scaling law (exact)")
        shipped.continuation_s = time.perf_counter() - t0
        return shipped
    cont = subject_walker(mass_kg, height_m, sex, ref, log=log, own_last=True)
    t1 = time.perf_counter()
    fp = cont.fixed_point
    out = StableSubject(None, "failed", continued=cont, continuation_s=t1 - t0,
                        rho_continued=fp.spectral_radius if fp.converged else math.nan)
    if not cont.reached:
        out.reason = (f"the continuation to the subject's body stopped at lambda = "
                      f"{cont.path[-1][0]:.4f}")
        return out
    body = cont.problem
    if fp.stable and fp.valid and fp.spectral_radius <= max_radius:
        out.problem, out.status = body, "accepted"
        out.spectral_radius, out.valid = fp.spectral_radius, True
        return out
    if log is not None:
        log(f"the gait on the subject's body has spectral radius {fp.spectral_radius:.4f}; "
            f"fitting the nearest gait with rho <= {max_radius:g}")
    best = nearest_stable_gait(body, max_radius)
    out.stabilised, out.stabilise_s = True, time.perf_counter() - t1
    if best is None:
        out.reason = (f"no stable valid gait (rho <= {max_radius:g}) near the continued one "
                      f"(rho {fp.spectral_radius:.4f})")
        return out
    out.problem = body.with_parameters(best.parameters).with_state(best.state)
    out.status, out.spectral_radius = "accepted", best.fixed_point.spectral_radius
    out.valid = bool(best.valid)
    return out


SUBJECTS_FILE = "anthropometry/subjects.csv"


def subject_row(subject_id: str) -> dict:
    """Mass (kg), height (m) and sex of a bundled subject (data/anthropometry/subjects.csv,
    WBDS metadata)."""
    path = bundled_dir("data") / SUBJECTS_FILE
    table = pd.read_csv(path)
    missing = [c for c in ("subject_id", "mass_kg", "height_m", "sex") if c not in table]
    if missing:
        raise ProblemError(f"{path}: the subjects table has no column "
                           f"{', '.join(missing)}")
    row = table[table["subject_id"] == subject_id]
    if row.empty:
        raise ProblemError(f"unknown subject {subject_id!r}; known: "
                           f"{', '.join(table['subject_id'])}")
    r = row.iloc[0]
    sex = {"F": "female", "M": "male"}.get(str(r["sex"]), str(r["sex"]))
    if sex not in SEXES:
        raise ProblemError(f"{path}: subject {subject_id}: sex must be F or M, got "
                           f"{r['sex']!r}")
    check_subject_body(r["mass_kg"], r["height_m"], f"{path}: subject {subject_id}")
    return {"mass_kg": float(r["mass_kg"]), "height_m": float(r["height_m"]), "sex": sex}
