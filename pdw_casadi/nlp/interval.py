"""One shooting interval (M fixed RK4 steps) as compiled CasADi code with its exact Jacobian.

The multiple-shooting NLP evaluates hundreds of intervals and their Jacobians per IPOPT
iteration. In CasADi's virtual machine that costs seconds; compiled it costs milliseconds.
CasADi cannot differentiate a compiled library by itself, so the interval is a
:class:`~pdw_casadi.engine.callback.NumericFunction` whose Jacobian is a second compiled function
(both built once per walker, phase and M, cached on disk by :mod:`pdw_casadi.engine.compile`).
Inside an MX graph ``interval.map(N)`` then differentiates through the compiled Jacobian.

Outputs of ``interval(x, p, m, h)``: the states after each of the M steps (nx x M) and, at
the same instants, the phase's named outputs followed by its event functions (ny x M).
"""

from __future__ import annotations

import casadi as ca

from pdw_casadi.engine.callback import NumericFunction
from pdw_casadi.engine.compile import HOT, LazyGroup, compiled, cse_function, native
from pdw_casadi.engine.rk4 import rk4_sensitivities
from pdw_casadi.model.hybrid import HybridSystem

_CACHE: dict = {}
_FAST: dict = {}  # key -> (interval, its Jacobian) symbolic, then their Native callables


def interval_output_names(hs: HybridSystem, phase: str) -> list[str]:
    """Row names of an interval's second output: phase outputs, then ``event:<name>``."""
    return [*hs.output_names[phase], *(f"event:{e.name}" for e in hs.event_list[phase])]


def _symbolic(hs: HybridSystem, phase: str, n_sub: int) -> tuple[ca.Function, ca.Function]:
    """The interval and its Jacobian (forward sensitivities through the RK4 stages)."""
    model = hs.model
    nx, npar, nm = hs.nx, hs.np, hs.nm
    nz = nx + npar + 1  # z = (x0, p, h)
    x, p, m = ca.SX.sym("x", nx), model.p, model.m
    rhs_jac = hs.rhs_jacobian(phase)
    yv = ca.vertcat(hs.outputs[phase].fun(x, p, m), hs.events[phase].fun(x, p, m))
    ny = yv.shape[0]
    y_jac = cse_function(f"y_jac_{phase}", [x, p, m],
                         [yv, ca.jacobian(yv, x), ca.jacobian(yv, p)])
    X, S = ca.MX.sym("X", nx), ca.MX.sym("S", nx * nz)
    H, P, M = ca.MX.sym("h"), ca.MX.sym("p", npar), ca.MX.sym("m", nm)
    Sm = ca.reshape(S, nx, nz)
    Sp = ca.DM(ca.horzcat(ca.DM.zeros(npar, nx), ca.DM.eye(npar), ca.DM.zeros(npar, 1)))
    eh = ca.DM(ca.horzcat(ca.DM.zeros(1, nx + npar), ca.DM.ones(1, 1)))

    def stage(xx, ss):
        k, A, B = rhs_jac(xx, P, M)
        return k, ca.mtimes(A, ss) + ca.mtimes(B, Sp)

    # h is a seed: the stage points x + c h k depend on it
    Xn, Sn = rk4_sensitivities(stage, X, Sm, H, eh)
    y, Cy, Dy = y_jac(Xn, P, M)
    dY = ca.mtimes(Cy, Sn) + ca.mtimes(Dy, Sp)
    Z = ca.MX.sym("Z", nx + nx * nz)
    Sz = Z[nx:]
    one = ca.Function("one", [X, S, H, P, M], [ca.vertcat(Xn, ca.vec(Sn)), y, ca.vec(dY)])
    step1 = ca.Function(f"sens1_{phase}", [Z, H, P, M], one(Z[:nx], Sz, H, P, M))
    acc = step1.mapaccum(f"iacc_{phase}", n_sub, [0], [0])
    X0 = ca.MX.sym("x", nx)
    S0 = ca.DM(ca.horzcat(ca.DM.eye(nx), ca.DM.zeros(nx, npar + 1)))
    Zs, _, dYs = acc(ca.vertcat(X0, ca.vec(S0)), H, P, M)
    dX = ca.vertcat(*[ca.reshape(Zs[nx:, j], nx, nz) for j in range(n_sub)])
    dYv = ca.vertcat(*[ca.reshape(dYs[:, j], ny, nz) for j in range(n_sub)])
    name = f"interval_{phase}_{n_sub}"
    y_fun = ca.Function("y", [x, p, m], [yv])
    plain = hs.step[phase].fun.mapaccum(f"acc_{phase}", n_sub, ["x"], ["xf"])
    Xp = plain(X0, H, P, M)
    fun = ca.Function(name, [X0, P, M, H], [Xp, y_fun.map(n_sub)(Xp, P, M)],
                      ["x", "p", "m", "h"], ["X", "Y"])
    outX, outY = ca.MX.sym("out_X", nx, n_sub), ca.MX.sym("out_Y", ny, n_sub)
    blocks = []
    for d in (dX, dYv):
        blocks += [d[:, :nx], d[:, nx:nx + npar], ca.MX(d.shape[0], nm), d[:, -1]]
    jac = ca.Function(f"jac_{name}", [X0, P, M, H, outX, outY], blocks)
    return fun, jac


def _symbolic_once(hs: HybridSystem, phase: str, n_sub: int) -> tuple[ca.Function, ca.Function]:
    key = (id(hs), phase, n_sub)
    if key not in _FAST:
        _FAST[key] = _symbolic(hs, phase, n_sub)
    return _FAST[key][:2]


def interval_library(hs: HybridSystem, phase: str, n_sub: int) -> LazyGroup:
    """The compiled library of the interval of ``phase`` with ``n_sub`` RK4 steps and its
    Jacobian (for :func:`~pdw_casadi.engine.compile.build_libraries`)."""
    sym, jac = _symbolic_once(hs, phase, n_sub)
    return LazyGroup({"interval": sym, "jacobian": jac}, HOT)


def _compiled(hs: HybridSystem, phase: str, n_sub: int) -> NumericFunction:
    sym, jac = _symbolic_once(hs, phase, n_sub)
    fast, jac_fast = compiled([sym, jac], HOT)
    return NumericFunction.wrap(sym.name(), sym, fast,
                                jacobian=lambda name: NumericFunction.wrap(name, jac_fast))


def compiled_interval(hs: HybridSystem, phase: str, n_sub: int) -> NumericFunction:
    """The (cached) compiled interval of ``phase`` with ``n_sub`` RK4 steps."""
    key = (id(hs), phase, n_sub)
    if key not in _CACHE:
        _CACHE[key] = _compiled(hs, phase, n_sub)
    return _CACHE[key]


def interval_natives(hs: HybridSystem, phase: str, n_sub: int) -> tuple:
    """Numpy-level callables (:class:`~pdw_casadi.engine.compile.Native`, the same compiled
    library) of the interval (x, p, m, h) -> (X, Y) and of its Jacobian (x, p, m, h, X, Y)
    -> dX/dx, dX/dp, dX/dm (zero), dX/dh, dY/dx, dY/dp, dY/dm, dY/dh (rows: the samples in
    vec order, sample-major; the nominal outputs X, Y are not read)."""
    key = (id(hs), phase, n_sub)
    compiled_interval(hs, phase, n_sub)
    if len(_FAST[key]) == 2:
        _FAST[key] = (*_FAST[key], *native(list(_FAST[key]), HOT))
    return _FAST[key][2:]
