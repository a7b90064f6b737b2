"""The seed searches of ``pdw-seed``: a first gait of a walker whose fits need one, returned
as data for the report.

A fit follows the event pattern of its starting gait, so a walker whose shipped gait lacks
a feature (rounded feet, heel off) needs a seed that has it. Three searches:

- :func:`run_arc_seed` (``arc``): a gait of the rolling-foot walker
  (``humanlike_6link_arc``) at nonzero toe and heel radii. The start is the ankle walker's
  shipped gait carried to the rolling-foot walker at r_toe = r_heel = 0, where it is the
  same gait; at its compliance the gait leaves its validity margins within micrometres of
  radius (the phase-I stance normal force sits on its 5 N bound), so the search carries it
  to the radii by the design continuation (:func:`~pdw_casadi.gait.design.continue_design`:
  the radii move linearly from 0 to the targets, the fixed point and every other
  compliance value, relative change, least norm, are the unknowns, and a validity margin
  that would break is held at its requirement + 10 %). The end point, its compliance put
  back inside the problem's bounds, is re-solved by Newton.
- :func:`run_heeloff_seed` (``heeloff``): a first heel-off gait of the forefoot-rocker
  walker (``humanlike_6link_heeloff``), from the ankle walker's shipped gait carried to
  that family, in three stages; every NLP has all validity margins and the periodicity as
  constraints and all compliance free within the problem's bounds
  (:class:`~pdw_casadi.nlp.shooting.ShootingNLP`): *push* (rounds of the NLP minimising the
  heel-off event at the end of phase II, the stance foot's centre-of-pressure distance from
  its toe times its normal force in N m, until it is below the threshold; with
  ``stability`` the NLP is the fit's, :class:`~pdw_casadi.fit.driver.FitSolver`: curves,
  timing target, stability bound, with ``weight`` times the event added), *cross*
  (natural-parameter continuation of the fixed point in ``k_clutch`` until the step has the
  toe-rocker phase II_toe) and *lengthen* (rounds of the NLP maximising the duration of
  II_toe until it lasts ``lengthen_ms``).
- :func:`run_toes_scan` and :func:`run_toes_continuation` (``toes``): heel-off gaits of the
  toe-foot walker (``humanlike_toes``) and what stops them. The scan samples the compliance
  values of :data:`TOES_RANGES` (uniformly, within the problem's bounds) at the problem's
  section state, simulates one step from each and tallies how every step ended, and how the
  steps whose stance heel lifted in single support (phase II_mtp) ended; for every whole
  step with heel off it solves for the fixed point (Newton from the step's end state) and
  records its phases, gait timing, spectral radius, eigenvalues and validity, best (stable,
  valid, heel off in 25-40 %) first. The continuation follows the problem's fixed point in
  one parameter (spectral radius, eigenvalues and the stance heel's load along the way).

Each returns a :class:`SeedRun`: its record (the JSON the report writes: the fixed point
``fixed_point`` and ``compliance`` that ``pdw-fit --state FILE --compliance FILE`` read)
and whether it found its gait. :func:`check_arc_request` and :func:`check_toes_request`
check a request against its walker before any work. The files and lines are rendered by
:mod:`pdw_casadi.report.seed_report`.
"""

from __future__ import annotations

import collections
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from pdw_casadi.engine.errors import NoGait, ProblemError
from pdw_casadi.gait.design import DesignOptions, continue_design
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stability import RADIUS_BOUND
from pdw_casadi.gait.timing import fixed_point_timing, gait_timing, phase_contacts
from pdw_casadi.model.feet.flat import SINGLE_SUPPORT
from pdw_casadi.model.feet.toes import SINGLE_SUPPORT_PHASES
from pdw_casadi.model.gait_data import GaitCurves
from pdw_casadi.model.problem import Problem, check_bounds, load_problem
from pdw_casadi.nlp.driver import IPOPT_TOL
from pdw_casadi.nlp.shooting import ShootingNLP

#: the searches of ``pdw-seed``
SEARCHES = ("arc", "heeloff", "toes")
#: where the arc and heel-off searches start: the ankle walker's shipped gait
ANKLE_PROBLEM = "humanlike_6link_ankle"
#: the compliance keys of the rolling feet's radii (m)
ARC_RADII = ("r_toe", "r_heel")

Log = Callable[[str], None]


def _quiet(line: str) -> None:
    """A log that drops its lines."""


@dataclass
class SeedRun:
    """What a seed search found.

    ``search``: one of :data:`SEARCHES` (``"toes-continuation"`` for the toe walker's
    continuation); ``problem``: the walker searched (units of the record's names);
    ``record``: the JSON content of the search (SI units: rad, rad/s, s, m, N m; gait
    timing in % of the cycle); ``found``: whether the search ended on the gait it looks for
    (a converged fixed point), the record being written either way.
    """

    search: str
    problem: Problem
    record: dict
    found: bool = True


# -- arc -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ArcRequest:
    """The rolling-foot seed's targets: the toe and heel arc radii ``r_toe``, ``r_heel``
    (m) and the continuation's ``n_min`` steps at least."""

    r_toe: float
    r_heel: float
    n_min: int = 10


def arc_start_problem() -> Problem:
    """The rolling-foot walker at the ankle walker's shipped gait and compliance, radii 0."""
    ankle = load_problem(ANKLE_PROBLEM)
    return load_problem("humanlike_6link_arc").replace(
        compliance={**ankle.compliance, "r_toe": 0.0, "r_heel": 0.0},
        slope=ankle.slope).with_state(ankle.state_vector())


def check_arc_request(request: ArcRequest) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless the radii lie within
    the rolling-foot walker's bounds."""
    problem = load_problem("humanlike_6link_arc")
    for key, flag in (("r_toe", "--r-toe"), ("r_heel", "--r-heel")):
        value = getattr(request, key)
        check_bounds(problem, {key: value}, f"{flag} {value:g}")


def run_arc_seed(request: ArcRequest, log: Log = _quiet) -> SeedRun:
    """Carry the ankle walker's gait to the radii of ``request`` (the module docstring);
    ``log`` gets the continuation's line. ``found``: Newton converged at the end point."""
    pb = arc_start_problem()
    names = pb.parameter_names
    theta0 = pb.parameter_vector()
    theta1 = theta0.copy()
    theta1[names.index("r_toe")], theta1[names.index("r_heel")] = request.r_toe, request.r_heel
    # every compliance value but the radii is free (relative change); the slope is held
    free = [[i] for i, n in enumerate(names) if n not in (*ARC_RADII, "slope") and theta0[i] != 0]
    opts = DesignOptions(hold_margins=True, n_min=request.n_min)
    path = continue_design(PoincareMap(pb), pb.state_vector(), theta0, theta1, free,
                           options=opts)
    lam = path.path[-1][0]
    log(f"continuation reached lambda = {lam:.4f} ({len(path.path)} points, "
        f"{path.wall_time_s:.0f} s); held: {sorted(path.held)}")
    x, theta = path.last.state, path.last.theta.copy()
    # the design does not know the fit's bounds: a value that drifted past one (ankle_rest
    # starts on its 0.6 rad bound) is put back on it before the fixed point is re-solved
    for i, n in enumerate(names[:-1]):
        lo, hi = pb.compliance_bounds.get(n, (-np.inf, np.inf))
        theta[i] = min(max(theta[i], lo), hi)
    fp = find_fixed_point(pb, x, theta, tol=1e-10)
    t = fixed_point_timing(pb, fp.state, theta)
    comp, slope = pb.split_parameters(theta)
    record = {"lambda": lam, "reached": path.reached, "wall_time_s": path.wall_time_s,
              "held": {k: list(v) for k, v in path.held.items()},
              "fixed_point": fp.state_dict(), "compliance": comp, "slope": slope,
              "converged": fp.converged, "spectral_radius": fp.spectral_radius,
              "valid": fp.valid, "failure": fp.failure, "margins": fp.margins,
              "double_support_pct": list(t.double_support_pct) if t else None,
              "stance_pct": t.stance_pct if t else None,
              "phase_durations_s": dict(t.phase_durations_s) if t else None}
    return SeedRun("arc", pb, record, found=bool(fp.converged))


# -- heel off ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class HeelOffRequest:
    """The heel-off seed's settings: push with the fit's NLP (``stability``: the curves of
    ``gait``, the timing target, the stability bound, ``weight`` in 1/(N m) times the
    heel-off event added), ``rounds`` NLP rounds per stage at most, ``max_iter`` IPOPT
    iterations per round, the heel-off margin ``threshold`` (N m) that ends the push, the
    ``k_clutch`` continuation ``step`` (N m/rad) and its ``max_steps``, the II_toe duration
    ``lengthen_ms`` (ms) the lengthening stage aims at (0: skip it)."""

    stability: bool = False
    gait: str = "female_fast.csv"
    weight: float = 1.0
    rounds: int = 12
    max_iter: int = 50
    threshold: float = 0.05
    step: float = 0.01
    max_steps: int = 500
    lengthen_ms: float = 15.0


def heeloff_start_problem() -> Problem:
    """The forefoot-rocker walker at the ankle walker's shipped gait and compliance."""
    ankle = load_problem(ANKLE_PROBLEM)
    return load_problem("humanlike_6link_heeloff").replace(
        compliance=dict(ankle.compliance), slope=ankle.slope).with_state(ankle.state_vector())


def heel_off_margin(nlp) -> ca.MX:
    """The heel-off event (N m) at the last RK4 sample of the NLP's last phase-II segment."""
    k = max(i for i, s in enumerate(nlp.specs) if s.phase == SINGLE_SUPPORT)
    names = nlp.output_names(SINGLE_SUPPORT)
    events = [e.name for e in nlp.hs.event_list[SINGLE_SUPPORT]]
    return nlp.Y[k][len(names) - len(events) + events.index("heel_off"), -1]


def toe_rocker_time(nlp) -> ca.MX:
    """The duration (s) of phase II_toe in the NLP's step."""
    return sum(nlp.T[k] for k, s in enumerate(nlp.specs) if s.phase == "II_toe")


def solve_seed_nlp(nlp, objective, max_iter: int):
    """IPOPT (L-BFGS) on the NLP's constraints with ``objective``: the unpacked answer and
    IPOPT's return status."""
    lo, hi = nlp.bounds()
    solver = ca.nlpsol("seed", "ipopt", {"x": nlp.w, "f": objective, "g": nlp.g},
                       {"ipopt": {"hessian_approximation": "limited-memory",
                                  "max_iter": max_iter, "print_level": 0, "sb": "yes",
                                  "tol": IPOPT_TOL, "mu_strategy": "adaptive"},
                        "print_time": False})
    sol = solver(x0=nlp.w0, lbx=lo, ubx=hi, lbg=nlp.lbg, ubg=nlp.ubg)
    return nlp.unpack(sol["x"].full()), solver.stats()["return_status"]


def _push_round(pb, x, p, request: HeelOffRequest, human: GaitCurves | None):
    """One push round from the fixed point (x, p): (section state, parameters, status)."""
    nlp = ShootingNLP(pb, x, p, free=tuple(pb.compliance_names), headroom_s=0.05)
    if human is None:
        u, status = solve_seed_nlp(nlp, heel_off_margin(nlp), request.max_iter)
        return u["xs"], u["p"], status
    # deferred: the fit stack, only for heeloff --stability (the seed's own NLP needs none)
    from pdw_casadi.fit.driver import FitSolver
    from pdw_casadi.fit.options import FitOptions

    opts = FitOptions(timing_weight=1.0, max_iter=request.max_iter, verbose=False)
    out = FitSolver(nlp, human, opts, log=lambda m: None,
                    extra=lambda n: request.weight * heel_off_margin(n)).solve(nlp.w0)
    u = nlp.unpack(out["w"])
    return u["xs"], u["p"], out["status"]


def _phases_of(sim, x, p) -> dict[str, float]:
    """The phase durations (s) of the step from x, {} when it fails."""
    run = sim.run(x, p, steps=1, record=False)
    return {} if run.failure is not None else dict(run.steps[0].phases)


def _margin_of(sim, x, p) -> float:
    """The heel-off event's smallest value in phase II of the step from x (N m)."""
    run = sim.run(x, p, steps=1, record=True)
    ii = run.trajectory[run.trajectory.phase == SINGLE_SUPPORT]
    return float((ii.cop_foot1_from_toe * ii.N_foot1).min())


def _push(pb, sim, x, p, request: HeelOffRequest, human, log: Log):
    """The push stage: NLP rounds until the heel-off margin is below the threshold."""
    for rnd in range(request.rounds):
        x, p, status = _push_round(pb, x, p, request, human)
        fp = find_fixed_point(pb, x, p, fallback=False)
        if not fp.converged:
            raise NoGait(f"push round {rnd}: the answer has no fixed point")
        x = fp.state
        margin = _margin_of(sim, x, p)
        log(f"push round {rnd}: {status}, heel-off margin {margin:.4g} N m, rho "
            f"{fp.spectral_radius:.3g}, valid {fp.valid}")
        if margin < request.threshold:
            break
    return x, p


def _cross(pb, sim, x, p, request: HeelOffRequest, log: Log):
    """The cross stage: continuation in k_clutch until the step has phase II_toe."""
    i = list(pb.parameter_names).index("k_clutch")
    for n in range(request.max_steps):
        if "II_toe" in _phases_of(sim, x, p):
            break
        q = p.copy()
        q[i] += request.step
        fp = find_fixed_point(pb, x, q, fallback=False, max_iter=15)
        if not fp.converged:
            raise NoGait(f"cross step {n}: no fixed point at k_clutch {q[i]:.4g}")
        x, p = fp.state, q
    else:
        raise NoGait("no heel off within the continuation steps")
    log(f"cross: heel off at k_clutch {p[i]:.6g} N m/rad")
    return x, p


def _lengthen(pb, sim, x, p, request: HeelOffRequest, log: Log):
    """The lengthen stage: NLP rounds maximising the duration of II_toe."""
    for rnd in range(request.rounds if request.lengthen_ms > 0 else 0):
        if _phases_of(sim, x, p).get("II_toe", 0.0) >= 1e-3 * request.lengthen_ms:
            break
        nlp = ShootingNLP(pb, x, p, free=tuple(pb.compliance_names), headroom_s=0.08)
        u, status = solve_seed_nlp(nlp, -100.0 * toe_rocker_time(nlp), request.max_iter)
        fp = find_fixed_point(pb, u["xs"], u["p"], fallback=True)
        ph = _phases_of(sim, fp.state, u["p"]) if fp.converged else {}
        log(f"lengthen round {rnd}: {status}, fixed point {fp.converged}, II_toe "
            f"{1e3 * ph.get('II_toe', 0.0):.1f} ms, rho {fp.spectral_radius:.3g}")
        if "II_toe" not in ph:
            break  # keep the last gait with heel off
        x, p = fp.state, u["p"]
    return x, p


def run_heeloff_seed(request: HeelOffRequest, human: GaitCurves | None = None,
                     log: Log = _quiet) -> SeedRun:
    """The heel-off seed of the module docstring; ``human``: the curves of
    ``request.gait`` (read by the caller; needed with ``request.stability``); ``log`` gets
    one line per round and the crossing. Raises :class:`~pdw_casadi.engine.errors.NoGait`
    when a stage loses the fixed point or no heel off is reached."""
    t0 = time.perf_counter()
    pb = heeloff_start_problem()
    sim = Simulator(pb)
    fp = find_fixed_point(pb, fallback=False)
    x, p = fp.state, fp.parameters
    x, p = _push(pb, sim, x, p, request, human if request.stability else None, log)
    x, p = _cross(pb, sim, x, p, request, log)
    x, p = _lengthen(pb, sim, x, p, request, log)
    fp = find_fixed_point(pb, x, p, fallback=False)
    record = {"fixed_point": dict(zip(pb.state_names, map(float, x), strict=True)),
              "compliance": dict(zip(pb.compliance_names, map(float, p[:-1]), strict=True)),
              "slope": float(p[-1]), "phases_s": _phases_of(sim, x, p),
              "spectral_radius": float(fp.spectral_radius), "valid": bool(fp.valid),
              "failure": fp.failure, "wall_time_s": time.perf_counter() - t0}
    return SeedRun("heeloff", pb, record, found=bool(fp.converged))


# -- toes ----------------------------------------------------------------------------------------
#: the walker family of the toes search (its phases II_mtp, II_stop and heel loads)
TOES_FAMILY = "humanlike_toes"
#: the compliance keys the toe walker's scan samples and their ranges: the stance ankle's
#: plantarflexing torque (quasi-stiffness, its rest angle, the clutch spring) moves the
#: centre of pressure towards the MTP joint, the MTP spring sets how the toes carry it
TOES_RANGES = {"k_clutch": (10.0, 200.0), "phi_clutch": (1.45, 1.70),
               "ankle_rest": (-0.2, 0.6), "k_ankle": (0.0, 40.0), "k_mtp": (1.0, 50.0),
               "mtp_rest": (-0.4, 0.0), "c_mtp": (0.005, 0.1)}


@dataclass(frozen=True)
class ToesRequest:
    """The toe walker's scan: ``samples`` compliance samples drawn with random ``seed``
    from ``ranges`` ((key, lo, hi) in the key's unit; empty: :data:`TOES_RANGES`; the keys
    not given stay at the problem's values), Newton on each heel-off step's end state for
    ``newton`` iterations at most."""

    samples: int = 200
    seed: int = 0
    newton: int = 20
    ranges: tuple[tuple[str, float, float], ...] = field(default_factory=tuple)

    def sampled(self) -> dict[str, tuple[float, float]]:
        """The sampled keys and their ranges."""
        return {k: (float(lo), float(hi)) for k, lo, hi in self.ranges} or dict(TOES_RANGES)


@dataclass(frozen=True)
class ToesContinuation:
    """The toe walker's continuation: its fixed point followed in parameter ``key`` (a
    compliance key or the slope) from the problem's value up to ``stop`` (the key's unit)
    in ``num`` steps."""

    key: str
    stop: float
    num: int


def check_toes_request(problem: Problem, request: ToesRequest | ToesContinuation) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless ``problem`` is a walker
    of the toe walker's family (:data:`TOES_FAMILY`: its phases name the toes' contacts) and
    the request fits it: a scan's every range names a compliance key, its ends are finite
    and ordered and it overlaps the key's bounds; a continuation names a parameter and ends
    within its bounds."""
    if problem.family != TOES_FAMILY:
        raise ProblemError(f"{problem.name} ({problem.family}): the toes search needs a "
                           f"walker of the {TOES_FAMILY} family")
    if isinstance(request, ToesContinuation):
        key = request.key
        if key not in problem.parameter_names:
            raise ProblemError(f"--continue {key}: {problem.name} has no parameter {key!r} "
                               f"(parameters: {', '.join(problem.parameter_names)})")
        check_bounds(problem, {key: request.stop}, f"--continue {key} {request.stop:g}")
        return
    keys = problem.compliance_names
    for key, (lo, hi) in request.sampled().items():
        where = f"--range {key} {lo:g} {hi:g}"
        if key not in keys:
            raise ProblemError(f"{where}: {problem.name} has no compliance key {key!r} "
                               f"(keys: {', '.join(keys)})")
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ProblemError(f"{where}: expected finite LO <= HI")
        blo, bhi = problem.compliance_bounds.get(key, (lo, hi))
        if max(lo, blo) > min(hi, bhi):
            raise ProblemError(f"{where}: lies outside the bounds [{blo:g}, {bhi:g}] of "
                               f"{key} (compliance_bounds of {problem.source or problem.name})")


def toes_timing(step, family: str = TOES_FAMILY) -> dict:
    """Heel off, toe off, stance (% of the cycle) and the double-support periods (% each)."""
    t = gait_timing(step.phases, step.step_length, phase_contacts(family))
    return {"heel_off_pct": t.heel_off_pct, "toe_off_pct": t.toe_off_pct,
            "stance_pct": t.stance_pct, "double_support_pct": list(t.double_support_pct)}


def toes_score(r: dict) -> tuple:
    """Sort key of a found gait: stable and valid first, then heel off inside 25-40 %,
    then rho."""
    ho = r["timing"].get("heel_off_pct") or 50.0
    stable = r["rho"] <= RADIUS_BOUND and r["valid"]
    return (not stable, abs(float(np.clip(ho, 25, 40)) - ho), r["rho"])


def _eigenvalues(fp) -> list[list[float]]:
    return [[float(e.real), float(e.imag)] for e in fp.eigenvalues]


def _toes_gait(q: Problem, sim, run, request: ToesRequest, ends) -> dict | None:
    """The fixed point of one whole heel-off step (None: Newton did not converge)."""
    fp = find_fixed_point(q, run.steps[0].x_section_end, q.parameter_vector(),
                          fallback=False, max_iter=request.newton)
    if not fp.converged:
        ends["whole step, Newton did not converge"] += 1
        return None
    step = sim.run(fp.state, fp.parameters, steps=1, record=False).steps[0]
    return {"compliance": {**q.compliance}, "slope": q.slope,
            "fixed_point": dict(zip(q.state_names, map(float, fp.state), strict=True)),
            "phases_s": dict(step.phases), "timing": toes_timing(step, q.family),
            "rho": float(fp.spectral_radius), "valid": bool(fp.valid), "failure": fp.failure,
            "eigenvalues": _eigenvalues(fp)}


def run_toes_scan(problem: Problem, request: ToesRequest, label: str | None = None,
                  log: Log = _quiet) -> SeedRun:
    """The toe walker's scan of the module docstring from ``problem``'s section state
    (``label``: the problem as the record names it, default its name); ``log`` gets one line
    per gait found. ``found``: at least one fixed point with heel off."""
    t0 = time.perf_counter()
    sim = Simulator(problem)
    rng = np.random.default_rng(request.seed)
    bounds = problem.compliance_bounds
    ranges = request.sampled()
    ends, found, all_ends = collections.Counter(), [], collections.Counter()
    for k in range(request.samples):
        comp = {}
        for key, (lo, hi) in ranges.items():
            blo, bhi = bounds.get(key, (lo, hi))
            comp[key] = float(rng.uniform(max(lo, blo), min(hi, bhi)))
        q = problem.replace(compliance=comp)
        run = sim.run(q.state_vector(), q.parameter_vector(), steps=1, record=False)
        # a start the simulator refuses at once (a non-finite state) has no step at all
        phases = [n for n, _ in run.steps[0].phases] if run.steps else []
        all_ends[run.failure.reason if run.failure else "whole step"] += 1
        if "II_mtp" not in phases:
            continue
        ends[run.failure.reason if run.failure else "whole step"] += 1
        if run.failure is not None:
            continue
        r = _toes_gait(q, sim, run, request, ends)
        if r is None:
            continue
        found.append(r)
        log(f"sample {k}: rho {r['rho']:.3g}, valid {r['valid']} ({r['failure']}), phases "
            f"{', '.join(r['phases_s'])}, timing {r['timing']}")
    found.sort(key=toes_score)
    record = {"problem": label or problem.name, "samples": request.samples,
              "seed": request.seed, "heel_off_step_ends": dict(ends),
              "step_ends": dict(all_ends), "gaits": found,
              "wall_time_s": time.perf_counter() - t0}
    return SeedRun("toes", problem, record, found=bool(found))


def run_toes_continuation(problem: Problem, request: ToesContinuation,
                          label: str | None = None, log: Log = _quiet) -> SeedRun:
    """Natural-parameter continuation of ``problem``'s fixed point as ``request`` asks
    (Newton from the previous point): per point the spectral radius, the eigenvalues,
    validity, phases and the smallest heel load of the stance foot in single support (N m;
    heel off where it reaches zero). ``label``: the problem as the record names it (default
    its name); ``log`` gets a line per point; ``found``: every point converged."""
    t0 = time.perf_counter()
    key, stop, num = request.key, request.stop, request.num
    sim = Simulator(problem)
    x, p = problem.state_vector(), problem.parameter_vector()
    i = list(problem.parameter_names).index(key)
    rows = []
    for v in np.linspace(p[i], stop, num):
        q = p.copy()
        q[i] = v
        fp = find_fixed_point(problem, x, q, fallback=False, max_iter=15)
        if not fp.converged:
            rows.append({key: float(v), "converged": False})
            break
        x, p = fp.state, q
        run = sim.run(x, p, steps=1, record=True)
        traj = run.trajectory
        single = traj[traj.phase.isin(SINGLE_SUPPORT_PHASES)]
        load = single.heelload_foot1.min() if "heelload_foot1" in single else float("nan")
        rows.append({key: float(v), "converged": True, "rho": float(fp.spectral_radius),
                     "eigenvalues": _eigenvalues(fp), "valid": bool(fp.valid),
                     "failure": fp.failure, "phases": [n for n, _ in run.steps[0].phases],
                     "min_heel_load_Nm": float(load)})
        log(f"{key} {v:.4g}: rho {fp.spectral_radius:.3g}, valid {fp.valid}, heel load "
            f"{load:.3g} N m, phases {', '.join(rows[-1]['phases'])}")
    record = {"problem": label or problem.name, "continuation": rows,
              "wall_time_s": time.perf_counter() - t0}
    return SeedRun("toes-continuation", problem, record,
                   found=all(r["converged"] for r in rows))
