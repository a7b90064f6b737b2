"""The stability row's "schur" bound (pdw_casadi.nlp.stability.schur_radius): rho_32 made
smooth where the leading eigenvalue pair meets on the real axis, with an exact gradient."""

from __future__ import annotations

import numpy as np

from pdw_casadi.nlp.stability import schur_radius, smooth_radius


def _pair(d: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """A 7 x 7 matrix whose leading pair is 0.88 +- sqrt(-d) (complex for d > 0, real for
    d < 0, defective at 0) in a random basis, and the direction that moves d."""
    Q, _ = np.linalg.qr(rng.standard_normal((7, 7)))
    B = np.diag([0.5, 0.2, 0.1, 0.0, 0.05, 0.3, 0.0])
    B[:2, :2] = [[0.88, 1.0], [-d, 0.88]]
    E = np.zeros((7, 7))
    E[1, 0] = -1.0
    return Q @ B @ Q.T, Q @ E @ Q.T


def test_schur_radius_is_rho32_away_from_a_meeting_pair_and_bounds_the_radius():
    rng = np.random.default_rng(0)
    for _ in range(20):
        J = 0.3 * rng.standard_normal((7, 7))
        r, _ = schur_radius(J)
        assert r >= np.abs(np.linalg.eigvals(J)).max()
        assert r <= 1.001 * smooth_radius(J)[0]
    for d in (-1e-5, 0.0, 1e-5):  # at the meeting point it still bounds the radius
        J, _ = _pair(d, np.random.default_rng(1))
        assert schur_radius(J)[0] >= np.abs(np.linalg.eigvals(J)).max()


def test_schur_radius_gradient_is_exact_and_continuous_where_rho32_jumps():
    """Finite differences agree with the analytic gradient on both sides of the meeting
    point and on it; along d (steps of 5e-6) the derivative of rho_32 jumps by more than 10
    in one step (measured 18.5), that of the schur bound changes by less than 0.5 per step
    (measured 0.14)."""
    rng = np.random.default_rng(2)
    for _ in range(5):
        J, E = 0.3 * rng.standard_normal((7, 7)), rng.standard_normal((7, 7))
        h = 1e-6
        fd = (schur_radius(J + h * E)[0] - schur_radius(J - h * E)[0]) / (2 * h)
        assert abs(fd - np.sum(schur_radius(J)[1] * E)) < 1e-6 * max(1, abs(fd))
    ds = np.linspace(1e-4, -1e-4, 41)
    slopes, old = [], []
    for d in ds:
        J, E = _pair(d, np.random.default_rng(3))
        h = 1e-8
        fd = (schur_radius(J + h * E)[0] - schur_radius(J - h * E)[0]) / (2 * h)
        an = np.sum(schur_radius(J)[1] * E)
        assert abs(fd - an) < 1e-4 * max(1, abs(an))
        slopes.append(an)
        old.append(np.sum(smooth_radius(J)[1] * E))
    assert np.max(np.abs(np.diff(old))) > 10  # rho_32's derivative jumps
    assert np.max(np.abs(np.diff(slopes))) < 0.5
