"""Physical and numerical facts of the simulated humanlike walker (paper sections II.B-II.C).

Every test asserts a law (energy conservation, constraint invariance, the angular-momentum
statements of the impacts, the energy balance of a step) or an agreement with the paper's
Table 2 / Table 3 gait and with the independent numpy implementation.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from conftest import full_states, phase_runs
from hypothesis import given, settings
from hypothesis import strategies as st

from pdw_casadi.gait.simulate import Plan, Simulator

SWAP = [3, 2, 1, 0, 5, 4]
NO_DAMPING = {"c_ankle": 0.0, "c_knee_flex": 0.0, "c_knee_ext": 0.0, "c_knee_stance": 0.0}
BOTH_ENGAGED = {"eng1": 1.0, "eng2": 1.0, "flex1": 0.0, "flex2": 0.0, "armed2": 0.0}


def _point(hs, x, p, name) -> np.ndarray:
    P = hs.points(x, p).full()
    return P[:, hs.point_names.index(name)]


def _normal(p) -> np.ndarray:
    gamma = float(p[-1])
    return np.array([math.sin(gamma), math.cos(gamma)])


def _total_energy(hs, X, p, mv) -> np.ndarray:
    """KE + PE + spring energy (J) of the columns of X."""
    return np.array([float(np.sum(hs.energy(X[:, j], p, mv).full()))
                     for j in range(X.shape[1])])


# -- (a) energy conservation without dampers ------------------------------------------------
def test_energy_conserved_within_each_phase_without_dampers(problem, hs, impact_states):
    """No dampers, both knee springs engaged and never disengaged (theta_dis = -1 rad):
    the walker is conservative inside every phase, so KE + PE + spring energy is constant
    (here to 1e-8 relative). With the knee springs locked straight-ish the swing toe scuffs
    in phase II, so phase III is checked separately from the Table-2 heel-strike state."""
    pb = problem.replace(compliance={**NO_DAMPING, "theta_dis": -1.0})
    p = pb.parameter_vector()
    sim = Simulator(pb, hs)
    res = sim.run(pb.state_vector(), p, steps=1, record=True, mode=dict(BOTH_ENGAGED))
    runs = phase_runs(res.trajectory)
    assert [name for name, _ in runs][:2] == ["I", "II"]
    for name, frame in runs:
        e = (frame["kinetic_J"] + frame["potential_J"] + frame["spring_J"]).to_numpy()
        assert len(e) > 50, name
        assert np.ptp(e) <= 1e-8 * abs(e[0]), (name, np.ptp(e))
        assert np.max(np.abs(frame["damping_work_J"].to_numpy())) == 0.0
        assert not res.events["event"].isin(["knee1_disengage"]).any()

    # phase III from the (Table 2) heel-strike state, dampers off, both springs engaged
    x_post = hs.impact["heel_strike"](impact_states["heel_strike"], p)[3].full().ravel()
    rec: list = []
    end = sim.run_phase("III", x_post, p, dict(BOTH_ENGAGED), 0.0, rec, Plan())
    assert end.failure is None and end.event.name == "foot_strike" and end.duration_s > 0.005
    X = np.hstack([x_post[:, None]] + [chunk.states for chunk in rec])
    mv = [float(BOTH_ENGAGED[k]) for k in hs.mode_keys]
    e = _total_energy(hs, X, p, mv)
    assert np.ptp(e) <= 1e-8 * abs(e[0])


# -- (b) constraints hold along the step ---------------------------------------------------
def test_contact_constraints_hold_in_every_phase(hs, table2_step, params, contact_funs):
    """Each phase's contact rows stay at their phase-start values and E(q) qd stays 0
    (< 1e-8) over the Table-2 step: eq. (12) enforces the constraints at acceleration
    level, so any drift would be integration error."""
    p = params
    x0 = hs.model.section_to_full(table2_step.steps[0].x_section_start, p).full().ravel()
    runs = phase_runs(table2_step.trajectory)
    assert [n for n, _ in runs] == ["I", "II", "III"]
    start = x0
    for name, frame in runs:
        if name == "III":  # starts just after the heel-strike impact
            start = hs.impact["heel_strike"](start, p)[3].full().ravel()
        rows0, vel0 = (v.full().ravel() for v in contact_funs[name](start, p))
        assert np.max(np.abs(vel0)) < 1e-10, name
        X = full_states(hs, frame)
        for j in range(X.shape[1]):
            rows, vel = (v.full().ravel() for v in contact_funs[name](X[:, j], p))
            assert np.max(np.abs(rows - rows0)) < 1e-8, (name, j, rows - rows0)
            assert np.max(np.abs(vel)) < 1e-8, (name, j, vel)
        start = X[:, -1]


def test_stance_contacts_are_on_the_ground_at_the_section(hs, table2_step, params):
    """At the section: stance toe at the origin, stance heel and trailing toe at height 0."""
    x0 = hs.model.section_to_full(table2_step.steps[0].x_section_start, params).full().ravel()
    n = _normal(params)
    assert np.allclose(_point(hs, x0, params, "toe1"), 0.0, atol=1e-14)
    for name in ("heel1", "toe2"):
        assert abs(_point(hs, x0, params, name) @ n) < 1e-12, name


# -- (c) impacts: the paper's angular-momentum statements -----------------------------------
ALL = ("shank1", "thigh1", "thigh2", "shank2", "hip", "foot1", "foot2")
# eq. (15), heel strike: leg 2 leads (its heel strikes), leg 1 trails (toe pivot)
HEEL_STRIKE = [
    ("heel2", ALL),                                           # whole walker
    ("ankle2", tuple(b for b in ALL if b != "foot2")),       # all but the leading foot
    ("knee2", tuple(b for b in ALL if b not in ("foot2", "shank2"))),
    ("hip", ("shank1", "thigh1", "foot1")),                  # trailing leg
    ("knee1", ("foot1", "shank1")),
    ("ankle1", ("foot1",)),
]
# eq. (17), foot strike: leg 2's foot lands flat, leg 1 trails on its toe
FOOT_STRIKE = [
    ("toe1", ALL),
    ("ankle1", tuple(b for b in ALL if b != "foot1")),
    ("knee1", tuple(b for b in ALL if b not in ("foot1", "shank1"))),
    ("hip", ("shank2", "thigh2", "foot2")),                  # leading leg
    ("knee2", ("foot2", "shank2")),
    ("ankle2", ("foot2",)),
]


def _momentum_fun(hs, statements) -> ca.Function:
    sysm, pts = hs.model.system, hs.model.points
    L = ca.vertcat(*[sysm.angular_momentum(names, pts[about]) for about, names in statements])
    return ca.Function("L", [sysm.q, sysm.qd, hs.model.p], [L])


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _velocity_fun(hs, name) -> ca.Function:
    sysm = hs.model.system
    return ca.Function("v", [sysm.q, sysm.qd, hs.model.p],
                       [sysm.velocity(hs.model.points[name])])


def test_heel_strike_satisfies_eq15(hs, impact_states, params, contact_funs):
    """L+ = L- + (P_Ft1 - P) x I about the leading heel, ankle, knee, the hip, the trailing
    knee and ankle (I: impulse at the trailing toe); hip velocity the same seen from the
    trailing toe and the leading heel; and E_III qd+ = 0."""
    p, x = params, impact_states["heel_strike"]
    _, impulse, checks, x_post = (v.full().ravel() for v in hs.impact["heel_strike"](x, p))
    q, qd_m, qd_p = x[:8], x[8:16], x_post[8:16]
    assert np.array_equal(x_post[:8], q)  # positions do not change in an impact
    I_toe = impulse[0:2]
    L = _momentum_fun(hs, HEEL_STRIKE)
    dL = (L(q, qd_p, p) - L(q, qd_m, p)).full().ravel()
    toe1 = _point(hs, x, p, "toe1")
    for k, (about, _) in enumerate(HEEL_STRIKE):
        moment = _cross(toe1 - _point(hs, x, p, about), I_toe)
        assert abs(dL[k] - moment) < 1e-10, (about, dL[k], moment)
    assert np.max(np.abs(dL)) > 1e-3  # the toe impulse really contributes (not vacuous)
    v_toe1 = _velocity_fun(hs, "toe1")(q, qd_p, p).full().ravel()
    v_heel2 = _velocity_fun(hs, "heel2")(q, qd_p, p).full().ravel()
    v_hip = _velocity_fun(hs, "hip")(q, qd_p, p).full().ravel()
    assert np.allclose(v_hip - v_toe1, v_hip - v_heel2, atol=1e-10, rtol=0)
    assert np.max(np.abs(contact_funs["III"](x_post, p)[1].full())) < 1e-10
    # the gait pattern's assumptions: pushing toe impulse, trailing heel rises
    assert _normal(p) @ I_toe > 0
    assert all(c > 0 for c in checks)


def test_foot_strike_satisfies_eq17(hs, impact_states, params, contact_funs):
    """L+ = L- + (P_A2 + R - P) x I about the trailing toe, ankle, knee, the hip, the
    leading knee and ankle, with I the impulse under the landing foot and R from its ankle
    to the impulse's point of application; dqf2+ = 0; both toes at rest after the impact;
    the next phase's (I, after the leg swap) velocity constraints hold."""
    p, x = params, impact_states["foot_strike"]
    x_plus, impulse, checks, x_post = (v.full().ravel() for v in hs.impact["foot_strike"](x, p))
    q, qd_m, qd_p = x[:8], x[8:16], x_post[8:16]
    qf2 = q[5]
    toe2, heel2, ankle2 = (_point(hs, x, p, n) for n in ("toe2", "heel2", "ankle2"))
    l_f = float(np.linalg.norm(toe2 - heel2))
    # impulse on the landing foot: force at toe2 plus the couple of the row l_f cos(qf2)
    I_foot = impulse[2:4]
    couple = -l_f * math.sin(qf2) * impulse[4]
    d = np.array([math.sin(qf2), -math.cos(qf2)])
    s = -couple / _cross(d, I_foot)  # point of application s behind the toe, on the sole
    assert 0.0 < s < l_f
    R = toe2 - s * d - ankle2
    L = _momentum_fun(hs, FOOT_STRIKE)
    dL = (L(q, qd_p, p) - L(q, qd_m, p)).full().ravel()
    for k, (about, _) in enumerate(FOOT_STRIKE):
        moment = _cross(ankle2 + R - _point(hs, x, p, about), I_foot)
        assert abs(dL[k] - moment) < 1e-10, (about, dL[k], moment)
    assert abs(qd_p[5]) < 1e-10  # dq_f2+ = 0
    v_toe1 = _velocity_fun(hs, "toe1")(q, qd_p, p).full().ravel()
    v_ankle2 = _velocity_fun(hs, "ankle2")(q, qd_p, p).full().ravel()
    assert np.allclose(v_toe1, 0.0, atol=1e-10) and np.allclose(v_ankle2, 0.0, atol=1e-10)
    assert np.max(np.abs(contact_funs["I"](x_plus, p)[1].full())) < 1e-10
    assert _normal(p) @ I_foot > 0
    assert all(c > 0 for c in checks)


# -- (d) energy balance of a step ------------------------------------------------------------
def test_step_energy_balance(problem, hs, table2_step, params, numpy_walker, impact_states):
    """E_start - E_end = damping work + impact losses + spring energy lost at the stance
    knee's disengagement, to < 1e-6 J: as booked by the simulator (StepRecord), and again
    with the numpy implementation's energy and impact formulas."""
    sr = table2_step.steps[0]
    assert abs(sr.energy_residual_J) < 1e-6
    assert sr.dissipated_damping_J > 0 and sr.impact_loss_J > 0 and sr.spring_loss_J > 0

    nw = numpy_walker
    mdl = nw.Model(nw.load_params(problem.source))
    q0, qd0 = nw.section_to_full(sr.x_section_start, mdl.p, mdl)
    e_start = mdl.energy(q0, qd0, knees=("spring", "ext"))  # stance knee engaged only
    impact_loss = 0.0
    for name, x in impact_states.items():
        q, qd = x[:8], x[8:16]
        qd_plus, _ = mdl.impact(q, qd, nw.IMPACT_ROWS[name])
        M = mdl.mass_matrix(np.sin(q[:6]), np.cos(q[:6]))
        impact_loss += 0.5 * qd @ M @ qd - 0.5 * qd_plus @ M @ qd_plus
        if name == "foot_strike":
            q_end, qd_end = q, qd_plus
    events = set(table2_step.events["event"])
    assert {"knee1_disengage", "knee2_engage"} <= events
    c = problem.compliance
    spring_loss = 0.5 * c["k_knee"] * (c["theta_dis"] - c["theta_eq"]) ** 2
    e_end = mdl.energy(q_end, qd_end, knees=("ext", "spring"))  # swing knee now engaged
    damping = table2_step.trajectory["damping_work_J"].iloc[-1]
    balance = (e_start - e_end) - (damping + impact_loss + spring_loss)
    assert abs(balance) < 1e-6, balance
    assert abs(impact_loss - sr.impact_loss_J) < 1e-9
    assert abs(spring_loss - sr.spring_loss_J) < 1e-9


# -- (e) the paper's gait ---------------------------------------------------------------------
def test_table2_step_walks_and_matches_numpy(problem, table2_step, numpy_walker):
    """Table 2 + Table 3 at slope 0.1484: one step I -> II -> III with guards toe_off,
    heel_strike, foot_strike in this order, landing within 0.05 of where it started
    (numpy reference: 0.01653), and the end state agrees with tests/numpy_walker.py."""
    res = table2_step
    assert res.failure is None and res.completed_steps == 1
    assert abs(problem.slope - 0.1484) < 1e-12
    assert [name for name, _ in res.steps[0].phases] == ["I", "II", "III"]
    guards = res.events[res.events["kind"] == "guard"]
    assert guards["event"].tolist() == ["toe_off", "heel_strike", "foot_strike"]
    assert guards["phase"].tolist() == ["I", "II", "III"]
    assert np.all(np.diff(guards["t"].to_numpy()) > 0)
    x0, x1 = res.poincare_states
    residual = np.linalg.norm(x1 - x0)
    assert residual < 0.05

    nw = numpy_walker
    ref = nw.simulate_step(x0, nw.load_params(problem.source), diagnostics=False)
    assert abs(np.linalg.norm(ref["x7_end"] - x0) - 0.016524) < 1e-6
    assert abs(residual - np.linalg.norm(ref["x7_end"] - x0)) < 1e-6
    assert np.max(np.abs(x1 - ref["x7_end"])) < 1e-6, x1 - ref["x7_end"]
    durations = dict(res.steps[0].phases)
    for name, d in ref["phase_durations"].items():
        assert abs(durations[name] - d) < 1e-6, name


def test_events_are_located_on_their_switching_surfaces(problem, table2_step):
    """The state recorded at every guard and mode switch lies on that event's surface:
    toe-off at zero trailing-toe normal force, heel strike at zero heel height, foot strike
    with the foot flat, knee switches at theta_dis / theta_eq / zero knee rate."""
    traj, ev = table2_step.trajectory, table2_step.events
    deg = 180 / math.pi
    c, gamma = problem.compliance, problem.slope
    surfaces = {
        "toe_off": (lambda r: r["release_N_toe2"], 1e-8),                        # N
        "heel_strike": (lambda r: r["heel2_height_m"], 1e-12),            # m
        "foot_strike": (lambda r: r["qf2"] - (math.pi / 2 - gamma), 1e-12),  # rad
        "knee1_disengage": (lambda r: r["knee1_deg"] / deg - c["theta_dis"], 1e-12),
        "knee2_engage": (lambda r: r["knee2_deg"] / deg - c["theta_eq"], 1e-12),
        "knee1_rate": (lambda r: r["dq2"] - r["dq1"], 1e-10),               # rad/s
        "knee2_rate": (lambda r: r["dq3"] - r["dq4"], 1e-10),
    }
    assert set(ev["event"]) <= set(surfaces)
    for _, e in ev.iterrows():
        rows = traj[(traj["t"] == e["t"]) & (traj["phase"] == e["phase"])]
        assert len(rows) >= 1, e["event"]
        fun, tol = surfaces[e["event"]]
        value = fun(rows.iloc[0])
        assert abs(value) < tol, (e["event"], value)


# -- (f) the leg swap --------------------------------------------------------------------------
def test_leg_swap_is_an_involution_preserving_contacts_and_energy(hs, impact_states, params,
                                                                  contact_funs, table2_step):
    p = params
    x_pre = impact_states["foot_strike"]
    x_plus, _, _, x_post = (v.full().ravel() for v in hs.impact["foot_strike"](x_pre, p))
    tr = next(t for t in hs.model.transitions if t.ends_step)
    sysm = hs.model.system
    relabel = ca.Function("relabel", [sysm.q, sysm.qd], list(tr.relabel))

    def swap(x):
        q, qd = (v.full().ravel() for v in relabel(x[:8], x[8:16]))
        return np.concatenate([q, qd, x[16:]])

    # the model's relabel is the permutation [3,2,1,0,5,4] of the angles and their rates
    q6, qd6 = x_post[:6], x_post[8:14]
    assert np.array_equal(x_plus[:6], q6[SWAP]) and np.array_equal(x_plus[8:14], qd6[SWAP])
    assert np.array_equal(q6[SWAP][SWAP], q6)
    # toe 1 is at the origin and at rest after foot strike, so swapping twice is the identity
    assert np.allclose(swap(swap(x_post)), x_post, atol=1e-12, rtol=0)
    assert np.allclose(swap(x_post), x_plus, atol=0, rtol=0)
    # the swapped state is a valid start of phase I
    n, gamma = _normal(p), float(p[-1])
    assert np.allclose(_point(hs, x_plus, p, "toe1"), 0.0, atol=1e-15)
    for name in ("heel1", "toe2"):
        assert abs(_point(hs, x_plus, p, name) @ n) < 1e-9, name
    assert abs(x_plus[4] - (math.pi / 2 - gamma)) < 1e-9
    assert np.max(np.abs(contact_funs["I"](x_plus, p)[1].full())) < 1e-10
    assert np.allclose(hs.model.full_to_section(x_plus).full().ravel(),
                       table2_step.poincare_states[1], atol=0, rtol=0)
    # kinetic + spring energy are invariant when legs and knee-spring states swap together
    for e1 in (0.0, 1.0):
        for e2 in (0.0, 1.0):
            m = {"eng1": e1, "eng2": e2, "flex1": 0.0, "flex2": 0.0, "armed2": 0.0}
            ms = {**m, "eng1": e2, "eng2": e1}
            before = hs.energy(x_post, p, hs.mode_vector(m)).full().ravel()
            after = hs.energy(x_plus, p, hs.mode_vector(ms)).full().ravel()
            assert abs(before[0] - after[0]) < 1e-10 * before[0]
            assert abs(before[2] - after[2]) < 1e-12


# -- (g) the Poincare section ------------------------------------------------------------------
ANGLE = st.floats(-0.05, 0.05, allow_nan=False)
RATE = st.floats(-0.5, 0.5, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.tuples(ANGLE, ANGLE, ANGLE, ANGLE, RATE, RATE, RATE))
def test_section_state_maps_to_a_phase_one_state(hs, params, contact_funs, problem, delta):
    """Any section state near Table 2 gives a full state satisfying phase I: stance foot
    flat with its toe at the origin, trailing toe on the ground, all contacts at rest."""
    p = params
    xs = problem.state_vector() + np.array(delta)
    x = hs.model.section_to_full(xs, p).full().ravel()
    n, gamma = _normal(p), float(p[-1])
    assert np.allclose(_point(hs, x, p, "toe1"), 0.0, atol=1e-15)
    assert abs(x[4] - (math.pi / 2 - gamma)) < 1e-15 and x[12] == 0.0
    for name in ("heel1", "toe2"):
        assert abs(_point(hs, x, p, name) @ n) < 1e-12, name
    assert np.max(np.abs(contact_funs["I"](x, p)[1].full())) < 1e-12
    # the trailing shank leans back (q4 the root nearer q3), and the map inverts
    other_root = -2 * gamma - x[3]  # the two roots are -gamma +- acos(...)
    assert abs(x[3] - x[2]) <= abs(other_root - x[2])
    assert np.allclose(hs.model.full_to_section(x).full().ravel(), xs, atol=0, rtol=0)


@pytest.mark.parametrize("steps", [2])
def test_walks_several_steps_near_the_fixed_point(problem, steps):
    """Table 2 is close to a fixed point: consecutive section states stay within 0.05."""
    from pdw_casadi.gait.simulate import simulate

    res = simulate(problem, steps=steps, record=False)
    assert res.failure is None and res.completed_steps == steps
    X = res.poincare_states
    assert np.max(np.linalg.norm(np.diff(X, axis=0), axis=1)) < 0.05
