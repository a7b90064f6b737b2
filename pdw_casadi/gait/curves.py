"""Gait-cycle curves of a walker and their goodness of fit to human data (docs/model.md).

A gait cycle runs from a heel strike of one leg to its next heel strike (two steps). At a
symmetric fixed point it is assembled from one recorded step: leg 2 from its heel strike to
the end of the step, leg 1 over the whole step, then leg 2 from the step's start to heel
strike. Time is normalised to 0..100 % and sampled like the data (101 points).
knee = degrees(q_thigh - q_shank); hip = degrees(q_thigh + slope) (the paper's "relative to
the ground"); thigh = degrees(q_thigh) (from the gravity vertical, like-for-like with the
human thigh column). R^2 = 1 - SS_res / SS_tot about the human mean.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pdw_casadi.model.gait_data import CYCLE_POINTS

CURVES = ("knee", "hip", "thigh")


def r_squared(model, human) -> float:
    """Coefficient of determination of ``model`` against ``human`` (same samples), -."""
    model, human = np.asarray(model, float), np.asarray(human, float)
    ss_res = float(np.sum((human - model) ** 2))
    ss_tot = float(np.sum((human - human.mean()) ** 2))
    return 1.0 - ss_res / ss_tot


#: the curves a walker is compared with: target -> (the walker's output stem, whose outputs
#: are ``<stem>1_deg`` and ``<stem>2_deg``, and the human curves' attribute, deg)
CURVE_TARGETS = {"knee": ("knee", "knee_deg"), "hip": ("hip", "hip_deg"),
                 "thigh": ("thigh", "thigh_deg")}


def cycle_time(t, leg: int, T, t_hs=None, after_hs: bool = True):
    """Time (s) since the gait cycle's start of leg ``leg``'s sample at time ``t`` (s) into a
    step lasting ``T`` (numpy or CasADi). ``t_hs``: the swing leg's heel strike in the step
    (None: the step begins at leg 1's heel strike, so leg 1 fills the cycle's first half);
    ``after_hs``: leg 2's sample lies after that heel strike (else before it: the cycle's
    end). The cycle is two steps long (docs/model.md)."""
    if t_hs is None:
        return t if leg == 1 else T + t
    if leg == 1:
        return T - t_hs + t
    return t - t_hs if after_hs else 2 * T - t_hs + t


def gait_cycle(step: pd.DataFrame, heel_strike_phase: str | None,
               n: int = CYCLE_POINTS) -> pd.DataFrame:
    """Model curves over one gait cycle (deg) from one recorded step at a fixed point.

    ``step``: the trajectory rows of one step (columns t, phase, knee1_deg, knee2_deg,
    hip1_deg, hip2_deg, thigh1_deg, thigh2_deg). ``heel_strike_phase``: the phase that
    begins at the swing leg's heel strike, from the walker model
    (``WalkerModel.heel_strike_phase``); None when the step itself begins at leg 1's heel
    strike (point feet): the cycle is then leg 1 over the step, then leg 2 over the step.
    Returns cycle_pct, knee_deg, hip_deg, thigh_deg.
    """
    t = step["t"].to_numpy() - step["t"].iloc[0]
    T = t[-1]
    ph = step["phase"].to_numpy()
    parts = []
    if heel_strike_phase is None:
        parts.append((cycle_time(t, 1, T), step, 1))
        parts.append((cycle_time(t, 2, T), step, 2))
    else:
        hits = np.flatnonzero(ph == heel_strike_phase)
        if hits.size == 0:
            raise ValueError(f"gait_cycle: the step has no phase {heel_strike_phase!r} (the "
                             f"heel-strike phase); its phases: {', '.join(dict.fromkeys(ph))}")
        i_hs = int(hits[0])
        t_hs = t[i_hs]
        a = slice(i_hs, None)
        parts.append((cycle_time(t[a], 2, T, t_hs), step.iloc[a], 2))
        parts.append((cycle_time(t, 1, T, t_hs), step, 1))
        c = slice(0, i_hs)
        parts.append((cycle_time(t[c], 2, T, t_hs, after_hs=False), step.iloc[c], 2))
    time = np.concatenate([p[0] for p in parts])
    out = {"cycle_pct": np.linspace(0.0, 100.0, n)}
    pct = 100.0 * time / (2 * T)
    # keep the post-impact sample where two samples share a time (impacts)
    keep = np.r_[np.diff(pct) > 1e-12, True]
    for name in CURVES:
        vals = np.concatenate([p[1][f"{name}{p[2]}_deg"].to_numpy() for p in parts])
        out[f"{name}_deg"] = np.interp(out["cycle_pct"], pct[keep], vals[keep])
    return pd.DataFrame(out)


def cycle_curves(sim, state, parameters) -> pd.DataFrame | None:
    """The gait-cycle curves (:func:`gait_cycle`) of one step simulated from a fixed point
    (``sim``: a :class:`~pdw_casadi.gait.simulate.Simulator`); None if that step fails."""
    one = sim.run(state, parameters, steps=1, record=True)
    if one.failure is not None:
        return None
    return gait_cycle(one.trajectory, sim.hs.model.heel_strike_phase)


def fit_scores(model: pd.DataFrame, human) -> dict:
    """R^2 of knee and hip (paper's definitions) and of the thigh (when the data has it)."""
    h = human.resample(len(model)) if len(human) != len(model) else human
    scores = {"r2_knee": r_squared(model["knee_deg"], h.knee_deg),
              "r2_hip": r_squared(model["hip_deg"], h.hip_deg)}
    if h.thigh_deg is not None:
        scores["r2_thigh"] = r_squared(model["thigh_deg"], h.thigh_deg)
    return scores
