"""The multiple-shooting NLP: its constraint Jacobian is exact (finite differences), the
starting gait is feasible to the integrator's accuracy, and a pure feasibility solve finds
the simulator's fixed point."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.shooting import ShootingNLP


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


class _Periodic:
    """Newton on the NLP's equality rows (square once the free parameters are held): the
    NLP's own periodic orbit, solved independently at any parameter value."""

    def __init__(self, nlp):
        eq = np.flatnonzero(nlp.lbg == nlp.ubg).tolist()
        self.g = ca.Function("g", [nlp.w], [nlp.g[eq]])
        self.J = ca.Function("J", [nlp.w], [ca.jacobian(nlp.g[eq], nlp.w)])
        ns, nf = nlp.xs.shape[0], len(nlp.free)
        self.ns = ns
        self.cols = np.r_[np.arange(ns), np.arange(ns + nf, nlp.w.shape[0])]

    def jacobian(self, w):
        from scipy.sparse import csc_matrix

        Jd = self.J(w)
        r, c = Jd.sparsity().get_triplet()
        return csc_matrix((np.asarray(Jd.nonzeros()), (r, c)), shape=Jd.shape)

    def solve(self, w, iters: int = 12):
        from scipy.sparse.linalg import spsolve

        w = w.copy()
        for _ in range(iters):
            res = self.g(w).full().ravel()
            step = spsolve(self.jacobian(w)[:, self.cols], res)
            w[self.cols] -= step
            if np.abs(step).max() < 1e-13:  # converged to round-off
                break
        assert np.abs(self.g(w).full()).max() < 1e-10
        return w


def test_stability_row_derivative_matches_independently_solved_fixed_points(problem):
    """The stability row's exact total derivative in k_ankle along the NLP's periodic orbits
    (its gradient, chained through the implicit function of the equality rows) matches
    central differences (Richardson) of orbits solved independently by Newton at
    k_ankle (1 +/- d), to 1e-5 relative; at the orbit the row equals the smooth bound of the
    simulator's exact eigenvalues to 1e-7."""
    from pdw_casadi.fit import RADIUS_NORM, StabilityRow

    fp = find_fixed_point(problem)
    nlp = ShootingNLP(problem, fp.state, fp.parameters, free=("k_ankle",))
    from scipy.sparse.linalg import spsolve

    row = StabilityRow(nlp)
    orbit = _Periodic(nlp)
    w = orbit.solve(nlp.w0)
    ns, cols = orbit.ns, orbit.cols
    sim_bound = float(np.sum(np.abs(fp.eigenvalues) ** RADIUS_NORM) ** (1 / RADIUS_NORM))
    assert abs(row.value(w) - sim_bound) < 1e-7
    # exact total derivative d rho / d pf
    grad = row.gradient(w)
    A = orbit.jacobian(w)
    dw = -spsolve(A[:, cols], A[:, [ns]].toarray().ravel())
    exact = grad[ns] + grad[cols] @ dw

    def rho_at(delta):
        w1 = w.copy()
        w1[ns] += delta
        w1[cols] += delta * dw  # predictor; Newton then solves the orbit afresh
        return row.value(orbit.solve(w1))

    def central(d):
        return (rho_at(d) - rho_at(-d)) / (2 * d)

    d = 1e-5
    fd = (4 * central(d) - central(2 * d)) / 3
    assert abs(exact - fd) < 1e-5 * abs(fd), (exact, fd)


def test_stability_row_gradient_is_exact_off_the_orbit(nlp6):
    """At an infeasible point near the orbit, the row's reverse-mode gradient matches
    central differences of the row itself in random directions (1e-6 relative)."""
    from pdw_casadi.fit import StabilityRow

    row = StabilityRow(nlp6)
    rng = np.random.default_rng(3)
    w = nlp6.w0 * (1 + 1e-5 * rng.standard_normal(nlp6.w0.size))
    g = row.gradient(w)
    for _ in range(3):
        v = rng.standard_normal(w.size)
        v /= np.linalg.norm(v)
        eps = 1e-6
        fd = (row.value(w + eps * v) - row.value(w - eps * v)) / (2 * eps)
        assert abs(g @ v - fd) < 1e-6 * max(abs(fd), 1.0), (g @ v, fd)


def _layout(spec):
    """A segment's prescribed layout: what a caller gives, none of what the NLP derives."""
    from pdw_casadi.nlp.shooting import SegmentSpec

    return SegmentSpec(spec.phase, spec.mode, spec.event, spec.transition, spec.n_int,
                       spec.n_sub, spec.duration0, step=spec.step)


def test_a_prescribed_gait_pattern_with_the_simulations_nodes_is_the_same_nlp(nlp6):
    """The NLP of a prescribed gait pattern (segments and nodes given, no simulation) is the
    simulated gait's NLP when given its layout and its nodes: the same unknowns at the
    start, the same rows and bounds, the same event signs derived from the guess, and the
    same rows' values there (the starting gait closes to 1e-6 either way)."""
    X = [np.asarray(ca.Function("X", [nlp6.w], [Xk])(nlp6.w0)) for Xk in nlp6.X]
    xs = nlp6.unpack(nlp6.w0)["xs"]
    pre = ShootingNLP(nlp6.problem, xs, nlp6.p0, free=tuple(nlp6.free),
                      segments=[_layout(s) for s in nlp6.specs], nodes=X)
    np.testing.assert_array_equal(pre.w0, nlp6.w0)
    np.testing.assert_array_equal(pre.lbg, nlp6.lbg)
    np.testing.assert_array_equal(pre.ubg, nlp6.ubg)
    assert pre.g_names == nlp6.g_names
    for a, b in zip(pre.specs, nlp6.specs, strict=True):
        assert (a.signs, a.gaps, a.start, a.first_signs, a.ahead, a.cross_sign) == \
            (b.signs, b.gaps, b.start, b.first_signs, b.ahead, b.cross_sign)
    g = ca.Function("g", [pre.w], [pre.g])(pre.w0).full().ravel()
    g_ref = ca.Function("g", [nlp6.w], [nlp6.g])(nlp6.w0).full().ravel()
    np.testing.assert_allclose(g, g_ref, rtol=0, atol=1e-12)
    assert max(v for _, v in pre.violations(pre.w0)) <= 1e-6


def test_a_prescribed_gait_pattern_is_checked_against_the_walker(nlp6):
    """A prescribed layout that the walker cannot take is refused with its reason: an
    unknown phase, a guard without its transition, nodes of the wrong shape, segments
    without nodes."""
    import dataclasses

    X = [np.asarray(ca.Function("X", [nlp6.w], [Xk])(nlp6.w0)) for Xk in nlp6.X]
    xs = nlp6.unpack(nlp6.w0)["xs"]
    layout = [_layout(s) for s in nlp6.specs]

    def build(segments, nodes):
        return ShootingNLP(nlp6.problem, xs, nlp6.p0, segments=segments, nodes=nodes)

    bad = [dataclasses.replace(layout[0], phase="IV"), *layout[1:]]
    with pytest.raises(ValueError, match="no phase 'IV'"):
        build(bad, X)
    bad = [dataclasses.replace(layout[0], transition=None), *layout[1:]]
    with pytest.raises(ValueError, match="ends in a transition"):
        build(bad, X)
    with pytest.raises(ValueError, match="nodes of shape"):
        build(layout, [X[0][:, :-1], *X[1:]])
    with pytest.raises(ValueError, match="both its segments and its nodes"):
        build(layout, None)
    # phases out of the walker's order, and a step that does not end
    with pytest.raises(ValueError, match="cannot follow"):
        build([layout[0], *layout[2:], layout[1]], [X[0], *X[2:], X[1]])
    with pytest.raises(ValueError, match="must end the step"):
        build(layout[:-1], X[:-1])
