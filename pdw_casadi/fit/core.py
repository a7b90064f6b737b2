"""Fit a walker's compliance and periodic gait to human knee and hip curves (one IPOPT NLP).

:func:`fit_gait` transcribes one step by multiple shooting (:mod:`pdw_casadi.nlp.shooting`),
minimises 1 - R^2 of the chosen curves (:mod:`pdw_casadi.fit.objective`) over the gait and
the compliance (and the slope with ``free_slope``) subject to the stability row
(:mod:`pdw_casadi.nlp.stability`: the smooth spectral-radius bound of the NLP step's own
Poincare Jacobian, exact gradient), from the atlas starts (:mod:`pdw_casadi.fit.starts`),
then checks the answer the way a reviewer would:

- **re-simulation**: the NLP's section state and parameters are run through the
  event-driven simulator for ``resim_steps`` steps; the largest deviation from the NLP's
  state must stay below ``resim_tol`` (:class:`~pdw_casadi.fit.FitOptions`; the NLP's map
  is the simulator's map);
- **stability**: the simulator's exact-AD eigenvalues at its fixed point are the verdict
  (rho <= max_radius);
- **validity**: the simulator's margins (contact forces, centre of pressure, clearance,
  impulses) at the fixed point;
- **consistency**: the objective interpolates the curves between RK4 samples chosen at the
  start; if the durations moved so far that the NLP objective and the re-simulated
  1 - R^2 differ by more than ``consistency_tol``, the NLP is built once more at the answer
  and solved again (``rounds``).
"""

from __future__ import annotations

import time

import numpy as np

from pdw_casadi.engine.compile import build_libraries
from pdw_casadi.engine.errors import NoGait
from pdw_casadi.engine.parallel import map_tasks
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.objective import check_targets
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Candidate, FitResult, evaluate_gait
from pdw_casadi.fit.rounds import fit_rounds
from pdw_casadi.fit.starts import Start, own_gait, select_starts
from pdw_casadi.fit.stride_fit import SidesFit, check_stride_targets, evaluate_stride
from pdw_casadi.gait.curves import fit_scores
from pdw_casadi.gait.fixed_point import FixedPointResult, find_fixed_point, own_fixed_point
from pdw_casadi.gait.poincare import PoincareMap, sensitivity_libraries
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import SideCurves
from pdw_casadi.model.system import gait_system, physical_parameter_vector
from pdw_casadi.nlp.interval import interval_library
from pdw_casadi.nlp.shooting import N_SUB, ShootingNLP
from pdw_casadi.nlp.stability import stability_libraries


class StepFit:
    """The one-step fit's part of :func:`~pdw_casadi.fit.rounds.fit_rounds`: the step's
    shooting NLP, the curve rows of ``human``, the checks of
    :func:`~pdw_casadi.fit.result.evaluate_gait` (start ``start``, ``label`` and its
    radius ``rho0`` in the progress lines)."""

    steps = 1

    def __init__(self, problem, human, opts: FitOptions, start: int, label: str, rho0: float,
                 log=print, floor: float | None = None):
        self.problem, self.human, self.opts, self.log = problem, human, opts, log
        self.floor = floor  # the knee R^2 floor (:func:`knee_floor`)
        self.start, self.label, self.rho0 = start, label, rho0
        self.sim = Simulator(problem)
        self.targets = opts.targets()
        self.free = tuple(opts.free or problem.compliance_names) + (
            ("slope",) if opts.free_slope else ())

    def nlp(self, x, p):
        opts = self.opts
        headroom = max(opts.segment_headroom_s,
                       opts.timing_headroom_s if opts.timing_weight > 0 else 0.0)
        return ShootingNLP(self.problem, x, p, free=self.free, sample_stride=opts.sample_stride,
                           hs=self.sim.hs, headroom_s=headroom)

    def solver(self, nlp) -> FitSolver:
        return FitSolver(nlp, self.human, self.opts, log=self.log, knee_floor=self.floor)

    def check(self, nlp, out: dict) -> Candidate | None:
        u = nlp.unpack(out["w"])
        cand = evaluate_gait(self.problem, u["xs"], u["p"], self.human, self.sim,
                             self.opts.resim_steps, self.opts.resim_tol, self.opts.max_radius)
        if cand is not None:
            cand.start = self.start
        return cand

    def polish(self, nlp, w) -> Candidate | None:
        cand = self.check(nlp, {"w": w})
        if cand is not None:
            # the gait is the simulator's fixed point, not the iterate: re-simulate it
            cand.resimulation_deviation = PoincareMap(self.problem, self.sim.hs) \
                .resimulation_deviation([cand.state], cand.parameters, self.opts.resim_steps)
            cand.objective = sum(1 - cand.scores[f"r2_{t}"] for t in self.targets)
        return cand

    def gap(self, cand: Candidate) -> float:
        return abs(cand.objective - sum(1 - cand.scores[f"r2_{t}"] for t in self.targets))

    def restart(self, cand: Candidate):
        return cand.state, cand.parameters

    def describe(self, nlp, rnd: int) -> str:
        return (f"start {self.start} ({self.label}, rho {self.rho0:.3f}) round {rnd}: "
                f"{len(nlp.specs)} segments, {nlp.w.shape[0]} unknowns, {nlp.g.shape[0]} "
                "constraints")

    def outcome(self, rnd: int, out: dict, rho: float, cand) -> str:
        return (f"start {self.start} round {rnd}: {out['status']} after {out['iterations']} "
                f"iterations ({out['wall_time_s']:.1f} s), objective {out['objective']:.4f}, "
                f"spectral radius {rho:.4f}"
                + (f", r2_knee {cand.scores['r2_knee']:.3f} r2_hip "
                   f"{cand.scores['r2_hip']:.3f}" if cand else ""))

    def where(self, rnd: int) -> str:
        return f"start {self.start} round {rnd}"


def knee_floor(problem, human, opts: FitOptions) -> float | None:
    """The knee R^2 floor of :attr:`FitOptions.knee_floor` as a number (None: no floor,
    or "reference" and the problem's own compliance has no gait or no knee curve; or no
    compliance value is free: the slope alone would be pinned to the start's knee)."""
    if opts.knee_floor is None or "knee" not in opts.targets():
        return None
    if not (opts.free or problem.compliance_names):
        return None
    if opts.knee_floor == "reference":
        gait = own_gait(problem)  # the curves of reference_gait, computed once per process
        value = None if gait is None else fit_scores(gait[0], human).get("r2_knee")
        return None if value is None or not np.isfinite(value) else float(value)
    if isinstance(opts.knee_floor, str):
        raise ValueError(f"knee_floor must be 'reference', a number or None, got "
                         f"{opts.knee_floor!r}")
    return float(opts.knee_floor)


def _fit_start(problem, human, opts: FitOptions, s: int, start: Start, log=print,
               floor: float | None = None):
    """One start: its fixed point, the NLP solve(s), checks. Returns (the best good round's
    candidate, else the last round's, or None; solves; notes)."""
    targets = opts.targets()
    fp0 = None
    if np.array_equal(start.state, problem.state_vector()) and \
            np.array_equal(start.parameters, problem.parameter_vector()):
        own = own_fixed_point(problem)  # the report's reference and the start ranking's
        if own.converged and own.method == "newton":
            fp0 = own  # what the call below would return
    if fp0 is None:
        fp0 = find_fixed_point(problem, start.state, start.parameters, max_iter=30,
                               fallback=False)
    if not fp0.converged:
        note = f"start {s} ({start.label}): no fixed point; skipped"
        log(note)
        return None, [], [note]
    fit = StepFit(problem, human, opts, s, start.label, fp0.spectral_radius, log=log,
                  floor=floor)
    rounds, solves, notes = fit_rounds(fit, fp0.state, fp0.parameters, opts, log=log,
                                       warm=start.warm if opts.atlas_warm_start else None)
    good = [c for c in rounds if c.good]
    best = max(good, key=lambda c: c.mean_score(targets)) if good else (
        rounds[-1] if rounds else None)
    return best, solves, notes


def _fit_start_task(args):
    problem, human, opts, s, start, floor = args
    return _fit_start(problem, human, opts, s, start, log=lambda m: None, floor=floor)


def fit_libraries(problem, opts: FitOptions, steps: int = 1) -> list:
    """Every compiled function a fit of ``problem`` on its ``steps``-step map calls: its
    walker, the Poincare map's sensitivities, the shooting intervals and the stability
    row's chain (for :func:`~pdw_casadi.engine.compile.build_libraries`)."""
    hs = PoincareMap(problem, steps=steps).hs if steps > 1 else gait_system(problem)
    items = [*hs.libraries(), *sensitivity_libraries(hs),
             *(interval_library(hs, phase, N_SUB) for phase in hs.phase_names)]
    if opts.stability_constraint:
        items += stability_libraries(hs, N_SUB)
    return items


def fit_gait(problem, human, options: FitOptions | None = None, log=print,
             workers: int = 1, scheduler: str | None = None):
    """Fit ``problem``'s compliance (and slope with ``free_slope``) and periodic gait to
    ``human`` curves (:class:`~pdw_casadi.model.gait_data.GaitCurves`).

    Starts: the ``multistart`` gaits of the atlas and the problem's own whose curves fit
    ``human`` best, the most stable first among near-equals (:func:`select_starts`), run on
    ``workers`` processes or a Dask ``scheduler`` when there are several (identical results
    in any mode). ``best`` is the stable (rho <= max_radius), valid
    candidate with the highest mean R^2 of the targets (None if no start gave one).

    Per-side curves (:class:`~pdw_casadi.model.gait_data.SideCurves`): the per-leg fit, the
    same rounds (:func:`~pdw_casadi.fit.rounds.fit_rounds`) on the stride, the two-step
    map (:func:`fit_sides`; ``options`` with its ``side`` and ``start``).
    """
    if isinstance(human, SideCurves):
        build_libraries(fit_libraries(problem, options or FitOptions(), steps=2), log=log)
        return fit_sides(problem, human, options, log=log)
    opts = options or FitOptions()
    check_targets(problem, human, opts)
    build_libraries(fit_libraries(problem, opts), log=log)
    targets = opts.targets()
    t_start = time.perf_counter()
    starts = select_starts(problem, human, opts)
    floor = knee_floor(problem, human, opts)
    if floor is not None:
        log(f"knee R^2 floor {floor:.4f} (the problem's own compliance on these curves)")
    for s, st in enumerate(starts):
        log(f"start {s}: {st.label}" + ("" if np.isnan(st.score) else
                                         f" (mean R^2 {st.score:.3f} before fitting)"))
    if len(starts) > 1 and (workers > 1 or scheduler):
        tasks = [(problem, human, opts, s, st, floor) for s, st in enumerate(starts)]
        results = list(map_tasks(_fit_start_task, tasks, workers=workers, scheduler=scheduler))
    else:
        results = [_fit_start(problem, human, opts, s, st, log=log, floor=floor)
                   for s, st in enumerate(starts)]
    candidates = [r[0] for r in results if r[0] is not None]
    solves = [x for r in results for x in r[1]]
    notes = [x for r in results for x in r[2]]
    good = [c for c in candidates if c.good]
    best = max(good, key=lambda c: c.mean_score(targets), default=None)
    return FitResult(problem, best, candidates, solves, opts, time.perf_counter() - t_start,
                     targets, notes)


def symmetric_start(problem, sides: SideCurves, opts: FitOptions, log=print):
    """The per-leg fit's start on a walker with equal legs: (section state, step parameters,
    label, the start fit's solves, notes, its NLP solution with multipliers or None).
    ``opts.start`` "fit": the one-step fit to the mean of both sides (:func:`fit_gait`),
    "atlas" (or when that fit finds no stable valid gait): the atlas or problem gait that
    fits the mean best."""
    mean = sides.mean()
    notes: list[str] = []
    if opts.start == "fit":
        log("symmetric start: the one-step fit to the mean of both sides")
        res = fit_gait(problem, mean, opts, log=log)
        cand = res.best
        if cand is not None:
            return cand.state, cand.parameters, "symmetric fit to the mean of both sides", \
                res.solves, res.notes, cand.warm
        notes = [*res.notes, "the symmetric start fit found no stable valid gait; starting "
                             "from the atlas"]
        log(notes[-1])
    start = select_starts(problem, mean, opts)[0]
    fp = find_fixed_point(problem, start.state, start.parameters, max_iter=30,
                          fallback=False)
    if not fp.converged:
        raise NoGait(f"the start gait {start.label} has no fixed point")
    return fp.state, fp.parameters, start.label, [], notes, None


def fit_sides(problem, sides: SideCurves, options: FitOptions | None = None,
              log=print) -> FitResult:
    """Fit each leg of ``problem``'s walker to its side of ``sides`` on the stride
    (:mod:`pdw_casadi.fit.stride_fit`): :func:`fit_rounds` on the two-step map
    (:class:`~pdw_casadi.fit.stride_fit.SidesFit`). ``problem``: a symmetric walker (the
    start is :func:`symmetric_start`, repeated twice), or one whose legs differ (the start
    is its own stride fixed point). The result's candidates are two-step candidates
    (:class:`~pdw_casadi.fit.result.Candidate`, ``steps`` 2); its ``start`` is the symmetric
    start (label, state, parameters, R^2 and curves per leg), its ``free`` the stride NLP's
    free names."""
    opts = options or FitOptions()
    check_stride_targets(problem, sides, opts)
    t_start = time.perf_counter()
    targets = opts.targets()
    smap = PoincareMap(problem, steps=2)
    if problem.asymmetric:
        fp0 = find_fixed_point(problem, pmap=smap, fallback=False)
        if not fp0.converged:
            raise NoGait(f"{problem.name}: no stride fixed point near its initial state")
        x, theta, label, solves, notes = fp0.state, fp0.parameters, "the problem's own " \
            "stride gait", [], []
        warm = None
    else:
        x, p, label, solves, notes, warm = symmetric_start(problem, sides, opts, log)
        theta = physical_parameter_vector(problem.with_parameters(p))
    solves = list(solves)
    start = evaluate_stride(smap, (x, x), theta, sides, opts.resim_steps, opts.resim_tol,
                            opts.max_radius) if not problem.asymmetric else None
    start_info = {"label": label, "state": np.asarray(x, float).tolist(),
                  "parameters": np.asarray(theta, float).tolist(),
                  "scores": None if start is None else start.scores,
                  "curves": None if start is None else start.report["curves"]}
    fit = SidesFit(problem, sides, opts, label, log=log)
    rounds, more, more_notes = fit_rounds(fit, x, theta, opts, log=log,
                                          warm=warm if opts.stride_warm_start else None)
    solves += more
    notes = list(notes) + more_notes
    good = [c for c in rounds if c.good]
    best = max(good, key=lambda c: c.mean_score(targets)) if good else None
    return FitResult(problem, best, rounds, solves, opts, time.perf_counter() - t_start,
                     targets, notes, start=start_info, free=fit.free)


class RefitCorrector:
    """A continuation corrector that refits the compliance at every point of a sweep.

    Called with (x_guess, p) by :func:`pdw_casadi.gait.continuation.continue_branch`: the
    compliance of ``p`` (the neighbour's fit) is the NLP's start, the swept value of ``p``
    stays fixed, and the best stable valid fit's fixed point is returned (its ``parameters``
    hold the refitted compliance, so the next point starts from them). If the fit finds no
    stable valid gait, the plain Newton fixed point at ``p`` is returned.
    """

    def __init__(self, problem, human, options: FitOptions | None = None):
        self.problem, self.human = problem, human
        # no knee floor: the swept value moves the problem's own gait with it
        self.options = options or FitOptions(verbose=False, atlas="", knee_floor=None)

    def __call__(self, x_guess, p) -> FixedPointResult:
        pb = self.problem.with_parameters(p).with_state(np.asarray(x_guess, float))
        res = fit_gait(pb, self.human, self.options, log=lambda m: None)
        if res.best is not None:
            return res.best.fixed_point
        return find_fixed_point(pb, x_guess, p, max_iter=10, fallback=False)
