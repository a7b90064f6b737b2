"""Planar multibody dynamics in absolute coordinates, following eqs. (1)-(12) of the paper.

Bodies are rigid links (mass, inertia about the COM, absolute angle) or point masses. Their
COM positions and angles, stacked, are the rectangular coordinates r(q); T = dr/dq,
M_q = T^T M T and F_q = T^T (F - M Tdot qd). Contact sets are holonomic constraint rows
eps(q) = 0 with Jacobian E; the constrained accelerations and multipliers solve eq. (12),
and inelastic impacts solve M_q (qd+ - qd-) = E^T Lambda, E qd+ = 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


def direction(angle):
    """Unit vector (sin q, -cos q): proximal-to-distal direction of a link at absolute angle q."""
    return ca.vertcat(ca.sin(angle), -ca.cos(angle))


def cross2(a, b):
    """z-component of the cross product of two planar vectors."""
    return a[0] * b[1] - a[1] * b[0]


@dataclass(frozen=True)
class Body:
    """A rigid link or a point mass.

    ``com`` is its centre of mass (2x1 SX in q), ``angle`` its absolute angle (SX in q) or
    ``None`` for a point mass; ``mass`` in kg, ``inertia`` about the COM in kg m^2 (numbers,
    or SX symbols when the body is a runtime parameter).
    """

    name: str
    mass: float
    inertia: float
    com: ca.SX
    angle: ca.SX | None = None


@dataclass(frozen=True)
class ContactSet:
    """Named holonomic constraint rows eps(q) = 0 (constant offsets do not matter)."""

    name: str
    rows: ca.SX
    labels: tuple[str, ...]


class PlanarSystem:
    """Mass matrix, forces and constrained dynamics of a planar chain, all as SX expressions."""

    def __init__(self, q: ca.SX, qd: ca.SX, bodies: list[Body], g: float):
        self.q, self.qd, self.bodies, self.g = q, qd, bodies, g
        rows, masses, weights = [], [], []
        for b in bodies:
            rows += [b.com[0], b.com[1]]
            masses += [b.mass, b.mass]
            weights += [0.0, -b.mass * g]
            if b.angle is not None:
                rows.append(b.angle)
                masses.append(b.inertia)
                weights.append(0.0)
        self.r = ca.vertcat(*rows)
        # masses may be numbers (baked into the graph) or SX (runtime body parameters)
        numeric = all(isinstance(v, int | float) for v in masses + weights)
        vec = ca.DM if numeric else (lambda v: ca.vertcat(*[ca.SX(x) for x in v]))
        self.M = vec(masses)
        self.T = ca.jacobian(self.r, q)
        self.M_q = ca.mtimes([self.T.T, ca.diag(self.M), self.T])
        tdot_qd = ca.jtimes(ca.mtimes(self.T, qd), q, qd)
        self.F_gravity = ca.mtimes(self.T.T, vec(weights))
        self.F_velocity = -ca.mtimes(self.T.T, self.M * tdot_qd)
        self.kinetic = 0.5 * ca.mtimes([qd.T, self.M_q, qd])
        self.potential = sum(b.mass * g * b.com[1] for b in bodies)

    def generalized_torque(self, tau, plus_angle, minus_angle=None):
        """Generalized force of a torque ``tau`` acting + on one link and - on another."""
        jac = ca.jacobian(plus_angle, self.q)
        if minus_angle is not None:
            jac = jac - ca.jacobian(minus_angle, self.q)
        return jac.T * tau

    def velocity(self, point):
        """Velocity (2x1 SX) of a point given as an SX expression in q."""
        return ca.jtimes(point, self.q, self.qd)

    def angular_momentum(self, names, about):
        """Angular momentum (kg m^2/s) of the named bodies about a point (SX in q)."""
        total = 0
        for b in self.bodies:
            if b.name not in names:
                continue
            total += b.mass * cross2(b.com - about, self.velocity(b.com))
            if b.angle is not None:
                total += b.inertia * ca.jtimes(b.angle, self.q, self.qd)
        return total

    def constraint_jacobian(self, contact: ContactSet):
        return ca.jacobian(contact.rows, self.q)

    def constrained_dynamics(self, contact: ContactSet | None, F_q):
        """Solve eq. (12): accelerations qdd and multipliers lambda (forces along the rows).

        The KKT system ``[M_q -E^T; E 0] [qdd; lambda] = [F_q; -Edot qd]`` is solved exactly,
        but by structure instead of one dense symbolic solve (the dense 13x13 solve was 80 %
        of the right-hand side's operations): a row whose Jacobian has a single entry
        (x_t1, y_t1, l_f cos qf1) fixes that coordinate's acceleration directly; the rest is
        a small KKT system solved through LDL^T of the (SPD) mass-matrix block and the Schur
        complement of the remaining rows; the eliminated rows' multipliers follow from their
        coordinates' equations of motion.
        """
        n = self.q.shape[0]
        if contact is None or contact.rows.shape[0] == 0:
            return _ldl_solve(self.M_q, F_q), ca.SX(0, 1)
        E = self.constraint_jacobian(contact)
        m = E.shape[0]
        c = -ca.jtimes(ca.mtimes(E, self.qd), self.q, self.qd)
        fixed: dict[int, int] = {}  # row -> the only column it touches
        for i in range(m):
            cols = [j for j in range(n) if E.sparsity().has_nz(i, j)]
            if len(cols) == 1 and cols[0] not in fixed.values():
                fixed[i] = cols[0]
        C = list(fixed.values())
        R = [j for j in range(n) if j not in C]
        N = [i for i in range(m) if i not in fixed]
        M, F = self.M_q, F_q
        qdd = [None] * n
        for i, j in fixed.items():
            qdd[j] = c[i] / E[i, j]
        qdd_C = ca.vertcat(*[qdd[j] for j in C]) if C else ca.SX(0, 1)
        rhs_R = F[R] - (ca.mtimes(M[R, C], qdd_C) if C else 0)
        L, D = _ldl(M[R, R])
        u = _ldl_apply(L, D, rhs_R)
        lam = [None] * m
        if N:
            E_NR = E[N, R]
            Y = _ldl_apply(L, D, E_NR.T)
            c_N = c[N] - (ca.mtimes(E[N, C], qdd_C) if C else 0)
            lam_N = _ldl_solve(ca.mtimes(E_NR, Y), c_N - ca.mtimes(E_NR, u))
            qdd_R = u + ca.mtimes(Y, lam_N)
            for k, i in enumerate(N):
                lam[i] = lam_N[k]
        else:
            lam_N, qdd_R = ca.SX(0, 1), u
        for k, j in enumerate(R):
            qdd[j] = qdd_R[k]
        qdd = ca.vertcat(*qdd)
        for i, j in fixed.items():
            # coordinate j's equation of motion: M[j,:] qdd - sum_k E[k,j] lam_k = F[j]
            other = ca.dot(E[N, j], lam_N) if N else 0
            lam[i] = (ca.dot(M[j, :].T, qdd) - F[j] - other) / E[i, j]
        return qdd, ca.vertcat(*lam)

    def impact(self, contact: ContactSet):
        """Inelastic impact: post-impact velocities and impulses (N s) along the rows."""
        n = self.q.shape[0]
        E = self.constraint_jacobian(contact)
        m = E.shape[0]
        kkt = ca.blockcat([[self.M_q, -E.T], [E, ca.SX(m, m)]])
        sol = ca.solve(kkt, ca.vertcat(ca.mtimes(self.M_q, self.qd), ca.SX(m, 1)))
        return sol[:n], sol[n:]


def _ldl(A):
    """Dense symbolic LDL^T factors (L unit lower triangular, D diagonal as a list) of an SPD
    matrix, without pivoting (the mass matrix is SPD, so no pivoting is needed)."""
    n = A.shape[0]
    L = [[ca.SX(0) for _ in range(n)] for _ in range(n)]
    D = []
    for j in range(n):
        d = A[j, j] - sum((L[j][k] * L[j][k] * D[k] for k in range(j)), ca.SX(0))
        D.append(d)
        L[j][j] = ca.SX(1)
        for i in range(j + 1, n):
            s = A[i, j] - sum((L[i][k] * L[j][k] * D[k] for k in range(j)), ca.SX(0))
            L[i][j] = s / d
    return L, D


def _ldl_apply(L, D, B):
    """(L D L^T)^-1 B for the factors of :func:`_ldl` (B: n x k SX)."""
    n = len(D)
    cols = []
    for c in range(B.shape[1]):
        y = []
        for i in range(n):  # L y = b
            y.append(B[i, c] - sum((L[i][k] * y[k] for k in range(i)), ca.SX(0)))
        z = [y[i] / D[i] for i in range(n)]
        x = [None] * n
        for i in reversed(range(n)):  # L^T x = z
            x[i] = z[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), ca.SX(0))
        cols.append(ca.vertcat(*x))
    return ca.horzcat(*cols)


def _ldl_solve(A, b):
    """A^-1 b for a symmetric positive definite SX matrix A."""
    L, D = _ldl(A)
    return _ldl_apply(L, D, b)
