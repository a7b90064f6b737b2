"""Rolling feet (pdw_casadi/model/walkers/humanlike_6link_arc.py): toe and heel arcs that roll
without slip where the 6-link walker pivots. With zero radii it is the ankle walker; with
the shipped radii the rolling contacts hold (the foot's material point at the contact is at
rest), the impacts are inelastic onto the rolling rows and the step stays passive."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import full_states, phase_runs

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.mechanics.rolling import RollingArc
from pdw_casadi.model.problem import load_problem

#: the rolling contacts of each phase and impact: (tag, sole point, foot angle index, toe?)
ROLLING = {"I": [("toe2", "toe2", 5, True)],
           "III": [("toe1", "toe1", 4, True), ("heel2", "heel2", 5, False)]}


@pytest.fixture(scope="module")
def arc():
    pb = load_problem("humanlike_6link_arc")
    assert pb.compliance["r_toe"] > 0 and pb.compliance["r_heel"] > 0
    return pb


@pytest.fixture(scope="module")
def arc_step(arc):
    """One recorded step of the shipped rolling-foot gait (simulator, result)."""
    sim = Simulator(arc)
    res = sim.run(arc.state_vector(), arc.parameter_vector(), steps=1, record=True)
    assert res.failure is None, res.failure
    assert [n for n, _ in res.steps[0].phases] == ["I", "II", "III"]
    return sim, res


def _arc_functions(hs, arc_pb):
    """tag -> CasADi function x -> (rolling rows, their rate E qd, velocity of the foot's
    material point over the ground contact), for every rolling contact."""
    model = hs.model
    q, qd, x = model.system.q, model.system.qd, hs.x_sym
    p = ca.DM(arc_pb.parameter_vector())
    names = list(model.parameter_names)
    gamma = p[-1]
    n = ca.vertcat(ca.sin(gamma), ca.cos(gamma))
    t = ca.vertcat(ca.cos(gamma), -ca.sin(gamma))
    out = {}
    for tag, point, iq, toe in {c for cs in ROLLING.values() for c in cs}:
        r = p[names.index("r_toe" if toe else "r_heel")]
        a = RollingArc(model.points[point], q[iq], r, n, t, gamma, np.pi / 3, toe)
        contact = a.centre - r * n
        # rigid foot: v_P = v_C + qf_dot x (P - C)
        rel = contact - a.centre
        v_mat = ca.jtimes(a.centre, q, qd) + qd[iq] * ca.vertcat(-rel[1], rel[0])
        rows = ca.substitute(a.rows, model.p, p)
        out[tag] = ca.Function(tag, [x], [hs.subs_x(e) for e in (
            rows, ca.jtimes(rows, q, qd), ca.substitute(v_mat, model.p, p))])
    return out


def test_zero_radii_step_is_the_ankle_walker():
    """r_toe = r_heel = 0 walks the ankle walker's step from its shipped gait: same phases,
    durations to 1e-12 s and end state to 1e-10 (measured 1.2e-11: the rolling rows have
    two Jacobian entries each where the point rows have one, so the constrained dynamics
    take the Schur-complement path instead of fixing x_t1, y_t1 directly; same equations,
    other rounding)."""
    ankle = load_problem("humanlike_6link_ankle")
    arc0 = load_problem("humanlike_6link_arc").replace(
        compliance={**ankle.compliance, "r_toe": 0.0, "r_heel": 0.0},
        slope=ankle.slope).with_state(ankle.state_vector())
    a, b = (Simulator(pb).run(pb.state_vector(), pb.parameter_vector(), steps=1,
                              record=False).steps[0] for pb in (arc0, ankle))
    assert [n for n, _ in a.phases] == [n for n, _ in b.phases] == ["I", "II", "III"]
    assert np.allclose([d for _, d in a.phases], [d for _, d in b.phases], atol=1e-12)
    assert np.allclose(a.x_section_end, b.x_section_end, rtol=0, atol=1e-10)
    assert a.impact_loss_J == pytest.approx(b.impact_loss_J, rel=1e-9)


def test_energy_balance_closes_with_rolling_feet(arc_step):
    """The step's energy books close at the shipped radii: start - end energy = damper work
    + impact and spring losses, to the simulator's RK4 level (1e-6 J). Any ideal contact
    does no work, so this checks the integration and the loss accounting; that the arcs
    roll rather than slip is checked below (the material contact point at rest)."""
    _, res = arc_step
    st = res.steps[0]
    assert abs(st.energy_residual_J) < 1e-6
    assert st.impact_loss_J > 0


def test_rolling_contacts_hold_along_the_phases(arc, arc_step):
    """In phases I and III the rolling rows stay at their phase-start values and their rate
    at zero (integration accuracy, 1e-8), and the foot's material point over the contact is
    at rest (1e-8 m/s): the arc rolls, it does not slip. The contact moves into the arc
    (its angle grows in I and in III for the toe, falls for the heel arc towards flat)."""
    sim, res = arc_step
    hs = sim.hs
    funs = _arc_functions(hs, arc)
    x0 = hs.model.section_to_full(res.steps[0].x_section_start, arc.parameter_vector())
    start = x0.full().ravel()
    p = arc.parameter_vector()
    for name, frame in phase_runs(res.trajectory):
        if name == "III":
            start = hs.impact["heel_strike"](start, p)[3].full().ravel()
        X = full_states(hs, frame)
        for tag, *_ in ROLLING.get(name, []):
            rows0 = funs[tag](start)[0].full().ravel()
            for j in range(X.shape[1]):
                rows, rate, v = (e.full().ravel() for e in funs[tag](X[:, j]))
                assert np.max(np.abs(rows - rows0)) < 1e-8, (name, tag, j)
                assert np.max(np.abs(rate)) < 1e-8, (name, tag, j)
                assert np.max(np.abs(v)) < 1e-8, (name, tag, j)
            ang = frame[f"arc_{tag}_deg"].to_numpy()
            assert (np.diff(ang) < 0).all() if tag == "heel2" else (np.diff(ang) > 0).all()
        start = X[:, -1]


def test_impacts_land_on_the_rolling_rows_and_lose_energy(arc, arc_step):
    """Heel strike and foot strike: the post-impact velocities satisfy every rolling row of
    the impact (1e-12), the normal impulses push (> 0) and kinetic energy is lost."""
    sim, res = arc_step
    hs = sim.hs
    funs = _arc_functions(hs, arc)
    p = arc.parameter_vector()
    runs = dict(phase_runs(res.trajectory))
    mv = hs.mode_vector(hs.model.initial_mode)
    for tr, rolling in (("heel_strike", ("toe1", "heel2")), ("foot_strike", ("toe1",))):
        source = "II" if tr == "heel_strike" else "III"
        x_minus = full_states(hs, runs[source].iloc[[-1]])[:, 0]
        imp = hs.impact_at(tr, x_minus, p)
        for tag in rolling:
            assert np.max(np.abs(funs[tag](imp.x_post)[1].full())) < 1e-12, (tr, tag)
            assert np.max(np.abs(funs[tag](imp.x_post)[2].full())) < 1e-12, (tr, tag)
        assert all(v > 0 for k, v in zip(hs.check_names[tr], imp.checks, strict=True)
                   if k.startswith("impulse_toe") or k.startswith("impulse_heel")), tr
        lost = hs.energy_at(x_minus, p, mv).kinetic - hs.energy_at(imp.x_post, p, mv).kinetic
        assert lost > 0, tr


@pytest.mark.slow
def test_zero_radii_fixed_point_is_the_ankle_walkers():
    """The fixed point and the eigenvalues of the step map's Jacobian at r = 0 equal the
    ankle walker's: state to 1e-10, eigenvalues to 1e-9 (measured 1e-12 and 4e-11; the
    Jacobians differ by 2e-9 entrywise: the same maps, other rounding, see above)."""
    ankle = load_problem("humanlike_6link_ankle")
    arc0 = load_problem("humanlike_6link_arc").replace(
        compliance={**ankle.compliance, "r_toe": 0.0, "r_heel": 0.0},
        slope=ankle.slope).with_state(ankle.state_vector())
    a, b = find_fixed_point(arc0, tol=1e-12), find_fixed_point(ankle, tol=1e-12)
    assert a.converged and b.converged
    assert np.allclose(a.state, b.state, rtol=0, atol=1e-10)
    ea, eb = (np.sort_complex(np.asarray(r.eigenvalues)) for r in (a, b))
    assert np.allclose(ea, eb, rtol=0, atol=1e-9)
