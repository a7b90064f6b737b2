"""The multiple-shooting NLP: its constraint Jacobian is exact (finite differences), the
starting gait is feasible to the integrator's accuracy, and a pure feasibility solve finds
the simulator's fixed point."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.fixed_point import find_fixed_point
from pdw_casadi.problem import load_problem
from pdw_casadi.shooting import ShootingNLP


@pytest.fixture(scope="module")
def nlp6(problem):
    fp = find_fixed_point(problem)
    return ShootingNLP(problem, fp.state, fp.parameters, free=tuple(problem.compliance_names))


def _jac_vs_fd(nlp, rng, n_dirs=3, eps=1e-6):
    w = nlp.w0 * (1 + 1e-4 * rng.standard_normal(nlp.w0.size))
    g = ca.Function("g", [nlp.w], [nlp.g])
    J = ca.Function("J", [nlp.w], [ca.jacobian(nlp.g, nlp.w)])(w)
    worst = 0.0
    for _ in range(n_dirs):
        v = rng.standard_normal(w.size)
        v /= np.linalg.norm(v)
        fd = (g(w + eps * v).full() - g(w - eps * v).full()).ravel() / (2 * eps)
        ad = (J @ v).full().ravel()
        worst = max(worst, np.linalg.norm(ad - fd) / np.linalg.norm(fd))
    return worst


def test_constraint_jacobian_matches_finite_differences(nlp6):
    """Directional derivatives of all 10k constraints at a random point near the guess."""
    assert _jac_vs_fd(nlp6, np.random.default_rng(1)) < 1e-5


def test_starting_gait_is_feasible(nlp6, problem):
    """At the simulator's fixed point, the NLP's own integrator closes the step to 1e-6
    (the step sizes differ slightly from the simulator's; margins of Table 3 hold)."""
    bad = [(n, v) for n, v in nlp6.violations(nlp6.w0) if v > 1e-6]
    assert not bad, bad[:5]
    # every segment ends on its event, in the simulator's order
    names = [nlp6.hs.event_list[s.phase][s.event].name for s in nlp6.specs]
    assert names == ["toe_off", "knee2_rate", "knee2_engage", "knee1_disengage", "knee1_rate",
                     "heel_strike", "foot_strike"]


def test_feasibility_solve_finds_the_compass_gait_fixed_point():
    """With no free parameters the NLP is a periodic-orbit solve: from a perturbed guess it
    lands on the published compass-gait fixed point (Newton on the simulator)."""
    pb = load_problem("compass_gait")
    ref = find_fixed_point(pb)
    nlp = ShootingNLP(pb, ref.state, pb.parameter_vector())
    w0 = nlp.w0.copy()
    w0[: ref.state.size] += 1e-3
    lo, hi = nlp.bounds()
    solver = ca.nlpsol("feas", "ipopt", {"x": nlp.w, "f": 0, "g": nlp.g},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-12,
                        "ipopt.hessian_approximation": "limited-memory"})
    sol = solver(x0=w0, lbx=lo, ubx=hi, lbg=nlp.lbg, ubg=nlp.ubg)
    assert solver.stats()["success"]
    xs = nlp.unpack(sol["x"].full())["xs"]
    assert np.abs(xs - ref.state).max() < 1e-7
    assert _jac_vs_fd(nlp, np.random.default_rng(2)) < 1e-6


def test_stability_bound_is_the_fixed_points_and_its_gradient_matches_perturbed_fixed_points(
        nlp6, problem):
    """The NLP's stability row is a function of the parameters alone: moving the NLP's
    section state off the orbit does not change it, it equals the smooth bound of the
    eigenvalues of the exact Jacobian at the fixed point, and its derivative in k_ankle
    matches fixed points solved independently at k_ankle +/- 1e-5 (relative)."""
    from pdw_casadi.fit import RADIUS_NORM, _RadiusBound
    from pdw_casadi.poincare import PoincareMap

    def bound(fp):
        m = np.abs(fp.eigenvalues)
        return float(np.sum(m ** RADIUS_NORM) ** (1 / RADIUS_NORM))

    rb = _RadiusBound(PoincareMap(problem), nlp6)
    fp = find_fixed_point(problem)
    z = np.r_[fp.state, np.ones(len(nlp6.free))]
    r_on = rb.rho(z)
    r_off = rb.rho(np.r_[fp.state + 1e-4, z[fp.state.size:]])
    assert abs(r_on - bound(fp)) < 1e-8
    assert abs(r_off - r_on) < 1e-8
    i = problem.parameter_names.index("k_ankle")
    d = 1e-5  # central-difference truncation at 1e-4 is 1.2e-3 (rho is that curved)
    ends = []
    for s in (1, -1):
        p = fp.parameters.copy()
        p[i] *= 1 + s * d
        ends.append(bound(find_fixed_point(problem, fp.state, p)))
    fd = (ends[0] - ends[1]) / (2 * d)  # per unit of the scaled parameter
    g = rb.gradient(z)[fp.state.size + nlp6.free.index("k_ankle")]
    assert abs(g - fd) < 1e-3 * abs(fd), (g, fd)
