"""The curve-fit objective on the multiple-shooting grid: 1 - R^2 of knee and hip, summed.

MODEL.md's gait cycle runs from the swing leg's heel strike over two steps. Within one
step of duration T with heel strike at t_hs, leg 1's angles at time t fall at cycle
percentage 100 (T - t_hs + t) / (2T) and leg 2's at 100 (t - t_hs) / (2T) after heel strike
and 100 (2T - t_hs + t) / (2T) before it. The objective evaluates the model's angles at
every RK4 sample of the NLP (0.5 ms apart), the human mean curve there (a cubic B-spline
through the 101 data points), and sums the squared errors with weight
dpct = 100 h / (2T), so that sum_samples dpct err^2 is the integral the 101-point sum of R^2
approximates; divided by the human curve's 101-point sum of squares about its mean it is
1 - R^2 up to quadrature error (< 1e-3; the R^2 we report is always the 101-point one of
the re-simulated gait, :mod:`pdw_casadi.curves`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

#: fit target -> (model output stem, human column)
TARGETS = {"knee": ("knee", "knee_deg"), "hip": ("hip", "hip_deg"), "thigh": ("thigh", "thigh_deg")}


def human_spline(human, column: str) -> tuple[ca.Function, float]:
    """B-spline of a human curve over cycle percentage, and its 101-point SS about the mean."""
    h = human.resample(101)
    vals = np.asarray(getattr(h, column), float)
    spline = ca.interpolant(f"human_{column}", "bspline", [np.asarray(h.cycle_pct, float)],
                            vals)
    return spline, float(np.sum((vals - vals.mean()) ** 2))


def curve_errors(nlp, human, targets=("knee", "hip")) -> dict:
    """Per target: (list of (err, weight) per segment and leg, SS_tot). ``err`` is the model
    minus human angle (deg) at the segment's RK4 samples (1 x N M, MX); ``weight`` the cycle
    percentage per sample, 100 h / (2T)."""
    T = nlp.step_time
    k_hs = next(k for k, s in enumerate(nlp.specs) if s.phase == nlp.model.heel_strike_phase)
    t_hs = nlp.t_start[k_hs]
    out = {}
    for target in targets:
        stem, column = TARGETS[target]
        if getattr(human, column) is None:
            raise ValueError(f"the gait file has no {column} column (needed for {target})")
        spline, ss_tot = human_spline(human, column)
        parts = []
        for k, _s in enumerate(nlp.specs):
            ts = nlp.sample_t[k]
            n = ts.shape[1]
            w = 100 * nlp.h_k[k] / (2 * T)
            pct1 = 100 * (T - t_hs + ts) / (2 * T)
            pct2 = 100 * ((ts - t_hs) if k >= k_hs else (2 * T - t_hs + ts)) / (2 * T)
            for leg, pct in ((1, pct1), (2, pct2)):
                model = nlp.output(k, f"{stem}{leg}_deg")
                parts.append((model - spline.map(n)(pct), w))
        out[target] = (parts, ss_tot)
    return out


def curve_objective(nlp, human, targets=("knee", "hip")):
    """Sum over ``targets`` of (model - human)^2 integrated over the cycle / SS_tot (MX).

    Returns (objective, terms) with one 1 - R^2 estimate per target in ``terms``.
    """
    terms = {}
    for target, (parts, ss_tot) in curve_errors(nlp, human, targets).items():
        terms[target] = sum(w * ca.sumsqr(err) for err, w in parts) / ss_tot
    return sum(terms.values()), terms
