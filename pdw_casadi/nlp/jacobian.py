"""The constraint Jacobian of a multiple-shooting NLP, assembled from its structure.

Every row of the NLP is a function G(x, S) of the unknowns x and of the RK4 samples S of
its shooting intervals (states and outputs at every RK4 step); the samples of interval j of
segment k depend only on its node X_kj, the step's parameters p and the step size
h_k = T_k / (N_k M). So

    dg/dx = G_x + G_S S_x,

with G_x, G_S the (sparse) Jacobians of the rows once the samples are symbols (plain
CasADi expressions: expanded to SX, differentiated and evaluated in milliseconds) and S_x
block-sparse, each block the compiled interval's own exact Jacobian (dS/dX_kj, dS/dp,
dS/dh: :func:`pdw_casadi.nlp.interval.interval_natives`, compiled code called
per interval). Left to CasADi, the same Jacobian of the MX graph (forward sweeps through the
Python-called intervals) took seconds to build and about a second per evaluation
(docs/results/fit.md). The two agree to rounding (tests/test_fit_jacobian.py).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import casadi as ca
import numpy as np
import scipy.sparse as sps

from pdw_casadi.engine.callback import NumericFunction
from pdw_casadi.engine.compile import stored
from pdw_casadi.nlp.interval import interval_natives


def _rows_jacobian(G: ca.Function) -> ca.Function:
    """(x, S, p) -> (dg/dx, dg/dS) of the rows G(x, S, p)."""
    try:  # SX: differentiated and evaluated far faster than the MX graph
        G = G.expand()
        xs_, S_, p_ = G.sx_in()
    except RuntimeError:  # a walker function that has no SX form
        xs_, S_, p_ = G.mx_in()
    gv = G(xs_, S_, p_)
    return ca.Function("rows_jac", [xs_, S_, p_], [ca.jacobian(gv, xs_), ca.jacobian(gv, S_)])


class StructuredJacobian:
    """d g / d x of rows ``g`` (MX in the NLP unknowns ``x``, whose first entries are the
    :class:`~pdw_casadi.nlp.shooting.ShootingNLP` unknowns ``nlp.w``) by the chain rule above.

    :attr:`sparsity` is the fixed (structural) pattern; :meth:`values` its nonzeros at a
    point; :meth:`function` a CasADi function (x, p) -> dg/dx for nlpsol.
    """

    def __init__(self, nlp, g: ca.MX, x: ca.MX, workers: int | None = None,
                 params: ca.MX | None = None):
        """``workers``: threads that evaluate the compiled intervals side by side (default:
        one per core; the results do not depend on it). ``params``: the NLP's parameters
        (a symbol column) on which the rows may depend: an input of the stored rows'
        Jacobian, so that it serves every value (e.g. every gait file's curves)."""
        self.nlp = nlp
        nx = nlp.hs.nx
        self.n_x, self.m = x.shape[0], g.shape[0]
        SX = [ca.MX.sym(f"S_X{k}", *X.shape) for k, X in enumerate(nlp.samples)]
        SY = [ca.MX.sym(f"S_Y{k}", *Y.shape) for k, Y in enumerate(nlp.Y)]
        gs = ca.graph_substitute(g, [*nlp.samples, *nlp.Y], SX + SY)
        S = ca.vertcat(*[ca.vec(a) for a in SX + SY])
        p = ca.MX.sym("p", 0, 1) if params is None else params
        self.n_p = p.shape[0]
        G = ca.Function("rows_of_samples", [x, S, p], [gs])
        if G.has_free():
            raise ValueError("the rows depend on the samples other than through the NLP's "
                             "intervals")
        #: the rows as a function of (x, S, p): what the stored Jacobian is keyed by
        self.rows_of_samples = G
        self._G = stored(G, lambda: _rows_jacobian(G), "rows_jac")
        Gx0, GS0 = (self._G.sparsity_out(i) for i in range(2))
        used = np.unique(np.asarray(GS0.get_col(), int)) if GS0.nnz() else np.zeros(0, int)
        self._used = used
        # where every used sample lives: (block = segment k and X or Y, its row in the
        # segment's mapped interval Jacobian, the interval j)
        o, blocks = 0, []
        for k, s in enumerate(nlp.specs):
            blocks.append((k, "X", o, nx, s))
            o += nx * s.n_int * s.n_sub
        for k, s in enumerate(nlp.specs):
            ny = nlp.Y[k].shape[0]
            blocks.append((k, "Y", o, ny, s))
            o += ny * s.n_int * s.n_sub
        self.n_S = o
        # w layout (ShootingNLP._build): xs, pf, T, vec(X_k) per segment, ...
        ns, nf = nlp.xs.shape[0], len(nlp.free)
        o_T = ns + nf
        o_X, ox = [], o_T + len(nlp.specs)
        for s in nlp.specs:
            o_X.append(ox)
            ox += nx * (s.n_int + 1)
        # d p_step / d pf per step (p_step = p[perm], p = p0 with the free entries pf * scale)
        free_of = {nlp.param_names.index(n): j for j, n in enumerate(nlp.free)}
        self._dp = []
        for perm in nlp.step_perms:
            idx = np.arange(nlp.p0.size) if perm is None else np.asarray(perm)
            D = np.zeros((idx.size, nf))
            for i, q in enumerate(idx):
                if int(q) in free_of:
                    j = free_of[int(q)]
                    D[i, j] = nlp.p_scale[j]
            self._dp.append(D)
        width = nx + nf + 1  # per used sample: its node, the free parameters, its duration
        cols = np.empty((used.size, width), int)
        self._groups = []  # per block: (positions in used, local rows, intervals)
        for k, kind, start, nrow, s in blocks:
            size = nrow * s.n_int * s.n_sub
            sel = np.nonzero((used >= start) & (used < start + size))[0]
            if not sel.size:
                continue
            loc = used[sel] - start  # = (j n_sub + m) nrow + i
            per = nrow * s.n_sub
            j = loc // per
            lr = loc % per
            cols[sel, :nx] = o_X[k] + j[:, None] * nx + np.arange(nx)[None, :]
            cols[sel, nx: nx + nf] = ns + np.arange(nf)[None, :]
            cols[sel, -1] = o_T + k
            self._groups.append((k, kind, sel, lr, j, s))
        self._Sx_indices = cols.ravel()
        self._Sx_indptr = np.arange(used.size + 1) * width
        self._width = width
        self._o_X, self._o_T, self._ns, self._nf = o_X, o_T, ns, nf
        # the structural pattern of G_x + G_S S_x, fixed for nlpsol
        Gx = sps.csc_matrix((np.ones(Gx0.nnz()), Gx0.row(), Gx0.colind()),
                            shape=(self.m, self.n_x))
        GS = sps.csc_matrix((np.ones(GS0.nnz()), GS0.row(), GS0.colind()),
                            shape=(self.m, self.n_S))[:, used]
        Sx = self._Sx(np.ones(used.size * width))
        P = (abs(Gx) + abs(GS) @ abs(Sx)).tocsc()
        P.sort_indices()
        self.sparsity = ca.Sparsity(self.m, self.n_x, P.indptr.tolist(), P.indices.tolist())
        counts = np.diff(P.indptr)
        self._keys = np.repeat(np.arange(self.n_x), counts) * self.m + P.indices
        self._plan(Gx0, GS0, cols)
        # per worker thread its own copy of each phase's compiled interval and Jacobian
        # (buffers are per copy); interval i of every segment goes to worker i % workers
        pairs = {s.phase: interval_natives(nlp.hs, s.phase, s.n_sub) for s in nlp.specs}
        self._workers = max(1, min(workers if workers is not None else os.cpu_count() or 1,
                                   max(s.n_int for s in nlp.specs)))
        self._native = [pairs] + [{ph: tuple(f.clone() if hasattr(f, "clone") else f
                                             for f in pair) for ph, pair in pairs.items()}
                                  for _ in range(self._workers - 1)]
        self._pool = ThreadPoolExecutor(self._workers) if self._workers > 1 else None

    def _plan(self, Gx0: ca.Sparsity, GS0: ca.Sparsity, cols: np.ndarray) -> None:
        """Where each product G_S[i, k] S_x[k, j] and each entry of G_x goes among the
        nonzeros of dg/dx (fixed patterns, so planned once): :meth:`values` is then one
        weighted ``bincount``. The products of an entry are summed in ascending k, as a
        sparse matrix product sums them, so the values do not depend on the plan."""
        m, width = self.m, self._width
        rows = np.asarray(GS0.row(), np.int64)
        k = np.searchsorted(self._used, np.asarray(GS0.get_col(), np.int64))
        a = np.repeat(np.arange(rows.size), width)  # the G_S nonzero of each product
        b = (k[:, None] * width + np.arange(width)[None, :]).ravel()  # its S_x entry
        pos = np.searchsorted(self._keys, cols.ravel()[b].astype(np.int64) * m + rows[a])
        order = np.lexsort((k[a], pos))
        self._prod = (a[order], b[order], pos[order])
        self._pos_x = np.searchsorted(self._keys, np.asarray(Gx0.get_col(), np.int64) * m
                                      + np.asarray(Gx0.row(), np.int64))

    def _Sx(self, data) -> sps.csr_matrix:
        return sps.csr_matrix((data, self._Sx_indices, self._Sx_indptr),
                              shape=(self._used.size, self.n_x))

    def _intervals(self, worker: int, segments: list) -> dict:
        """Samples and Jacobians of the intervals i = worker (mod workers) of every segment
        (``segments``: per segment its nodes, parameters, mode and step size)."""
        out = {}
        for k, (s, X, ps, mode, h) in enumerate(segments):
            fwd, jacf = self._native[worker][s.phase]
            for i in range(worker, s.n_int, self._workers):
                a, b = fwd(X[:, i], ps, mode, h)
                out[k, i] = (a, b, jacf(X[:, i], ps, mode, h, a, b))
        return out

    def values(self, x, p=None) -> np.ndarray:
        """The nonzeros of dg/dx at ``x`` (and the parameters ``p``, default none) in
        :attr:`sparsity`'s order."""
        p_val = np.zeros(0) if p is None else np.asarray(p, float).ravel()
        if p_val.size != self.n_p:
            raise ValueError(f"{self.n_p} parameter values expected, got {p_val.size}")
        nlp, nx, nf = self.nlp, self.nlp.hs.nx, self._nf
        x = np.asarray(x, float).ravel()
        u = nlp.unpack(x[: nlp.w.shape[0]])
        p, T = u["p"], u["T"]
        S = np.empty(self.n_S)
        data = np.empty((self._used.size, self._width))
        segments = []
        for k, s in enumerate(nlp.specs):
            perm = nlp.step_perms[s.step]
            X = x[self._o_X[k]: self._o_X[k] + nx * (s.n_int + 1)].reshape(
                (nx, s.n_int + 1), order="F")[:, :-1]
            segments.append((s, X, p if perm is None else p[perm], np.asarray(s.mode, float),
                             T[k] / (s.n_int * s.n_sub)))
        if self._pool is None:
            done = self._intervals(0, segments)
        else:
            done = {}
            for part in self._pool.map(self._intervals, range(self._workers),
                                       [segments] * self._workers):
                done.update(part)
        outs = {}
        o = 0
        for k, (s, _X, ps, _m, _h) in enumerate(segments):
            got = [done[k, i] for i in range(s.n_int)]
            Xs, Ys = np.hstack([g[0] for g in got]), np.hstack([g[1] for g in got])
            jac = [np.hstack([g[2][q] for g in got]) for q in range(8)]
            outs[k] = (Xs, Ys, jac, s, ps)
        for k, _s in enumerate(nlp.specs):  # S: all X samples, then all Y samples
            Xs = outs[k][0]
            S[o: o + Xs.size] = Xs.ravel(order="F")
            o += Xs.size
        for k, _s in enumerate(nlp.specs):
            Ys = outs[k][1]
            S[o: o + Ys.size] = Ys.ravel(order="F")
            o += Ys.size
        for k, kind, sel, lr, j, s in self._groups:
            blocks, step = outs[k][2], s.step
            dx0, dp, dh = (blocks[0], blocks[1], blocks[3]) if kind == "X" else \
                (blocks[4], blocks[5], blocks[7])
            npar = dp.shape[1] // s.n_int
            cx = j[:, None] * nx + np.arange(nx)[None, :]
            data[sel, :nx] = dx0[lr[:, None], cx]
            cp = j[:, None] * npar + np.arange(npar)[None, :]
            data[sel, nx: nx + nf] = dp[lr[:, None], cp] @ self._dp[step]
            data[sel, -1] = dh[lr, j] / (s.n_int * s.n_sub)
        Gx, GS = self._G(x, S, p_val)
        a, b, pos = self._prod
        out = np.bincount(pos, weights=np.asarray(GS.nonzeros())[a] * data.ravel()[b],
                          minlength=self._keys.size)
        out[self._pos_x] += np.asarray(Gx.nonzeros())
        return out

    def function(self, name: str = "structured_jacobian") -> NumericFunction:
        """(x, p) -> dg/dx as a CasADi function (a Python callback; keep it referenced)."""
        sp = self.sparsity
        dense = ca.Sparsity.dense

        def into(args, outs):  # CasADi's own buffers: no DM of every nonzero
            outs[0][:] = self.values(args[0], args[1])

        return NumericFunction(name, [dense(self.n_x, 1), dense(self.n_p, 1)], [sp], None,
                               buffers=into)
