"""Continuation sweeps: the compass gait's period doubling against an independent root-find,
branch points against independent fixed-point solves, a sweep that runs into an invalid
region, and the bifurcation test functions on matrices with known eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from pdw_casadi.gait.bifurcation import (
    is_neimark_sacker,
    phi_fold,
    phi_neimark_sacker,
    phi_period_doubling,
)
from pdw_casadi.gait.continuation import parameter_index, tangent, with_value
from pdw_casadi.gait.fixed_point import find_fixed_point, stability, validity_slacks
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.sweep import sweep
from pdw_casadi.model.problem import ProblemError, load_problem

DEG = np.pi / 180


@pytest.fixture(scope="module")
def compass():
    return load_problem("compass_gait")


@pytest.fixture(scope="module")
def compass_sweep(compass):
    """Continuation from the bundled 3 deg gait up to 6 deg (13 values, 0.25 deg apart)."""
    return sweep(compass, np.linspace(3, 6, 13) * DEG)


def _fd_monodromy(sim: Simulator, x, p, eps=1e-6) -> np.ndarray:
    """dP/dx by central differences of the event-driven simulator (no AD involved)."""
    n = x.size
    J = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        xp = sim.run(x + e, p, steps=1, record=False).steps[0].x_section_end
        xm = sim.run(x - e, p, steps=1, record=False).steps[0].x_section_end
        J[:, j] = (xp - xm) / (2 * eps)
    return J


def test_compass_first_period_doubling_matches_independent_root_find(compass, compass_sweep):
    events = compass_sweep.events
    pd_events = [e for e in events if e.kind == "period_doubling"]
    assert len(pd_events) == 1 and events[0] is pd_events[0]  # the first event on the way up
    pd_ev = pd_events[0]
    assert pd_ev.crossing == "outward" and pd_ev.refined
    # independent estimate: the slope where the most negative real eigenvalue of a
    # finite-difference monodromy matrix is -1 (no AD Jacobian, no continuation module).
    # Plain Newton solves walk from 3 deg to the bracket in 0.25 deg steps (a solve from the
    # 3 deg state alone does not reach 4.3 deg), then every trial slope starts from there.
    sim = Simulator(compass)
    p0 = compass.parameter_vector()
    lo, hi = pd_ev.bracket
    x = compass.state_vector()
    for gamma in np.arange(3.25 * DEG, lo + 1e-12, 0.25 * DEG):
        fp = find_fixed_point(compass, x, np.append(p0[:-1], gamma), tol=1e-12)
        assert fp.converged
        x = fp.state

    def most_negative_plus_one(gamma):
        fp = find_fixed_point(compass, x, np.append(p0[:-1], gamma), tol=1e-12)
        assert fp.converged
        mu = stability(_fd_monodromy(sim, fp.state, fp.parameters)).eigenvalues
        return float(np.min(mu[np.abs(mu.imag) < 1e-9].real)) + 1.0

    gamma_pd = brentq(most_negative_plus_one, lo, hi, xtol=1e-12)
    assert abs(pd_ev.value - gamma_pd) < 1e-7  # rad
    # the event sits between the last stable and the first unstable grid point
    table = compass_sweep.table.sort_values("slope")
    stable = table[table["stable"]]["slope"]
    assert stable.max() < pd_ev.value < table[~table["stable"]]["slope"].min()
    # at the located slope the eigenvalue is -1 to the precision of the location
    assert pd_ev.eigenvalues.real.min() == pytest.approx(-1.0, abs=1e-6)
    assert 4.0 < pd_ev.value / DEG < 5.0


def test_branch_points_agree_with_independent_solves(compass, compass_sweep):
    table = compass_sweep.table
    assert table["converged"].all() and table["valid"].all()
    assert len(table) == 13 and table["on_grid"].all()
    names = compass.state_names
    p0 = compass.parameter_vector()
    x = compass.state_vector()
    for _, row in table.sort_values("slope").iterrows():
        # plain Newton from the previous solve (0.25 deg away): no predictor, no sweep code
        fp = find_fixed_point(compass, x, np.append(p0[:-1], row["slope"]), tol=1e-12)
        assert fp.converged
        x = fp.state
        np.testing.assert_allclose(row[names].to_numpy(float), fp.state, rtol=0, atol=1e-8)
        assert row["spectral_radius"] == pytest.approx(fp.spectral_radius, abs=1e-7)
        assert row["step_time_s"] == pytest.approx(fp.step_time_s, abs=1e-8)
    # a steeper slope walks faster and takes longer steps (compass gait, Goswami et al.)
    t = table.sort_values("slope")
    assert np.all(np.diff(t["speed_m_s"]) > 0) and np.all(np.diff(t["step_length_m"]) > 0)


def test_tangent_predictor_is_the_slope_derivative(compass):
    """dx*/dgamma from the implicit function theorem vs a central difference of solves."""
    P = PoincareMap(compass)
    p = compass.parameter_vector()
    k = parameter_index(compass, "slope")
    fp = find_fixed_point(compass, pmap=P, tol=1e-13)
    h = 1e-5
    sols = []
    for s in (-1, 1):
        q = p.copy()
        q[k] += s * h
        sols.append(find_fixed_point(compass, fp.state, q, pmap=P, tol=1e-13).state)
    np.testing.assert_allclose(tangent(fp, k), (sols[1] - sols[0]) / (2 * h), rtol=1e-5,
                               atol=1e-6)


def test_sweep_into_invalid_region_stops_and_keeps_rows(compass):
    """Demand 120 N of stance-foot normal force: the force falls with the slope (about
    123.5 N at 4 deg, 117.8 N at 4.5 deg), so the gait pattern ends near 4.3 deg."""
    pb = compass.replace(validity={**compass.validity, "min_normal_force": 120.0})
    rows = []
    res = sweep(pb, np.linspace(3, 6, 13) * DEG, on_row=rows.append)
    table = res.table
    assert len(rows) == len(table)  # every row was handed out as it was found
    assert table["valid"].iloc[:-1].all() and not table["valid"].iloc[-1]
    assert table["slope"].max() < 4.75 * DEG  # stopped at the first invalid point
    assert list(table["slope"]) == sorted(table["slope"])
    bnd = [e for e in res.events if e.kind == "boundary"]
    assert len(bnd) == 1 and "swing:min_N_foot1" in bnd[0].reason
    lo, hi = bnd[0].bracket
    assert table["slope"].iloc[-2] == pytest.approx(lo) and table["slope"].iloc[-1] == hi
    # at the reported slope the margin sits on its requirement
    p = pb.parameter_vector()
    p[-1] = bnd[0].value
    x_last_valid = table[pb.state_names].iloc[-2].to_numpy(float)
    fp = find_fixed_point(pb, x_last_valid, p, tol=1e-12)
    assert fp.converged
    assert validity_slacks(fp.margins, pb)["swing:min_N_foot1"] == pytest.approx(0, abs=1e-4)
    assert res.stable_ranges()[0]["to_event"] == "boundary"


def test_sweep_over_a_compliance_value_and_bad_parameter():
    pb = load_problem("humanlike_6link")
    with pytest.raises(ProblemError, match="no parameter 'k_hip'"):
        sweep(pb, [1.0, 2.0], parameter="k_hip")
    assert parameter_index(pb, "k_knee") == pb.compliance_names.index("k_knee")
    assert parameter_index(pb, "slope") == len(pb.compliance)


def test_humanlike_compliance_continuation_to_its_boundary():
    """Continuation over the knee stiffness k_knee (N m/rad) of the 6-link walker, from
    Table 3's 116.2 down towards 116.0: the branch ends where the orbit fails (the centre of
    pressure reaches the toe in phase I), bracketed to spacing / 4096, and every point
    agrees with a plain Newton solve at its stiffness started from the Table-2 fixed point."""
    pb = load_problem("humanlike_6link")
    res = sweep(pb, np.linspace(116.0, 116.2, 3), parameter="k_knee")
    table = res.table
    assert table["k_knee"].iloc[0] == 116.2 and table["converged"].all()
    assert np.all(np.diff(table["k_knee"]) < 0)  # one branch, downwards, stopped early
    (bnd,) = [e for e in res.events if e.kind == "boundary"]
    assert "cop1_at_toe" in bnd.reason
    lo, hi = sorted(bnd.bracket)
    assert hi - lo <= 0.1 / 4096 * (1 + 1e-9) and lo < bnd.value < hi
    assert table["k_knee"].min() == pytest.approx(hi)
    x0 = table[pb.state_names].iloc[0].to_numpy(float)
    k = parameter_index(pb, "k_knee")
    P = PoincareMap(pb)
    for _, row in table.iloc[1:].iterrows():
        fp = find_fixed_point(pb, x0, with_value(pb.parameter_vector(), k, row["k_knee"]),
                              pmap=P)
        assert fp.converged
        np.testing.assert_allclose(row[pb.state_names].to_numpy(float), fp.state, rtol=0,
                                   atol=1e-8)


# -- test functions on matrices with known eigenvalues -------------------------------------
def _rot(r, theta):
    return r * np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


def _pair(r, third=0.3):
    A = np.zeros((3, 3))
    A[:2, :2], A[2, 2] = _rot(r, 0.4), third
    return np.linalg.eigvals(A)


def test_test_functions_change_sign_only_at_their_crossing():
    mu = np.linalg.eigvals
    cases = {  # kind -> eigenvalues just inside and just outside the unit circle
        "period_doubling": (mu(np.diag([0.5, -0.9])), mu(np.diag([0.5, -1.1]))),
        "fold": (mu(np.diag([0.9, 0.2])), mu(np.diag([1.1, 0.2]))),
        "neimark_sacker": (_pair(0.9), _pair(1.1)),
    }
    phis = {"period_doubling": phi_period_doubling, "fold": phi_fold,
            "neimark_sacker": phi_neimark_sacker}
    for kind, (inside, outside) in cases.items():
        for name, phi in phis.items():
            changed = np.sign(phi(inside)) != np.sign(phi(outside))
            assert changed == (name == kind), (kind, name)
    # at |mu| = 1 the pair is a Neimark-Sacker point; two reals with product 1 are not
    unit = _pair(1.0)
    assert abs(phi_neimark_sacker(unit)) < 1e-12 and is_neimark_sacker(unit)
    saddle = mu(np.diag([2.0, 0.5, 0.3]))
    assert abs(phi_neimark_sacker(saddle)) < 1e-12 and not is_neimark_sacker(saddle)


def test_sweep_of_one_legs_value_runs_on_the_stride_map():
    """A walker whose right ankle is stiffer: its gait is a fixed point of the stride map,
    swept over ``right.k_ankle`` down to the left leg's value, where the stride is two equal
    steps: the stride's spectral radius is the square of the step map's and its period twice
    the step time; every row is a stride fixed point and its margins carry the stance leg."""
    from pdw_casadi.gait.stride import stride_map

    pb = load_problem("humanlike_6link")
    step = find_fixed_point(pb, tol=1e-11)
    k = pb.compliance["k_ankle"]
    stiff = pb.replace(legs={"right": {"compliance": {"k_ankle": k + 0.05}}}).with_state(
        step.state)
    assert parameter_index(stiff, "right.k_ankle") != parameter_index(stiff, "left.k_ankle")
    with pytest.raises(ProblemError, match="no parameter"):
        parameter_index(stiff, "k_ankle")  # both legs' keys are named by their leg
    res = sweep(stiff, [k + 0.05, k], parameter="right.k_ankle")
    tab = res.table
    assert tab["converged"].all() and tab["valid"].all()
    assert (tab["residual"] < 1e-10).all()
    assert any(c.startswith("margin:right.") for c in tab.columns)
    equal = tab.loc[np.isclose(tab["right.k_ankle"], k)].iloc[0]
    assert abs(equal["spectral_radius"] - step.spectral_radius ** 2) < 1e-8
    assert abs(equal["step_time_s"] - 2 * step.step_time_s) < 1e-9
    stiffer = tab.loc[np.isclose(tab["right.k_ankle"], k + 0.05)].iloc[0]
    smap = stride_map(stiff)
    x = np.array([stiffer[n] for n in smap.state_names])
    r = smap.evaluate(x, jacobian=False)
    assert np.abs(r.x_next - x).max() < 1e-10
