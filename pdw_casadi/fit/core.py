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

from pdw_casadi.engine.parallel import map_tasks
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.objective import TARGETS, CurveError
from pdw_casadi.fit.options import FitOptions
from pdw_casadi.fit.result import Candidate, FitResult, Solve, evaluate_gait, mean_score
from pdw_casadi.fit.starts import Start, select_starts
from pdw_casadi.gait.fixed_point import FixedPointResult, find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.nlp.shooting import ShootingNLP


def check_targets(problem, human, opts: FitOptions) -> None:
    """Raise :class:`CurveError` before any work when the curves or the walker lack a target."""
    if opts.hip_target not in ("hip", "thigh"):
        raise CurveError(f"hip_target must be 'hip' or 'thigh', got {opts.hip_target!r}")
    for target in opts.targets():
        column = TARGETS[target][1]
        if getattr(human, column, None) is None:
            raise CurveError(f"the gait file has no {column} column (needed for {target})")


def _consistency_gap(cand: Candidate, targets) -> float:
    """|NLP objective - sum of 1 - R^2 of the re-simulated gait|."""
    return abs(cand.objective - sum(1 - cand.scores[f"r2_{t}"] for t in targets))


def _fit_start(problem, human, opts: FitOptions, s: int, start: Start, log=print):
    """One start: its fixed point, the NLP solve(s), checks. Returns (the best good round's
    candidate, else the last round's, or None; solves; notes)."""
    sim = Simulator(problem)
    targets = opts.targets()
    free = tuple(opts.free or problem.compliance_names) + (("slope",) if opts.free_slope else ())
    solves: list[Solve] = []
    notes: list[str] = []
    fp0 = find_fixed_point(problem, start.state, start.parameters, max_iter=30, fallback=False)
    if not fp0.converged:
        notes.append(f"start {s} ({start.label}): no fixed point; skipped")
        log(notes[-1])
        return None, solves, notes
    x, p = fp0.state, fp0.parameters
    rounds: list[Candidate] = []
    for rnd in range(opts.rounds):
        try:
            headroom = max(opts.segment_headroom_s,
                           opts.timing_headroom_s if opts.timing_weight > 0 else 0.0)
            nlp = ShootingNLP(problem, x, p, free=free, sample_stride=opts.sample_stride,
                              hs=sim.hs, headroom_s=headroom)
        except ValueError as exc:
            notes.append(f"start {s} round {rnd}: {exc}")
            log(notes[-1])
            break
        log(f"start {s} ({start.label}, rho {fp0.spectral_radius:.3f}) round {rnd}: "
            f"{len(nlp.specs)} segments, {nlp.w.shape[0]} unknowns, {nlp.g.shape[0]} "
            "constraints")
        out = FitSolver(nlp, human, opts, log=log).solve(nlp.w0)
        u = nlp.unpack(out["w"])
        cand = evaluate_gait(problem, u["xs"], u["p"], human, sim, opts.resim_steps,
                             opts.resim_tol) if out["success"] else None
        rho = cand.fixed_point.spectral_radius if cand else float("nan")
        hist = out["history"]
        solves.append(Solve(s, rnd, out["status"], out["iterations"], out["wall_time_s"],
                            out["objective"], rho,
                            hist[-1].spectral_bound if hist else float("nan")))
        log(f"start {s} round {rnd}: {out['status']} after {out['iterations']} iterations "
            f"({out['wall_time_s']:.1f} s), objective {out['objective']:.4f}, spectral radius "
            f"{rho:.4f}" + (f", r2_knee {cand.scores['r2_knee']:.3f} r2_hip "
                            f"{cand.scores['r2_hip']:.3f}" if cand else ""))
        if cand is None:
            notes.append(f"start {s} round {rnd}: {out['status']}"
                         + ("; no fixed point of the simulator there" if out["success"] else ""))
            break
        cand.start, cand.objective = s, out["objective"]
        rounds.append(cand)
        if _consistency_gap(cand, targets) <= opts.consistency_tol * max(cand.objective, 1e-6):
            break
        x, p = cand.state, cand.parameters
    good = [c for c in rounds if c.good(opts)]
    best = max(good, key=lambda c: mean_score(c, targets)) if good else (
        rounds[-1] if rounds else None)
    return best, solves, notes


def _fit_start_task(args):
    problem, human, opts, s, start = args
    return _fit_start(problem, human, opts, s, start, log=lambda m: None)


def fit_gait(problem, human, options: FitOptions | None = None, log=print,
             workers: int = 1, scheduler: str | None = None) -> FitResult:
    """Fit ``problem``'s compliance (and slope with ``free_slope``) and periodic gait to
    ``human`` curves (:class:`~pdw_casadi.model.gait_data.GaitCurves`).

    Starts: the ``multistart`` gaits of the atlas and the problem's own whose curves fit
    ``human`` best, the most stable first among near-equals (:func:`select_starts`), run on
    ``workers`` processes or a Dask ``scheduler`` when there are several (identical results
    in any mode). ``best`` is the stable (rho <= max_radius), valid
    candidate with the highest mean R^2 of the targets (None if no start gave one).
    """
    opts = options or FitOptions()
    check_targets(problem, human, opts)
    targets = opts.targets()
    t_start = time.perf_counter()
    starts = select_starts(problem, human, opts)
    for s, st in enumerate(starts):
        log(f"start {s}: {st.label}" + ("" if np.isnan(st.score) else
                                         f" (mean R^2 {st.score:.3f} before fitting)"))
    if len(starts) > 1 and (workers > 1 or scheduler):
        tasks = [(problem, human, opts, s, st) for s, st in enumerate(starts)]
        results = list(map_tasks(_fit_start_task, tasks, workers=workers, scheduler=scheduler))
    else:
        results = [_fit_start(problem, human, opts, s, st, log=log)
                   for s, st in enumerate(starts)]
    candidates = [r[0] for r in results if r[0] is not None]
    solves = [x for r in results for x in r[1]]
    notes = [x for r in results for x in r[2]]
    good = [c for c in candidates if c.good(opts)]
    best = max(good, key=lambda c: mean_score(c, targets), default=None)
    return FitResult(problem, best, candidates, solves, opts, time.perf_counter() - t_start,
                     targets, notes)


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
        self.options = options or FitOptions(verbose=False, atlas="")

    def __call__(self, x_guess, p) -> FixedPointResult:
        pb = self.problem.with_parameters(p).with_state(np.asarray(x_guess, float))
        res = fit_gait(pb, self.human, self.options, log=lambda m: None)
        if res.best is not None:
            return res.best.fixed_point
        return find_fixed_point(pb, x_guess, p, max_iter=10, fallback=False)
