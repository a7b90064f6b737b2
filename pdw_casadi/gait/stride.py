"""The stride map: two steps, one with each physical leg as the stance leg.

A walker whose two legs differ (a prosthesis, an orthosis, a subject's asymmetry) has no
one-step periodic gait: its gait repeats every stride. The stride map is the composition

    S(x, theta) = P(P(x, p_left(theta)), p_right(theta))

of the step map P of :mod:`pdw_casadi.gait.poincare`, where theta holds each *physical* leg's
parameters and p_left / p_right put them into the step's roles: in the first step the left
leg is leg 1 (stance, docs/model.md), in the second the right leg is. So the parameters follow
the physical leg through the leg swap. A stride starts at the section with the left leg
leading. The exact AD Jacobian follows by the chain rule from the step map's:
dS/dx = P2_x P1_x and dS/dtheta = P2_x P1_p Pi_1 + P2_p Pi_2 (Pi: the role permutations).

Walkers with a per-leg build (``build_per_leg`` in their family module: every body and
compliance value a runtime parameter, leg by leg) use it, theta = [left compliance, right
compliance, left anthropometry, right anthropometry, shared body values, slope]; the others
compose their ordinary step map with the same p twice (symmetric walkers only).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import pandas as pd

from pdw_casadi.gait.poincare import MapResult, PoincareError, PoincareMap
from pdw_casadi.gait.simulate import SimulationResult, Simulator, StepRecord
from pdw_casadi.model.hybrid import HybridSystem
from pdw_casadi.model.margins import leg_key
from pdw_casadi.model.problem import LEG_SIDES, Problem, ProblemError, load_problem
from pdw_casadi.model.system import per_leg_system


def _layout(problem: Problem):
    """(compliance keys, leg anthropometry keys, shared anthropometry keys) of the family."""
    from pdw_casadi.model.walkers import get_family

    fam = get_family(problem.family)
    comp = tuple(fam.compliance_keys)
    leg = tuple(fam.leg_keys["anthropometry"])
    shared = tuple(k for k in fam.anthropometry_keys if k not in leg)
    return comp, leg, shared


def physical_parameter_names(problem: Problem) -> tuple[str, ...]:
    """Names of theta: ``left.k_ankle``, ..., ``right.J_f``, shared body keys, ``slope``."""
    if per_leg_system(problem) is None:
        return (*problem.compliance, "slope")
    comp, leg, shared = _layout(problem)
    return (*(f"{s}.{k}" for s in LEG_SIDES for k in comp),
            *(f"{s}.{k}" for s in LEG_SIDES for k in leg), *shared, "slope")


def physical_parameter_vector(problem: Problem) -> np.ndarray:
    """theta of ``problem`` (order of :func:`physical_parameter_names`; SI units)."""
    if per_leg_system(problem) is None:
        return problem.parameter_vector()
    comp, leg, shared = _layout(problem)
    vals = {s: problem.leg_values(s) for s in LEG_SIDES}
    return np.array([*(vals[s][0][k] for s in LEG_SIDES for k in comp),
                     *(vals[s][1][k] for s in LEG_SIDES for k in leg),
                     *(problem.anthropometry[k] for k in shared), problem.slope], float)


def with_physical_parameters(problem: Problem, theta) -> Problem:
    """A copy of ``problem`` whose legs carry the values of theta (per-leg walkers)."""
    theta = np.asarray(theta, float).ravel()
    names = physical_parameter_names(problem)
    if theta.size != len(names):
        raise ProblemError(f"{problem.name}: theta has {theta.size} values, expected "
                           f"{len(names)}")
    if per_leg_system(problem) is None:
        return problem.with_parameters(theta)
    d = dict(zip(names, map(float, theta), strict=True))
    comp, leg, shared = _layout(problem)
    base_c = {k: d[f"left.{k}"] for k in comp}
    base_a = {**problem.anthropometry, **{k: d[f"left.{k}"] for k in leg},
              **{k: d[k] for k in shared}}
    right_c = {k: d[f"right.{k}"] for k in comp if d[f"right.{k}"] != base_c[k]}
    right_a = {k: d[f"right.{k}"] for k in leg if d[f"right.{k}"] != base_a[k]}
    legs = {}
    if right_c or right_a:
        legs["right"] = {"compliance": right_c, "anthropometry": right_a}
    return problem.replace(compliance=base_c, anthropometry=base_a, slope=d["slope"],
                           legs=legs)


@dataclass
class StrideResult(MapResult):
    """S(x, theta) with exact derivatives (``dx``, ``dp`` = dS/dtheta, ``step_time`` = the
    stride time, s); ``steps``: the two step maps' results (left stance, then right)."""

    steps: tuple = field(default_factory=tuple)
    step_parameters: tuple = field(default_factory=tuple)


class StrideMap(PoincareMap):
    """The stride map S(x, theta) of a problem's walker (see the module docstring)."""

    def __init__(self, problem):
        if not isinstance(problem, Problem):
            problem = load_problem(problem)
        hs = per_leg_system(problem)
        if hs is None and problem.asymmetric:
            raise ProblemError(f"{problem.name}: the {problem.family} walker has no per-leg "
                               f"build, so its legs cannot differ")
        super().__init__(problem, hs)
        self.per_leg = hs is not None
        self.parameter_names = physical_parameter_names(problem)
        n = len(self.parameter_names)
        if self.per_leg:
            comp, leg, shared = _layout(problem)
            nc, nl = len(comp), len(leg)
            # theta -> role vector of the second step: the right leg's blocks come first
            idx = np.arange(n)
            perm = np.r_[idx[nc:2 * nc], idx[:nc], idx[2 * nc + nl:2 * nc + 2 * nl],
                         idx[2 * nc:2 * nc + nl], idx[2 * nc + 2 * nl:]]
        else:
            perm = np.arange(n)
        self.perm = perm
        self.Pi2 = np.eye(n)[perm]  # p_right = Pi2 @ theta
        self._ell = _section_step_length(self.hs)

    def default_parameters(self) -> np.ndarray:
        return physical_parameter_vector(self.problem)

    def step_parameters(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """(p of the left-stance step, p of the right-stance step) from theta."""
        theta = np.asarray(theta, float).ravel()
        return theta.copy(), theta[self.perm]

    def evaluate(self, x, p=None, jacobian: bool = True, record: bool = False,
                 margins: bool = False) -> StrideResult:
        """Simulate one stride from section state ``x`` with physical parameters ``p``."""
        theta = self.default_parameters() if p is None else np.asarray(p, float).ravel()
        p1, p2 = self.step_parameters(theta)
        x = np.asarray(x, float).ravel()
        r1 = PoincareMap.evaluate(self, x, p1, jacobian, record, margins)
        r2 = PoincareMap.evaluate(self, r1.x_next, p2, jacobian, record, margins)
        sim = _merged(r1.sim, r2.sim)
        T = r1.step_time + r2.step_time
        if not jacobian:
            return StrideResult(r2.x_next, None, None, T, None, None, sim, steps=(r1, r2),
                                step_parameters=(p1, p2))
        dx = r2.dx @ r1.dx
        dp = r2.dx @ r1.dp + r2.dp @ self.Pi2
        dT_dx = r1.dT_dx + r2.dT_dx @ r1.dx
        dT_dp = r1.dT_dp + r2.dT_dx @ r1.dp + r2.dT_dp @ self.Pi2
        return StrideResult(r2.x_next, dx, dp, T, dT_dx, dT_dp, sim, steps=(r1, r2),
                            step_parameters=(p1, p2))

    def step_length(self, x_end, p_next) -> tuple[float, np.ndarray, np.ndarray]:
        """Length (m) of the step that ended in section state ``x_end`` (read from the
        section geometry with the next step's role parameters ``p_next``), with its exact
        gradients with respect to ``x_end`` and ``p_next``."""
        if self._ell is None:
            raise ValueError(f"{self.problem.family}: no toe points for the section step "
                             f"length")
        v, gx, gp = (np.asarray(a, float).ravel() for a in self._ell(x_end, p_next))
        return float(v[0]), gx, gp


def _section_step_length(hs: HybridSystem):
    """CasADi function (xs, p) -> (step length, d/dxs, d/dp) of walkers with toe points:
    after the swap the new leading toe sits at the origin and the trailing toe where the
    old leading toe was, so the step length is -(trailing toe . downhill direction)."""
    if "toe2" not in hs.point_names:
        return None
    model = hs.model
    xs = ca.SX.sym("xs", len(model.state_names))
    p = model.p
    # the walker's own step length (leading minus trailing toe along the slope), read
    # with the legs' roles after the swap
    ell = -hs.step_length.fun(model.section_to_full(xs, p), p)
    return ca.Function("section_step_length", [xs, p],
                       [ell, ca.jacobian(ell, xs), ca.jacobian(ell, p)])


def _merged(s1: SimulationResult, s2: SimulationResult) -> SimulationResult:
    """One record for the stride (phases, lengths, losses, margins of both steps; margin
    names prefixed with the stance leg) so that fixed-point reports read the whole stride."""
    a, b = s1.steps[0], s2.steps[0]
    rec = StepRecord(0, a.t_start, [*a.phases, *b.phases], a.x_section_start, b.x_section_end,
                     a.step_length + b.step_length,
                     a.dissipated_damping_J + b.dissipated_damping_J,
                     a.impact_loss_J + b.impact_loss_J, a.spring_loss_J + b.spring_loss_J,
                     a.energy_start_J, b.energy_end_J,
                     {**{leg_key(LEG_SIDES[0], k): v for k, v in a.margins.items()},
                      **{leg_key(LEG_SIDES[1], k): v for k, v in b.margins.items()}})
    return SimulationResult(None, [], [rec], None, s2.state_names, s2.final_state,
                            s2.final_mode)


def find_stride_fixed_point(problem, x0=None, theta=None, tol: float = 1e-10,
                            max_iter: int = 30, fallback: bool = True,
                            smap: StrideMap | None = None):
    """Periodic gait of the stride map: S(x, theta) = x by Newton with the exact Jacobian
    (:func:`pdw_casadi.gait.fixed_point.find_fixed_point` on the stride map). The result's
    eigenvalues are those of dS/dx; its step time and length are the stride's (s, m)."""
    from pdw_casadi.gait.fixed_point import find_fixed_point

    smap = smap or StrideMap(problem)
    theta = smap.default_parameters() if theta is None else np.asarray(theta, float)
    return find_fixed_point(smap.problem, x0=x0, p=theta, tol=tol, max_iter=max_iter,
                            fallback=fallback, pmap=smap)


def asymmetry_pct(a: float, b: float) -> float:
    """Symmetry index 100 (a - b) / ((a + b) / 2), % (Robinson et al. 1987; 0 = symmetric)."""
    return 100.0 * (a - b) / (0.5 * (a + b))


def stride_report(smap: StrideMap, x, theta=None, curves: bool = True) -> dict:
    """Per-leg gait measures of the stride from section state ``x`` (a stride fixed point).

    Per physical leg: the length (m) and time (s) of the step on which it is the stance
    leg, its stance and swing share of the stride (%), and (``curves``) its knee and hip
    curves over its own gait cycle (heel strike to heel strike, deg); for the stride: the
    double-support share (%), step-length and step-time asymmetry (% , left minus right,
    :func:`asymmetry_pct`), speed (m/s). Phase names follow the walker (docs/model.md).
    """
    theta = smap.default_parameters() if theta is None else np.asarray(theta, float)
    p1, p2 = smap.step_parameters(theta)
    sim = Simulator(smap.problem, smap.hs)
    res = sim.run(x, p1, steps=1, record=curves)
    if res.failure is not None:
        raise PoincareError(res.failure)
    res2 = sim.run(res.steps[0].x_section_end, p2, steps=1, record=curves, mode=res.final_mode)
    if res2.failure is not None:
        raise PoincareError(res2.failure)
    steps = (res.steps[0], res2.steps[0])
    hsp = smap.hs.model.heel_strike_phase
    T = sum(s.step_time for s in steps)
    out: dict = {"stride_time_s": T, "stride_length_m": sum(s.step_length for s in steps)}
    out["speed_m_s"] = out["stride_length_m"] / T
    # double support: phases with both feet on the ground (first and heel-strike phases of
    # the 6-link walker); point-foot walkers have none
    double = 0.0
    if hsp is not None:
        first = smap.hs.phase_names[0]
        double = sum(d for s in steps for ph, d in s.phases if ph in (first, hsp))
    out["double_support_pct"] = 100.0 * double / T
    legs = {}
    for i, side in enumerate(LEG_SIDES):
        own, other = steps[i], steps[1 - i]
        swing = sum(d for ph, d in other.phases
                    if hsp is not None and ph not in (smap.hs.phase_names[0], hsp))
        if hsp is None:
            swing = other.step_time
        legs[side] = {"step_length_m": own.step_length, "step_time_s": own.step_time,
                      "stance_pct": 100.0 * (T - swing) / T, "swing_pct": 100.0 * swing / T}
    out["legs"] = legs
    out["step_length_asymmetry_pct"] = asymmetry_pct(legs["left"]["step_length_m"],
                                                     legs["right"]["step_length_m"])
    out["step_time_asymmetry_pct"] = asymmetry_pct(legs["left"]["step_time_s"],
                                                   legs["right"]["step_time_s"])
    if curves:
        a, b = res.trajectory, res2.trajectory
        out["curves"] = {"left": stride_cycle(a, b, hsp), "right": stride_cycle(b, a, hsp)}
    return out


def stride_timing(smap: StrideMap, x, theta=None) -> dict:
    """Gait timing of each physical leg's cycle (its stance step, then its swing step) at
    the stride from section state ``x``: ``{"left": GaitTiming, "right": GaitTiming}``
    (:mod:`pdw_casadi.gait.timing`; the cycle's speed is the stride length over its time).
    Raises :class:`~pdw_casadi.engine.errors.TimingError` for a walker that declares no timing."""
    from pdw_casadi.gait.timing import step_timing

    r = smap.evaluate(x, theta, jacobian=False)
    steps = [step.sim.steps[0] for step in r.steps]
    fam = smap.problem.family
    return {side: step_timing(fam, steps[i], steps[1 - i]) for i, side in enumerate(LEG_SIDES)}


def stride_cycle(own: pd.DataFrame, other: pd.DataFrame, heel_strike_phase: str | None,
                 n: int = 101) -> pd.DataFrame:
    """Knee, hip and thigh curves (deg) of the leg that is leg 1 in step ``own`` and leg 2
    in step ``other`` (the two recorded steps of a stride at its fixed point), over that
    leg's gait cycle from its heel strike to its next one, at 0..100 % (``n`` points)."""
    from pdw_casadi.gait.curves import CURVES

    to = own["t"].to_numpy() - own["t"].iloc[0]
    tb = other["t"].to_numpy() - other["t"].iloc[0]
    Ta, Tb = to[-1], tb[-1]
    if heel_strike_phase is None:
        parts = [(to, own, 1), (Ta + tb, other, 2)]
    else:
        hits = np.flatnonzero(other["phase"].to_numpy() == heel_strike_phase)
        if hits.size == 0:
            raise ValueError(f"stride_cycle: the step has no phase {heel_strike_phase!r}")
        i = int(hits[0])
        t_hs = tb[i]
        parts = [(tb[i:] - t_hs, other.iloc[i:], 2), (Tb - t_hs + to, own, 1),
                 (Tb - t_hs + Ta + tb[:i], other.iloc[:i], 2)]
    time = np.concatenate([p[0] for p in parts])
    pct = 100.0 * time / (Ta + Tb)
    keep = np.r_[np.diff(pct) > 1e-12, True]
    out = {"cycle_pct": np.linspace(0.0, 100.0, n)}
    for name in CURVES:
        vals = np.concatenate([p[1][f"{name}{p[2]}_deg"].to_numpy() for p in parts])
        out[f"{name}_deg"] = np.interp(out["cycle_pct"], pct[keep], vals[keep])
    return pd.DataFrame(out)


def stride_simulator(problem) -> tuple[Simulator, list[np.ndarray]]:
    """A simulator of ``problem``'s walker and the step parameters to use in turn
    (``Simulator.run(..., p_steps=...)``): step 0 with the left leg in stance, step 1 with
    the right, and so on."""
    smap = problem if isinstance(problem, StrideMap) else StrideMap(problem)
    return Simulator(smap.problem, smap.hs), list(smap.step_parameters(
        smap.default_parameters()))
