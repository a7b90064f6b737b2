"""The ctypes call path of compiled functions returns what CasADi itself returns, and the
structured constrained dynamics solve the KKT system of eq. (12)."""

from __future__ import annotations

import casadi as ca
import numpy as np
from conftest import full_states

from pdw_casadi.engine.compile import HOT, Lazy, interpreted


def test_native_call_matches_casadi(tmp_path, monkeypatch):
    """Dense and sparse outputs, matrix, scalar and list arguments, several calls."""
    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    x, h, m = ca.SX.sym("x", 3), ca.SX.sym("h"), ca.SX.sym("m", 2)
    y = ca.vertcat(ca.sin(x[0]) * h, x[1] * x[2] + m[0], ca.exp(m[1]))
    fun = ca.Function("native_probe", [x, h, m],
                      [y, ca.jacobian(y, x), ca.horzcat(x, 2 * x)])
    assert not fun.sparsity_out(1).is_dense()
    lazy = Lazy(fun, HOT)
    rng = np.random.default_rng(1)
    for _ in range(3):
        args = (rng.normal(size=3), float(rng.normal()), list(rng.normal(size=2)))
        ref = [np.asarray(v) for v in fun(*args)]
        dm = [np.asarray(v) for v in lazy(*args)]
        for got in (dm, lazy.np(*args), interpreted(fun)(*args)):
            assert len(got) == 3
            for r, g in zip(ref, got, strict=True):
                assert g.shape == r.shape
                np.testing.assert_array_equal(g, r)
    # symbolic arguments go to the CasADi function itself (derivatives stay available)
    xs = ca.SX.sym("xs", 3)
    jac = ca.jacobian(lazy(xs, 1.0, [0.0, 0.0])[0], xs)
    assert jac.shape == (3, 3)


def test_constrained_dynamics_solve_the_kkt_system(hs, table2_step, params):
    """At states of the Table-2 step, qdd and lambda of each phase satisfy
    M_q qdd - E^T lambda = F_q and E qdd = -Edot qd to rounding (relative 1e-12)."""
    model, sysm = hs.model, hs.model.system
    q, qd = sysm.q, sysm.qd
    frame = table2_step.trajectory
    mv = hs.mode_vector(model.initial_mode)
    for name, ph in hs.phases.items():
        E = ca.jacobian(ph.contact.rows, q)
        res_dyn = ca.mtimes(sysm.M_q, ph.qdd) - ca.mtimes(E.T, ph.lam) - model.F_q
        res_con = ca.mtimes(E, ph.qdd) + ca.jtimes(ca.mtimes(E, qd), q, qd)
        scale = ca.vertcat(ca.mtimes(ca.fabs(sysm.M_q), ca.fabs(ph.qdd)),
                           ca.mtimes(ca.fabs(E.T), ca.fabs(ph.lam)), ca.fabs(model.F_q))
        f = ca.Function("kkt_res", [q, qd, model.p, model.m],
                        [ca.vertcat(res_dyn, res_con), ca.mmax(scale)])
        X = full_states(hs, frame[frame["phase"] == name])
        for j in range(0, X.shape[1], max(1, X.shape[1] // 20)):
            r, s = f(X[:8, j], X[8:16, j], params, mv)
            assert float(ca.mmax(ca.fabs(r))) < 1e-12 * float(s), (name, j)


def test_build_libraries_fills_the_cache_that_the_first_calls_load(tmp_path, monkeypatch):
    """Libraries compiled side by side are the ones the lazy functions load: afterwards no
    call compiles, a second build only verifies, and the values are CasADi's."""
    import pdw_casadi.engine.compile as compile_module
    from pdw_casadi.engine.compile import PLAIN, LazyGroup, build_libraries

    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    x = ca.SX.sym("x", 2)
    f = ca.Function("side_f", [x], [ca.sin(x) * x[1]])
    g = ca.Function("side_g", [x], [ca.exp(x[0]) + x[1] ** 2])
    h = ca.Function("side_h", [x], [ca.jacobian(ca.sin(x[0]) * x[1], x)])
    lazy, group = Lazy(f, HOT), LazyGroup({"g": g, "h": h}, PLAIN)
    lines = []
    assert build_libraries([lazy, group, lazy], log=lines.append) == 2
    assert len(list(tmp_path.glob("*.so"))) == 2 and len(lines) == 1

    def no_build(*args):
        raise AssertionError("a library was compiled again")

    monkeypatch.setattr(compile_module, "_build", no_build)
    assert build_libraries([lazy, group], log=lines.append) == 2 and len(lines) == 1
    arg = np.array([0.3, -1.2])
    np.testing.assert_array_equal(lazy.np(arg), np.asarray(f(arg)))
    np.testing.assert_array_equal(group.np("g")(arg), np.asarray(g(arg)))
    np.testing.assert_array_equal(group.np("h")(arg), np.asarray(h(arg)))


def test_a_stored_function_is_built_once_and_loaded_with_the_same_values(tmp_path,
                                                                        monkeypatch):
    """stored(): the first call builds and stores the derived function, a second (as in a
    new process: the key is the source's serialization) loads it without building, with
    identical values; a damaged file is rebuilt; at most STORED_KEEP are kept per tag."""
    import casadi as ca

    from pdw_casadi.engine import compile as comp

    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    x = ca.SX.sym("x", 3)
    src = ca.Function("src", [x], [ca.vertcat(ca.sin(x[0]) * x[1], x[2] ** 3)])
    builds = []

    def build():
        builds.append(1)
        return ca.Function("src_jac", [x], [ca.jacobian(src(x), x)])

    first = comp.stored(src, build, "t")
    again = comp.stored(src, build, "t")
    assert len(builds) == 1
    pt = np.array([0.3, -1.2, 2.0])
    assert np.array_equal(np.asarray(first(pt)), np.asarray(again(pt)))
    assert np.allclose(np.asarray(again(pt)), [[np.cos(0.3) * -1.2, np.sin(0.3), 0],
                                               [0, 0, 12.0]])
    (path,) = tmp_path.glob("t_*.casadi.z")
    path.write_bytes(b"not a function")
    assert np.array_equal(np.asarray(comp.stored(src, build, "t")(pt)), np.asarray(first(pt)))
    assert len(builds) == 2
    monkeypatch.setattr(comp, "STORED_KEEP", 2)
    for k in range(4):  # other sources: the oldest stored ones go
        z = ca.SX.sym("z")
        comp.stored(ca.Function(f"s{k}", [z], [z * (k + 2)]), lambda: src, "t")
    assert len(list(tmp_path.glob("t_*.casadi.z"))) == 2


def test_a_merged_function_is_stored_and_computes_what_casadi_merges(tmp_path, monkeypatch):
    """cse_function(): the same function as CasADi's own common-subexpression elimination
    (the same operations, the same values bit for bit, fewer operations than unmerged), and
    a second call (as a new process) loads it from the cache instead of merging again."""
    import casadi as ca

    from pdw_casadi.engine import compile as comp

    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p")
    e = ca.sin(x[0] + p) * ca.cos(x[1]) + ca.sin(x[0] + p) ** 2
    outs = [ca.vertcat(e, ca.cos(x[1]) * p), ca.jacobian(e, x)]
    ref = ca.Function("f", [x, p], outs, ["x", "p"], ["y", "J"], {"cse": True})
    plain = ca.Function("f", [x, p], outs, ["x", "p"], ["y", "J"])
    merged = comp.cse_function("f", [x, p], outs, ["x", "p"], ["y", "J"])
    assert merged.n_instructions() == ref.n_instructions() < plain.n_instructions()
    assert merged.name_in() == ["x", "p"] and merged.name_out() == ["y", "J"]
    # the first process's function is the one later processes load: what is keyed by its
    # serialization (an NLP's rows' Jacobian) is found by every process
    assert merged.serialize() == comp.cse_function("f", [x, p], outs, ["x", "p"],
                                                   ["y", "J"]).serialize()
    (path,) = tmp_path.glob("cse_*.casadi.z")
    built = path.stat().st_mtime_ns
    monkeypatch.setattr(comp.ca, "Function", _no_merge(ca.Function))
    again = comp.cse_function("f", [x, p], outs, ["x", "p"], ["y", "J"])
    assert path.stat().st_mtime_ns >= built and len(list(tmp_path.glob("cse_*"))) == 1
    pt = [np.array([0.4, -0.9]), 1.3]
    for a, b in zip(ref(*pt), again(*pt), strict=True):
        assert np.array_equal(np.asarray(a), np.asarray(b))


_ROWS_KEY = """
import hashlib
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.jacobian import StructuredJacobian
from pdw_casadi.nlp.shooting import ShootingNLP
pb = load_problem("compass_gait")
fp = find_fixed_point(pb)
nlp = ShootingNLP(pb, fp.state, fp.parameters, free=(), sample_stride=5)
rows = StructuredJacobian(nlp, nlp.g, nlp.w).rows_of_samples
print(hashlib.sha1(rows.serialize().encode()).hexdigest())
"""


def test_the_first_process_on_an_empty_cache_keys_the_rows_jacobian_as_later_ones(tmp_path):
    """The NLP's rows call the walker's merged functions, and the stored rows' Jacobian is
    keyed by the rows' serialization: the process that merged and stored those functions
    (an empty cache) must key it as every later process that loads them, or the second
    run builds the Jacobian again (measured: 0.9 s for the bundled fit)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PDW_CACHE": str(tmp_path), "PDW_NO_COMPILE": "1"}
    keys = [subprocess.run([sys.executable, "-c", _ROWS_KEY], capture_output=True, text=True,
                           env=env, timeout=300, check=True).stdout.strip().splitlines()[-1]
            for _ in range(2)]
    assert list(tmp_path.glob("cse_*.casadi.z"))  # the first process stored them
    assert keys[0] == keys[1]


def _no_merge(function):
    """ca.Function that refuses to merge (a stored merged function must be loaded)."""

    def make(*args):
        if args and isinstance(args[-1], dict) and args[-1].get("cse"):
            raise AssertionError("merged again instead of loaded")
        return function(*args)

    make.deserialize = function.deserialize
    return make


def test_a_library_found_by_signature_is_checked_by_its_values(tmp_path, monkeypatch):
    """A new process finds a function's library under its cheap signature without hashing
    its serialization; a function of the same structure with another constant (another
    body's walker) shares the signature but not the values, so it gets its own library,
    which computes its own values."""
    import casadi as ca

    from pdw_casadi.engine import compile as comp

    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    hashed = []
    full = comp._full_key
    monkeypatch.setattr(comp, "_full_key", lambda f, fl: hashed.append(1) or full(f, fl))

    def walker(mass):
        x = ca.SX.sym("x", 2)
        return ca.Function("leg", [x], [ca.vertcat(mass * ca.sin(x[0]), x[1] ** 2 / mass)])

    pt = np.array([0.4, 1.5])
    light, heavy = walker(2.0), walker(3.0)
    assert comp._signature([light], comp.PLAIN) == comp._signature([heavy], comp.PLAIN)
    first = comp.compiled(light, comp.PLAIN)
    assert len(hashed) == 1
    comp._KEYS.clear()  # as a new process: nothing remembered by identity
    again = comp.compiled(walker(2.0), comp.PLAIN)
    assert len(hashed) == 1  # found by its signature and values, not hashed
    assert np.array_equal(np.asarray(again(pt)), np.asarray(first(pt)))
    other = comp.compiled(heavy, comp.PLAIN)
    assert len(hashed) == 2  # same signature, other values: hashed, its own library
    assert np.allclose(np.asarray(other(pt)).ravel(), [3.0 * np.sin(0.4), 1.5 ** 2 / 3.0])
    assert len(list(tmp_path.glob("leg_*.so"))) == 2


def test_an_undefined_output_beside_defined_ones_is_still_found_by_signature(tmp_path,
                                                                           monkeypatch):
    """A function with one output undefined (NaN) at the probe point, as an adjoint's seed
    of a guard at a random state, is still recognised by the values of its other outputs
    (no serialization hashed); one whose every output is NaN proves nothing and is hashed.
    The key used last comes first in its signature's index, so a process of one walker
    probes one library."""
    import casadi as ca

    from pdw_casadi.engine import compile as comp

    monkeypatch.setenv("PDW_CACHE", str(tmp_path))
    hashed = []
    full = comp._full_key
    monkeypatch.setattr(comp, "_full_key", lambda f, fl: hashed.append(1) or full(f, fl))

    def guard(mass, defined=True):
        x = ca.SX.sym("x", 2)
        nan = ca.sqrt(-1 - x[0] ** 2)  # NaN for every real x
        return ca.Function("guard", [x], [ca.vertcat(mass * x[0], x[1] / mass) if defined
                                          else nan * mass, nan])

    comp.compiled(guard(2.0), comp.PLAIN)
    comp.compiled(guard(3.0), comp.PLAIN)
    assert len(hashed) == 2
    index = tmp_path / "keys" / comp._signature([guard(2.0)], comp.PLAIN)
    second_first = index.read_text().split()
    comp._KEYS.clear()  # as a new process
    comp.compiled(guard(2.0), comp.PLAIN)
    assert len(hashed) == 2  # found by its finite output, not hashed
    assert index.read_text().split() == second_first[::-1]  # the one used last first
    comp._KEYS.clear()
    comp.compiled(guard(2.0, defined=False), comp.PLAIN)
    comp._KEYS.clear()
    comp.compiled(guard(2.0, defined=False), comp.PLAIN)
    assert len(hashed) == 4  # all NaN: nothing proven, hashed each time
