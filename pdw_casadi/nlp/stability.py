"""The stability row of the fit NLP: a smooth bound of the spectral radius of the Poincare
Jacobian of the NLP's *own* discretised step, with its exact gradient.

The NLP's step (:class:`~pdw_casadi.nlp.shooting.ShootingNLP`) is: the section state xs mapped to
the full state, then per segment k its N_k shooting intervals of M RK4 steps of size
h_k = T_k / (N_k M), the segment's ending event g_k = 0 fixing T_k, the impact map (or the
identity at a mode switch), and after the last segment the leg swap back to the section.
Its Jacobian J = dP/dxs (ns x ns) is therefore the chain, evaluated at the NLP's nodes:

    Z <- [Phi Z + c_k beta e^T]  per interval (Phi = dX_next/dX,
                                  beta = dX_next/dh, c_k = 1/(N_k M);
                                  Z = [R | b], R = dX/dxs, b = dX/dT_k)
    R <- (I - b gx / (gx b)) R    at a segment end (gx = dg_k/dx:
                                  the saltation projection)
    R <- D R                      across an impact (D = d impact / dx)
    J  = d section / dx . D_last R

A stride NLP (two steps, ``step_perms``) runs the chain through both steps' segments, each
with its step's parameters p_i = theta[perm_i]; between the steps the section projection

    R <- E(xs_2, p_2) . d section / dx . D R   (E = d section_to_full / d xs)

where xs_2 is the NLP's own unknown section state of step 2, so J = J_2 J_1 is the stride's
Jacobian and the parameter adjoints of both steps are gathered into theta (theta_bar[perm_i]
+= p_bar_i).

At a feasible point this is the exact derivative of the NLP's discrete map (the implicit
function of its continuity and event rows), so at the answer it is the re-simulated step's
Jacobian to the integrator's accuracy. The row is rho_q(J) = (sum |lambda_i|^q)^(1/q) >=
max |lambda_i| (q = 32): no kinks where eigenvalues trade places. Its gradient in all NLP
unknowns is exact: analytic eigenvalue derivatives (d lambda_i = w_i dJ v_i) for dJ, then
one reverse (adjoint) sweep through the chain above, whose interval blocks are the reverse
mode of the forward sensitivities (second-order AD of the RK4 step, compiled once per
walker and phase). No finite differences, no nested Newton.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.linalg import schur, solve_sylvester

from pdw_casadi.engine.compile import HOT, LazyGroup, cse_function, interpreted
from pdw_casadi.engine.rk4 import rk4_sensitivities
from pdw_casadi.model.hybrid import HybridSystem, Impact

RADIUS_NORM = 32  # q of the smooth spectral-radius bound
#: relative gap |lambda_2| - |lambda_3| (of |lambda_1|) below which the leading pair is not
#: separated from the rest and :func:`schur_radius` falls back to :func:`smooth_radius`
PAIR_SEPARATION = 1e-6


def smooth_radius(J: np.ndarray, q: int = RADIUS_NORM) -> tuple[float, np.ndarray]:
    """rho_q(J) = (sum |lambda_i|^q)^(1/q) and its gradient dJbar = d rho_q / dJ (same shape).

    max |lambda| <= rho_q <= n^(1/q) max |lambda| (a complex pair counts 2^(1/32) = 1.022).
    The derivative uses left/right eigenvectors (simple eigenvalues, generic here).
    """
    lam, V = np.linalg.eig(J)
    W = np.linalg.inv(V)  # rows: left eigenvectors normalised so that W V = I
    mag = np.abs(lam)
    top = mag.max()
    if top == 0:
        return 0.0, np.zeros_like(J)
    rho = float(top * np.sum((mag / top) ** q) ** (1 / q))
    a = (mag / rho) ** (q - 1)  # d rho / d |lambda_i|
    mu = np.where(mag > 0, np.conj(lam) / np.where(mag > 0, mag, 1), 0)  # d|l| = Re(mu dl)
    # d lambda_i = W[i] dJ V[:, i] = tr(V[:, i] W[i] dJ)  ->  dJbar = Re(sum a mu V W)^T
    X = (V * (a * mu)) @ W
    return rho, np.real(X).T


def power_bound(J: np.ndarray, k: int = 64) -> tuple[float, np.ndarray]:
    """||J^k||_F^(1/k) (k a power of two) and its gradient dJbar (same shape).

    An upper bound of the spectral radius for every k (rho(J)^k = rho(J^k) <= ||J^k||),
    tight as k grows, and smooth in J: unlike any function of the eigenvalue moduli it has
    no kink where two real eigenvalues meet and become a complex pair.
    """
    s = int(round(math.log2(k)))
    if 2 ** s != k:
        raise ValueError(f"k must be a power of two, got {k}")
    A = [np.asarray(J, float)]
    for _ in range(s):
        A.append(A[-1] @ A[-1])
    F = float(np.linalg.norm(A[-1]))
    if not math.isfinite(F) or F == 0.0:
        return (math.nan if not math.isfinite(F) else 0.0), np.zeros_like(J)
    b = F ** (1.0 / k)
    Abar = (b / (k * F)) * A[-1] / F
    for Ai in reversed(A[:-1]):
        Abar = Abar @ Ai.T + Ai.T @ Abar
    return b, Abar


def _smooth_relu(x: float, eps: float) -> tuple[float, float]:
    """max(0, x) rounded over |x| < eps (C^1, >= max(0, x)) and its derivative."""
    if x >= eps:
        return x, 1.0
    if x <= -eps:
        return 0.0, 0.0
    return (x + eps) ** 2 / (4 * eps), (x + eps) / (2 * eps)


def _power_sum(s: float, p: float, q: int) -> tuple[float, float, float]:
    """l1^q + l2^q of the roots of z^2 - s z + p (a polynomial in s, p) and its partials."""
    e0, e1 = 2.0, s
    d0s, d1s, d0p, d1p = 0.0, 1.0, 0.0, 0.0
    for _ in range(q - 1):
        e2 = s * e1 - p * e0
        d2s = e1 + s * d1s - p * d0s
        d2p = s * d1p - e0 - p * d0p
        e0, e1, d0s, d1s, d0p, d1p = e1, e2, d1s, d2s, d1p, d2p
    return e1, d1s, d1p


def schur_radius(J: np.ndarray, q: int = RADIUS_NORM,
                 eps: float = 0.2) -> tuple[float, np.ndarray]:
    """rho_q of :func:`smooth_radius` made smooth where the leading pair of eigenvalues meets
    on the real axis, and its gradient dJbar (J's shape).

    The leading pair (the two eigenvalues of largest modulus) enters through its invariants
    s = l1 + l2 and p = l1 l2, read off the 2 x 2 leading block T11 of J's ordered real
    Schur form J = Z T Z^T (smooth in J while the pair stays apart from the other
    eigenvalues, also where it is defective; ds = tr(W dJ V), dp = tr(adj(T11) W dJ V) with V
    = Z[:, :2] and W the block's left projector). Its share of sum |l|^q is 2 p^(q/2) + a
    smoothed max(0, l1^q + l2^q - 2 p^(q/2)): exactly |l1|^q + |l2|^q for a complex pair and
    for real roots away from their meeting point, and an upper bound by at most ``eps``/2
    of 2 p^(q/2) near it (so rho_q stays >= the spectral radius). The other eigenvalues
    enter as in :func:`smooth_radius`. Falls back to :func:`smooth_radius` for a matrix
    smaller than 3 x 3 or a pair not separated from the rest.
    """
    J = np.asarray(J, float)
    n = J.shape[0]
    lam = np.linalg.eigvals(J)
    mag = np.sort(np.abs(lam))[::-1]
    top = mag[0]
    if n < 3 or top == 0 or not (mag[1] - mag[2]) > PAIR_SEPARATION * top:
        return smooth_radius(J, q)
    A = J / top
    cut = 0.5 * (mag[1] + mag[2]) / top
    T, Z, sdim = schur(A, output="real", sort=lambda x, y: np.hypot(x, y) > cut)
    if sdim != 2:
        return smooth_radius(J, q)
    T11, T12, T22 = T[:2, :2], T[:2, 2:], T[2:, 2:]
    Y = solve_sylvester(T11, -T22, -T12)  # T11 Y - Y T22 = -T12
    V = Z[:, :2]
    W = np.hstack([np.eye(2), -Y]) @ Z.T
    s, p = float(np.trace(T11)), float(np.linalg.det(T11))
    adj = np.array([[T11[1, 1], -T11[0, 1]], [-T11[1, 0], T11[0, 0]]])
    Ps, Ps_s, Ps_p = _power_sum(s, p, q)
    if p > 0:
        base = 2 * p ** (q / 2)
        r, dr = _smooth_relu(Ps - base, eps * base)
        # d base / dp; the relu's width eps base moves with p too
        dbase = q * p ** (q / 2 - 1)
        x = Ps - base
        if abs(x) < eps * base:  # d/dp of (x + eps b)^2 / (4 eps b) at fixed x, via b
            e = eps * base
            dr_de = (x + e) / (2 * e) - (x + e) ** 2 / (4 * e ** 2)
        else:
            dr_de = 0.0
        G = base + r
        G_s = dr * Ps_s
        G_p = dbase + dr * (Ps_p - dbase) + dr_de * eps * dbase
    else:  # real roots of opposite signs (or a zero root): |l1|^q + |l2|^q = l1^q + l2^q
        G, G_s, G_p = Ps, Ps_s, Ps_p
    # the other eigenvalues (those of T22), as smooth_radius treats them; their invariant
    # subspace has the right basis U = Z [Y; I] and the left rows L = Z[:, 2:]^T
    lr, Vr = np.linalg.eig(T22)
    Wr = np.linalg.inv(Vr)
    mr = np.abs(lr)
    S = G + float(np.sum(mr ** q))
    rho_a = S ** (1.0 / q)
    dS = G_s * (V @ W).T + G_p * (V @ adj @ W).T
    U = Z @ np.vstack([Y, np.eye(n - 2)])
    L = Z[:, 2:].T
    mu = np.where(mr > 0, np.conj(lr) / np.where(mr > 0, mr, 1), 0)
    X = (Vr * (q * mr ** (q - 1) * mu)) @ Wr
    dS = dS + np.real(U @ X @ L).T
    # rho = top rho_a(J / top): d rho / dJ = d rho_a / dA = (1/q) S^(1/q - 1) dS/dA
    return float(top * rho_a), (1.0 / q) * S ** (1.0 / q - 1) * dS


@dataclass
class _Blocks:
    """Compiled pieces of one walker's chain (value and reverse mode of each)."""

    interval: dict  # phase -> (fwd, adj) numpy callables
    project: dict  # phase -> (fwd, adj)
    impact: dict  # transition -> (fwd, adj)
    last: dict  # transition -> (fwd, adj): section Jacobian after the impact
    section: tuple  # (fwd, adj)
    libraries: list  # the compiled libraries behind them (one per phase, one for the section)


#: the blocks of each hybrid system (per sub-step count), kept only while the system lives
_BLOCKS: weakref.WeakKeyDictionary[HybridSystem, dict[int, _Blocks]] = \
    weakref.WeakKeyDictionary()


def _blocks(hs: HybridSystem, n_sub: int) -> _Blocks:
    per_system = _BLOCKS.setdefault(hs, {})
    if n_sub in per_system:
        return per_system[n_sub]
    model = hs.model
    nx, npar, nm = hs.nx, hs.np, hs.nm
    ns = len(model.state_names)
    x, p, m = ca.SX.sym("x", nx), model.p, model.m
    Z = ca.SX.sym("Z", nx, ns + 1)
    groups: dict[str, dict[str, ca.Function]] = {}
    for phase in hs.phase_names:
        group = groups[phase] = {}
        # one RK4 step with its forward sensitivities, Z <- dX_next/d(xs, T_k) Z: the stages
        # chain the right-hand side's Jacobian (small SX code, compiled in seconds; the
        # reverse sweep then needs only that Jacobian's reverse mode, second-order AD)
        xdot = hs.rhs[phase](x, p, m)
        rj = cse_function(f"zrhs_{phase}", [x, p, m], [xdot, ca.jacobian(xdot, x)])
        A = ca.MX.sym("A", nx + nx * (ns + 1))  # (X, vec Z)
        X, Zm = A[:nx], ca.reshape(A[nx:], nx, ns + 1)
        H, P, M, C = ca.MX.sym("h"), ca.MX.sym("p", npar), ca.MX.sym("m", nm), ca.MX.sym("c")
        # dh/dT_k = c: the last column (b = dX/dT_k) also moves the stage points
        E = ca.horzcat(ca.MX(1, ns), C)

        def stage(xx, zz, rj=rj, P=P, M=M):
            k, Ak = rj(xx, P, M)
            return k, ca.mtimes(Ak, zz)

        Xn, Zn = rk4_sensitivities(stage, X, Zm, H, E)
        one = ca.Function(f"zstep_{phase}", [A, H, P, M, C], [ca.vertcat(Xn, ca.vec(Zn))])
        acc = one.mapaccum(f"zacc_{phase}", n_sub)
        out = acc(A, H, P, M, C)[:, -1]
        group.update(_named(ca.Function(f"zint_{phase}_{n_sub}", [A, H, P, M, C],
                                        [out[nx:]])))
        # the saltation projection at the segment's ending event (one-hot ``sel``)
        sel = ca.SX.sym("sel", len(hs.event_list[phase]))
        g = ca.dot(sel, hs.events[phase].fun(x, p, m))
        gx = ca.jacobian(g, x)
        R, b = Z[:, :ns], Z[:, ns]
        Rp = R - ca.mtimes(b, ca.mtimes(gx, R)) / ca.mtimes(gx, b)
        group.update(_named(cse_function(f"zproj_{phase}", [x, p, m, sel, ca.vec(Z)],
                                         [ca.vec(Rp)])))
    # impacts: three calls per sweep, but large expressions (the impulse solve expanded),
    # which gcc takes minutes to compile: CasADi's interpreter runs them in milliseconds;
    # without common-subexpression elimination, which would take longer to build (0.6 s
    # each) than it saves over a fit (a fraction of a millisecond per call; same numbers)
    R = ca.SX.sym("R", nx, ns)
    vm: dict[str, ca.Function] = {}
    for tr in hs.model.transitions:
        xp = Impact(*hs.impact[tr.name].fun(x, p)).x_plus
        if tr.ends_step:
            out = model.full_to_section(xp)
            vm.update(_named(ca.Function(f"zlast_{tr.name}", [x, p, ca.vec(R)],
                                         [ca.vec(ca.jtimes(out, x, R))])))
        else:
            vm.update(_named(ca.Function(f"zimp_{tr.name}", [x, p, ca.vec(R)],
                                         [ca.vec(ca.jtimes(xp, x, R))])))
    xs = ca.SX.sym("xs", ns)
    E0 = ca.jacobian(model.section_to_full(xs, p), xs)
    groups["zsec"] = _named(ca.Function("zsec", [xs, p], [ca.vec(E0)]))
    # one library per phase: compiled side by side on a cold start (build_libraries)
    lazy = {key: LazyGroup(group, HOT) for key, group in groups.items()}

    def pair(name, key):
        return lazy[key].np(name), lazy[key].np(f"adj1_{name}")

    def vm_pair(name):
        return interpreted(vm[name]), interpreted(vm[f"adj1_{name}"])

    blocks = _Blocks(
        interval={ph: pair(f"zint_{ph}_{n_sub}", ph) for ph in hs.phase_names},
        project={ph: pair(f"zproj_{ph}", ph) for ph in hs.phase_names},
        impact={tr.name: vm_pair(f"zimp_{tr.name}") for tr in hs.model.transitions
                if not tr.ends_step},
        last={tr.name: vm_pair(f"zlast_{tr.name}") for tr in hs.model.transitions
              if tr.ends_step},
        section=pair("zsec", "zsec"), libraries=list(lazy.values()))
    per_system[n_sub] = blocks
    return blocks


def stability_libraries(hs: HybridSystem, n_sub: int) -> list:
    """The compiled libraries of the stability row's chain for walker ``hs`` with ``n_sub``
    RK4 steps per interval (for :func:`~pdw_casadi.engine.compile.build_libraries`)."""
    return list(_blocks(hs, n_sub).libraries)


def _named(f: ca.Function) -> dict[str, ca.Function]:
    """``f`` and its reverse mode ``adj1_<name>``: (inputs, output seed) -> input seeds
    (the nominal output, which the reverse sweep of these functions does not read, is left
    out)."""
    ins = f.mx_in()
    f = ca.Function(f.name(), ins, [ca.densify(o) for o in f.call(ins)])
    adj = f.reverse(1)
    seed = ca.MX.sym("seed", f.sparsity_out(0))
    nominal = ca.MX(adj.sparsity_in(len(ins)))
    outs = adj.call([*ins, nominal, seed])
    return {f.name(): f, f"adj1_{f.name()}": ca.Function(
        f"adj1_{f.name()}", [*ins, seed], [ca.densify(o) for o in outs])}


class StabilityRow:
    """rho_q of the NLP step's Poincare Jacobian as a function of the NLP unknowns ``w``
    (see the module docstring): :meth:`value`, :meth:`gradient` (exact), :meth:`poincare_jacobian`.

    ``nlp`` is a :class:`~pdw_casadi.nlp.shooting.ShootingNLP`; all its segments must use the
    same number of RK4 steps per interval. The last forward sweep is cached, so the gradient
    at the point just evaluated costs one reverse sweep.
    """

    def __init__(self, nlp, q: int = RADIUS_NORM, bound: str = "eigenvalues",
                 power: int = 64):
        if bound not in ("eigenvalues", "power", "schur"):
            raise ValueError(f"bound must be 'eigenvalues', 'power' or 'schur', got {bound!r}")
        self.nlp, self.q, self.bound, self.power = nlp, q, bound, power
        hs = nlp.hs
        subs = {s.n_sub for s in nlp.specs}
        if len(subs) != 1:
            raise ValueError("the stability row needs one n_sub for all segments")
        self.n_sub = subs.pop()
        self.blocks = _blocks(hs, self.n_sub)
        self.nx, self.ns = hs.nx, nlp.xs.shape[0]
        self.nf = len(nlp.free)
        self.free_idx = [nlp.param_names.index(n) for n in nlp.free]
        # layout of w: xs, pf, T, then vec(X_k) column-major per segment, then the section
        # states of steps 2.. (strides)
        self.o_T = self.ns + self.nf
        self.o_X = []
        o = self.o_T + len(nlp.specs)
        for s in nlp.specs:
            self.o_X.append(o)
            o += self.nx * (s.n_int + 1)
        self.perms = nlp.step_perms
        self.o_xs = [0]
        for _ in range(1, len(self.perms)):
            self.o_xs.append(o)
            o += self.ns
        self.n = o
        specs = nlp.specs
        # segments after which the next step starts (the section projection, not the last)
        self.step_end = [k + 1 < len(specs) and specs[k + 1].step != s.step
                         for k, s in enumerate(specs)]
        self.sel = []
        for s in nlp.specs:
            e = np.zeros(len(hs.event_list[s.phase]))
            e[s.event] = 1.0
            self.sel.append(e)
        self._cache = None

    # -- helpers ----------------------------------------------------------------------------
    def _unpack(self, w):
        w = np.asarray(w, float).ravel()
        xs = [w[o: o + self.ns] for o in self.o_xs]
        p = self.nlp.p0.copy()
        p[self.free_idx] = w[self.ns: self.o_T] * self.nlp.p_scale
        ps = [p if i is None else p[i] for i in self.perms]  # each step's parameters
        T = w[self.o_T: self.o_T + len(self.nlp.specs)]
        X = [w[o: o + self.nx * (s.n_int + 1)].reshape((self.nx, s.n_int + 1), order="F")
             for o, s in zip(self.o_X, self.nlp.specs, strict=True)]
        return xs, ps, T, X

    def _forward(self, w):
        """One forward sweep: J and the stored inputs of every block."""
        b, nx, ns = self.blocks, self.nx, self.ns
        xs, ps, T, X = self._unpack(w)
        R = b.section[0](xs[0], ps[0]).reshape((nx, ns), order="F")
        tape = []
        J = None
        for k, s in enumerate(self.nlp.specs):
            p = ps[s.step]
            mode = np.asarray(s.mode, float)
            c = 1.0 / (s.n_int * s.n_sub)
            h = T[k] * c
            Z = np.zeros((nx, ns + 1))
            Z[:, :ns] = R
            zs = []
            fwd = b.interval[s.phase][0]
            for j in range(s.n_int):
                a = np.concatenate([X[k][:, j], Z.ravel(order="F")])
                out = fwd(a, h, p, mode, c)
                zs.append(a)
                Z = out.reshape((nx, ns + 1), order="F")
            xe = X[k][:, -1]
            Zend = Z
            R = b.project[s.phase][0](xe, p, mode, self.sel[k], Z.ravel(order="F")).reshape(
                (nx, ns), order="F")
            Rproj = R
            link = None
            if s.transition is not None:
                if k == len(self.nlp.specs) - 1:
                    J = b.last[s.transition][0](xe, p, R.ravel(order="F")).reshape(
                        (ns, ns), order="F")
                elif self.step_end[k]:
                    # this step's section Jacobian, then into the next step's full state
                    Js = b.last[s.transition][0](xe, p, R.ravel(order="F")).reshape(
                        (ns, ns), order="F")
                    i = self.nlp.specs[k + 1].step
                    E = b.section[0](xs[i], ps[i]).reshape((nx, ns), order="F")
                    R = E @ Js
                    link = (Js, E)
                else:
                    R = b.impact[s.transition][0](xe, p, R.ravel(order="F")).reshape(
                        (nx, ns), order="F")
            tape.append((zs, h, c, mode, xe, Zend, Rproj, link))
        if J is None:
            raise ValueError("the NLP's last segment must end in the section transition")
        return J, (xs, ps, T, X, tape)

    def _eval(self, w):
        w = np.asarray(w, float).ravel()
        if self._cache is not None and np.array_equal(self._cache[0], w):
            return self._cache[1]
        try:
            J, tape = self._forward(w)
            ok = bool(np.all(np.isfinite(J)))
        except (RuntimeError, np.linalg.LinAlgError):
            ok = False
        res = (J, tape) if ok else None
        self._cache = (w.copy(), res)
        return res

    # -- public -----------------------------------------------------------------------------
    def poincare_jacobian(self, w) -> np.ndarray:
        """J = dP/dxs of the NLP's step at unknowns ``w`` (ns x ns)."""
        res = self._eval(w)
        return np.full((self.ns, self.ns), np.nan) if res is None else res[0]

    def value(self, w) -> float:
        """rho_q(J(w)) (NaN where the chain is not finite: IPOPT cuts its step back)."""
        res = self._eval(w)
        if res is None:
            return math.nan
        return self._bound(res[0])[0]

    def _bound(self, J):
        if self.bound == "power":
            return power_bound(J, self.power)
        if self.bound == "schur":
            return schur_radius(J, self.q)
        return smooth_radius(J, self.q)

    def gradient(self, w) -> np.ndarray:
        """Exact d rho_q / dw (one reverse sweep through the chain)."""
        res = self._eval(w)
        if res is None:
            return np.full(self.n, np.nan)
        J, (xs, ps, T, X, tape) = res
        _, Jbar = self._bound(J)
        b, nx, ns = self.blocks, self.nx, self.ns
        g = np.zeros(self.n)
        pbars = [np.zeros(p.size) for p in ps]  # per step, d rho / d p_i
        specs = self.nlp.specs
        Rbar = None
        for k in range(len(specs) - 1, -1, -1):
            s = specs[k]
            p, pbar = ps[s.step], pbars[s.step]
            zs, h, c, mode, xe, Zend, Rproj, link = tape[k]
            o = self.o_X[k]
            xe_sl = slice(o + nx * s.n_int, o + nx * (s.n_int + 1))
            if k == len(specs) - 1:
                adj = b.last[s.transition][1]
                xb, pb, Rb = adj(xe, p, Rproj.ravel(order="F"), Jbar.ravel(order="F"))
            elif link is not None:  # R_next = E(xs_i, p_i) Js
                Js, E = link
                i = specs[k + 1].step
                xsb, pb = b.section[1](xs[i], ps[i], (Rbar @ Js.T).ravel(order="F"))
                g[self.o_xs[i]: self.o_xs[i] + ns] += np.ravel(xsb)
                pbars[i] += np.ravel(pb)
                adj = b.last[s.transition][1]
                xb, pb, Rb = adj(xe, p, Rproj.ravel(order="F"), (E.T @ Rbar).ravel(order="F"))
            elif s.transition is not None:
                adj = b.impact[s.transition][1]
                xb, pb, Rb = adj(xe, p, Rproj.ravel(order="F"), Rbar.ravel(order="F"))
            else:
                xb, pb, Rb = np.zeros(nx), np.zeros(p.size), Rbar.ravel(order="F")
            g[xe_sl] += np.ravel(xb)
            pbar += np.ravel(pb)
            adj = b.project[s.phase][1]
            zf = Zend.ravel(order="F")
            xb, pb, _, _, Zb = adj(xe, p, mode, self.sel[k], zf, np.ravel(Rb))
            g[xe_sl] += np.ravel(xb)
            pbar += np.ravel(pb)
            Zb = np.ravel(Zb)
            adj = b.interval[s.phase][1]
            for j in range(s.n_int - 1, -1, -1):
                a = zs[j]
                ab, hb, pb, _, _ = adj(a, h, p, mode, c, Zb)
                ab = np.ravel(ab)
                g[o + nx * j: o + nx * (j + 1)] += ab[:nx]
                Zb = ab[nx:]
                g[self.o_T + k] += float(np.ravel(hb)[0]) * c
                pbar += np.ravel(pb)
            Rbar = Zb.reshape((nx, ns + 1), order="F")[:, :ns]
        adj = b.section[1]
        xsb, pb = adj(xs[0], ps[0], Rbar.ravel(order="F"))
        g[: self.ns] += np.ravel(xsb)
        pbars[0] += np.ravel(pb)
        if len(self.perms) == 1 and self.perms[0] is None:
            theta_bar = pbars[0]
        else:  # p_i = theta[perm_i]: gather each step's adjoint back into theta
            theta_bar = np.zeros(self.nlp.p0.size)
            for perm, pb in zip(self.perms, pbars, strict=True):
                np.add.at(theta_bar, perm, pb)
        g[self.ns: self.o_T] += theta_bar[self.free_idx] * self.nlp.p_scale
        return g
