"""The classical fourth-order Runge-Kutta step, once, for every integrator of the toolkit.

The simulator's steps, its fused chunks, the Poincare map's sensitivities and the shooting
intervals of the NLP all take the same step, so that their discrete maps agree exactly.
The stages work on CasADi expressions (SX or MX) and on numpy arrays alike.
"""

from __future__ import annotations

import casadi as ca


def rk4(f, x, h, k1=None):
    """One RK4 step of x' = f(x) of size ``h``; ``k1``: f(x) when already known (a fused
    chunk carries it over from the previous step's end)."""
    k1 = f(x) if k1 is None else k1
    k2 = f(x + h / 2 * k1)
    k3 = f(x + h / 2 * k2)
    k4 = f(x + h * k3)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def rk4_sensitivities(f, x, S, h, eh=None):
    """One RK4 step with its forward sensitivities.

    ``f(x, S) -> (k, dk)``: the right-hand side at ``x`` and its directional derivative
    along the sensitivity columns ``S`` (dx/dz, one column per seed z). ``eh``: the row
    vector of the seed that is the step size h itself (then the stage points x + c h k get
    their dependence on h, c k e_h); None when h is not a seed. Returns (x_next, S_next).
    """

    def shifted(s, k, c):
        # c k e_h: the stage point's derivative with respect to h (c = 1/2 or 1)
        if eh is None:
            return s
        return s + ca.mtimes(k / 2 if c == 0.5 else k, eh)

    k1, d1 = f(x, S)
    k2, d2 = f(x + h / 2 * k1, shifted(S + h / 2 * d1, k1, 0.5))
    k3, d3 = f(x + h / 2 * k2, shifted(S + h / 2 * d2, k2, 0.5))
    k4, d4 = f(x + h * k3, shifted(S + h * d3, k3, 1.0))
    ksum = k1 + 2 * k2 + 2 * k3 + k4
    x_next = x + h / 6 * ksum
    S_next = S + h / 6 * (d1 + 2 * d2 + 2 * d3 + d4)
    if eh is not None:
        S_next = S_next + ca.mtimes(ksum / 6, eh)
    return x_next, S_next
