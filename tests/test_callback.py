"""Python functions inside CasADi graphs (pdw_casadi.engine.callback.NumericFunction): the
copy-free buffer path computes what the DM path computes, in an NLP graph too, and the
inputs it hands over stay valid after the call."""

from __future__ import annotations

import casadi as ca
import numpy as np

from pdw_casadi.engine.callback import NumericFunction


def _pair(kept: list):
    sp_out = ca.Sparsity.lower(3)  # 6 structural nonzeros, column-major

    def values(x):
        kept.append(x)  # a callee that keeps its input (as the stability row's cache does)
        return np.array([x[0] * x[1], np.sin(x[2]), x[0] ** 2, x[1] - x[2], 2.0, x.sum()])

    dm = NumericFunction("dm", [ca.Sparsity.dense(3, 1)], [sp_out],
                         lambda a: [ca.DM(sp_out, values(np.asarray(a[0]).ravel()))])

    def into(args, outs):
        outs[0][:] = values(args[0])

    buf = NumericFunction("buf", [ca.Sparsity.dense(3, 1)], [sp_out], None, buffers=into)
    return dm, buf


def test_the_buffer_path_computes_what_the_dm_path_computes_and_its_inputs_are_copies():
    kept: list = []
    dm, buf = _pair(kept)
    x = np.array([0.3, -1.7, 2.2])
    a, b = dm(x), buf(x)
    assert a.sparsity() == b.sparsity() and np.array_equal(a.nonzeros(), b.nonzeros())
    # inside an MX graph evaluated twice at other points: the same values, and the input
    # the callee kept from the first call still holds the first point
    X = ca.MX.sym("x", 3)
    g = ca.Function("g", [X], [ca.sumsqr(buf(2 * X)) + ca.sumsqr(dm(2 * X))])
    v1 = float(g(x))
    first = kept[-1].copy()
    v2 = float(g(-x))
    assert np.array_equal(first, 2 * x)
    assert np.array_equal(kept[-4], 2 * x) and np.array_equal(kept[-1], -2 * x)
    assert v1 == 2 * float(ca.sumsqr(dm(2 * x))) and v2 == 2 * float(ca.sumsqr(dm(-2 * x)))


def test_a_numeric_function_takes_one_evaluator():
    """evaluate or buffers, exactly one: the other would never run (CasADi calls only the
    buffer path when it exists)."""
    import pytest

    dense = ca.Sparsity.dense(1, 1)
    with pytest.raises(ValueError, match="one of them"):
        NumericFunction("none", [dense], [dense], None)
    with pytest.raises(ValueError, match="one of them"):
        NumericFunction("both", [dense], [dense], lambda a: [a[0]],
                        buffers=lambda args, outs: None)
