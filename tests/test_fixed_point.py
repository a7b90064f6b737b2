"""Fixed points and stability: the published compass-gait and kneed-walker gaits, and the
humanlike 6-link gait near the paper's Table 2."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point, stability
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.problem import load_problem


def _top3(ev):
    ev = np.asarray(ev)
    ev = ev[np.argsort(-np.abs(ev), kind="stable")][:3]
    return ev


def _match_eigs(got, expected, tol=1e-5):
    got = list(_top3(got))
    for e in expected:
        k = int(np.argmin([abs(g - e) for g in got]))
        assert abs(got.pop(k) - e) < tol, (e, got)


def test_compass_gait_published_gait():
    pb = load_problem("compass_gait")
    fp = find_fixed_point(pb)
    assert fp.converged and fp.residual < 1e-9
    q_st, q_sw, dq_st, dq_sw = fp.state
    assert abs(abs(q_st + pb.slope) - 0.2710287) < 1e-6
    assert abs(abs(q_sw + pb.slope) - 0.2710287) < 1e-6
    assert abs(abs(dq_st) - 1.0923836) < 1e-6
    assert abs(abs(dq_sw) - 0.3773739) < 1e-6
    assert abs(fp.step_time_s - 0.7343464) < 1e-6
    _match_eigs(fp.eigenvalues, [-0.199726 + 0.544476j, -0.199726 - 0.544476j, 0.131573])
    assert abs(fp.spectral_radius - 0.579952) < 1e-5
    assert fp.stable
    assert np.sort(np.abs(fp.eigenvalues))[0] < 1e-8  # the constrained section: one ~0


def test_kneed_walker_published_gait():
    pb = load_problem("kneed_walker")
    fp = find_fixed_point(pb)
    assert fp.converged and fp.residual < 1e-9
    q_st, q_sw, dq_st, dq_sw_t, dq_sw_s = fp.state
    assert abs(abs(q_st - q_sw) - 0.4792840) < 1e-6
    assert abs(abs(dq_st) - 1.1338166) < 1e-6
    assert abs(abs(dq_sw_t) - 0.1087293) < 1e-6
    assert abs(abs(dq_sw_s) - 0.1087293) < 1e-6
    assert abs(fp.step_time_s - 0.545846) < 1e-6
    _match_eigs(fp.eigenvalues, [0.548185 + 0.498578j, 0.548185 - 0.498578j, 0.107749])
    assert abs(fp.spectral_radius - 0.741004) < 1e-5
    assert fp.stable
    assert np.sort(np.abs(fp.eigenvalues))[1] < 1e-8  # two structural ~0 eigenvalues


def test_humanlike_fixed_point_near_table2_and_fd_spectral_radius():
    pb = load_problem("humanlike_6link")
    x0, p = pb.state_vector(), pb.parameter_vector()
    P = PoincareMap(pb)
    fp = find_fixed_point(pb, pmap=P)
    assert fp.converged and fp.residual < 1e-9
    assert np.linalg.norm(fp.state - x0) < 2e-2
    # slightly unstable: a complex pair 0.9199 +/- 0.4092i, spectral radius ~1.0068
    assert abs(fp.spectral_radius - 1.0068) < 1e-3
    lead = fp.eigenvalues[0]
    assert abs(lead.real - 0.9199) < 1e-3 and abs(abs(lead.imag) - 0.4092) < 1e-3
    assert not fp.stable
    # monodromy matrix by central differences of the event-driven simulator
    sim = Simulator(pb)
    eps, n = 1e-5, fp.state.size
    J = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        xp = sim.run(fp.state + e, p, steps=1, record=False).steps[0].x_section_end
        xm = sim.run(fp.state - e, p, steps=1, record=False).steps[0].x_section_end
        J[:, j] = (np.asarray(xp) - np.asarray(xm)) / (2 * eps)
    assert abs(stability(J).spectral_radius - fp.spectral_radius) < 1e-4


def test_stability_of_known_matrix():
    # block diagonal: pair 0.66 +/- 0.88i (|.| = 1.1), then 0.5 and -0.1
    A = np.zeros((4, 4))
    A[:2, :2] = [[0.66, -0.88], [0.88, 0.66]]
    A[2, 2], A[3, 3] = -0.1, 0.5
    st = stability(A)
    assert st.spectral_radius == pytest.approx(1.1, abs=1e-12)
    assert not st.stable
    np.testing.assert_allclose(np.abs(st.eigenvalues), [1.1, 1.1, 0.5, 0.1], atol=1e-12)
    assert st.eigenvalues[0].imag != 0 and st.eigenvalues[2].real == pytest.approx(0.5)
    assert stability(0.8 * A).stable
    assert stability(np.diag([0.3, -0.95])).spectral_radius == pytest.approx(0.95)
