"""The curve-fit objective on the multiple-shooting grid: 1 - R^2 of knee and hip, summed.

The gait cycle (docs/model.md) runs from the swing leg's heel strike over two steps. Within
one step of duration T with heel strike at t_hs, leg 1's angles at time t fall at cycle
percentage 100 (T - t_hs + t) / (2T) and leg 2's at 100 (t - t_hs) / (2T) after heel strike
and 100 (2T - t_hs + t) / (2T) before it. A walker whose step itself begins at the heel
strike (``heel_strike_phase`` None: point feet) has t_hs = 0. The objective is the 101-point sum of
squared errors of R^2 itself (see :func:`curve_errors`), divided by the human curve's sum of
squares about its mean: 1 - R^2 per curve. The R^2 we report is always the one of the
re-simulated gait (:mod:`pdw_casadi.gait.curves`).
"""

from __future__ import annotations

from typing import NamedTuple

import casadi as ca
import numpy as np

from pdw_casadi.engine.errors import CurveError
from pdw_casadi.gait.curves import CURVE_TARGETS, cycle_time
from pdw_casadi.model.gait_data import CYCLE_POINTS

#: two samples of one part further apart than this many times its median sample spacing do
#: not bracket the cycle points between them (a gap in the part, not an RK4 interval; the
#: spacing varies by at most the 1.25 of the NLP's step-size bound between segments)
GAP_FACTOR = 3.0

#: fit target -> (model output stem, human column)
TARGETS = CURVE_TARGETS


class CurveRows(NamedTuple):
    """One target's error rows at the human curve's 101 cycle points."""

    #: the model minus the human angle (deg), 1 x 101 MX of the NLP unknowns
    err: ca.MX
    #: the human curve's sum of squares about its mean (deg^2): sum err^2 / ss_tot = 1 - R^2
    ss_tot: float
    #: the model's angle alone (deg), 1 x 101 MX: ``err`` = ``model`` - ``values``. What
    #: depends on the gait file only through ``values``, so that an NLP built on
    #: ``model`` with the human curve as its parameter is the same for every gait file
    model: ca.MX
    #: the human angles (deg), 101 values
    values: np.ndarray


def check_targets(problem, human, opts) -> None:
    """Raise :class:`CurveError` before any work when the curves or the walker lack a target
    of ``opts`` (:class:`~pdw_casadi.fit.FitOptions`)."""
    if opts.hip_target not in ("hip", "thigh"):
        raise CurveError(f"hip_target must be 'hip' or 'thigh', got {opts.hip_target!r}")
    for target in opts.targets():
        column = TARGETS[target][1]
        if getattr(human, column, None) is None:
            raise CurveError(f"the gait file has no {column} column (needed for {target})")


def curve_errors(nlp, human, targets=("knee", "hip")) -> dict:
    """Per target its :class:`CurveRows`: ``err`` the model minus human angle (deg) at the
    101 points of the gait cycle (1 x 101 MX), so that sum err^2 / ``ss_tot`` is 1 - R^2 of
    the 101-point definition.

    The model's value at cycle point j is the linear interpolation between the two RK4
    samples (0.5 ms apart, of the leg whose part of the cycle holds j) that bracket it in the
    starting gait, at the point's own cycle percentage, which moves with the durations: the
    same interpolation as :func:`pdw_casadi.gait.curves.gait_cycle`, so the objective is the R^2
    we report as long as the bracket holds, and stays smooth when it drifts.
    """
    names = set(nlp.output_names(nlp.specs[0].phase))
    for target in targets:
        if target not in TARGETS:
            raise CurveError(f"unknown fit target {target!r} (one of {', '.join(TARGETS)})")
        stem, column = TARGETS[target]
        if getattr(human, column) is None:
            raise CurveError(f"the gait file has no {column} column (needed for {target})")
        missing = [f"{stem}{leg}_deg" for leg in (1, 2) if f"{stem}{leg}_deg" not in names]
        if missing:
            raise CurveError(f"walker {nlp.model.name!r} has no {target} outputs "
                             f"({', '.join(missing)}): it cannot be fitted to {target} curves")
    T = nlp.step_time
    hs_phase = nlp.model.heel_strike_phase
    pct = {1: [], 2: []}
    k_hs, t_hs = len(nlp.specs), None  # no heel-strike phase: the step begins at leg 1's
    if hs_phase is not None:
        k_hs = next(k for k, s in enumerate(nlp.specs) if s.phase == hs_phase)
        t_hs = nlp.t_start[k_hs]
    for k in range(len(nlp.specs)):
        ts = nlp.sample_t[k]
        for leg in (1, 2):
            pct[leg].append(100 * cycle_time(ts, leg, T, t_hs, k >= k_hs) / (2 * T))
    pct = {leg: ca.horzcat(*rows) for leg, rows in pct.items()}

    def model(stem):
        return {leg: ca.horzcat(*[nlp.output(k, f"{stem}{leg}_deg")
                                  for k in range(len(nlp.specs))]) for leg in (1, 2)}

    return interpolated_errors(nlp, pct, model, human, targets)


def interpolated_errors(nlp, pct: dict, model, human, targets) -> dict:
    """Per target its :class:`CurveRows`: the model minus human angle (deg) at the human
    curve's 101 cycle points. ``pct``: part -> the cycle percentage of that part's RK4
    samples (1 x n MX of the NLP unknowns; a part is a stretch of the cycle, e.g. one
    leg's samples); ``model(stem)``: part -> the model's ``stem`` angle at the same
    samples. Each cycle point is the linear interpolation between the two samples of one
    part that bracket it at the starting gait (``nlp.w0``); the part whose bracket holds
    the point is chosen."""
    pct0 = {leg: ca.Function("pct", [nlp.w], [v])(nlp.w0).full().ravel()
            for leg, v in pct.items()}
    h = human.resample(CYCLE_POINTS)
    grid = np.asarray(h.cycle_pct, float)
    # leg 2's samples run 50..100 % then 0..1.6 %: bracket in cycle order, not time order
    order = {leg: np.argsort(pct0[leg], kind="stable") for leg in pct}
    spacing = {leg: float(np.median(np.diff(pct0[leg][order[leg]]))) for leg in pct}
    choice = []  # (leg, sample a, sample b) bracketing each cycle point
    for g in grid:
        options = []
        for leg in pct:
            o = order[leg]
            p = pct0[leg][o]
            j = int(np.clip(np.searchsorted(p, g) - 1, 0, p.size - 2))
            outside = max(p[j] - g, g - p[j + 1], 0.0)
            if outside == 0.0 and p[j + 1] - p[j] > GAP_FACTOR * spacing[leg]:
                # the part's samples straddle a stretch of the cycle it does not cover (leg
                # 2 of a step: before and after its heel strike): not a bracket, but as far
                # from the point as its nearer sample
                outside = min(g - p[j], p[j + 1] - g)
            options.append((outside, leg, int(o[j]), int(o[j + 1])))
        choice.append(min(options)[1:])
    out = {}
    for target in targets:
        stem, column = TARGETS[target]
        vals = np.asarray(getattr(h, column), float)
        ss_tot = float(np.sum((vals - vals.mean()) ** 2))
        y = model(stem)
        at = []
        for (leg, a, b), g in zip(choice, grid, strict=True):
            pa, pb = pct[leg][a], pct[leg][b]
            ya, yb = y[leg][a], y[leg][b]
            at.append(ya + (yb - ya) * (g - pa) / (pb - pa))
        model_at = ca.horzcat(*at)
        out[target] = CurveRows(model_at - ca.DM(vals).T, ss_tot, model_at, vals)
    return out
