"""Every setting of the fit, in one place."""

from __future__ import annotations

from dataclasses import dataclass, field

from pdw_casadi.gait.stability import MAX_RADIUS, RADIUS_MARGIN, map_radius
from pdw_casadi.model.gait_data import SIDES
from pdw_casadi.nlp.driver import IPOPT_TOL, Stall
from pdw_casadi.nlp.multipliers import WARM_IPOPT

#: the settings of the per-leg fit only (a one-step fit ignores them)
PER_LEG_FIELDS = ("side", "start", "stride_warm_start")


def row_power(stability_power: int, steps: int) -> int:
    """The power k = ``stability_power`` / ``steps`` of a stability row ||M^k||_F^(1/k) on
    the map M of ``steps`` steps, a power of two (:meth:`FitOptions.row_power`)."""
    k, rem = divmod(stability_power, steps)
    if rem or k < 1 or k & (k - 1):
        raise ValueError(f"stability_power {stability_power} is not a power of two "
                         f"times the map's {steps} steps")
    return k


@dataclass
class FitOptions:
    """Settings of :func:`~pdw_casadi.fit.fit_gait`.

    Targets: ``hip_target`` "hip" (the paper's hip angle, thigh + slope) or "thigh" (thigh
    from the gravity vertical, like-for-like with the human thigh column).

    Stability: ``max_radius`` is the largest accepted spectral radius per step of the
    simulator's Poincare map (the verdict; default the toolkit's one home for it,
    :data:`~pdw_casadi.gait.stability.MAX_RADIUS`); a fit on the stride, two steps, accepts a
    stride radius up to ``max_radius``^2 (:meth:`accepted_radius`,
    :attr:`~pdw_casadi.fit.result.Candidate.stable`); the NLP bounds its stability row
    (``stability_bound``: by default ||J^8||_F^(1/8) of its own step's Jacobian J, an upper
    bound of rho) by ``max_radius - radius_margin``, on the stride by that squared
    (:meth:`radius_bound`), so the verdict holds with ``radius_margin`` to spare for the
    NLP's and the simulator's step sizes.

    Starts: the ``multistart`` gaits, of the atlas entries (stable gaits shipped with the
    package) and the problem's own, whose curves fit the user's best, the most stable first
    among those within ``start_r2_tolerance`` (:func:`~pdw_casadi.fit.starts.rank_starts`);
    ``atlas`` a path to another atlas file (None: the bundled one; ``""``: no atlas, the
    problem's own gait only).

    IPOPT: ``max_iter``, ``tol``, ``hessian`` ("limited-memory": L-BFGS), ``ipopt`` extra
    options. ``rounds``: NLP solves per start; a second one is built at the first answer
    only when the objective's sample brackets moved (``consistency_tol``) or its
    re-simulation deviation is at least ``resim_tol`` (the NLP's RK4 grid, set from the
    start's phase durations, no longer matches the simulator's).

    The per-leg fit (per-side curves, :func:`~pdw_casadi.fit.core.fit_sides`; the one-step
    fit ignores these): ``side``, whose compliance is free, "both" (each leg its own),
    "left" or "right" (the other leg keeps the start's); ``start``, "fit" (the symmetric
    step fit to the mean of both sides first, with these settings, then repeated twice) or
    "atlas" (the atlas or problem gait that fits that mean best, as the step fit picks it,
    repeated twice; no extra solve). "fit" is the default: the meaningful comparison (what
    per-leg compliance adds to the best symmetric fit), and the better answer where both
    were measured (``docs/results/per-leg-fit.md``).
    """

    hip_target: str = "hip"
    free_slope: bool = False
    slope_bounds: tuple[float, float] = (0.05, 0.25)  # rad
    free: tuple[str, ...] | None = None  # compliance names to fit (default: all)
    max_radius: float = MAX_RADIUS
    radius_margin: float = RADIUS_MARGIN
    stability_constraint: bool = True
    #: the stability row: "power" (||J^k||_F^(1/k), k = ``stability_power``: no
    #: perturbation grows by more than the bound^k over k steps, which implies rho <= bound;
    #: a stride's row covers the same k steps: :meth:`row_power`),
    #: "schur" (rho_32 of the eigenvalue moduli, smooth where the leading pair meets the real
    #: axis: pdw_casadi.nlp.stability.schur_radius) or "eigenvalues" (rho_32 itself).
    #: A bound on the spectral radius alone lets the NLP's answer sit where I - J is nearly
    #: singular and J strongly non-normal, so that its stability is fragile and IPOPT creeps
    #: along the bound; the k-step bound keeps J away from there (docs/results/fit.md)
    stability_bound: str = "power"
    stability_power: int = 8
    #: no iterate's stability row lies more than this above the bound (or the start's own
    #: radius, if higher): IPOPT cuts back every step that would go there (None: no cap).
    #: Under the radius row fits used to leave the stable region for hundreds of
    #: iterations; under the eight-step bound, from the atlas's warm starts, a cap of 0.01
    #: made IPOPT crawl along it (cut-backs at every step): 0.03 took 8 corpus files from
    #: a median of 24 to 22 iterations (docs/results/fit.md)
    iterate_radius_slack: float | None = 0.03
    #: a start above the bound may rise to its own radius + ``iterate_radius_slack``; with
    #: ``ratchet_cap`` the cap comes down to the bound + ``iterate_radius_slack`` once an
    #: iterate's row first reaches it, so that no later step leaves the stable region
    #: (pdw_casadi.nlp.driver.Progress; docs/results/fit.md)
    ratchet_cap: bool = False
    #: a start whose stability row lies above ``radius_stage_ratio`` x the bound (an
    #: unstable start: a walker's first gait, a seed) is brought down by continuation
    #: first: solves with the bound relaxed to bound x ratio^k, k = n - 1, ..., 1, each from
    #: where the one before ended, so that no solve asks more than a factor ``ratio`` of its
    #: start; then the fit's own solve (None: one solve from the start, whatever its row;
    #: :func:`~pdw_casadi.fit.rounds.relax_stability`). Off: with 2 the two shipped unstable
    #: starts measured (the forefoot rocker's, the toe walker's) found no gait, and the toe
    #: walker's fit without it does (docs/results/timing.md)
    radius_stage_ratio: float | None = None
    #: IPOPT's iterations in each relaxed solve (its answer only has to hold its bound)
    radius_stage_iter: int = 100
    #: a constraint knee R^2 >= floor: "reference" (the R^2 of the problem's own compliance
    #: on the same curves, when it has a gait), a number, or None (no floor); the sum of
    #: 1 - R^2 alone may trade knee for hip below the problem file's own knee. Only with
    #: compliance values free (a slope-only fit has nothing else to hold the knee with)
    #: (docs/results/fit.md)
    knee_floor: str | float | None = "reference"
    #: the NLP holds knee R^2 this much above the floor: IPOPT holds a row to its
    #: constraint tolerance, and the re-simulated R^2 differs from the NLP's samples by
    #: about 1e-5; without it a fit on its floor ended 4e-5 below it (WBDS18_early)
    knee_floor_margin: float = 1e-4
    multistart: int = 1
    #: starts whose curves fit the user's within this much mean R^2 of the best count as
    #: equally good; of those the most stable goes first (why: docs/results/fit-settings.md)
    start_r2_tolerance: float = 0.01
    atlas: str | None = None
    #: the constraint Jacobian: "structured" (assembled from the shooting structure,
    #: pdw_casadi.nlp.jacobian) or "casadi" (CasADi's Jacobian of the MX graph: slower, the
    #: reference the structured one is tested against)
    jacobian: str = "structured"
    #: threads that evaluate the shooting intervals of the structured Jacobian side by side
    #: (None: one per core; the answer does not depend on it)
    threads: int | None = None
    max_iter: int = 300
    tol: float = IPOPT_TOL
    #: the largest barrier parameter IPOPT may choose (its ``mu_max``): a fit starts at a
    #: stable gait near the answer, with about 10^4 inequality rows (margins, event signs)
    #: against an objective of order 0.1-1; when IPOPT's adaptive rule resets the barrier to
    #: 1e-4..1e-3, the barrier terms outweigh the objective and push the iterate far from the
    #: start (fits then took three times the iterations). 1e-5 keeps the barrier's share of
    #: the merit function near the objective's (docs/results/fit.md). None: IPOPT's default
    mu_max: float | None = 1e-5
    hessian: str = "limited-memory"
    #: the curvature pairs IPOPT's L-BFGS keeps (``limited_memory_max_history``; None:
    #: IPOPT's 6) in a one-step solve and in a stride's. A stride's iterates wandered across
    #: its stability bound with six: with 50, 6 of 8 per-side fits (four subjects, paper and
    #: own bodies) converged against 4 of 8, in 14 % less time; a one-step fit took 21 %
    #: longer with 50 (nine files; docs/results/per-leg-fit.md)
    lbfgs_history: int | None = None
    stride_lbfgs_history: int | None = 50
    rounds: int = 2
    consistency_tol: float = 1e-3  # relative gap NLP objective vs re-simulated 1 - R^2
    #: RK4 samples between checked event signs and margins (two per shooting interval of
    #: ten RK4 steps): every second sample gave 2.5 times the inequality rows and half again
    #: the time per iteration for the same answers; the simulator's check stays the judge
    #: (docs/results/fit.md)
    sample_stride: int = 5
    #: every segment may grow this much (s) beyond its starting duration plus one interval
    #: (its shooting intervals bound it; docs/results/fit-settings.md)
    segment_headroom_s: float = 0.0
    #: weight of the optional timing target (0: off, pdw-fit --timing): the objective adds
    #: timing_weight ((stance % - the human toe-off %) / 10 %)^2, the model's stance in % of
    #: its gait cycle from the NLP's own phase durations (pdw_casadi.gait.timing); R^2 is unchanged
    timing_weight: float = 0.0
    #: with the timing target on, every segment may grow this much (s): double support must
    #: be free to grow from a few ms to tens of ms within one solve
    timing_headroom_s: float = 0.06
    #: when IPOPT stops short of convergence (its iteration limit, a failed restoration), the
    #: fit checks its lowest-objective iterate that held every row and bound to ``tol`` on
    #: the simulator instead of reporting no gait; such an answer is marked not certified
    #: (:attr:`~pdw_casadi.fit.result.Candidate.certified`): stable and valid as checked, but
    #: not shown to be the NLP's optimum
    keep_best_feasible: bool = True
    #: when a solve stops short of convergence (its limit, a stall) or gives no stable
    #: valid gait, the fit polishes the ``polish_keep`` lowest-objective
    #: iterates whose largest row or bound violation was at most ``polish_infeasibility``
    #: on the simulator (Newton on the Poincare map at the iterate's parameters from its
    #: section state) and takes the best stable valid one if it fits better than the
    #: solve's best feasible iterate, marked not certified (None: off)
    polish_infeasibility: float | None = 1e-2
    polish_keep: int = 3
    #: a solve is stopped as stalled when over ``stall_window`` iterations its objective
    #: moved by at most ``stall_rtol`` of its size while its least infeasibility stayed above
    #: ``stall_infeasibility`` and did not fall below half the least one before
    #: (pdw_casadi.nlp.driver.Stall; None: never); its iterates are then polished as above
    #: and, ``stall_restarts`` times per start, a new round starts from the polished gait
    stall_window: int | None = 30
    stall_rtol: float = 1e-3
    stall_infeasibility: float = 1e-5
    stall_restarts: int = 1
    #: a solve is also stopped as stalled when it zig-zags across a bound: over
    #: ``stall_window`` iterations the best objective of the iterates feasible to
    #: ``stall_plateau_infeasibility`` fell by at most ``stall_rtol`` of its size while an
    #: iterate strayed to an infeasibility of ``stall_wander`` or more; such a solve ends
    #: with its best iterate, without a restart (None: this form off;
    #: pdw_casadi.nlp.driver.Stall, docs/results/fit.md)
    stall_plateau_infeasibility: float | None = 1e-4
    stall_wander: float = 1e-3
    #: start the first solve from an atlas entry's stored NLP solution with its multipliers
    #: (``warm_ipopt``) instead of from the entry's gait alone: with the checks at every
    #: fifth RK4 sample it took twice the iterations (the user's curves move the optimum off
    #: the entry's active set, which the small barrier then crawls along;
    #: docs/results/fit.md), so it is off
    atlas_warm_start: bool = False
    #: start the stride NLP of a per-leg fit from the symmetric fit's NLP solution with
    #: its multipliers mapped onto the stride's rows
    #: (:meth:`~pdw_casadi.fit.driver.FitSolver.stride_point`) and IPOPT's ``warm_ipopt``
    #: options, instead of from the symmetric gait alone (docs/results/per-leg-fit.md)
    stride_warm_start: bool = True
    #: IPOPT's options of a warm restart from a kept iterate with its multipliers: the
    #: iterate is taken as it is (tiny bound pushes) and the barrier starts small, so that
    #: the restart does not leave the point it starts from
    warm_ipopt: dict = field(default_factory=lambda: dict(WARM_IPOPT))
    resim_steps: int = 20  # steps of the re-simulation check
    resim_tol: float = 1e-6  # largest accepted re-simulation deviation (rad, rad/s)
    verbose: bool = True  # one progress line per IPOPT iteration
    log_file: str | None = None  # the full IPOPT log (e.g. DIR/ipopt.log)
    ipopt: dict = field(default_factory=dict)  # extra IPOPT options (override the defaults)
    #: the per-leg fit's: whose compliance is free ("both", "left", "right")
    side: str = "both"
    #: the per-leg fit's start: "fit" (the symmetric fit to the mean of both sides) or "atlas"
    start: str = "fit"

    def __post_init__(self):
        if self.radius_stage_ratio is not None and not self.radius_stage_ratio > 1:
            raise ValueError(f"radius_stage_ratio must exceed 1 (or be None), got "
                             f"{self.radius_stage_ratio}")

    def targets(self) -> tuple[str, str]:
        return ("knee", self.hip_target)

    def free_sides(self) -> tuple[str, ...]:
        """The legs whose compliance the per-leg fit frees (``side``)."""
        if self.side == "both":
            return SIDES
        if self.side not in SIDES:
            raise ValueError(f"side must be 'both', 'left' or 'right', got {self.side!r}")
        return (self.side,)

    def stall_rule(self) -> Stall | None:
        """The stall rule of these settings (``stall_*``; None: ``stall_window`` None), for
        every solve that walks like the fit's (the fit's, the prosthesis design's)."""
        if self.stall_window is None:
            return None
        return Stall(self.stall_window, self.stall_rtol, self.stall_infeasibility,
                     plateau_infeasibility=self.stall_plateau_infeasibility,
                     wander=self.stall_wander)

    def row_power(self, steps: int = 1) -> int:
        """The power k of the stability row ||M^k||_F^(1/k) on the map M of ``steps`` steps:
        ``stability_power / steps``, so that every row bounds the growth of a perturbation
        over the same ``stability_power`` steps. Then a stride's row at a symmetric gait
        (M = J^2) is the one step's row squared, the stride's bound (the per-step bound
        squared) holds exactly where the step's does, and a stride NLP started at a step's
        answer starts on the same constraint with the same multiplier."""
        if self.stability_bound != "power":
            return self.stability_power  # unused by the other rows
        return row_power(self.stability_power, steps)

    def radius_bound(self, steps: int = 1) -> float:
        """The NLP's stability-row bound on the map of ``steps`` steps: the per-step bound
        ``max_radius - radius_margin`` to the power ``steps``
        (:func:`~pdw_casadi.gait.stability.map_radius`)."""
        return map_radius(self.max_radius - self.radius_margin, steps)

    def accepted_radius(self, steps: int = 1) -> float:
        """The verdict's largest accepted spectral radius of the map of ``steps`` steps:
        ``max_radius`` to the power ``steps`` (the rule of
        :attr:`~pdw_casadi.fit.result.Candidate.stable`)."""
        return map_radius(self.max_radius, steps)
