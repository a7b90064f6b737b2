"""The toe foot (pdw_casadi/model/feet/toes.py, family humanlike_toes): rear foot and toes at a
spring-damped MTP joint with a stop. Its physics: the energy books close over a step, every
impact balances momentum and loses kinetic energy, every contact holds along its phase, the
step map's exact Jacobian matches finite differences, heel off and the roll onto the toe tip
are smooth, and with the MTP joint locked the walker is the flat-foot (ankle) walker."""

from __future__ import annotations

import tomllib

import casadi as ca
import numpy as np
import pytest
from conftest import model_functions

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.engine.resources import bundled_dir
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import gait_timing, phase_contacts
from pdw_casadi.model.feet.toes import TOES_LOCKED, rear_body
from pdw_casadi.model.problem import load_problem, problem_from_dict
from pdw_casadi.model.system import hybrid_system
from pdw_casadi.model.walkers import FAMILIES
from pdw_casadi.model.walkers import humanlike_6link_ankle as ankle
from pdw_casadi.model.walkers.humanlike_6link import build, register_six_link

#: a stiff, late clutch spring on the shipped gait (found by pdw-seed toes): the
#: trailing toes roll onto their tip and leave the ground before the MTP joint reaches its
#: stop, the swing toes spring back onto it, and the stance heel lifts in single support
#: (phases I, I_tip, II, II_stop, II_mtp); the step then fails at the heel strike (the
#: trailing toes' impulse pulls)
HEEL_OFF = {"k_clutch": 136.3784, "phi_clutch": 1.6477, "ankle_rest": 0.4095, "k_ankle": 2.5905,
            "k_mtp": 13.1144, "mtp_rest": -0.0285, "c_mtp": 0.0559}
LOCKED = "test_toes_locked_6link"
if LOCKED not in FAMILIES:  # registered once per session
    register_six_link(LOCKED, "The ankle walker with toe feet, MTP joints locked (a test's).",
                      foot=TOES_LOCKED, ext=ankle.EXTENSION,
                      nonnegative_compliance=ankle.EXTRA_NONNEGATIVE)


@pytest.fixture(scope="module")
def toes():
    return load_problem("humanlike_toes")


@pytest.fixture(scope="module")
def sim(toes):
    return Simulator(toes)


def _run(sim, pb, steps=1, step_size=None):
    if step_size is not None:
        pb = pb.replace(numerics={**pb.numerics, "step_size": step_size})
        sim = Simulator(pb)
    return sim.run(pb.state_vector(), pb.parameter_vector(), steps=steps, record=True)


@pytest.fixture(scope="module")
def plain_step(sim, toes):
    """The shipped gait: a whole step I, I_tip, I_stop, II_stop, III (the trailing toes roll
    onto their tip, the foot reaches its stop there; the stance heel stays down until the
    other heel strikes)."""
    res = _run(sim, toes)
    assert res.failure is None
    assert [n for n, _ in res.steps[0].phases] == ["I", "I_tip", "I_stop", "II_stop", "III"]
    return res


@pytest.fixture(scope="module")
def heel_off_step(sim, toes):
    """Every single- and double-support phase of the foot: I, I_tip, II, II_stop, II_mtp."""
    res = _run(sim, toes.replace(compliance=HEEL_OFF))
    assert [n for n, _ in res.steps[0].phases] == ["I", "I_tip", "II", "II_stop", "II_mtp"]
    assert res.failure.reason == "heel_strike_mtp:impulse_toes1"
    return res


def _locked_problem(family=LOCKED):
    """The shipped ankle walker's problem with the toe foot's segments of humanlike_toes."""
    raw = tomllib.loads((bundled_dir("problems") / "humanlike_6link_ankle.toml").read_text())
    toe = load_problem("humanlike_toes").anthropometry
    raw["walker"] = {**raw["walker"], "family": family}
    raw["anthropometry"] = {**raw["anthropometry"],
                            **{k: toe[k] for k in ("l_toe", "l_toec", "m_toe", "J_toe")}}
    return problem_from_dict(raw, name=family)


def _state(row, names):
    return np.r_[[row[n] for n in names], [row["d" + n] for n in names], row.damping_work_J]


# -- the part ---------------------------------------------------------------------------
def test_segments_make_table_1_foot(toes):
    """Rear foot + toes in line have Table 1's foot mass, centre of mass and inertia."""
    a = toes.anthropometry
    m_r, c_r, j_r = rear_body(a)
    toes_c = a["l_ft"] - a["l_toe"] + a["l_toec"]
    assert m_r + a["m_toe"] == pytest.approx(a["m_f"], rel=1e-14)
    assert (m_r * c_r + a["m_toe"] * toes_c) / a["m_f"] == pytest.approx(a["l_fc"], rel=1e-12)
    j = j_r + m_r * (c_r - a["l_fc"]) ** 2 + a["J_toe"] + a["m_toe"] * (toes_c - a["l_fc"]) ** 2
    assert j == pytest.approx(a["J_f"], rel=1e-12)
    assert m_r > 0 and j_r > 0


def test_toes_heavier_than_the_foot_are_refused():
    raw = tomllib.loads((bundled_dir("problems") / "humanlike_toes.toml").read_text())
    raw["anthropometry"]["J_toe"] = 1e-3  # more than the whole foot's J_f less the rest
    with pytest.raises(ProblemError, match="rear foot"):
        problem_from_dict(raw, name="heavy_toes")


def test_extra_coordinates_and_the_leg_swap(toes):
    """The foot adds qtoe1, qtoe2 after the chain's coordinates; foot strike swaps them with
    the legs (new qtoe1 = old qtoe2) and the section puts both toes flat."""
    hs = hybrid_system(toes)
    names = hs.model.q_names
    assert names[8:] == ("qtoe1", "qtoe2") and hs.nq == 10
    fs = next(t for t in hs.model.transitions if t.name == "foot_strike")
    q = hs.model.system.q
    assert ca.depends_on(fs.relabel[0][8], q[9]) and ca.depends_on(fs.relabel[0][9], q[8])
    x = hs.section_to_full.np(toes.state_vector(), toes.parameter_vector()).ravel()
    flat = np.pi / 2 - toes.slope
    assert x[8] == pytest.approx(flat, abs=1e-15) and x[9] == pytest.approx(flat, abs=1e-15)
    assert x[10 + 8] == 0 and abs(x[10 + 9]) < 1e-14  # toes at rest


# -- physics ------------------------------------------------------------------------------
def test_energy_balance_over_a_step(sim, toes, plain_step):
    """Potential energy lost = damper work (ankles, knees, MTP joints) + impact losses
    (the toes' stop on the tip, heel strike, foot strike) + spring losses + the change of
    kinetic and spring energy: the residual is RK4's error (below 1e-6 J at the shipped
    0.5 ms step), converging at fourth order (16x smaller at half the step, 8x asked)."""
    st = plain_step.steps[0]
    coarse = abs(st.energy_residual_J)
    assert st.impact_loss_J > 0 and st.dissipated_damping_J > 0
    assert coarse < 1e-6
    fine = abs(_run(sim, toes, step_size=2.5e-4).steps[0].energy_residual_J)
    assert fine < coarse / 8


def test_energy_is_conserved_along_every_phase(heel_off_step):
    """kinetic + potential + spring energy + damper work is constant along each phase (to
    1e-5 J: RK4's error, largest in I_tip where the MTP spring turns the toes about their
    tip; the stance knee's spring disengagement, a declared spring loss, excepted) and
    continuous through the smooth transitions (toes roll onto the tip, heel off: no impact
    there)."""
    traj = heel_off_step.trajectory
    ev = heel_off_step.events
    total = (traj.kinetic_J + traj.potential_J + traj.spring_J + traj.damping_work_J).to_numpy()
    t = traj.t.to_numpy()
    losses = ev[ev.event == "knee1_disengage"].t.to_numpy()
    for name in ("I", "I_tip", "II_stop", "II_mtp"):
        idx = np.flatnonzero(traj.phase.to_numpy() == name)
        jumps = np.diff(total[idx])
        kept = [not any(t[i] <= tl <= t[j] for tl in losses)
                for i, j in zip(idx[:-1], idx[1:], strict=True)]
        assert len(jumps) >= 2 and abs(jumps[kept].sum()) < 1e-5, name
    # (toe off from I_tip releases the trailing ankle's clutch spring: a declared loss)
    for a, b in (("I", "I_tip"), ("II_stop", "II_mtp")):
        assert total[traj.phase == a][-1] == pytest.approx(total[traj.phase == b][0],
                                                           abs=1e-12)


def _impact_states(hs, *runs):
    """(transition, pre-impact state row) of every impact the runs went through: the last
    sample of the phase that a guard with an impact ended."""
    out = []
    for res in runs:
        traj, ev = res.trajectory, res.events
        for _, e in ev[ev.kind == "guard"].iterrows():
            tr = hs.transitions.get((e.phase, e.event))
            if tr is None or tr.contact is None:
                continue
            rows = traj[(traj.phase == e.phase) & (traj.t <= e.t + 1e-12)]
            out.append((tr.name, rows.iloc[-1]))
    return out


def test_impacts_balance_momentum_and_lose_energy(toes, plain_step, heel_off_step):
    """Every impact: M_q (qd+ - qd-) = E^T Lambda (generalized momentum balance, 1e-10),
    E qd+ = 0 (the closed contacts at rest, 1e-10 rad/s or m/s: rounding of a solve with
    velocities ~10) and the kinetic energy lost is >= 0."""
    hs = hybrid_system(toes)
    sysm, p = hs.model.system, toes.parameter_vector()
    q = sysm.q
    names = hs.model.q_names
    trs = {t.name: t for t in hs.model.transitions}
    mq = ca.Function("mq", [q, hs.model.p], [sysm.M_q])
    seen = set()
    for name, row in _impact_states(hs, plain_step, heel_off_step):
        seen.add(name)
        x = _state(row, names)
        imp = hs.impact_at(name, x, p)
        E = ca.Function("E", [q], [ca.jacobian(trs[name].contact.rows, q)])(x[:10]).full()
        qd_minus, qd_plus = x[10:20], imp.x_post[10:20]
        lhs = mq(x[:10], p).full() @ (qd_plus - qd_minus)
        assert np.allclose(lhs, E.T @ imp.impulse, atol=1e-10), name
        assert np.abs(E @ qd_plus).max() < 1e-10, name
        ke = [hs.energy_at(s, p, hs.mode_vector(hs.model.initial_mode)).kinetic
              for s in (x, imp.x_post)]
        assert ke[0] - ke[1] >= 0, name
    assert seen >= {"toes_stop", "toes_stop_tip", "heel_strike", "heel_strike_mtp",
                    "foot_strike"}


def test_contacts_hold_along_each_phase(toes, plain_step, heel_off_step):
    """Each phase's contact rows keep their phase-start values (to 1e-9 m or rad) and their
    rates stay zero (to 1e-6: the index-reduced dynamics hold E qd = 0 at RK4 accuracy, the
    drift largest in I_tip, where the MTP spring turns the toes fast about their tip)."""
    hs = hybrid_system(toes)
    q, qd = hs.model.system.q, hs.model.system.qd
    names = hs.model.q_names
    seen = set()
    for res in (plain_step, heel_off_step):
        traj = res.trajectory
        for ph in hs.model.phases:
            seg = traj[traj.phase == ph.name]
            if seg.empty or ph.contact.rows.shape[0] == 0:
                continue
            f = ca.Function("c", [q, qd], [ph.contact.rows,
                                           ca.jtimes(ph.contact.rows, q, qd)])
            vals = [f(seg[list(names)].iloc[i].to_numpy(),
                      seg[["d" + n for n in names]].iloc[i].to_numpy())
                    for i in range(len(seg))]
            rows = np.hstack([v[0].full() for v in vals])
            rates = np.hstack([v[1].full() for v in vals])
            assert np.abs(rows - rows[:, :1]).max() < 1e-9, ph.name
            assert np.abs(rates).max() < 1e-6, ph.name
            seen.add(ph.name)
    assert seen == {"I", "I_tip", "I_stop", "II", "II_stop", "II_mtp", "III"}


def test_heel_off_is_smooth(toes, heel_off_step):
    """At heel off the rear foot's ground moment about the MTP joint is zero, the state is
    continuous, the heel leaves from rest and rises while the toes stay flat."""
    traj = heel_off_step.trajectory
    ii, mtp = traj[traj.phase == "II_stop"], traj[traj.phase == "II_mtp"]
    assert abs(ii.heelload_foot1.iloc[-1]) < 1e-9 and (ii.heelload_foot1.iloc[:-1] > 0).all()
    cols = [c for c in traj.columns if c.startswith(("q", "dq", "x_t", "dx_t", "y_t", "dy_t"))]
    assert np.array_equal(ii[cols].iloc[-1].to_numpy(), mtp[cols].iloc[0].to_numpy())
    assert mtp.heel1_height_m.iloc[0] < 1e-12
    assert (np.diff(mtp.heel1_height_m.to_numpy()) > 0).all()
    flat = np.pi / 2 - toes.slope
    assert np.abs(mtp.qtoe1 - flat).max() < 1e-9
    assert (mtp.N_toes1 > 0).all() and (mtp.copmargin_toes1 > 0).all()


def test_toes_roll_onto_the_tip_smoothly(heel_off_step):
    """Phase I ends where the trailing toes' centre of pressure reaches the tip (the toes'
    couple zero); in I_tip the toes rotate about the tip, which stays put."""
    traj = heel_off_step.trajectory
    i, tip = traj[traj.phase == "I"], traj[traj.phase == "I_tip"]
    assert i.release_copmargin_toes2.iloc[-1] == pytest.approx(0, abs=1e-9)
    assert tip.release_N_tip2.iloc[0] == pytest.approx(i.release_N_toes2.iloc[-1], rel=1e-9)
    assert tip.toes2_tilt_deg.iloc[-1] > 0.1


def test_timing_from_the_contacts():
    """Heel off is the start of II_mtp, toe off the end of I_tip, in the cycle that starts
    at heel strike (phase III of the previous step)."""
    d = {"I": 0.02, "I_tip": 0.03, "II": 0.01, "II_stop": 0.3, "II_mtp": 0.1, "III": 0.03}
    T = sum(d.values())
    t = gait_timing(list(d.items()), 0.6, phase_contacts("humanlike_toes"))
    assert t.heel_off_pct == pytest.approx(
        100 * (d["III"] + d["I"] + d["I_tip"] + d["II"] + d["II_stop"]) / (2 * T), rel=1e-12)
    assert t.stance_pct == pytest.approx(
        100 * (T + d["I"] + d["I_tip"] + d["III"]) / (2 * T), rel=1e-12)


@pytest.mark.slow
def test_poincare_jacobian_matches_finite_differences(toes):
    """The exact-AD Jacobian of the step map (through toe off, the toes' stop impact, heel
    strike, foot strike and the swap of the toe coordinates) matches central finite
    differences of the simulator's map to 1e-5 relative."""
    from pdw_casadi.gait.poincare import PoincareMap

    P = PoincareMap(toes)
    x, p = toes.state_vector(), toes.parameter_vector()
    J = P.evaluate(x, p).dx
    eps = 1e-6
    fd = np.column_stack([(P.evaluate(x + eps * e, p, jacobian=False).x_next
                           - P.evaluate(x - eps * e, p, jacobian=False).x_next) / (2 * eps)
                          for e in np.eye(x.size)])
    assert np.abs(J - fd).max() < 1e-5 * max(1.0, np.abs(J).max())


@pytest.mark.slow
def test_shooting_nlp_closes_through_the_toe_phases(toes):
    """The shooting NLP at the shipped gait has the simulator's segment chain (the toes
    rolling onto the tip, the stop's impact on the tip, toe off into the held swing) and its
    own integrator closes the step: every equality row to 1e-6."""
    from pdw_casadi.gait.fixed_point import find_fixed_point
    from pdw_casadi.nlp.shooting import ShootingNLP

    fp = find_fixed_point(toes, fallback=False)
    assert fp.converged
    nlp = ShootingNLP(toes, fp.state, fp.parameters, free=tuple(toes.compliance_names))
    chain = [(s.phase, nlp.hs.event_list[s.phase][s.event].name, s.transition)
             for s in nlp.specs if s.transition is not None]
    assert chain == [("I", "toes2_cop_at_tip", "toes_roll"),
                     ("I_tip", "stop2_on_tip", "toes_stop_tip"),
                     ("I_stop", "toe_off", "toe_off_stop"),
                     ("II_stop", "heel_strike", "heel_strike"),
                     ("III", "foot_strike", "foot_strike")]
    equality = {n for n, lo, hi in zip(nlp.g_names, nlp.lbg, nlp.ubg, strict=True) if lo == hi}
    assert {"periodicity", "impact[toes_stop_tip]"} <= equality
    worst = max((v for n, v in nlp.violations(nlp.w0) if n in equality), default=0.0)
    assert worst < 1e-6


# -- the locked MTP joint is the flat foot --------------------------------------------------
def test_locked_toes_build_the_ankle_walker():
    """With the MTP joint locked the toe foot (two bodies in line) gives the ankle walker's
    model: the mass matrices agree to rounding (1e-15 relative) and every phase's dynamics,
    multipliers, events and outputs and every impact at random states to 1e-10 relative
    (the impact's KKT solve amplifies the rounding to ~3e-12)."""
    rng = np.random.default_rng(5)
    pb, ref = _locked_problem(), load_problem("humanlike_6link_ankle")
    a, b = build(pb, ankle.EXTENSION, TOES_LOCKED), build(ref, ankle.EXTENSION)
    assert [ph.name for ph in a.phases] == [ph.name for ph in b.phases]
    assert [tr.name for tr in a.transitions] == [tr.name for tr in b.transitions]

    fa, fb = (model_functions(x, [x.system.M_q, x.F_q, x.spring_energy]) for x in (a, b))
    p = ref.parameter_vector()
    for _ in range(5):
        q = rng.uniform(-0.6, 0.6, 8) + np.array([0, 0, 0, 0, 1.4, 1.4, 0, 0])
        qd = rng.uniform(-2, 2, 8)
        m = rng.integers(0, 2, a.m.shape[0]).astype(float)
        outs_a, outs_b = fa(q, qd, p, m), fb(q, qd, p, m)
        mq = outs_b[0].full()
        assert np.abs(outs_a[0].full() - mq).max() < 1e-15 * np.abs(mq).max()
        for u, v in zip(outs_a, outs_b, strict=True):
            u, v = u.full(), v.full()
            if v.size == 0:  # a transition without an impact
                assert u.size == 0
                continue
            assert np.allclose(u, v, rtol=1e-10, atol=1e-10 * max(1.0, np.abs(v).max()))


@pytest.mark.slow
def test_locked_toes_step_equals_the_ankle_walker_step():
    """One step of the toe walker with locked MTP joints from the ankle walker's shipped gait
    equals the ankle walker's step: phase durations and the end state to 1e-8."""
    pb, ref = _locked_problem(), load_problem("humanlike_6link_ankle")
    a, b = (Simulator(x).run(x.state_vector(), x.parameter_vector(), steps=1,
                             record=False).steps[0] for x in (pb, ref))
    assert [n for n, _ in a.phases] == [n for n, _ in b.phases] == ["I", "II", "III"]
    assert np.allclose([d for _, d in a.phases], [d for _, d in b.phases], rtol=0, atol=1e-8)
    assert np.allclose(a.x_section_end, b.x_section_end, rtol=0, atol=1e-8)
