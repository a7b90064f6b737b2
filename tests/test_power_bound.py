"""The stability row's "power" bound (pdw_casadi.nlp.stability.power_bound):
||J^k||_F^(1/k) bounds the spectral radius and the k-step growth of every perturbation, falls
to the radius as k grows, and has an exact gradient; and the fit's assembled constraint
Jacobian, whose stability row is computed on its own thread, is the row's own gradient
stacked under the structured Jacobian."""

from __future__ import annotations

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pdw_casadi.nlp.stability import power_bound


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from([2, 8, 32]))
def test_power_bound_bounds_radius_and_k_step_growth(seed, k):
    rng = np.random.default_rng(seed)
    J = 0.4 * rng.standard_normal((6, 6))
    b, _ = power_bound(J, k)
    rho = np.abs(np.linalg.eigvals(J)).max()
    assert b >= rho * (1 - 1e-12)
    # every perturbation's growth over k steps is at most b^k (spectral norm <= Frobenius)
    assert np.linalg.norm(np.linalg.matrix_power(J, k), 2) <= b ** k * (1 + 1e-12)


def test_power_bound_tends_to_the_radius_and_sees_transient_growth():
    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    normal = Q @ np.diag([0.88, 0.87, 0.3, 0.1, 0.0]) @ Q.T
    shear = normal + 50.0 * np.outer(Q[:, 0], Q[:, 1])  # same eigenvalues, non-normal
    assert abs(np.abs(np.linalg.eigvals(shear)).max() - 0.88) < 1e-9
    # normal: ||J^k||_F^(1/k) = (sum |l|^2k)^(1/2k) -> 0.88 from above
    b = [power_bound(normal, k)[0] for k in (8, 64, 512)]
    assert b[0] > b[1] > b[2] > 0.88 and b[0] - 0.88 > 0.02 and b[2] - 0.88 < 1e-3
    # non-normal: the same radius, but 8 steps can amplify a perturbation; the bound says so
    assert power_bound(shear, 8)[0] > 1.0 > power_bound(normal, 8)[0]


def test_power_bound_gradient_matches_finite_differences():
    rng = np.random.default_rng(2)
    J = 0.3 * rng.standard_normal((7, 7))
    for k in (8, 32):
        _, G = power_bound(J, k)
        for _ in range(3):
            V = rng.standard_normal(J.shape)
            eps = 1e-6
            fd = (power_bound(J + eps * V, k)[0] - power_bound(J - eps * V, k)[0]) / (2 * eps)
            assert abs(np.sum(G * V) - fd) < 1e-7 * max(1.0, abs(fd)), (k, np.sum(G * V), fd)


def test_assembled_jacobian_stacks_the_rows_and_the_stability_gradient():
    """nlp_functions with a structured Jacobian and a stability row (row on its own thread):
    g ends with the row's value and jac_g's last row is its exact gradient, the other rows
    the structured Jacobian's, bit for bit, at a point off the orbit."""
    from pdw_casadi.gait.fixed_point import find_fixed_point
    from pdw_casadi.model.problem import load_problem
    from pdw_casadi.nlp.driver import nlp_functions
    from pdw_casadi.nlp.jacobian import StructuredJacobian
    from pdw_casadi.nlp.shooting import ShootingNLP
    from pdw_casadi.nlp.stability import StabilityRow

    pb = load_problem("compass_gait")
    fp = find_fixed_point(pb)
    nlp = ShootingNLP(pb, fp.state, fp.parameters, free=("slope",), sample_stride=2)
    row = StabilityRow(nlp, bound="power", power=8)
    n_w = nlp.w.shape[0]
    _, jac_g, _keep = nlp_functions(nlp.w, ca.sumsqr(nlp.w), nlp.g, row, n_w, nlp, [None], 2)
    rng = np.random.default_rng(5)
    w = nlp.w0 * (1 + 1e-4 * rng.standard_normal(n_w))
    g, J = jac_g(w, ca.DM(0, 1))
    m = nlp.g.shape[0]
    row_grad = StabilityRow(nlp, bound="power", power=8).gradient(w)
    assert np.linalg.norm(row_grad) > 0
    assert float(g[m]) == StabilityRow(nlp, bound="power", power=8).value(w)
    Jf = J.full()
    np.testing.assert_array_equal(Jf[m], row_grad)
    ref = ca.DM(StructuredJacobian(nlp, nlp.g, nlp.w, 1).sparsity,
                StructuredJacobian(nlp, nlp.g, nlp.w, 1).values(w)).full()
    np.testing.assert_array_equal(Jf[:m], ref)
