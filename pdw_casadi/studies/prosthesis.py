"""Prosthetic-leg design: the compliance of a lighter leg that makes the gait symmetric.

A below-knee prosthesis is lighter than the limb it replaces. On one physical leg (default
the right) the shank and foot masses and inertias are reduced by a fraction; the walker's
gait then becomes asymmetric. :func:`design_prosthesis` finds the prosthetic leg's free
compliance (ankle and knee) for which the stride's periodic gait has equal left and right
step lengths and step times: continuation from the symmetric walker (lambda = 0) to the
lighter leg (lambda = 1), solving at every step the stride fixed point together with the
symmetry conditions and the least relative change of the free compliance
(:mod:`pdw_casadi.gait.design`, exact AD Jacobians through the stride map).

Stability is read from the stride map: its spectral radius rho_S is the product of two
steps, so sqrt(rho_S) is the per-step radius comparable with a symmetric walker's rho.

:func:`design_prosthesis_nlp` poses the design as one IPOPT NLP instead (the fit's
machinery on the stride, :meth:`pdw_casadi.nlp.shooting.ShootingNLP.stride`): unknowns the
stride's shooting nodes and the prosthetic leg's free compliance; constraints the
shooting rows (continuity, events, validity margins), equal left and right step lengths and
step times (from the NLP's own geometry and durations) and the stride's stability row
rho_32(J_2 J_1) <= ``max_stride_radius`` - ``radius_margin``
(:mod:`pdw_casadi.nlp.stability`); objective the least relative change of the prosthetic
leg's compliance from the sound leg's, sum ((c_prosthetic - c_sound) / c_sound)^2
(relative changes, not log ratios: a damper's lower bound is 0). The mass reduction is
reached in ``mass_steps`` homotopy steps, each warm-started from the last, and every answer
is checked by re-simulation on the stride map (fixed point, spectral radius, validity,
asymmetry).

The design keeps the gait pattern (event order) of the gait it starts from. How far each
variant gets (the sound leg fixed or adapting, the mass distribution and the slope free, a
symmetry tolerance), what caps it and the designs (the shipped
``data/designs/humanlike_6link_prosthesis30.toml``; the 28.9 % one, invalid under the guard
rule, beside the results page) are measured in ``docs/results/prosthesis.md``, each with its
``pdw-design`` command.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from pdw_casadi.engine import interrupt
from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.fit.options import FitOptions, row_power
from pdw_casadi.gait.design import (
    DesignOptions,
    combined,
    continue_design,
    next_homotopy_step,
    phase_time_conditions,
    symmetry_conditions,
)
from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL
from pdw_casadi.gait.stability import RADIUS_BOUND, RADIUS_MARGIN, map_radius, step_radius
from pdw_casadi.gait.stride import (
    find_stride_fixed_point,
    physical_parameter_names,
    physical_parameter_vector,
    stride_map,
    stride_report,
    with_physical_parameters,
)
from pdw_casadi.model.problem import Problem, ProblemError, load_problem
from pdw_casadi.nlp.driver import (
    IPOPT_TOL,
    NEAR_START_IPOPT,
    Progress,
    ipopt_settings,
    nlp_functions,
    succeeded,
)
from pdw_casadi.nlp.multipliers import WARM_IPOPT, bound_multipliers, map_multipliers
from pdw_casadi.nlp.shooting import ShootingNLP
from pdw_casadi.nlp.stability import StabilityRow

#: the prosthetic leg's compliance left free by default (the angles stay)
FREE = ("k_ankle", "c_ankle", "k_knee", "c_knee_flex", "c_knee_ext", "c_knee_stance")
#: the prosthetic leg's compliance the NLP design leaves free by default: all eight (the
#: knee-spring angles too: docs/results/prosthesis.md, "Homotopy settings, measured")
NLP_FREE = FREE + ("theta_eq", "theta_dis")
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


#: two mass reductions closer than this (-) are the same point of a design's path
STOP_TOL = 1e-9


def homotopy_level(done: float, step: float, lighter: float,
                   stops: Sequence[float] = ()) -> tuple[float, bool]:
    """The mass reduction (-) of the homotopy's next solve after the accepted ``done`` with
    the step ``step``: ``done + step``, but never past ``lighter`` nor past the next of
    ``stops`` ahead (:attr:`DesignNLPOptions.stops`), and whether a stop cut it short."""
    level = min(done + step, lighter)
    # the tolerance: a stop reached is not a stop ahead
    ahead = [float(v) for v in stops if done + STOP_TOL < v < level]
    return min(ahead, default=level), bool(ahead)


def homotopy_step_after(step: float, tried: float, stopped: bool, accepted: bool,
                        max_step: float) -> float:
    """The mass homotopy's next step after a solve ``tried`` (-) past the last accepted point,
    planned as ``step`` and cut short by a stop when ``stopped``:
    :func:`~pdw_casadi.gait.design.next_homotopy_step` of the step tried, except after an
    accepted solve that a stop cut short, where the planned step is the one doubled (a stop
    is a point the user asked for, not a sign that the step was too long)."""
    return next_homotopy_step(step if stopped and accepted else tried, accepted, max_step)


@dataclass
class ProsthesisResult:
    """The designed walker: ``problem`` (prosthetic leg, designed compliance, the gait's
    section state as initial state), its stride ``fixed_point``, the ``report``
    (:func:`pdw_casadi.gait.stride.stride_report`), the compliance found per free key, the
    continuation path, whether it reached the full mass reduction, and the wall time (s)."""

    problem: Problem
    fixed_point: object
    report: dict
    compliance: dict
    path: list
    reached: bool
    wall_time_s: float
    #: the NLP design's solves, one per homotopy step (:class:`DesignSolve`)
    solves: list = field(default_factory=list)
    #: the prosthetic leg's designed mass distribution (DesignNLPOptions.mass_distribution)
    mass_distribution: dict = field(default_factory=dict)
    #: the sound leg's adapted compliance (DesignNLPOptions.free_sound)
    sound_compliance: dict = field(default_factory=dict)

    @property
    def step_radius(self) -> float:
        """sqrt of the stride map's spectral radius: the per-step equivalent (-)."""
        return step_radius(self.fixed_point.spectral_radius, 2)

    def design_at(self, lighter: float, side: str = "right") -> tuple[Problem, np.ndarray]:
        """The designed walker at an accepted point ``lighter`` (-) of the homotopy's
        ``path`` (a stop of :attr:`DesignNLPOptions.stops`, or any point it reached) and its
        stride gait's section state; KeyError if the path has no point there."""
        sound, _ = sound_problem(self.problem, side)
        levels = []
        for _, x, theta in self.path:
            # the point's own masses say how much lighter it is (the continuation's path
            # counts in its homotopy parameter, the NLP's in the mass reduction)
            walker = with_physical_parameters(prosthetic_problem(sound, 0.0, side), theta)
            level = 1.0 - lighter_mass(walker, side)
            levels.append(level)
            if abs(level - lighter) <= STOP_TOL:
                return walker.replace(initial_state=dict(zip(walker.initial_state, x,
                                                             strict=True))), np.asarray(x)
        raise KeyError(f"the design's path has no point at {100 * lighter:g} % lighter "
                       f"(points: {', '.join(f'{100 * v:g}' for v in levels)} %)")


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
    smap = stride_map(problem)
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
    smap_d = stride_map(designed)
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
    atlas = json.loads((bundled_dir("data") / "atlas" / "humanlike_6link.json").read_text())
    entry = next((e for e in atlas["entries"] if e["label"] == label), None)
    if entry is None:
        raise ProblemError(f"no atlas entry {label!r}; known: "
                           f"{', '.join(e['label'] for e in atlas['entries'])}")
    return load_problem(atlas["problem"]).with_parameters(entry["parameters"]).with_state(
        entry["state"])


@dataclass
class DesignNLPOptions:
    """Settings of :func:`design_prosthesis_nlp`.

    Homotopy in the mass reduction, each NLP warm-started from the last answer: the first
    step is ``first_step`` (a fraction of the mass), a solved step doubles the next (at most
    ``max_step``), a failed one is retried at half the size (down to ``min_step``), at most
    ``max_solves`` NLP solves; ``first_step`` >= ``lighter`` solves the target directly.
    ``symmetry_tol_pct``: the largest accepted |step-length| and |step-time asymmetry| in
    the NLP, % (0: equal; below the verdict's ``symmetry_verdict_pct``).
    Stability: the NLP bounds the smooth bound rho_32 (>= the spectral radius) of the
    stride Jacobian by ``max_stride_radius - radius_margin``; the re-simulated stride
    radius is the verdict (<= ``max_stride_radius``; 0.81 = 0.9 per step: the fit's
    per-step NLP bound :data:`~pdw_casadi.gait.stability.RADIUS_BOUND` squared, as
    ``FitOptions.radius_bound(2)`` squares it; the margin comes off the stride's radius
    here, 0.80, not off the step's as in the fit's stride NLP, 0.89^2). IPOPT:
    ``max_iter``, ``tol``, ``hessian``; ``sample_stride`` as in
    :class:`~pdw_casadi.fit.FitOptions`.

    How the defaults were chosen (measured first steps, tolerances, floors and freedoms):
    ``docs/results/prosthesis.md``, "Homotopy settings, measured".
    """

    first_step: float = 0.003
    max_step: float = 0.1
    min_step: float = 1e-4
    max_solves: int = 20
    symmetry_tol_pct: float = 0.0
    #: the verdict's largest |step-length| and |step-time asymmetry|, % (symmetry_tol_pct,
    #: the NLP's own tolerance, must lie below it)
    symmetry_verdict_pct: float = 1.0
    max_stride_radius: float = map_radius(RADIUS_BOUND, 2)  # 0.9 per step, squared
    radius_margin: float = RADIUS_MARGIN
    max_iter: int = 100  # IPOPT iterations per homotopy step
    tol: float = IPOPT_TOL
    hessian: str = "limited-memory"
    #: the stability row (:attr:`FitOptions.stability_bound`): "eigenvalues" (rho_32 of the
    #: stride Jacobian) or "power" (the fit's eight-step bound, ||(J_2 J_1)^4||_F^(1/4);
    #: FitOptions.row_power). The eight-step bound measured on the 30 % design: from the
    #: atlas gait, whose eight-step row lies above the bound, the first steps fell back to
    #: 0.15 % and 9 solves reached 10.65 % in 14 minutes, against 30 % in 656 s
    #: (docs/results/prosthesis.md)
    stability_bound: str = "eigenvalues"
    #: the L-BFGS pairs IPOPT keeps in a design solve (``limited_memory_max_history``; None:
    #: IPOPT's 6). The fit's stride setting, 50, converged 7 of 9 homotopy steps against 2
    #: of 8 but doubled the time of an iteration: the 30 % design took 1,161 s against 656 s
    #: (docs/results/prosthesis.md)
    lbfgs_history: int | None = None
    #: the event and margin checks at every ``sample_stride``-th RK4 sample, as the fit's
    #: (:attr:`FitOptions.sample_stride`, one home): against 2, the 30 % design took 429 s
    #: against 711 s, 606 iterations against 700, the same verdict, the compliance within
    #: 0.53 % of the shipped design's (docs/results/prosthesis.md, "Checks at every fifth
    #: sample")
    sample_stride: int = FitOptions.sample_stride
    headroom_s: float = 0.0
    #: shortest segment (s): the event order is the NLP's gait pattern (ShootingNLP.bounds);
    #: a modelling floor, not a physical one
    t_min_s: float = 1e-3
    #: the prosthetic leg's body values designed beside its compliance (among l_sc, J_s,
    #: l_fc, J_f: where a prosthetist places the mass; the masses stay (1 - lighter) x the
    #: sound leg's), each within ``mass_distribution_bounds`` x the sound leg's value and
    #: counted in the least-change objective like the compliance; () : the inertias scale
    #: with the mass and the COM positions stay the sound leg's
    mass_distribution: tuple = ()
    mass_distribution_bounds: dict = field(default_factory=lambda: dict(
        l_sc=(0.6, 1.3), J_s=(0.3, 1.5), l_fc=(0.5, 1.5), J_f=(0.3, 1.5)))
    #: the slope free too (the walker's energy supply; shared by both legs, not in the
    #: objective; bounds of ShootingNLP.bounds)
    free_slope: bool = False
    #: the sound leg's compliance keys that adapt too (the whole gait adapts to the
    #: prosthesis, as an amputee's does), counted in the least-change objective as relative
    #: changes from their values at the start; () : the sound leg keeps its compliance
    free_sound: tuple = ()
    #: accept a homotopy step whose IPOPT solve stopped without success (iteration limit)
    #: when its answer re-simulates as the verdict asks: a stride fixed point that is stable
    #: (<= max_stride_radius), valid and with both asymmetries below symmetry_verdict_pct.
    #: The re-simulation
    #: is the verdict either way; False: only IPOPT successes are accepted
    accept_verified: bool = False
    verbose: bool = False
    #: log after every solve what binds there (rows and bounds by |multiplier|) and the
    #: IPOPT inf_pr / inf_du trend
    diagnose: bool = False
    ipopt: dict = field(default_factory=dict)
    #: the fit's walk carried to the design's solves (the same code: the driver's
    #: :class:`~pdw_casadi.nlp.driver.Progress`): a solve that stops short of convergence
    #: answers with its best iterate that holds every row and bound (the lowest
    #: least-change objective among them) instead of its last one, which may have wandered
    #: off the valid gaits; False: the last iterate
    keep_best_feasible: bool = True
    #: a solve is stopped as stalled by the fit's stall rule
    #: (:meth:`~pdw_casadi.fit.FitOptions.stall_rule` of these settings; None: never)
    stall: FitOptions | None = field(default_factory=FitOptions)
    #: mass reductions (fractions, below ``lighter``) that the homotopy lands on exactly on
    #: its way: each becomes an accepted point of the result's ``path``
    #: (:meth:`ProsthesisResult.design_at`), so that one run designs the prosthesis at 10,
    #: 20 and 30 % lighter, say; a step cut short by a stop does not shorten the next one
    #: (:func:`homotopy_step_after`)
    stops: tuple = ()
    #: start each homotopy step's NLP from the last accepted step's multipliers, mapped
    #: by row name (:func:`~pdw_casadi.nlp.multipliers.map_multipliers`), with IPOPT's
    #: warm options (:data:`~pdw_casadi.nlp.multipliers.WARM_IPOPT`); False (the default:
    #: warm, the 30 % design's homotopy was rejected at 18.9 and 14.1 %, which it passes
    #: cold; at every fifth sample, with ``near_start`` and ``step_tol``, it took 234.5 s
    #: against 429 s but ended on another design, its least-change objective 0.271 against
    #: 0.253; docs/results/prosthesis.md): every step cold
    warm_start: bool = False
    #: with ``warm_start``: a warm solve that is not accepted is tried again cold at the
    #: same mass before the homotopy halves its step (the warm start is an accelerator; the
    #: cold solve is the reference)
    warm_retry_cold: bool = True
    #: a cold step (no multipliers) starts IPOPT near its starting point, the last answer:
    #: a small barrier and small bound pushes (:data:`~pdw_casadi.nlp.driver.NEAR_START_IPOPT`).
    #: Measured on the 30 % design with ``step_tol``: the first step 10 iterations against
    #: 100, but from the second step on IPOPT's adaptive barrier rises from 1e-4 to 10 and
    #: the iterates leave (with the barrier capped, the rows active at the last answer are
    #: pushed off), so the whole design took 674 s against 656 s and came out elsewhere
    #: (docs/results/prosthesis.md, "Where the 30 % design's time goes").
    #: False: IPOPT's own start
    near_start: bool = False
    #: IPOPT's tolerance (``tol``) of a homotopy step that is neither the target nor one of
    #: ``stops``: such a step is a stepping stone, whose least change the next step moves
    #: again, and its answer is checked on the simulator like any other; its rows are held
    #: to ``step_constr_viol_tol`` (IPOPT's ``constr_viol_tol``, unscaled) all the same.
    #: None (the default; measured with ``near_start``, above): every step to ``tol``
    step_tol: float | None = None
    step_constr_viol_tol: float = 1e-7

    def ipopt_options(self, warm: bool, stepping_stone: bool) -> dict:
        """IPOPT's options of a design solve: ``warm`` (from the last step's multipliers,
        :data:`~pdw_casadi.nlp.multipliers.WARM_IPOPT`) or cold (near its start when
        ``near_start``), to ``tol`` or, a ``stepping_stone`` (a homotopy step short of the
        target and the stops), to ``step_tol``; ``ipopt`` overrides any of them."""
        start = WARM_IPOPT if warm else NEAR_START_IPOPT if self.near_start else {}
        # IPOPT's acceptable level as ipopt_settings sets it for tol (100 x), so that a
        # stepping stone's is not tighter than its own tolerance
        loose = {"tol": self.step_tol, "acceptable_tol": 100 * self.step_tol,
                 "constr_viol_tol": self.step_constr_viol_tol} \
            if stepping_stone and self.step_tol is not None else {}
        return ipopt_settings(self.hessian, self.max_iter, self.tol,
                              {**start, **loose, **self.ipopt}, history=self.lbfgs_history)

    @property
    def max_step_radius(self) -> float:
        """The per-step spectral radius of the verdict: a stride is two steps."""
        return step_radius(self.max_stride_radius, 2)

    def check_symmetry_tol(self) -> None:
        """Raise :class:`ProblemError` unless the NLP's symmetry tolerance lies inside the
        verdict's, [0, ``symmetry_verdict_pct``) %."""
        if not 0.0 <= self.symmetry_tol_pct < self.symmetry_verdict_pct:
            raise ProblemError(f"symmetry_tol_pct must lie in [0, {self.symmetry_verdict_pct:g})"
                               f" %, got {self.symmetry_tol_pct}")

    def symmetric(self, length_pct: float, time_pct: float) -> bool:
        """Both asymmetries (%) below the verdict's ``symmetry_verdict_pct``."""
        return bool(abs(length_pct) < self.symmetry_verdict_pct
                    and abs(time_pct) < self.symmetry_verdict_pct)

    def verified(self, fp, report) -> bool:
        """The verdict on a stride fixed point ``fp`` with its :func:`stride_report`: converged,
        valid, stride radius <= ``max_stride_radius``, symmetric."""
        return bool(fp.converged and fp.valid and fp.spectral_radius <= self.max_stride_radius
                    and report is not None
                    and self.symmetric(report["step_length_asymmetry_pct"],
                                       report["step_time_asymmetry_pct"]))


@dataclass
class DesignSolve:
    """One homotopy step of :func:`design_prosthesis_nlp`: the mass reduction (-), IPOPT
    status, iterations, wall time (s), the NLP's stability bound at the answer, and the
    re-simulated stride radius, asymmetries (%) and validity (None where no fixed point),
    and what binds at the answer."""

    lighter: float
    status: str
    iterations: int
    wall_time_s: float
    nlp_radius: float
    stride_radius: float
    step_length_asymmetry_pct: float
    step_time_asymmetry_pct: float
    valid: bool | None
    #: what binds at the answer (:meth:`ProsthesisDesignSolver.binding`, the 20 largest)
    binding: list = field(default_factory=list)
    #: the homotopy took this answer as its next point
    accepted: bool = False
    #: the iteration whose iterate is the answer when the solve stopped short
    #: (DesignNLPOptions.keep_best_feasible; None: IPOPT's own answer)
    fallback_iteration: int | None = None
    #: started from the last accepted step's multipliers (DesignNLPOptions.warm_start)
    warm: bool = False

    @property
    def answered_with(self) -> str:
        """Which iterate the answer is, for the progress and report lines: "" (IPOPT's own
        answer) or "its best feasible iterate, iteration N"."""
        return "" if self.fallback_iteration is None else \
            f"its best feasible iterate, iteration {self.fallback_iteration}"


class ProsthesisDesignSolver:
    """The design NLP of :func:`design_prosthesis_nlp`: IPOPT on a stride
    :class:`~pdw_casadi.nlp.shooting.ShootingNLP` whose free parameters are the prosthetic
    leg's compliance (``free``: names like ``right.k_ankle``), with the symmetry rows, the
    stability row and the least-change objective (module docstring).

    ``pinned`` (name -> value): NLP parameters held at a value other than the one the NLP
    was built at (its unknown with equal bounds): a homotopy step builds the NLP at the
    last answer, whose gait simulates, and pins the body values at the next mass.
    ``bounds`` (name -> (lo, hi), SI): bounds of free NLP parameters the problem's
    compliance bounds do not cover (the prosthesis's mass distribution)."""

    def __init__(self, nlp, free: Sequence[str], sound: dict, opts: DesignNLPOptions,
                 pinned: dict | None = None, log=print, bounds: dict | None = None):
        self.nlp, self.opts, self.log = nlp, opts, log
        obj = 0
        for name in free:
            j = nlp.param_names.index(name)
            c = sound[name]
            # relative change from the sound leg's value (its magnitude, at least 0.01 in
            # the parameter's units, like the NLP's own scaling of free parameters)
            obj = obj + ((nlp.p[j] - c) / max(abs(c), 1e-2)) ** 2
        L1, L2 = nlp.step_lengths
        T1, T2 = nlp.step_times
        self.asym = ca.Function("asymmetry", [nlp.w], [
            100 * (L1 - L2) / (0.5 * (L1 + L2)), 100 * (T1 - T2) / (0.5 * (T1 + T2))])
        rows = ca.vertcat(*self.asym(nlp.w))
        self.objective = ca.Function("design_objective", [nlp.w], [obj])
        self.row = StabilityRow(nlp, bound=opts.stability_bound,
                                power=row_power(FitOptions.stability_power, nlp.n_steps))
        self.n_w = nlp.w.shape[0]
        self.nlp_fun, self.jac_g, self._keep = nlp_functions(
            nlp.w, obj, ca.vertcat(nlp.g, rows), self.row, self.n_w, nlp)
        self.lbx, self.ubx = nlp.bounds(t_min=opts.t_min_s)
        ns = nlp.xs.shape[0]
        for name, (lo, hi) in (bounds or {}).items():
            j = nlp.free.index(name)
            self.lbx[ns + j], self.ubx[ns + j] = lo / nlp.p_scale[j], hi / nlp.p_scale[j]
        for name, v in (pinned or {}).items():
            j = nlp.free.index(name)
            self.lbx[ns + j] = self.ubx[ns + j] = v / nlp.p_scale[j]
        tol = opts.symmetry_tol_pct
        self.lbg = np.r_[nlp.lbg, -tol, -tol, -np.inf]
        self.ubg = np.r_[nlp.ubg, tol, tol, opts.max_stride_radius - opts.radius_margin]

    def warm_from(self, last) -> tuple[np.ndarray, np.ndarray] | None:
        """This NLP's multipliers (lam_x, lam_g) from the last homotopy step's solve
        ``last`` = (its solver, its answer :meth:`solve`): the shooting rows by name (blocks
        of another size resampled along their segment), the asymmetry and stability rows
        as they were, the free parameters' bounds by name (rescaled to this NLP's scales),
        the durations' by segment. None when the segments' phases differ."""
        solver, out = last
        nlp, old = self.nlp, solver.nlp
        if [s.phase for s in nlp.specs] != [s.phase for s in old.specs]:
            return None
        n_old = len(old.g_names)
        lam_s, _ = map_multipliers(old.g_names, out["lam_g"][:n_old], nlp.g_names,
                                   nlp.hs.nx)
        lam_g = np.r_[lam_s, out["lam_g"][n_old:]]
        lam_x = bound_multipliers(out["lam_x"], old.free, old.p_scale, len(old.specs), nlp)
        return lam_x, lam_g

    def solve(self, w0, warm: tuple[np.ndarray, np.ndarray] | None = None,
              stepping_stone: bool = False) -> dict:
        """Solve from ``w0`` (with ``warm`` = (lam_x, lam_g): from those multipliers with
        IPOPT's warm options; without, near ``w0`` when ``near_start``) to ``tol``, or to
        ``step_tol`` when ``stepping_stone`` (a homotopy step short of the target and the
        stops): the answer ``w``, IPOPT status, iterations, wall time (s)."""
        opts = self.opts
        ipopt = opts.ipopt_options(warm is not None, stepping_stone)
        progress = Progress(self.n_w, self.lbg.size, self.lbg, self.ubg, self.lbx, self.ubx,
                             lambda x: {}, True, self.log if opts.verbose else None,
                             feasible_tol=opts.tol if opts.keep_best_feasible else None,
                             stall=None if opts.stall is None else opts.stall.stall_rule())
        solver = ca.nlpsol("pdw_design", "ipopt", self.nlp_fun,
                           {"ipopt": ipopt, "print_time": False, "iteration_callback": progress,
                            "jac_g": self.jac_g, "show_eval_warnings": False})
        w0 = np.clip(w0, self.lbx, self.ubx)
        t0 = time.perf_counter()
        args = {} if warm is None else {"lam_x0": warm[0], "lam_g0": warm[1]}
        sol = solver(x0=w0, lbx=self.lbx, ubx=self.ubx, lbg=self.lbg, ubg=self.ubg, **args)
        interrupt.check()  # Ctrl-C inside IPOPT ends the design, not this one solve
        st = solver.stats()
        # IPOPT relaxes bounds by about 1e-8 of their size: a compliance value at its lower
        # bound 0 comes back slightly negative, which is not a walker (the problem file
        # refuses it)
        w = np.clip(sol["x"].full().ravel(), self.lbx, self.ubx)
        success = succeeded(st["return_status"])
        best = progress.best_feasible
        # a solve stopped short (its limit, a stall): its best iterate that holds every row
        fallback = None if success or best is None else best.iteration
        g = sol["g"].full().ravel()
        lam_g, lam_x = sol["lam_g"].full().ravel(), sol["lam_x"].full().ravel()
        if fallback is not None:  # the iterate, its rows and its multipliers
            w = np.clip(best.x, self.lbx, self.ubx)
            g = self.nlp_fun(w, np.zeros(0))[1].full().ravel()
            lam_g, lam_x = best.lam_g, best.lam_x
        hist = st.get("iterations", {})
        return {"w": w, "status": st["return_status"], "iterations":
                int(st["iter_count"]) if progress.history else 0,  # unset if it never iterated
                "wall_time_s": time.perf_counter() - t0, "radius": self.row.value(w),
                "success": success, "fallback_iteration": fallback,
                "g": g, "lam_g": lam_g, "lam_x": lam_x,
                "inf_pr": list(hist.get("inf_pr", [])), "inf_du": list(hist.get("inf_du", []))}

    @property
    def row_label(self) -> str:
        """The stability row's name in the log and the binding table: "rho32" or the
        eight-step bound's "power4"."""
        row = self.row
        return "rho32" if row.bound == "eigenvalues" else \
            f"power{row.power}" if row.bound == "power" else row.bound

    def row_names(self) -> list[str]:
        """Names of the NLP's rows: the shooting rows, the two asymmetry rows, stability."""
        return [*self.nlp.g_names, "asymmetry:step_length", "asymmetry:step_time",
                f"stability:{self.row_label}"]

    def binding(self, out: dict, top: int = 10, tol: float = IPOPT_TOL) -> list[dict]:
        """The inequality rows, asymmetry rows and bounds that bind at a solve's answer
        ``out`` (:meth:`solve`), by name: the largest |multiplier| of the group, the
        smallest distance to its bound (in the row's units), how many of its rows are
        within ``tol`` of a bound, and the largest violation; sorted by |multiplier|,
        ``top`` of them. Unknowns at a bound are named ``bound:T[k] ...`` (durations)
        and ``bound:<parameter>``."""
        names = self.row_names()
        g, lam = out["g"], out["lam_g"]
        w, lam_x = out["w"], out["lam_x"]
        rows = []
        for i, name in enumerate(names):
            if self.lbg[i] == self.ubg[i] and not name.startswith("asymmetry"):
                continue  # the shooting equalities (continuity, events, impacts) always bind
            gap = min(g[i] - self.lbg[i], self.ubg[i] - g[i])
            rows.append((name, abs(lam[i]), gap))
        nlp = self.nlp
        ns, nf = nlp.xs.shape[0], len(nlp.free)
        for j, name in enumerate(nlp.free):
            i = ns + j
            if self.lbx[i] == self.ubx[i]:
                continue  # pinned body values
            gap = min(w[i] - self.lbx[i], self.ubx[i] - w[i]) * nlp.p_scale[j]
            rows.append((f"bound:{name}", abs(lam_x[i]), gap))
        for k, s in enumerate(nlp.specs):
            i = ns + nf + k
            rows.append((f"bound:T[{k}] step {s.step} phase {s.phase}", abs(lam_x[i]),
                         min(w[i] - self.lbx[i], self.ubx[i] - w[i])))
        groups: dict[str, dict] = {}
        for name, lm, gap in rows:
            d = groups.setdefault(name, {"name": name, "multiplier": 0.0, "gap": math.inf,
                                         "active": 0, "violation": 0.0})
            d["multiplier"] = max(d["multiplier"], lm)
            d["gap"] = min(d["gap"], gap)
            d["active"] += int(abs(gap) <= tol)
            d["violation"] = max(d["violation"], -gap)
        out_rows = sorted(groups.values(), key=lambda d: -d["multiplier"])
        return [d for d in out_rows if d["multiplier"] > 0 or d["active"]][:top]


def sound_problem(problem: Problem, side: str = "right") -> tuple[Problem, float]:
    """(the symmetric walker with the sound leg's body and compliance on both sides, the
    mass reduction of ``problem``'s ``side`` leg) for a walker made by
    :func:`prosthetic_problem` (shank and foot mass and inertia scaled by one factor)."""
    other = "left" if side == "right" else "right"
    lighter = 1.0 - lighter_mass(problem, side)
    a, b = problem.leg_values(side)[1], problem.leg_values(other)[1]
    for k in ("m_s", "m_f"):  # inertias and COM positions may have been designed
        if abs(a[k] - b[k] * (1.0 - lighter)) > 1e-9 * abs(b[k]):
            raise ProblemError(f"{problem.name}: {side}.{k} is not the {other} leg's x "
                               f"{1 - lighter:.6f}: not a prosthetic_problem walker")
    if other != "left":
        raise ProblemError(f"{problem.name}: the sound leg must be the left one")
    # the sound leg's values on both legs (its compliance may have adapted in the design)
    comp, anthro = problem.leg_values(other)
    return problem.replace(legs={}, compliance=comp, anthropometry=anthro), lighter


def _log_diagnosis(solver: ProsthesisDesignSolver, out: dict, log) -> None:
    """What binds at a solve's answer and how IPOPT got there (one line each)."""
    pr, du = out["inf_pr"], out["inf_du"]
    if pr:
        at = sorted({0, *range(0, len(pr), max(1, len(pr) // 8)), len(pr) - 1})
        log("  inf_pr/inf_du: " + ", ".join(f"{i}: {pr[i]:.1e}/{du[i]:.1e}" for i in at))
    for d in solver.binding(out):
        log(f"  binding {d['name']}: |lambda| {d['multiplier']:.3g}, gap {d['gap']:.3g}, "
            f"{d['active']} active, violation {max(d['violation'], 0.0):.2g}")


def _design_solve(solver: ProsthesisDesignSolver, target: Problem, level: float, warm,
                  stepping_stone: bool, log) -> tuple[dict, object, DesignSolve]:
    """One solve of a homotopy step at the mass reduction ``level`` (-) of ``target``, from
    ``warm`` multipliers or cold, and its verdict on the simulator: IPOPT's answer, the
    stride fixed point near it, and the :class:`DesignSolve` (accepted or not), logged."""
    opts, nlp = solver.opts, solver.nlp
    out = solver.solve(nlp.w0, warm, stepping_stone=stepping_stone)
    if opts.diagnose:
        _log_diagnosis(solver, out, log)
    u = nlp.unpack(out["w"])
    fp = find_stride_fixed_point(target, x0=u["xs"], theta=u["p"], tol=FIXED_POINT_TOL,
                                 fallback=False, smap=nlp.stride_map)
    report = stride_report(nlp.stride_map, fp.state, fp.parameters, curves=False) \
        if fp.converged else None
    sv = DesignSolve(
        level, out["status"], out["iterations"], out["wall_time_s"], out["radius"],
        fp.spectral_radius if fp.converged else math.nan,
        report["step_length_asymmetry_pct"] if report else math.nan,
        report["step_time_asymmetry_pct"] if report else math.nan,
        fp.valid if fp.converged else None, solver.binding(out, top=20),
        fallback_iteration=out["fallback_iteration"], warm=warm is not None)
    sv.accepted = opts.verified(fp, report) and (out["success"] or opts.accept_verified)
    kept = sv.answered_with and f", {sv.answered_with}"
    log(f"{100 * level:g} % lighter{' (warm)' if warm is not None else ''}: "
        f"{out['status']} after {out['iterations']} iterations ({out['wall_time_s']:.1f} s)"
        f"{kept}; NLP {solver.row_label} {out['radius']:.4f}, re-simulated stride radius "
        f"{sv.stride_radius:.4f}, asymmetry length/time {sv.step_length_asymmetry_pct:.3f} / "
        f"{sv.step_time_asymmetry_pct:.3f} %, valid {sv.valid}: "
        f"{'accepted' if sv.accepted else 'rejected'}")
    return out, fp, sv


def design_prosthesis_nlp(problem: Problem, x0=None, lighter: float = 0.3,
                          side: str = "right", free: Sequence[str] = NLP_FREE,
                          options: DesignNLPOptions | None = None,
                          log=print) -> ProsthesisResult:
    """Design the prosthetic leg's compliance as one stride NLP per homotopy step (module
    docstring): ``problem`` the symmetric walker to start from, ``x0`` its periodic gait's
    section state (default: the stride fixed point near the problem's initial state),
    ``lighter`` the shank and foot mass and inertia reduction of the ``side`` leg (-),
    ``free`` its compliance keys to design, ``log`` one line per NLP solve (None: quiet).
    ``reached``: every homotopy step solved and the
    final answer re-simulates as a stable (stride radius <= ``max_stride_radius``), valid
    gait with both asymmetries below ``symmetry_verdict_pct``."""
    t0 = time.perf_counter()
    opts = options or DesignNLPOptions()
    opts.check_symmetry_tol()
    log = log or (lambda msg: None)
    start, done0 = problem, 0.0
    if problem.asymmetric:  # continue an earlier design (its own TOML)
        problem, done0 = sound_problem(problem, side)
    names = list(physical_parameter_names(problem))
    other = "left" if side == "right" else "right"
    dist = [f"{side}.{k}" for k in opts.mass_distribution]
    keys = [f"{side}.{k}" for k in free]
    theta_sound = physical_parameter_vector(problem)
    # the least-change references: the prosthetic leg's values from the sound leg's, the
    # sound leg's (free_sound) from its own at the start
    sound = {f"{side}.{k}": float(theta_sound[names.index(f"{other}.{k}")])
             for k in (*free, *opts.mass_distribution)}
    adapt = [f"{other}.{k}" for k in opts.free_sound]
    sound.update({k: float(theta_sound[names.index(k)]) for k in adapt})
    dist_bounds = {f"{side}.{k}": tuple(f * sound[f"{side}.{k}"]
                                        for f in opts.mass_distribution_bounds[k])
                   for k in opts.mass_distribution}
    shared = ("slope",) if opts.free_slope else ()
    if x0 is None:
        fp0 = find_stride_fixed_point(start, tol=FIXED_POINT_TOL)
        if not fp0.converged:
            raise ProblemError(f"{start.name}: no periodic gait near its initial state")
        x0 = fp0.state
    x = np.asarray(x0, float)
    # the body values held at (1 - lighter) x the sound leg's: the masses, and the
    # inertias unless the mass distribution is designed
    body = [f"{side}.{k}" for k in LIGHTER_KEYS if k not in opts.mass_distribution]
    theta = physical_parameter_vector(start)
    path, solves = [(done0, x.copy(), theta.copy())], []
    fp = report = target = None
    ok = False
    step = min(opts.first_step, lighter)
    if any(not 0.0 < v < lighter for v in opts.stops):
        raise ProblemError(f"stops must lie between 0 and lighter = {lighter:g} (fractions, "
                           f"not %), got {opts.stops}")
    last = None  # the last accepted step's (solver, solve)
    while len(solves) < opts.max_solves:
        done = path[-1][0]
        level, stopped = homotopy_level(done, step, lighter, opts.stops)
        target = prosthetic_problem(problem, level, side)
        theta_t = physical_parameter_vector(target)
        # built at the last answer (its gait simulates; at the lighter leg with the old
        # compliance it may not), the body values pinned at the new mass
        nlp = ShootingNLP.stride(target, x, theta,
                                 free=(*keys, *adapt, *dist, *body, *shared),
                                 sample_stride=opts.sample_stride, headroom_s=opts.headroom_s)
        pinned = {k: float(theta_t[names.index(k)]) for k in body}
        solver = ProsthesisDesignSolver(nlp, (*keys, *adapt, *dist), sound, opts, pinned,
                                    log=log, bounds=dist_bounds)
        warm = solver.warm_from(last) if last is not None and opts.warm_start else None
        # a warm solve that is not accepted is tried again cold at the same level
        # (warm_retry_cold) before the step is halved
        tries = [warm, None] if warm is not None and opts.warm_retry_cold else [warm]
        for attempt in tries:
            out, fp, sv = _design_solve(solver, target, level, attempt,
                                        level < lighter and not stopped, log)
            solves.append(sv)
            good = sv.accepted
            if good or len(solves) >= opts.max_solves:
                break
        step = homotopy_step_after(step, level - done, stopped, good, opts.max_step)
        if not good:
            if step < opts.min_step:
                break
            continue
        x, theta = fp.state, fp.parameters
        last = (solver, out)  # the next step starts from its multipliers
        path.append((level, x.copy(), theta.copy()))
        if level >= lighter:
            ok = True
            break
    last_level, x, theta = path[-1]
    final = prosthetic_problem(problem, last_level, side)
    designed = with_physical_parameters(final, theta).replace(
        name=f"{problem.name}_prosthesis",
        initial_state=dict(zip(problem.initial_state, x, strict=True)))
    smap = stride_map(designed)
    fp = find_stride_fixed_point(designed, x0=x, theta=theta, tol=FIXED_POINT_TOL, fallback=False,
                                 smap=smap)
    report = stride_report(smap, fp.state, fp.parameters) if fp.converged else None
    comp = {k: float(theta[names.index(f"{side}.{k}")]) for k in free}
    mass = {k: float(theta[names.index(f"{side}.{k}")]) for k in opts.mass_distribution}
    sound_comp = {k: float(theta[names.index(f"{other}.{k}")]) for k in opts.free_sound}
    good = ok and opts.verified(fp, report)
    return ProsthesisResult(designed, fp, report, comp, path, bool(good),
                            time.perf_counter() - t0, solves, mass, sound_comp)
