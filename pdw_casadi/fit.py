"""Fit a walker's compliance and periodic gait to human knee and hip curves (one IPOPT NLP).

:func:`fit_gait` transcribes one step by multiple shooting (:mod:`pdw_casadi.shooting`),
minimises 1 - R^2 of the chosen curves (:mod:`pdw_casadi.objective`) over the gait and the
compliance (and the slope with ``free_slope``), then checks the answer the way a reviewer
would:

- **re-simulation**: the NLP's section state and parameters are run through the
  event-driven simulator for 20 steps; the largest deviation from the NLP's state is reported
  (it must stay below 1e-6: the NLP's map is the simulator's map);
- **stability** is a constraint of the NLP: (sum_i |lambda_i|^32)^(1/32) <= max_radius -
  0.01, a smooth upper bound of the spectral radius (the plain max has kinks where
  eigenvalues trade places). The lambda_i are the eigenvalues of the exact-AD Jacobian of
  the simulator's Poincare map at its fixed point x*(p) for the NLP's parameters (Newton
  from the NLP's section state), so the bound is a function of the parameters alone; its
  gradient is by central differences of that exact Jacobian. A linearised constraint in an
  outer loop does not work for this walker: rho is steep and curved in the compliance
  (d rho / d ln k_ankle ~ 97 at Table 3; a linear prediction is wrong in sign already for
  0.2 % steps);
- **rounds**: the objective interpolates the curves between RK4 samples chosen at the
  round's starting gait. When IPOPT stops with the NLP objective and the re-simulated
  1 - R^2 apart (the durations moved), or stalls along the stability bound, the NLP is
  rebuilt at the answer's exact gait and solved again (``FitOptions.rounds``);
- **validity**: the simulator's margins (contact forces, centre of pressure, clearance,
  impulses) at the fixed point.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import pandas as pd

from .callback import NumericFunction
from .curves import fit_scores, gait_cycle
from .fixed_point import FixedPointResult, find_fixed_point
from .objective import curve_errors
from .shooting import ShootingNLP
from .simulate import Simulator

RESIM_STEPS = 20
#: a round's NLP objective must match the re-simulated 1 - R^2 to this relative gap, or the
#: NLP is rebuilt at its answer (new sample brackets) and solved again
CONSISTENCY_TOL = 1e-3
RADIUS_NORM = 32  # q of the smooth spectral-radius bound constrained in the NLP


@dataclass
class FitOptions:
    """Settings of :func:`fit_gait`.

    ``hip_target``: "hip" (the paper's hip angle, thigh + slope) or "thigh" (thigh from the
    gravity vertical, like-for-like with the human thigh column). ``max_radius``: largest
    accepted spectral radius of the Poincare map (stability margin 1 - max_radius).
    """

    hip_target: str = "hip"
    free_slope: bool = False
    slope_bounds: tuple[float, float] = (0.05, 0.25)  # rad
    max_radius: float = 0.91  # the NLP bounds the smooth bound by 0.90, so rho <= 0.9
    stability_constraint: bool = True  # rho <= max_radius - 0.01 as an NLP constraint
    multistart: int = 1
    seed: int = 0
    spread: float = 0.3  # relative log-normal spread of the multistart compliance
    max_iter: int = 150
    rounds: int = 3  # NLP solves per start, each rebuilt at the previous answer
    tol: float = 1e-6
    sample_stride: int = 2
    verbose: bool = True
    free: tuple[str, ...] | None = None  # compliance names to fit (default: all)
    ipopt: dict = field(default_factory=dict)  # extra IPOPT options (override the defaults)


@dataclass
class Solve:
    """One IPOPT solve: status, iterations, wall time (s), objective (sum of 1 - R^2)."""

    start: int
    round: int
    status: str
    iterations: int
    wall_time_s: float
    objective: float
    spectral_radius: float = float("nan")

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class Candidate:
    """A fitted gait with its checks."""

    start: int
    state: np.ndarray
    parameters: np.ndarray
    fixed_point: FixedPointResult
    scores: dict
    curves: pd.DataFrame
    resimulation_deviation: float
    objective: float

    @property
    def stable(self) -> bool:
        return self.fixed_point.stable

    @property
    def valid(self) -> bool:
        return self.fixed_point.valid and self.resimulation_deviation < 1e-6


@dataclass
class FitResult:
    """The best fit, every start's outcome and the IPOPT solves."""

    problem: object
    best: Candidate | None
    candidates: list[Candidate]
    solves: list[Solve]
    options: FitOptions
    wall_time_s: float
    targets: tuple[str, ...]
    notes: list[str] = field(default_factory=list)

    def starts_frame(self) -> pd.DataFrame:
        rows = []
        for c in self.candidates:
            rows.append({"start": c.start, **c.scores, "objective": c.objective,
                         "spectral_radius": c.fixed_point.spectral_radius,
                         "stable": c.stable, "valid": c.valid,
                         "resimulation_deviation": c.resimulation_deviation,
                         "failure": c.fixed_point.failure})
        return pd.DataFrame(rows)


def _curves_of(problem, sim: Simulator, x, p):
    one = sim.run(x, p, steps=1, record=True)
    if one.failure is not None:
        return None
    return gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase)


def evaluate_gait(problem, x, p, human, sim: Simulator | None = None,
                  resim_steps: int = RESIM_STEPS) -> Candidate | None:
    """Checks of a gait (x: section state, p: parameters): fixed point, stability, margins,
    20-step re-simulation deviation of x itself, curves and R^2 against ``human``."""
    sim = sim or Simulator(problem)
    run = sim.run(x, p, steps=resim_steps, record=False)
    ps = run.poincare_states
    dev = float(np.abs(ps - x).max()) if run.failure is None else math.inf
    fp = find_fixed_point(problem, x, p, max_iter=15, fallback=False)
    if not fp.converged:
        return None
    curves = _curves_of(problem, sim, fp.state, fp.parameters)
    if curves is None:
        return None
    return Candidate(-1, fp.state, fp.parameters, fp, fit_scores(curves, human), curves, dev,
                     float("nan"))


class _RadiusBound:
    """The stability constraint's function for the NLP: a smooth upper bound of the spectral
    radius, (sum |lambda|^32)^(1/32), of the exact-AD Poincare Jacobian at the simulator's
    fixed point x*(p) of the NLP's current parameters (:meth:`function`).

    Near feasibility it depends on the parameters only. Evaluating it at the NLP's own
    section state would couple it to the states of infeasible iterates, and rho is so
    steep in (x, p) near this walker's fold that IPOPT then wanders along the bound
    (measured: rho 0.94 in the NLP, 0.98 at the simulator's fixed point of the same
    parameters). x*(p) comes from Newton's method started at the NLP's section state (so
    that it is the NLP's own orbit, not the other branch near the fold), else at the
    implicit-function prediction from the last fixed point; the gradient is by central
    differences in the parameters (second derivatives of the hybrid map are not
    available). Where no fixed point is found, the
    Jacobian at the NLP's section state itself stands in (see :meth:`rho`); where the
    step fails even there, the value is NaN: IPOPT treats it as an evaluation error and
    cuts its step back (a large finite value sends it into restoration, measured)."""

    def __init__(self, pmap, nlp: ShootingNLP, fd_step: float = 1e-6, tol: float = 1e-10):
        self.pmap, self.nlp, self.h, self.tol = pmap, nlp, fd_step, tol
        self.ns, self.nf = nlp.xs.shape[0], len(nlp.free)
        self.cols = [nlp.param_names.index(name) for name in nlp.free]
        self.last = None  # (p, x*, dP/dx, dP/dp) of the last base fixed point
        self.mode = "fixed_point"  # how the last base point was evaluated

    def _params(self, z) -> np.ndarray:
        p = self.nlp.p0.copy()
        p[self.cols] = np.asarray(z, float).ravel()[self.ns:] * self.nlp.p_scale
        return p

    def _newton(self, x, p, max_iter: int = 8):
        # plain Newton rather than find_fixed_point, which also evaluates the margins at
        # its answer: that would double the cost of every finite difference
        eye = np.eye(x.size)
        for _ in range(max_iter):
            try:
                r = self.pmap.evaluate(x, p)
            except Exception:  # noqa: BLE001 (a failed step means no fixed point here)
                return None
            G = r.x_next - x
            if not np.all(np.isfinite(G)) or np.linalg.norm(G) > 0.5:
                return None
            if np.linalg.norm(G) < self.tol:
                return x, r
            x = x - np.linalg.solve(r.dx - eye, G)
        return None

    def _predict(self, p):
        """First-order prediction of x*(p) from the last base fixed point."""
        p_l, x_l, J_l, Jp_l = self.last
        return x_l + np.linalg.solve(np.eye(x_l.size) - J_l, Jp_l @ (p - p_l))

    def _fixed_point(self, z, update: bool):
        p = self._params(z)
        if update:
            # the NLP's own section state first: near the fold a second fixed point (the
            # other branch, with a different rho) lies close by, and a prediction from
            # another iterate can land on it (measured: rho 0.94 there, 1.74 on the NLP's
            # orbit). At a converged NLP the section state is the fixed point itself; the
            # prediction only serves infeasible iterates whose state is too far for Newton
            guesses = [np.asarray(z, float).ravel()[: self.ns]]
            if self.last is not None:
                guesses.append(self._predict(p))
        else:
            guesses = [self._predict(p)]  # a finite-difference neighbour of the base point
        for x in guesses:
            found = self._newton(x, p)
            if found is not None:
                if update:
                    self.last = (p, found[0], found[1].dx, found[1].dp)
                return found[1].dx
        return None

    @staticmethod
    def _bound(J) -> float:
        # max |l| <= (sum |l|^q)^(1/q) <= n^(1/q) max |l| (q = 32: a complex pair counts
        # 2^(1/32) = 1.022); the plain max has kinks where two eigenvalues trade places
        m = np.abs(np.linalg.eigvals(J))
        top = m.max()
        return float(top * np.sum((m / top) ** RADIUS_NORM) ** (1 / RADIUS_NORM)) if top else 0.0

    def _state_jacobian(self, z):
        z = np.asarray(z, float).ravel()
        try:
            return self.pmap.evaluate(z[: self.ns], self._params(z)).dx
        except Exception:  # noqa: BLE001 (a failed step is a value, not an error, here)
            return None

    def rho(self, z, update: bool = True) -> float:
        """The bound at the NLP's unknowns ``z`` (section state, scaled free parameters).
        Base points (``update``) fall back to the Jacobian at the NLP's own section state
        where Newton finds no fixed point (an infeasible iterate far from any orbit; the
        two agree as the iterate becomes feasible); their finite-difference neighbours use
        the base point's definition."""
        if update:
            J = self._fixed_point(z, True)
            self.mode = "fixed_point"
            if J is None:
                J, self.mode = self._state_jacobian(z), "state"
        else:
            J = self._fixed_point(z, False) if self.mode == "fixed_point" else \
                self._state_jacobian(z)
        return math.nan if J is None else self._bound(J)

    def gradient(self, z) -> np.ndarray:
        """Central differences (forward ones, at half the cost, are within 6e-4 relative
        at the fitted gait, but sent IPOPT on a 4:50 path instead of 1:53, measured)."""
        z = np.asarray(z, float).ravel()
        r0 = self.rho(z)  # the base fixed point warm-starts the perturbed ones
        g = np.zeros(z.size)
        if math.isnan(r0):
            return np.full(z.size, math.nan)
        for i in range(self.ns if self.mode == "fixed_point" else 0, z.size):
            e = np.zeros(z.size)
            e[i] = self.h * max(1.0, abs(z[i]))
            up, down = self.rho(z + e, False), self.rho(z - e, False)
            if math.isnan(up) or math.isnan(down):  # one-sided next to a missing fixed point
                g[i] = (up - r0) / e[i] if math.isnan(down) else (r0 - down) / e[i]
            else:
                g[i] = (up - down) / (2 * e[i])
        return g

    def function(self, name: str = "rho") -> NumericFunction:
        n = self.ns + self.nf
        dense = ca.Sparsity.dense

        def jacobian(jname):
            return NumericFunction(jname, [dense(n, 1), dense(1, 1)], [dense(1, n)],
                                   lambda a: [ca.DM(self.gradient(a[0])).T])

        return NumericFunction(name, [dense(n, 1)], [dense(1, 1)],
                               lambda a: [self.rho(a[0])], jacobian)


class _BestFeasible(ca.Callback):
    """IPOPT iteration callback keeping the nearly feasible iterate (largest constraint
    violation below ``tol``) with the lowest objective, and stopping IPOPT (status
    User_Requested_Stop) once that objective has not improved by ``stall_tol`` for
    ``stall_iter`` iterations (iterates whose objective lies ``explore_gap`` below the best
    count as progress). With the stability bound active, IPOPT can wander along it for
    hundreds of iterations with the objective flat to 1e-4 and inf_pr jumping between 1e-5
    and 1e-1; the kept iterate's compliance then starts the next round."""

    def __init__(self, name, nx, ng, lbg, ubg, tol: float = 1e-4, stall_iter: int = 30,
                 stall_tol: float = 1e-4, explore_gap: float = 1e-2):
        ca.Callback.__init__(self)
        self.nx, self.ng, self.lbg, self.ubg, self.tol = nx, ng, lbg, ubg, tol
        self.stall_iter, self.stall_tol, self.explore_gap = stall_iter, stall_tol, explore_gap
        self.best = None
        self.iter = self.last_gain = 0
        self.construct(name, {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        if n == "f":
            return ca.Sparsity.dense(1)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        d = dict(zip(ca.nlpsol_out(), arg, strict=False))
        g = np.asarray(d["g"]).ravel()
        viol = max(float(np.max(self.lbg - g, initial=0)), float(np.max(g - self.ubg, initial=0)))
        f = float(d["f"])
        self.iter += 1
        if viol < self.tol and (self.best is None or f < self.best[0]):
            if self.best is None or f < self.best[0] - self.stall_tol:
                self.last_gain = self.iter
            self.best = (f, np.asarray(d["x"]).ravel().copy())
        elif self.best is not None and f < self.best[0] - self.explore_gap:
            # an infeasible iterate well below the best feasible objective: IPOPT is
            # still heading somewhere better (measured: 0.24 against 0.28), not stalled
            self.last_gain = self.iter
        stalled = self.best is not None and self.iter - self.last_gain >= self.stall_iter
        return [1 if stalled else 0]


class _Solver:
    """IPOPT on one ShootingNLP. The curve errors at the RK4 samples are extra unknowns E
    (E - err(w) = 0), so the objective sum w E^2 / SS_tot has a trivial gradient and one
    constraint-Jacobian pass per iteration serves all derivatives; each error row depends on
    few unknowns, which keeps the Jacobian's colouring cheap."""

    def __init__(self, nlp: ShootingNLP, human, targets, opts: FitOptions):
        self.nlp = nlp
        errs = curve_errors(nlp, human, targets)
        err_rows, obj = [], 0
        self.E = []
        for _target, (parts, ss_tot) in errs.items():
            for err, w in parts:
                E = ca.MX.sym(f"E{len(self.E)}", 1, err.shape[1])
                self.E.append(E)
                err_rows.append(ca.vec(E - err))
                obj = obj + w * ca.sumsqr(E) / ss_tot
        self.e = ca.vertcat(*[ca.vec(E) for E in self.E])
        self.err = ca.Function("err", [nlp.w], [ca.vertcat(*[ca.vec(err) for p, _ in
                                                             errs.values() for err, _w in p])])
        self.f = obj
        self.x = ca.vertcat(nlp.w, self.e)
        self.g_base = ca.vertcat(nlp.g, *err_rows)
        self.opts = opts
        self.lo, self.hi = nlp.bounds(opts.slope_bounds)
        self.rho_row = None
        if opts.stability_constraint and nlp.free:
            from .poincare import PoincareMap

            self.rho_fun = _RadiusBound(PoincareMap(nlp.problem), nlp).function()
            self.rho_row = self.rho_fun(ca.vertcat(nlp.xs, nlp.pf))

    def solve(self, w0):
        """Solve from ``w0`` (unknowns of the ShootingNLP); a dict with the solution."""
        nlp, opts = self.nlp, self.opts
        g = self.g_base
        lbg = np.r_[nlp.lbg, np.zeros(self.e.shape[0])]
        ubg = np.r_[nlp.ubg, np.zeros(self.e.shape[0])]
        if self.rho_row is not None:
            g = ca.vertcat(g, self.rho_row)
            lbg, ubg = np.r_[lbg, 0.0], np.r_[ubg, opts.max_radius - 0.01]
        ipopt = {"hessian_approximation": "limited-memory", "max_iter": opts.max_iter,
                 "tol": opts.tol, "acceptable_tol": 100 * opts.tol, "acceptable_iter": 10,
                 "print_level": 5 if opts.verbose else 0, "print_frequency_iter": 10,
                 "sb": "yes", "mu_strategy": "adaptive", **opts.ipopt}
        keeper = _BestFeasible("pdw_fit_iterates", self.x.shape[0], g.shape[0], lbg, ubg)
        solver = ca.nlpsol("pdw_fit", "ipopt", {"x": self.x, "f": self.f, "g": g},
                           {"ipopt": ipopt, "print_time": False, "iteration_callback": keeper,
                            # a NaN stability row is a deliberate step cut-back, not news
                            "show_eval_warnings": False})
        e0 = self.err(w0).full().ravel()
        lo, hi = self.lo, self.hi
        w0 = np.clip(w0, lo, hi)
        args = {"x0": np.r_[w0, e0], "lbx": np.r_[lo, np.full(e0.size, -np.inf)],
                "ubx": np.r_[hi, np.full(e0.size, np.inf)], "lbg": lbg, "ubg": ubg}
        t0 = time.perf_counter()
        sol = solver(**args)
        st = solver.stats()
        x = sol["x"].full().ravel()
        f_sol = float(sol["f"])
        converged = st["return_status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
        if not converged and keeper.best is not None:
            # stopped on the iteration limit or stalled: the best nearly feasible iterate
            # seen is the answer (the caller re-simulates it and may solve again from it)
            f_sol, x = keeper.best
        out = {"w": x[: nlp.w.shape[0]], "objective": f_sol,
               "lam_x": sol["lam_x"].full().ravel(), "lam_g": sol["lam_g"].full().ravel(),
               "status": st["return_status"], "iterations": int(st["iter_count"]),
               "wall_time_s": time.perf_counter() - t0,
               "success": bool(st["success"]) or st["return_status"] in (
                   "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded",
                   "User_Requested_Stop")}
        return out


def _starts(problem, opts: FitOptions) -> list[np.ndarray]:
    """Starting parameter vectors: the problem's own, then log-normal perturbations of its
    compliance inside the problem's bounds (reproducible with ``seed``)."""
    p0 = problem.parameter_vector()
    starts = [p0]
    rng = np.random.default_rng(opts.seed)
    names = problem.parameter_names
    for _ in range(max(0, opts.multistart - 1)):
        p = p0.copy()
        for i, name in enumerate(names[:-1]):
            lo, hi = problem.compliance_bounds.get(name, (-np.inf, np.inf))
            p[i] = float(np.clip(p0[i] * math.exp(opts.spread * rng.standard_normal()), lo, hi))
        starts.append(p)
    return starts


def _fit_start(problem, human, opts: FitOptions, s: int, p_start, log=print):
    """One start: fixed point of the starting compliance, up to ``opts.rounds`` NLP solves
    (each rebuilt at the previous answer), checks. Returns (the best round's candidate or
    None, solves, notes)."""
    sim = Simulator(problem)
    targets = ("knee", opts.hip_target)
    free = tuple(opts.free or problem.compliance_names) + (("slope",) if opts.free_slope else ())
    solves, notes = [], []
    fp0 = find_fixed_point(problem, problem.state_vector(), p_start, max_iter=30,
                           fallback=False)
    if not fp0.converged:
        notes.append(f"start {s}: no fixed point of the starting compliance; skipped")
        log(notes[-1])
        return None, solves, notes
    try:
        nlp = ShootingNLP(problem, fp0.state, p_start, free=free,
                          sample_stride=opts.sample_stride, hs=sim.hs)
    except ValueError as exc:
        notes.append(f"start {s}: {exc}")
        log(notes[-1])
        return None, solves, notes
    converged = False
    rounds: list[Candidate] = []  # every round's checked gait: a later one can end worse
    for rnd in range(opts.rounds):
        if rnd:
            # the objective interpolates the curves between RK4 samples chosen at the
            # starting gait; once the durations have moved, the NLP is rebuilt at the last
            # gait (exact simulator fixed point, new plan and brackets) and solved again
            try:
                nlp = ShootingNLP(problem, rounds[-1].state, rounds[-1].parameters,
                                  free=free, sample_stride=opts.sample_stride, hs=sim.hs)
            except ValueError as exc:
                notes.append(f"start {s} round {rnd}: {exc}")
                log(notes[-1])
                break
        else:
            log(f"start {s}: {len(nlp.specs)} segments, {nlp.w.shape[0]} unknowns, "
                f"{nlp.g.shape[0]} constraints; solving with IPOPT")
        out = _Solver(nlp, human, targets, opts).solve(nlp.w0)
        new = _check(problem, nlp, out, human, sim, s, rnd, solves, notes, log)
        if new is None:
            break
        rounds.append(new)
        converged = out["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
        if converged and _consistency_gap(new, targets) <= CONSISTENCY_TOL * max(
                new.objective, 1e-6):
            break
    if not rounds or converged:
        return _best_round(rounds, opts, targets), solves, notes
    # IPOPT stopped (iteration limit or stall): keep the last compliance and solve the NLP
    # again at it (states and durations only), so that what is reported is an exact NLP
    # gait of that compliance, re-simulated and checked like any other
    log(f"start {s}: IPOPT stopped ({out['status']}); re-solving the gait at its last "
        "compliance")
    try:
        fixed = ShootingNLP(problem, rounds[-1].state, rounds[-1].parameters, free=(),
                            sample_stride=opts.sample_stride, hs=sim.hs)
    except ValueError as exc:
        notes.append(f"start {s}: {exc}")
        return _best_round(rounds, opts, targets), solves, notes
    out = _Solver(fixed, human, targets, opts).solve(fixed.w0)
    final = _check(problem, fixed, out, human, sim, s, opts.rounds, solves, notes, log)
    if final is not None:
        rounds[-1] = final  # the same compliance, as an exact NLP gait
    return _best_round(rounds, opts, targets), solves, notes


def _good(c: Candidate, opts: FitOptions) -> bool:
    return c.stable and c.valid and c.fixed_point.spectral_radius <= opts.max_radius


def mean_score(c: Candidate, targets) -> float:
    """Mean R^2 of ``targets`` ("knee", "hip", "thigh") of a candidate: what fits rank by."""
    return float(np.mean([c.scores[f"r2_{t}"] for t in targets]))


def _best_round(rounds: list[Candidate], opts: FitOptions, targets) -> Candidate | None:
    """The stable, valid round with the best mean R^2 of the targets, else the last round."""
    good = [c for c in rounds if _good(c, opts)]
    if good:
        return max(good, key=lambda c: mean_score(c, targets))
    return rounds[-1] if rounds else None


def _consistency_gap(cand: Candidate, targets) -> float:
    """|NLP objective - sum of 1 - R^2 of the re-simulated gait|: zero when the objective's
    sample brackets (chosen at the round's starting gait) still hold at its optimum."""
    return abs(cand.objective - sum(1 - cand.scores[f"r2_{t}"] for t in targets))


def _check(problem, nlp, out, human, sim, s, rnd, solves, notes, log) -> Candidate | None:
    """Evaluate one solve's gait with the simulator; record the solve."""
    u = nlp.unpack(out["w"])
    cand = evaluate_gait(problem, u["xs"], u["p"], human, sim) if out["success"] else None
    rho = cand.fixed_point.spectral_radius if cand else float("nan")
    solves.append(Solve(s, rnd, out["status"], out["iterations"], out["wall_time_s"],
                        out["objective"], rho))
    log(f"start {s} round {rnd}: {out['status']} after {out['iterations']} "
        f"iterations ({out['wall_time_s']:.1f} s), objective {out['objective']:.4f}, "
        f"spectral radius {rho:.4f}"
        + (f", r2_knee {cand.scores['r2_knee']:.3f} r2_hip {cand.scores['r2_hip']:.3f}"
           if cand else ""))
    if cand is None:
        notes.append(f"start {s} round {rnd}: {out['status']}"
                     + ("; no fixed point of the simulator there" if out["success"] else ""))
        return None
    cand.start, cand.objective = s, out["objective"]
    return cand


def _fit_start_task(args):
    problem, human, opts, s, p_start = args
    return _fit_start(problem, human, opts, s, p_start, log=lambda m: None)


def fit_gait(problem, human, options: FitOptions | None = None, log=print,
             workers: int = 1) -> FitResult:
    """Fit ``problem``'s compliance (and slope with ``free_slope``) and periodic gait to
    ``human`` curves (:class:`~pdw_casadi.gait_data.GaitCurves`).

    Start 0 is the fixed point of the problem's own compliance (the paper's Table 3) near
    its initial state; further starts perturb the compliance (``multistart``), run on
    ``workers`` processes. See the module docstring for the checks. ``best`` is the stable,
    valid candidate with the highest mean R^2 of the targets (None if no start gave one).
    """
    opts = options or FitOptions()
    if opts.hip_target not in ("hip", "thigh"):
        raise ValueError(f"hip_target must be 'hip' or 'thigh', got {opts.hip_target!r}")
    targets = ("knee", opts.hip_target)
    t_start = time.perf_counter()
    starts = _starts(problem, opts)
    results = []
    if workers > 1 and len(starts) > 1:
        from concurrent.futures import ProcessPoolExecutor

        tasks = [(problem, human, opts, s, p) for s, p in enumerate(starts)]
        log(f"{len(starts)} starts on {workers} processes")
        with ProcessPoolExecutor(workers) as pool:
            for r in pool.map(_fit_start_task, tasks):
                results.append(r)
                c = r[0]
                log(f"start {len(results) - 1} done: " + (
                    f"r2_knee {c.scores['r2_knee']:.3f} r2_hip {c.scores['r2_hip']:.3f} "
                    f"spectral radius {c.fixed_point.spectral_radius:.4f}" if c else "failed"))
    else:
        for s, p in enumerate(starts):
            results.append(_fit_start(problem, human, opts, s, p, log=log))
    candidates = [r[0] for r in results if r[0] is not None]
    solves = [x for r in results for x in r[1]]
    notes = [x for r in results for x in r[2]]
    good = [c for c in candidates if _good(c, opts)]
    best = max(good, key=lambda c: mean_score(c, targets), default=None)
    return FitResult(problem, best, candidates, solves, opts, time.perf_counter() - t_start,
                     targets, notes)


class RefitCorrector:
    """A continuation corrector that refits the compliance at every point of a sweep.

    Called with (x_guess, p) by :func:`pdw_casadi.continuation.continue_branch`: the
    compliance of ``p`` (the neighbour's fit) is the NLP's start, the swept value of ``p``
    stays fixed, and the best stable valid fit's fixed point is returned (its ``parameters``
    hold the refitted compliance, so the next point starts from them). If the fit finds no
    stable valid gait, the plain Newton fixed point at ``p`` is returned. Each call is a full
    fit (about a minute or two for the 6-link walker).
    """

    def __init__(self, problem, human, options: FitOptions | None = None):
        self.problem, self.human = problem, human
        self.options = options or FitOptions(verbose=False)

    def __call__(self, x_guess, p) -> FixedPointResult:
        pb = self.problem.with_parameters(p).with_state(np.asarray(x_guess, float))
        res = fit_gait(pb, self.human, self.options, log=lambda m: None)
        if res.best is not None:
            return res.best.fixed_point
        return find_fixed_point(pb, x_guess, p, max_iter=10, fallback=False)
