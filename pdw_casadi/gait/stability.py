"""The stability a periodic gait must have to be accepted: one home for its spectral radius.

A gait is asymptotically stable when the spectral radius rho of its Poincare map's Jacobian
is below 1 (:attr:`~pdw_casadi.gait.fixed_point.FixedPointResult.stable`); the toolkit
accepts a gait only well inside that boundary, at :data:`MAX_RADIUS` per step. A map of n
steps (the stride: n = 2) is the product of its steps' maps, so its radius is accepted at
the per-step radius to the power n (:func:`map_radius`). An NLP holds its stability row
:data:`RADIUS_MARGIN` below the radius it is to meet, so that the verdict on the
simulator's own map holds despite the two integrators' different step sizes.

Who reads these: the fit (``FitOptions.max_radius``, ``radius_margin`` and
``radius_bound(steps)``), and two studies that accept at the fit's NLP bound
:data:`RADIUS_BOUND` instead, one margin stricter: a subject's body gait
(``studies.scaling.BODY_MAX_RADIUS``) and the prosthesis design's stride
(``DesignNLPOptions.max_stride_radius``).
"""

from __future__ import annotations

import math

#: the largest accepted spectral radius of the Poincare map per step (dimensionless): the
#: fit's verdict (``FitOptions.max_radius``, ``pdw-fit --max-radius``). A map of n steps is
#: accepted at MAX_RADIUS ** n (:func:`map_radius`). 0.91 so that the fit's NLP bound,
#: MAX_RADIUS - RADIUS_MARGIN, is 0.90 (commit 56b94e5, from 0.95: rho 0.881 at the same R^2
#: on female_fast)
MAX_RADIUS = 0.91
#: how far below the radius it is to meet an NLP holds its stability row (dimensionless, a
#: spectral radius): the NLP's RK4 grid and the simulator's step differ, so a row on its
#: bound must still pass the simulator's verdict (``FitOptions.radius_margin``, per step;
#: ``DesignNLPOptions.radius_margin``, on the stride's radius)
RADIUS_MARGIN = 0.01
#: the per-step bound the fit's NLP holds its stability row to (dimensionless):
#: MAX_RADIUS - RADIUS_MARGIN = 0.90 (``FitOptions.radius_bound(1)``). A subject's body gait
#: (``BODY_MAX_RADIUS``) and the prosthesis design's stride (two steps, 0.90 ** 2 = 0.81)
#: are accepted at it, one margin stricter than a fit's verdict. Both were set to 0.9 per
#: step after the fit's 0.91 (pdw-cohort, the stride design), with no reason recorded for
#: the difference; they stay so, since accepting them at MAX_RADIUS would change which
#: bodies and designs pass (docs/results/cohort.md and docs/results/prosthesis.md were
#: measured at 0.9)
RADIUS_BOUND = MAX_RADIUS - RADIUS_MARGIN


def map_radius(per_step: float, steps: int = 1) -> float:
    """The spectral radius (dimensionless) of a map of ``steps`` steps that matches
    ``per_step`` per step: ``per_step ** steps`` (the map's Jacobian is the product of its
    steps' Jacobians). The one rule by which a stride's radius is held to a step's."""
    return per_step ** steps


def step_radius(radius: float, steps: int = 1) -> float:
    """The per-step spectral radius (dimensionless) of a map of ``steps`` steps with
    spectral radius ``radius``: the inverse of :func:`map_radius` (a square root for a
    stride)."""
    if steps == 1:
        return radius
    return math.sqrt(radius) if steps == 2 else radius ** (1.0 / steps)
