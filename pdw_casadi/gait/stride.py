"""The stride: the periodic map of two steps, one with each physical leg as the stance leg.

A walker whose two legs differ (a prosthesis, an orthosis, a subject's asymmetry) has no
one-step periodic gait: its gait repeats every stride. The stride map is the composition

    S(x, theta) = P(P(x, p_left(theta)), p_right(theta))

of the step map P of :mod:`pdw_casadi.gait.poincare`, where theta holds each *physical* leg's
parameters and p_left / p_right put them into the step's roles: in the first step the left
leg is leg 1 (stance, docs/model.md), in the second the right leg is. So the parameters follow
the physical leg through the leg swap. A stride starts at the section with the left leg
leading. The exact AD Jacobian follows by the chain rule from the step map's:
dS/dx = P2_x P1_x and dS/dtheta = P2_x P1_p Pi_1 + P2_p Pi_2 (Pi: the role permutations).

The stride map is :class:`~pdw_casadi.gait.poincare.PoincareMap` with ``steps=2``
(:func:`stride_map`), the step map the same class with ``steps=1``.

Walkers with a per-leg build (``build_per_leg`` in their family module: every body and
compliance value a runtime parameter, leg by leg) use it, theta = [left compliance, right
compliance, left anthropometry, right anthropometry, shared body values, slope]; the others
compose their ordinary step map with the same p twice (symmetric walkers only).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdw_casadi.gait.curves import CURVES
from pdw_casadi.gait.fixed_point import FIXED_POINT_TOL, find_fixed_point
from pdw_casadi.gait.poincare import PoincareError, PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import step_timing
from pdw_casadi.model.gait_data import CYCLE_POINTS
from pdw_casadi.model.problem import LEG_SIDES, Problem, load_problem
from pdw_casadi.model.system import (  # noqa: F401 (the per-leg walker, re-exported)
    per_leg_system,
    physical_parameter_names,
    physical_parameter_vector,
    with_physical_parameters,
)


def stride_map(problem) -> PoincareMap:
    """The stride map S(x, theta) of ``problem``'s walker (a problem or a bundled name): the
    periodic map of two steps, ``PoincareMap(problem, steps=2)`` (module docstring)."""
    if not isinstance(problem, Problem):
        problem = load_problem(problem)
    return PoincareMap(problem, steps=2)


def period_steps(problem) -> int:
    """The steps after which ``problem``'s gait repeats: 2 (the stride) when its legs
    differ, else 1 (the step)."""
    return 2 if problem.asymmetric else 1


def find_stride_fixed_point(problem, x0=None, theta=None, tol: float = FIXED_POINT_TOL,
                            max_iter: int = 30, fallback: bool = True,
                            smap: PoincareMap | None = None):
    """Periodic gait of the stride map: S(x, theta) = x,
    :func:`~pdw_casadi.gait.fixed_point.find_fixed_point` on the two-step map. The result's
    eigenvalues are those of dS/dx; its step time and length are the stride's (s, m)."""
    smap = smap or stride_map(problem)
    return find_fixed_point(smap.problem, x0=x0, p=theta, tol=tol, max_iter=max_iter,
                            fallback=fallback, pmap=smap)


def asymmetry_pct(a: float, b: float) -> float:
    """Symmetry index 100 (a - b) / ((a + b) / 2), % (Robinson et al. 1987; 0 = symmetric)."""
    return 100.0 * (a - b) / (0.5 * (a + b))


def stride_report(smap: PoincareMap, x, theta=None, curves: bool = True) -> dict:
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


def stride_timing(smap: PoincareMap, x, theta=None) -> dict:
    """Gait timing of each physical leg's cycle (its stance step, then its swing step) at
    the stride from section state ``x``: ``{"left": GaitTiming, "right": GaitTiming}``
    (:mod:`pdw_casadi.gait.timing`; the cycle's speed is the stride length over its time).
    Raises :class:`~pdw_casadi.engine.errors.TimingError` for a walker that declares no timing."""
    r = smap.evaluate(x, theta, jacobian=False)
    steps = [step.sim.steps[0] for step in r.steps]
    fam = smap.problem.family
    return {side: step_timing(fam, steps[i], steps[1 - i]) for i, side in enumerate(LEG_SIDES)}


def stride_cycle(own: pd.DataFrame, other: pd.DataFrame, heel_strike_phase: str | None,
                 n: int = CYCLE_POINTS) -> pd.DataFrame:
    """Knee, hip and thigh curves (deg) of the leg that is leg 1 in step ``own`` and leg 2
    in step ``other`` (the two recorded steps of a stride at its fixed point), over that
    leg's gait cycle from its heel strike to its next one, at 0..100 % (``n`` points)."""
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
    the right, and so on. ``problem``: a problem or its stride map."""
    smap = problem if isinstance(problem, PoincareMap) else stride_map(problem)
    return Simulator(smap.problem, smap.hs), list(smap.step_parameters(
        smap.default_parameters()))
