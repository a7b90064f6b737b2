"""Periodic gaits: fixed points of the Poincare map and their stability.

``find_fixed_point`` solves P(x, p) = x by Newton's method with the exact AD Jacobian of
:mod:`pdw_casadi.gait.poincare` and a backtracking line search on ||P(x) - x||; the Jacobian is
refreshed whenever convergence slows (a chord step is cheap: one simulation). IPOPT on the
least-squares problem min ||P(x) - x||^2 is the fallback. Stability is read from the
eigenvalues of dP/dx at the fixed point (asymptotically stable: spectral radius < 1).
"""

from __future__ import annotations

import contextlib
import copy
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import pandas as pd

from pdw_casadi.engine import interrupt
from pdw_casadi.gait.poincare import PoincareError, PoincareMap
from pdw_casadi.model.margins import first_violation, slacks
from pdw_casadi.model.system import gait_system

#: |P(x) - x| (rad, rad/s) a periodic gait is solved to unless a caller asks otherwise
FIXED_POINT_TOL = 1e-10


@dataclass
class Stability:
    """Eigenvalues of the monodromy matrix dP/dx and the spectral radius (-)."""

    eigenvalues: np.ndarray
    spectral_radius: float

    @property
    def stable(self) -> bool:
        return bool(self.spectral_radius < 1.0)


def stability(jacobian) -> Stability:
    """Eigenvalues (sorted by modulus, largest first) and spectral radius of dP/dx."""
    ev = np.linalg.eigvals(np.asarray(jacobian, float))
    ev = ev[np.argsort(-np.abs(ev), kind="stable")]
    return Stability(ev, float(np.abs(ev).max()))


@dataclass
class FixedPointResult:
    """A periodic gait. Angles in rad, rates in rad/s, times in s, lengths in m, forces in N.

    ``margins``: validity margins of the orbit (smallest contact normal force per phase,
    impulses at impacts, centre-of-pressure distance from the foot ends, swing clearance,
    energy lost at knee-spring disengagement); ``valid`` is False with ``failure`` naming
    the broken assumption when the orbit leaves the assumed gait pattern.
    """

    state: np.ndarray
    state_names: tuple[str, ...]
    parameters: np.ndarray
    parameter_names: tuple[str, ...]
    residual: float
    iterations: int
    converged: bool
    jacobian: np.ndarray
    jacobian_p: np.ndarray
    eigenvalues: np.ndarray
    spectral_radius: float
    step_time_s: float
    step_length_m: float
    margins: dict
    valid: bool
    failure: str | None
    method: str
    wall_time_s: float
    history: list = field(default_factory=list)

    @property
    def stable(self) -> bool:
        return bool(self.converged and self.spectral_radius < 1.0)

    @property
    def speed_m_s(self) -> float:
        return self.step_length_m / self.step_time_s if self.step_time_s > 0 else float("nan")

    def state_dict(self) -> dict:
        return dict(zip(self.state_names, map(float, self.state), strict=True))

    def to_dict(self) -> dict:
        return {
            "fixed_point": self.state_dict(),
            "parameters": dict(zip(self.parameter_names, map(float, self.parameters),
                                   strict=True)),
            "residual": self.residual, "iterations": self.iterations,
            "converged": self.converged,
            "eigenvalues": [[float(e.real), float(e.imag)] for e in self.eigenvalues],
            "spectral_radius": self.spectral_radius, "stable": self.stable,
            "step_time_s": self.step_time_s, "step_length_m": self.step_length_m,
            "speed_m_s": self.speed_m_s, "margins": self.margins, "valid": self.valid,
            "failure": self.failure, "method": self.method, "wall_time_s": self.wall_time_s,
        }

    def to_frame(self) -> pd.DataFrame:
        return pd.DataFrame({"name": self.state_names, "value": self.state})


def validity_slacks(margins: dict, problem, hs=None) -> dict[str, float]:
    """Each validity margin of ``margins`` minus its required minimum (N, m or N s, by
    margin; the walker's :class:`~pdw_casadi.model.margins.Margin` specs, ``hs`` or the problem's
    hybrid system).

    The gait pattern holds while every slack is >= 0 (impulses: > 0); a slack reaching zero
    along a parameter sweep is a gait-pattern boundary. Margins that carry no requirement
    (e.g. the energy lost at knee-spring disengagement) are left out.
    """
    return slacks(margins, (hs or gait_system(problem)).margin_specs, problem.validity)


def validity_failure(margins: dict, problem, hs=None) -> str | None:
    """The first validity margin of ``margins`` below its required minimum (a message naming
    it and the requirement), or None."""
    return first_violation(margins, (hs or gait_system(problem)).margin_specs,
                           problem.validity)


def find_fixed_point(problem, x0=None, p=None, tol: float = FIXED_POINT_TOL, max_iter: int = 30,
                     fallback: bool = True, pmap: PoincareMap | None = None,
                     verbose: bool = False, steps: int = 1) -> FixedPointResult:
    """Fixed point of the periodic map of ``steps`` steps of ``problem`` (the step map, or
    the stride with ``steps=2``: :class:`~pdw_casadi.gait.poincare.PoincareMap`) near ``x0``
    with parameters ``p``.

    Args:
        problem: the walker problem (its initial state and parameters are the defaults).
        x0: starting section state (problem order; rad, rad/s).
        p: the map's parameters (default: its :meth:`~PoincareMap.default_parameters`: the
            compliance + slope vector in problem order; of a stride, theta).
        tol: Euclidean norm of P(x) - x to reach.
        max_iter: Newton iterations before giving up (then IPOPT if ``fallback``).
        pmap: the map (default: ``PoincareMap(problem, steps=steps)``).
    """
    t_start = time.perf_counter()
    P = pmap or PoincareMap(problem, steps=steps)
    x = np.asarray(problem.state_vector() if x0 is None else x0, float).ravel().copy()
    p = np.asarray(P.default_parameters() if p is None else p, float).ravel()
    n = x.size
    history = []
    method = "newton"
    converged = False
    it = 0
    try:
        r = P.evaluate(x, p)
    except PoincareError:
        # the map is not defined at the start (the walker fails in the first step): there
        # is nothing for Newton or IPOPT to work from
        return _finish(problem, P, x, p, False, 0, method, t_start, history)
    try:
        G = r.x_next - x
        J = r.dx - np.eye(n)
        fresh = True
        for it in range(1, max_iter + 1):
            norm = float(np.linalg.norm(G))
            history.append(norm)
            if verbose:
                print(f"  newton {it - 1:2d}: |P(x) - x| = {norm:.3e}")
            if norm < tol:
                converged = True
                it -= 1
                break
            dx = -np.linalg.lstsq(J, G, rcond=None)[0]
            alpha, accepted = 1.0, False
            while alpha > 1e-3:
                try:
                    xn = x + alpha * dx
                    Gn = P.evaluate(xn, p, jacobian=False).x_next - xn
                    if np.linalg.norm(Gn) < (1 - 1e-4 * alpha) * norm:
                        accepted = True
                        break
                except PoincareError:
                    pass
                alpha *= 0.5
            if not accepted:
                if fresh:
                    break
                r = P.evaluate(x, p)
                J, fresh = r.dx - np.eye(n), True
                continue
            ratio = np.linalg.norm(Gn) / norm
            step = xn - x
            # Broyden's rank-one update keeps the Newton model current between exact Jacobians
            J = J + np.outer(Gn - G - J @ step, step) / float(step @ step)
            x, G = xn, Gn
            fresh = False
            if ratio > 0.5 and np.linalg.norm(Gn) > tol:
                r = P.evaluate(x, p)
                G, J, fresh = r.x_next - x, r.dx - np.eye(n), True
        else:
            converged = float(np.linalg.norm(G)) < tol
    except PoincareError:
        converged = False
    if not converged and fallback:
        x, converged = _ipopt_fixed_point(P, x, p, tol)
        method = "ipopt"
    return _finish(problem, P, x, p, converged, it, method, t_start, history)


#: the problem's own fixed point, by the problem's content (a fit's report, start ranking and
#: first start all need it; a few entries: one command uses one or two problems)
_OWN: dict[str, FixedPointResult] = {}
_OWN_SIZE = 8


def own_fixed_point(problem) -> FixedPointResult:
    """:func:`find_fixed_point` of ``problem`` from its own state and parameters, computed
    once per process for a problem of the same content (a copy is returned: callers may
    change it)."""
    key = problem.content_key()
    if key not in _OWN:
        if len(_OWN) >= _OWN_SIZE:
            _OWN.pop(next(iter(_OWN)))
        _OWN[key] = find_fixed_point(problem)
    return copy.deepcopy(_OWN[key])


@contextlib.contextmanager
def _quiet_stderr():
    """Discard what is written to stderr (file descriptor 2, so C++ output too) inside the
    block: a map evaluation that fails inside IPOPT is reported by CasADi as a printed
    traceback and warning, and IPOPT then backtracks; the outcome is in the result."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError, AttributeError):  # no real stderr (e.g. captured)
        yield
        return
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            with contextlib.redirect_stderr(open(os.devnull, "w")) as devnull:
                try:
                    yield
                finally:
                    devnull.close()
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)


def _ipopt_fixed_point(P: PoincareMap, x, p, tol):
    """IPOPT least squares min ||P(x) - x||^2 with the exact Jacobian (fallback)."""
    f = P.as_casadi()
    xs = ca.MX.sym("x", x.size)
    res = f(xs, ca.DM(p)) - xs
    solver = ca.nlpsol("fp", "ipopt", {"x": xs, "f": 0.5 * ca.sumsqr(res)},
                       {"ipopt.print_level": 0, "print_time": False,
                        "ipopt.hessian_approximation": "limited-memory",
                        "ipopt.tol": tol ** 2, "ipopt.max_iter": 200})
    try:
        with _quiet_stderr():
            sol = solver(x0=x)
        interrupt.check()  # a Ctrl-C caught by CasADi inside the solve
        xn = np.asarray(sol["x"]).ravel()
        return xn, float(np.linalg.norm(P(xn, p) - xn)) < max(tol, 1e-8)
    except (RuntimeError, PoincareError):
        return x, False


def _finish(problem, P, x, p, converged, it, method, t_start, history) -> FixedPointResult:
    try:
        r = P.evaluate(x, p, jacobian=True, margins=True)  # margins, no trajectory frame
    except PoincareError as exc:
        nan = float("nan")
        return FixedPointResult(
            state=x, state_names=P.state_names, parameters=p,
            parameter_names=P.parameter_names, residual=nan, iterations=it, converged=False,
            jacobian=np.full((x.size, x.size), nan), jacobian_p=np.full((x.size, p.size), nan),
            eigenvalues=np.full(x.size, nan), spectral_radius=nan, step_time_s=nan,
            step_length_m=nan, margins={}, valid=False, failure=exc.failure.reason,
            method=method, wall_time_s=time.perf_counter() - t_start, history=history)
    st = stability(r.dx)
    sr = r.sim.steps[0]
    margins = dict(sr.margins)
    margins["spring_disengagement_loss_J"] = sr.spring_loss_J
    failure = validity_failure(margins, problem, P.hs)
    return FixedPointResult(
        state=x, state_names=P.state_names, parameters=p, parameter_names=P.parameter_names,
        residual=float(np.linalg.norm(r.x_next - x)), iterations=it, converged=converged,
        jacobian=r.dx, jacobian_p=r.dp, eigenvalues=st.eigenvalues,
        spectral_radius=st.spectral_radius, step_time_s=sr.step_time,
        step_length_m=sr.step_length, margins=margins, valid=failure is None,
        failure=failure, method=method, wall_time_s=time.perf_counter() - t_start,
        history=history)
