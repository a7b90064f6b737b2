"""The forefoot rocker (pdw_casadi/model/walkers/humanlike_6link_heeloff.py): the stance heel lifts
where the centre of pressure reaches the stance toe, without an impact, and the stance foot
then pivots on its toe (phase II_toe) until the swing heel strikes. A gait whose heel never
lifts is the ankle walker's; the toe-rocker phase is passive (its energy balance closes at
RK4 accuracy) and its contact holds."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import gait_timing, phase_contacts
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.system import hybrid_system
from pdw_casadi.model.walkers.humanlike_6link import Q_NAMES

#: a stiff, late-engaging clutch spring on the ankle walker's gait: the stance ankle's
#: plantarflexing torque carries the centre of pressure to the toe 0.41 s into the step
STIFF_CLUTCH = {"k_clutch": 200.0, "phi_clutch": 1.65}


@pytest.fixture(scope="module")
def heeloff():
    return load_problem("humanlike_6link_heeloff")


def _run(pb, steps=1, record=True, step_size=None):
    if step_size is not None:
        pb = pb.replace(numerics={**pb.numerics, "step_size": step_size})
    return Simulator(pb).run(pb.state_vector(), pb.parameter_vector(), steps=steps,
                             record=record)


@pytest.fixture(scope="module")
def ankle_start(heeloff):
    """The forefoot-rocker walker at the ankle walker's shipped gait and compliance."""
    ankle = load_problem("humanlike_6link_ankle")
    return heeloff.replace(compliance=dict(ankle.compliance), slope=ankle.slope).with_state(
        ankle.state_vector())


@pytest.fixture(scope="module")
def rocker_step(ankle_start):
    """One step from the ankle gait with the stiff clutch: I, II, heel off, II_toe."""
    res = _run(ankle_start.replace(compliance=STIFF_CLUTCH))
    assert [n for n, _ in res.steps[0].phases][:3] == ["I", "II", "II_toe"]
    return res


def test_without_heel_off_it_is_the_ankle_walker():
    """The ankle walker's shipped gait never brings the centre of pressure to the toe: the
    heel-off family walks the same three-phase step (durations and end state to 1e-12)."""
    ankle = load_problem("humanlike_6link_ankle")
    rocker = load_problem("humanlike_6link_heeloff").replace(
        compliance=dict(ankle.compliance), slope=ankle.slope).with_state(ankle.state_vector())
    a, b = (_run(pb, record=False).steps[0] for pb in (ankle, rocker))
    assert [n for n, _ in a.phases] == [n for n, _ in b.phases] == ["I", "II", "III"]
    assert np.allclose([d for _, d in a.phases], [d for _, d in b.phases], atol=1e-12)
    assert np.allclose(a.x_section_end, b.x_section_end, atol=1e-12)


def test_heel_off_fires_where_the_cop_reaches_the_toe(ankle_start, rocker_step):
    """The guard is the ankle walker's cop1_at_toe failure, at the same instant (1e-12 s);
    there the simulator's centre of pressure is at the toe (to 1e-9 m), before it inside the
    foot, and the heel is still on the ground."""
    ankle = load_problem("humanlike_6link_ankle").replace(
        compliance=STIFF_CLUTCH)
    fail = _run(ankle, record=False).failure
    ev = rocker_step.events
    t_off = float(ev[ev.event == "heel_off"].t.iloc[0])
    assert fail.reason == "cop1_at_toe" and fail.time == pytest.approx(t_off, abs=1e-12)
    ii = rocker_step.trajectory[rocker_step.trajectory.phase == "II"]
    assert ii.t.iloc[-1] == pytest.approx(t_off, abs=1e-12)
    assert abs(ii.cop_foot1_from_toe.iloc[-1]) < 1e-9
    assert (ii.cop_foot1_from_toe.iloc[:-1] > 0).all()
    assert abs(ii.heel1_height_m.iloc[-1]) < 1e-12


def test_heel_off_is_smooth(rocker_step):
    """No impact at heel off: the state is continuous, and since the flat-foot couple is
    zero there, the toe carries the whole stance force at once (normal force continuous to
    1e-9 relative) and the heel lifts from rest (height and rate zero, then rising)."""
    traj = rocker_step.trajectory
    ii, toe = traj[traj.phase == "II"], traj[traj.phase == "II_toe"]
    cols = [*Q_NAMES, *("d" + n for n in Q_NAMES)]
    assert np.allclose(ii[cols].iloc[-1], toe[cols].iloc[0], atol=0, rtol=0)
    assert toe.N_toe1.iloc[0] == pytest.approx(ii.N_foot1.iloc[-1], rel=1e-9)
    assert toe.dqf1.iloc[0] == 0.0 and toe.heel1_height_m.iloc[0] < 1e-12
    assert (np.diff(toe.heel1_height_m.to_numpy()) > 0).all()


def test_toe_rocker_contact_holds(rocker_step):
    """In II_toe the stance toe stays at rest (position and velocity at the origin to
    integration accuracy), pushes on the ground (normal force > 0) and the foot rotates
    (heel above the ground, tilting up to a few millimetres)."""
    toe = rocker_step.trajectory[rocker_step.trajectory.phase == "II_toe"]
    assert len(toe) > 20
    assert np.abs(toe[["x_t1", "y_t1", "dx_t1", "dy_t1"]].to_numpy()).max() < 1e-10
    assert (toe.N_toe1 > 0).all()
    assert toe.heel1_height_m.iloc[-1] > 1e-3


def test_energy_balance_closes_on_the_toe_rocker(ankle_start, rocker_step):
    """kinetic + potential + spring energy + damper work is constant through II_toe (no
    switch there): its drift is RK4's error, below 1e-7 J and falling by more than 8x when
    the step is halved (4th order: 16x)."""

    def drift(res):
        toe = res.trajectory[res.trajectory.phase == "II_toe"]
        assert not (res.events.phase == "II_toe").any() or \
            set(res.events[res.events.phase == "II_toe"].kind) <= {"guard", "failure"}
        total = toe.kinetic_J + toe.potential_J + toe.spring_J + toe.damping_work_J
        return float(np.abs(total - total.iloc[0]).max())

    coarse = drift(rocker_step)
    fine = drift(_run(ankle_start.replace(compliance=STIFF_CLUTCH), step_size=2.5e-4))
    assert 0 < coarse < 1e-7
    assert fine < coarse / 8


def test_mode_rules_at_heel_off_and_heel_strike_from_the_toe(heeloff):
    """Heel off changes no mode flag; the heel strike from the toe rocker starts the loading
    damper like the one from the flat foot, and both heel-strike impacts are the same map
    (same contact set: trailing toe, leading heel)."""
    hs = hybrid_system(heeloff)
    tr = {t.name: t for t in hs.model.transitions}
    m0 = dict(hs.model.initial_mode)
    assert tr["heel_off"].mode_after(m0) == m0
    assert tr["heel_strike_toe"].mode_after(m0) == tr["heel_strike"].mode_after(m0)
    assert tr["heel_strike_toe"].mode_after(m0)["load2"] == 1.0
    assert set(hs.transitions) >= {("II", "heel_off"), ("II", "heel_strike"),
                                   ("II_toe", "heel_strike")}
    x = Simulator(heeloff).run(heeloff.state_vector(), heeloff.parameter_vector(), steps=1,
                               record=True).trajectory
    last = x[x.phase == "II"].iloc[-1]
    state = np.r_[[last[n] for n in hs.model.q_names],
                  [last["d" + n] for n in hs.model.q_names], last.damping_work_J]
    p = heeloff.parameter_vector()
    a, b = hs.impact_at("heel_strike", state, p), hs.impact_at("heel_strike_toe", state, p)
    assert np.allclose(a.x_plus, b.x_plus, atol=1e-12)
    assert np.allclose(a.impulse, b.impulse, atol=1e-12)


def test_timing_reports_heel_off():
    """Heel off is the start of II_toe in the cycle that begins at heel strike (phase III of
    the previous step): 100 (t_III + t_I + t_II) / (2 T)."""
    t1, t2, t2t, t3 = 0.02, 0.4, 0.2, 0.03
    T = t1 + t2 + t2t + t3
    t = gait_timing([("I", t1), ("II", t2), ("II_toe", t2t), ("III", t3)], 0.6,
                    phase_contacts("humanlike_6link_heeloff"))
    assert t.heel_off_pct == pytest.approx(100 * (t3 + t1 + t2) / (2 * T), rel=1e-12)
    assert t.foot_flat_pct == pytest.approx(100 * t3 / (2 * T), rel=1e-12)
    assert t.stance_pct == pytest.approx(100 * (T + t1 + t3) / (2 * T), rel=1e-12)


@pytest.fixture(scope="module")
def shipped_gait(heeloff):
    """The shipped problem's fixed point: a gait whose stance heel lifts in single support."""
    from pdw_casadi.gait.fixed_point import find_fixed_point

    fp = find_fixed_point(heeloff, fallback=False)
    assert fp.converged
    run = Simulator(heeloff).run(fp.state, fp.parameters, steps=1, record=False)
    assert [n for n, _ in run.steps[0].phases] == ["I", "II", "II_toe", "III"]
    return fp


def test_shooting_nlp_closes_through_the_toe_rocker(heeloff, shipped_gait):
    """The shooting NLP at the heel-off gait has the segment chain of the simulator's plan
    (phase II ends on heel_off, II_toe on heel_strike) and its own integrator closes the
    step: every equality row (continuity, guards, transitions, periodicity) to 1e-6."""
    from pdw_casadi.nlp.shooting import ShootingNLP

    nlp = ShootingNLP(heeloff, shipped_gait.state, shipped_gait.parameters,
                      free=tuple(heeloff.compliance_names))
    chain = [(s.phase, nlp.hs.event_list[s.phase][s.event].name, s.transition)
             for s in nlp.specs if s.transition is not None]
    assert chain == [("I", "toe_off", "toe_off"), ("II", "heel_off", "heel_off"),
                     ("II_toe", "heel_strike", "heel_strike_toe"),
                     ("III", "foot_strike", "foot_strike")]
    equality = {n for n, lo, hi in zip(nlp.g_names, nlp.lbg, nlp.ubg, strict=True) if lo == hi}
    assert {"periodicity", "impact[heel_strike_toe]"} <= equality
    worst = max((v for n, v in nlp.violations(nlp.w0) if n in equality), default=0.0)
    assert worst < 1e-6


def test_poincare_jacobian_through_heel_off(heeloff, shipped_gait):
    """The exact-AD Jacobian of the step map (through the heel-off guard and the heel strike
    from the toe) matches central finite differences of the simulator's map to 1e-5
    relative."""
    from pdw_casadi.gait.poincare import PoincareMap

    P = PoincareMap(heeloff)
    x, p = shipped_gait.state, shipped_gait.parameters
    J = P.evaluate(x, p).dx
    eps = 1e-6
    fd = np.column_stack([(P.evaluate(x + eps * e, p, jacobian=False).x_next
                           - P.evaluate(x - eps * e, p, jacobian=False).x_next) / (2 * eps)
                          for e in np.eye(x.size)])
    assert np.abs(J - fd).max() < 1e-5 * np.abs(J).max()


def test_energy_balance_of_a_heel_off_step(heeloff, shipped_gait):
    """A whole step through heel off: E_start - E_end = damper work + impact losses (heel
    strike from the toe, foot strike) + spring losses (knee, clutch), to RK4's error, which
    falls by more than 8x when the step is halved."""
    x, p = shipped_gait.state, shipped_gait.parameters
    steps = []
    for h in (5e-4, 2.5e-4):
        pb = heeloff.replace(numerics={**heeloff.numerics, "step_size": h})
        sr = Simulator(pb).run(x, p, steps=1, record=False).steps[0]
        assert "II_toe" in dict(sr.phases)
        steps.append(sr)
    coarse, fine = steps
    assert coarse.impact_loss_J > 0 and coarse.spring_loss_J > 0
    assert 0 < abs(coarse.energy_residual_J) < 1e-5
    assert abs(fine.energy_residual_J) < abs(coarse.energy_residual_J) / 8
