"""Bifurcations and gait-pattern boundaries along a branch of periodic gaits.

Local bifurcations of a fixed point x*(lambda) of the Poincare map happen where an
eigenvalue mu of the monodromy matrix dP/dx crosses the unit circle. Each way of crossing
has a test function of the eigenvalues that is a polynomial in the matrix entries (so it is
continuous along the branch, whatever the eigenvalue ordering) and changes sign at the
crossing:

- fold (mu = +1):            phi_LP = prod_i (mu_i - 1)          = det(dP/dx - I)
- period doubling (mu = -1): phi_PD = prod_i (mu_i + 1)          = det(dP/dx + I)
- Neimark-Sacker (|mu| = 1 as a complex pair):
                             phi_NS = prod_{i<j} (mu_i mu_j - 1) = det(dP/dx (.) dP/dx - I)
  (bialternate product); it also vanishes at a *neutral saddle* (two real eigenvalues with
  mu_i mu_j = 1, no bifurcation), which is recognised and not reported.

A sign change between neighbouring points of a branch brackets the crossing, which is then
located by Brent's bracketing method (bisection safeguarded by inverse quadratic
interpolation, :func:`scipy.optimize.brentq`) on the test function, solving the fixed point
at every trial value. The gait-pattern boundary is located the same way on the slack of the
validity margin that reaches its minimum (:func:`~pdw_casadi.gait.fixed_point.validity_slacks`),
or, when the orbit itself fails (fall, centre of pressure leaving the foot, ...), by
bisection on "a valid fixed point exists".

A natural-parameter branch cannot pass a fold (a turning point): Newton stops converging
just beyond it. Such a branch end is reported as a fold when a real eigenvalue of the last
point is within ``fold_tol`` of +1, else as a plain branch end; either way with its bracket.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from pdw_casadi.gait.continuation import BranchEnd, BranchPoint, Corrector, predict, with_value
from pdw_casadi.gait.fixed_point import FixedPointResult, validity_slacks

#: event kinds and the words the report uses for them
KINDS = {
    "fold": "fold (eigenvalue through +1)",
    "period_doubling": "period doubling (eigenvalue through -1)",
    "neimark_sacker": "Neimark-Sacker (complex pair through the unit circle)",
    "boundary": "gait-pattern boundary",
    "branch_end": "end of the branch (corrector fails)",
}


def _pairs(mu):
    i, j = np.triu_indices(len(mu), k=1)
    return mu[i] * mu[j], i, j


def phi_fold(mu) -> float:
    """prod (mu_i - 1): changes sign when a real eigenvalue crosses +1."""
    return float(np.real(np.prod(np.asarray(mu) - 1.0)))


def phi_period_doubling(mu) -> float:
    """prod (mu_i + 1): changes sign when a real eigenvalue crosses -1."""
    return float(np.real(np.prod(np.asarray(mu) + 1.0)))


def phi_neimark_sacker(mu) -> float:
    """prod_{i<j} (mu_i mu_j - 1): changes sign when a complex pair crosses |mu| = 1."""
    prod, _, _ = _pairs(np.asarray(mu))
    return float(np.real(np.prod(prod - 1.0)))


TEST_FUNCTIONS = {"fold": phi_fold, "period_doubling": phi_period_doubling,
                  "neimark_sacker": phi_neimark_sacker}


#: multipliers closer than this (absolute) count as a complex-conjugate pair, and an
#: imaginary part above REAL_TOL as complex (:func:`is_neimark_sacker`)
CONJUGATE_TOL = 1e-6
REAL_TOL = 1e-9


def is_neimark_sacker(mu) -> bool:
    """At a zero of phi_NS: is the pair with mu_i mu_j closest to 1 a complex-conjugate pair
    (a Neimark-Sacker point) rather than two reals (a neutral saddle)?"""
    mu = np.asarray(mu)
    prod, i, j = _pairs(mu)
    k = int(np.argmin(np.abs(prod - 1.0)))
    return bool(abs(mu[i[k]].imag) > REAL_TOL
                and abs(mu[i[k]] - np.conj(mu[j[k]])) < CONJUGATE_TOL)


def outside(mu) -> int:
    """Number of eigenvalues outside the unit circle."""
    return int(np.sum(np.abs(np.asarray(mu)) > 1.0))


@dataclass
class BranchEvent:
    """A located bifurcation or boundary. ``value`` in the unit of ``parameter``;
    ``bracket``: the interval known to contain it; ``crossing``: ``"outward"`` when an
    eigenvalue leaves the unit circle as the parameter increases, ``"inward"`` when one
    enters; ``refined``: narrowed to the requested tolerance (Brent, bisection or the step
    halving of the continuation); False when a trial inside the bracket had no fixed point, so
    only the bracket between two points is known."""

    kind: str
    parameter: str
    value: float
    bracket: tuple[float, float]
    reason: str
    refined: bool = True
    crossing: str | None = None
    eigenvalues: np.ndarray | None = None
    spectral_radius: float | None = None
    state: dict | None = None
    branch: int = 0

    def to_dict(self) -> dict:
        ev = None if self.eigenvalues is None else [[float(e.real), float(e.imag)]
                                                    for e in self.eigenvalues]
        return {"kind": self.kind, "description": KINDS.get(self.kind, self.kind),
                "parameter": self.parameter, "value": float(self.value),
                "bracket": [float(b) for b in sorted(self.bracket)], "refined": self.refined,
                "reason": self.reason, "crossing": self.crossing, "eigenvalues": ev,
                "spectral_radius": self.spectral_radius, "fixed_point": self.state,
                "branch": self.branch}


class _Unresolved(RuntimeError):
    """No fixed point at a trial value inside a bracket."""


class Locator:
    """Fixed points at trial parameter values inside a bracket, each predicted (tangent)
    from the bracket end nearest to it and corrected by ``corrector``."""

    def __init__(self, corrector: Corrector, index: int, parameter: str,
                 predictor: str = "tangent"):
        self.corrector = corrector
        self.index = index
        self.parameter = parameter
        self.predictor = predictor

    def solve(self, anchors: list[BranchPoint], value: float) -> FixedPointResult:
        anchor = min(anchors, key=lambda a: abs(a.value - value))
        guess = predict([anchor], value, self.index, "tangent")
        return self.corrector(guess, with_value(anchor.result.parameters, self.index, value))

    def event(self, kind, value, bracket, reason, res, refined=True, crossing=None,
              branch=0) -> BranchEvent:
        ok = res is not None and res.converged
        return BranchEvent(kind, self.parameter, float(value),
                           (float(bracket[0]), float(bracket[1])), reason, refined, crossing,
                           res.eigenvalues if ok else None,
                           float(res.spectral_radius) if ok else None,
                           res.state_dict() if ok else None, branch)


def _zero_along(locator, points, a: float, b: float, g, xtol: float):
    """Brent's method on ``g(fixed point at v)`` for v between ``a`` and ``b``, each fixed
    point predicted from ``points`` and corrected by the locator: (v, the fixed point solved
    at v, or None). Raises :class:`_Unresolved` where no fixed point converges, ValueError
    without a sign change."""
    solved: dict[float, FixedPointResult] = {}

    def f(v):
        res = locator.solve(points, v)
        if not res.converged:
            raise _Unresolved(v)
        solved[v] = res
        return g(res)

    v = brentq(f, a, b, xtol=xtol, rtol=4 * np.finfo(float).eps)
    return v, solved.get(v)


def crossings(a: BranchPoint, b: BranchPoint, locator: Locator, xtol: float) -> list[BranchEvent]:
    """Eigenvalue crossings of the unit circle between two converged neighbouring points."""
    lo, hi = sorted((a, b), key=lambda pt: pt.value)
    events = []
    for kind, phi in TEST_FUNCTIONS.items():
        f_lo, f_hi = phi(lo.result.eigenvalues), phi(hi.result.eigenvalues)
        if np.sign(f_lo) == np.sign(f_hi):
            continue
        try:
            value, res = _zero_along(locator, [lo, hi], lo.value, hi.value,
                                     lambda r, phi=phi: phi(r.eigenvalues), xtol)
            res = res or locator.solve([lo, hi], value)
            refined = True
        except _Unresolved:
            value, res, refined = 0.5 * (lo.value + hi.value), None, False
        if kind == "neimark_sacker" and res is not None and res.converged \
                and not is_neimark_sacker(res.eigenvalues):
            continue  # a neutral saddle: two real eigenvalues with product 1, no bifurcation
        n_lo, n_hi = outside(lo.result.eigenvalues), outside(hi.result.eigenvalues)
        crossing = "outward" if n_hi > n_lo else "inward" if n_hi < n_lo else None
        events.append(locator.event(kind, value, (lo.value, hi.value),
                                    _crossing_reason(kind, res, crossing, locator.parameter),
                                    res, refined, crossing, a.branch))
    return events


def _crossing_reason(kind, res, crossing, parameter) -> str:
    where = {"outward": f"leaves the unit circle as {parameter} increases",
             "inward": f"enters the unit circle as {parameter} increases",
             None: "crosses the unit circle"}[crossing]
    if res is None or not res.converged:
        return f"{KINDS[kind]}: an eigenvalue {where} (not refined: no fixed point inside)"
    mu = res.eigenvalues
    if kind == "period_doubling":
        real = mu[np.abs(mu.imag) < 1e-9]
        e = real[np.argmin(np.abs(real + 1))] if real.size else mu[0]
        return f"eigenvalue {e.real:+.6f} {where}"
    if kind == "fold":
        real = mu[np.abs(mu.imag) < 1e-9]
        e = real[np.argmin(np.abs(real - 1))] if real.size else mu[0]
        return f"eigenvalue {e.real:+.6f} {where}"
    pair = mu[np.argmin(np.abs(np.abs(mu) - 1) + (np.abs(mu.imag) < 1e-9))]
    return (f"complex pair {pair.real:+.6f} +/- {abs(pair.imag):.6f}i (|mu| = {abs(pair):.6f}, "
            f"angle {np.degrees(abs(np.angle(pair))):.2f} deg) {where}")


def boundary(last: BranchPoint, value: float, point: BranchPoint | None, failure: str | None,
             problem, locator: Locator, xtol: float, bisect_tol: float) -> BranchEvent:
    """Locate where the gait pattern ends between a valid point ``last`` and ``value``.

    ``point``: the converged but invalid fixed point at ``value`` (a margin below its
    minimum: Brent on that margin's slack), or None when the orbit failed there (bisection on
    "a valid fixed point exists" down to ``bisect_tol``).
    """
    if point is not None and point.result.converged:
        slacks = validity_slacks(point.result.margins, problem)
        broken = [k for k, s in slacks.items() if s < 0 or (s <= 0 and "impulse" in k)]
        found = []
        for key in broken:
            try:
                v, res = _zero_along(
                    locator, [last, point], last.value, value,
                    lambda r, key=key: validity_slacks(r.margins, problem).get(key, np.nan), xtol)
                found.append((abs(v - last.value), v, key, res, True))
            except (_Unresolved, ValueError):
                found.append((abs(value - last.value), 0.5 * (last.value + value), key, None,
                              False))
        _, v, key, res, refined = min(found, key=lambda t: t[0])
        res = res or locator.solve([last, point], v)
        required = problem.validity
        reason = (f"validity margin {key} reaches its minimum "
                  f"(slack {validity_slacks(point.result.margins, problem)[key]:+.4g} at "
                  f"{value:.8g}; requirements {dict(required)})")
        return locator.event("boundary", v, (last.value, value), reason, res, refined,
                             branch=last.branch)
    # the orbit fails: bisect on the existence of a valid fixed point
    good, bad = last, value
    res_good = last.result
    while abs(bad - good.value) > bisect_tol:
        mid = 0.5 * (good.value + bad)
        res = locator.solve([good], mid)
        if res.converged and res.valid:
            good, res_good = BranchPoint(mid, res, branch=last.branch), res
        else:
            bad, failure = mid, res.failure or failure
    reason = f"the orbit fails beyond: {failure or 'no fixed point'}"
    return locator.event("boundary", 0.5 * (good.value + bad), (good.value, bad), reason,
                         res_good, refined=True, branch=last.branch)


def branch_end(end: BranchEnd, problem, locator: Locator, xtol: float, bisect_tol: float,
               fold_tol: float = 0.1) -> BranchEvent:
    """Name and locate the end of a branch
    (see :class:`~pdw_casadi.gait.continuation.BranchEnd`)."""
    if end.kind == "invalid":
        return boundary(end.last, end.failed_value, end.point, end.failure, problem, locator,
                        xtol, bisect_tol)
    if end.failure is not None:  # the orbit from (near) the fixed point fails
        return boundary(end.last, end.failed_value, None, end.failure, problem, locator,
                        xtol, bisect_tol)
    mu = end.last.result.eigenvalues
    real = mu[np.abs(mu.imag) < 1e-9].real
    near = float(real[np.argmin(np.abs(real - 1))]) if real.size else float("nan")
    bracket = (end.last.value, end.failed_value)
    if abs(near - 1) < fold_tol:
        reason = (f"the branch turns back (fold): Newton has no solution beyond "
                  f"{end.last.value:.8g}; real eigenvalue {near:+.6f} approaching +1")
        kind = "fold"
    else:
        reason = (f"Newton does not converge beyond {end.last.value:.8g} (eigenvalue nearest "
                  f"+1: {near:+.6f}); the branch could not be followed further")
        kind = "branch_end"
    # the step halving of the continuation has already bisected the bracket to min_step
    return locator.event(kind, 0.5 * sum(bracket), bracket, reason, end.last.result,
                         refined=True, branch=end.last.branch)
