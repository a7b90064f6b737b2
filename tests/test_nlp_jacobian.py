"""The structure-assembled constraint Jacobian of the fit NLP (pdw_casadi.nlp.jacobian) is
CasADi's own Jacobian of the same rows: same values to rounding, a pattern that holds it."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.jacobian import StructuredJacobian
from pdw_casadi.nlp.shooting import ShootingNLP


def _check(nlp, g, x, x0, P=None, p0=None):
    """``P``: the rows' parameters (a symbol column) and ``p0`` their values."""
    P = ca.MX.sym("p", 0, 1) if P is None else P
    p0 = np.zeros(0) if p0 is None else p0
    sj = StructuredJacobian(nlp, g, x, params=P)
    ref = ca.Function("J", [x, P], [ca.jacobian(g, x)])(x0, p0)
    mine = ca.DM(sj.sparsity, sj.values(x0, p0))
    # every entry CasADi finds nonzero lies in the assembled pattern
    refs = ref.sparsity()
    rows, cols = np.asarray(refs.get_triplet()[0]), np.asarray(refs.get_triplet()[1])
    vals = np.asarray(ref.nonzeros())
    A = mine.full()
    assert np.all(A[rows[vals != 0], cols[vals != 0]] != 0)
    scale = np.abs(vals).max()
    assert scale > 1.0  # a non-trivial Jacobian
    assert np.abs(A - ref.full()).max() <= 1e-12 * scale
    # the wrapped CasADi function gives the same values
    f = sj.function()
    np.testing.assert_array_equal(np.asarray(f(x0, p0).nonzeros()), sj.values(x0, p0))
    # the intervals evaluated on one thread or side by side on three: the same numbers, bit
    # for bit (each thread has its own copy of the compiled functions)
    one = StructuredJacobian(nlp, g, x, workers=1, params=P)
    three = StructuredJacobian(nlp, g, x, 3, params=P)
    assert three._workers == 3
    np.testing.assert_array_equal(one.values(x0, p0), sj.values(x0, p0))
    np.testing.assert_array_equal(three.values(x0, p0), sj.values(x0, p0))


def test_structured_jacobian_of_the_compass_gait_nlp_is_casadis():
    """Free slope, a perturbed point off the starting gait (so that no row is trivially
    zero), plus rows mixing nodes, durations and the slope nonlinearly, two of them scaled
    by parameters of the NLP (as the fit's rows take the human curves)."""
    pb = load_problem("compass_gait")
    fp = find_fixed_point(pb)
    nlp = ShootingNLP(pb, fp.state, fp.parameters, free=("slope",), sample_stride=2)
    extra = ca.MX.sym("e", 3)
    q = ca.MX.sym("q", 2)
    y = nlp.Y[0][0, :]
    g = ca.vertcat(nlp.g, extra - ca.vertcat(ca.sumsqr(y) * nlp.T[0] * q[0],
                                            nlp.p[-1] * nlp.T[-1] - q[1],
                                            ca.sin(nlp.samples[-1][1, 3]) * q[1]))
    x = ca.vertcat(nlp.w, extra)
    rng = np.random.default_rng(3)
    x0 = np.r_[nlp.w0 * (1 + 1e-3 * rng.standard_normal(nlp.w0.size)), rng.standard_normal(3)]
    _check(nlp, g, x, x0, q, np.array([1.7, -0.4]))


@pytest.mark.slow
def test_structured_jacobian_of_a_stride_nlp_is_casadis():
    """The per-leg walker's two-step NLP (parameters permuted per step, both legs' free
    compliance): the parameter chain rule through the permutations."""
    from pdw_casadi.gait.stride import stride_map
    from pdw_casadi.studies.prosthesis import atlas_problem

    base = atlas_problem()
    smap = stride_map(base)
    free = ("left.k_knee", "right.k_knee", "right.k_ankle")
    nlp = ShootingNLP.stride(base, base.state_vector(), smap.default_parameters(), free=free)
    rng = np.random.default_rng(4)
    x0 = nlp.w0 * (1 + 1e-4 * rng.standard_normal(nlp.w0.size))
    _check(nlp, nlp.g, nlp.w, x0)
