"""Benchmark the humanlike 6-link fixed point from Table 2: exact AD Jacobian vs FD Newton.

(a) ``find_fixed_point`` with the exact AD Jacobian of the Poincare map, eigenvalues included
    (the map is warmed up once so compilation / cache loading is excluded);
(b) a plain Newton iteration whose Jacobian is central finite differences of the event-driven
    simulator (14 extra simulations per Jacobian), same tolerance 1e-10, plus a final FD
    Jacobian for the eigenvalues.
"""

from __future__ import annotations

import time

import numpy as np

from pdw_casadi.gait.fixed_point import find_fixed_point, stability
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem

TOL = 1e-10
EPS = 1e-5


def fd_newton(sim: Simulator, x0, p, tol=TOL, max_iter=30):
    """Newton on P(x) - x with a central-difference Jacobian of the simulator."""

    def step(x):
        return np.asarray(sim.run(x, p, steps=1, record=False).steps[0].x_section_end, float)

    def fd_jac(x):
        n = x.size
        J = np.empty((n, n))
        for j in range(n):
            e = np.zeros(n)
            e[j] = EPS
            J[:, j] = (step(x + e) - step(x - e)) / (2 * EPS)
        return J

    x = np.asarray(x0, float).copy()
    n = x.size
    it = 0
    G = step(x) - x
    while np.linalg.norm(G) >= tol and it < max_iter:
        x = x - np.linalg.solve(fd_jac(x) - np.eye(n), G)
        G = step(x) - x
        it += 1
    J = fd_jac(x)
    return x, float(np.linalg.norm(G)), it, stability(J)


def main() -> None:
    problem = load_problem("humanlike_6link")
    x0, p = problem.state_vector(), problem.parameter_vector()
    P = PoincareMap(problem)
    P.evaluate(x0, p)  # warm-up: compilation / cache loading
    sim = Simulator(problem)
    sim.run(x0, p, steps=1, record=False)

    t0 = time.perf_counter()
    fp = find_fixed_point(problem, pmap=P, tol=TOL)
    t_ad = time.perf_counter() - t0

    t0 = time.perf_counter()
    x_fd, res_fd, it_fd, st_fd = fd_newton(sim, x0, p)
    t_fd = time.perf_counter() - t0

    np.set_printoptions(precision=7, suppress=True, linewidth=110)
    print(f"AD  Newton: {t_ad:7.3f} s  ({fp.iterations} iterations, residual {fp.residual:.2e}, "
          f"converged {fp.converged}) incl. eigenvalues")
    print(f"FD  Newton: {t_fd:7.3f} s  ({it_fd} iterations, residual {res_fd:.2e}) "
          f"incl. final FD Jacobian")
    print(f"ratio FD/AD = {t_fd / t_ad:.1f}x; target fixed point + eigenvalues < 1 s: "
          f"{'met' if t_ad < 1.0 else 'NOT met'}")
    print("fixed point (AD) =", fp.state)
    print(f"max |x_AD - x_FD| = {np.max(np.abs(fp.state - x_fd)):.3e}; "
          f"max |x_AD - Table 2| = {np.max(np.abs(fp.state - x0)):.3e}")
    print(f"spectral radius: AD {fp.spectral_radius:.6f}, FD {st_fd.spectral_radius:.6f} "
          f"(diff {abs(fp.spectral_radius - st_fd.spectral_radius):.2e})")
    print("eigenvalues (AD) =", fp.eigenvalues[:3])


if __name__ == "__main__":
    main()
