"""One evaluator of validity margins: a walker output ``clearance_<anything>`` is measured by
the simulator, checked by the fixed points' validity and constrained in the shooting NLP
alike (:mod:`pdw_casadi.model.margins`)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from pdw_casadi.gait.fixed_point import find_fixed_point, validity_failure, validity_slacks
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.hybrid import GUARD, HybridSystem
from pdw_casadi.model.margins import (
    CLEARANCE,
    GUARD_AHEAD,
    IMPULSE,
    NORMAL_FORCE,
    Margin,
    MarginKind,
)
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.system import gait_system
from pdw_casadi.model.walkers import get_family
from pdw_casadi.nlp.shooting import ShootingNLP

DEG = np.pi / 180
NAME = "clearance_hip_over_half_leg"  # a name no walker uses: only the prefix counts


@pytest.fixture(scope="module")
def walker():
    """The compass gait with one extra swing-phase output: the hip's height above half the
    leg length (m), which is not a margin of the shipped walker."""
    problem = load_problem("compass_gait")
    model = get_family("compass_gait").build(problem)
    leg = problem.anthropometry["a"] + problem.anthropometry["b"]
    phase = model.phases[0]
    phase.outputs = {**phase.outputs, NAME: model.common_outputs["hip_height_m"] - 0.5 * leg}
    hs = HybridSystem(model)
    fp = find_fixed_point(problem, p=np.array([3 * DEG]))
    assert fp.converged
    return problem, hs, fp


def _sim_margin(problem, hs, fp):
    sim = Simulator(problem, hs)
    res = sim.run(fp.state, fp.parameters, steps=1, record=True)
    return res, res.steps[0].margins


def test_the_naming_rule_gives_a_clearance_margin(walker):
    problem, hs, _ = walker
    key = f"swing:min_{NAME}"
    assert hs.margin_specs[key] == CLEARANCE
    assert hs.margin_specs["swing:min_N_foot1"] == NORMAL_FORCE
    assert hs.margin_specs["heel_strike:impulse_foot2"] == IMPULSE
    assert "heel_strike:foot1_rise_speed" not in hs.margin_specs  # a sign condition only


def test_simulator_measures_it_after_a_fifth_of_the_phase(walker):
    problem, hs, fp = walker
    res, margins = _sim_margin(problem, hs, fp)
    tr = res.trajectory
    leg = problem.anthropometry["a"] + problem.anthropometry["b"]
    late = tr["t"] >= 0.2 * res.steps[0].step_time
    # the hip is highest at mid-stance and lowest at the step's ends: the margin is the
    # height over half the leg at the last counted sample
    expected = float((tr["hip_height_m"][late] - 0.5 * leg).min())
    assert margins[f"swing:min_{NAME}"] == pytest.approx(expected, abs=1e-12)
    assert 0.3 * leg < expected < 0.5 * leg  # the legs are ~20 deg apart at heel strike


def test_validity_and_nlp_agree_on_the_margin(walker, monkeypatch):
    monkeypatch.setenv("PDW_NO_COMPILE", "1")  # this model's functions are built once here
    problem, hs, fp = walker
    _, margins = _sim_margin(problem, hs, fp)
    m = margins[f"swing:min_{NAME}"]
    key = f"swing:min_{NAME}"
    for need, broken in ((m - 0.01, False), (m + 0.01, True)):
        pb = problem.replace(validity={**problem.validity, "min_clearance": need})
        assert validity_slacks(margins, pb, hs)[key] == pytest.approx(m - need)
        why = validity_failure(margins, pb, hs)
        assert (why is not None and why.startswith(key)) is broken
        nlp = ShootingNLP(pb, fp.state, fp.parameters, hs=hs)
        rows = [i for i, n in enumerate(nlp.g_names) if n.endswith(f":{NAME}")]
        assert rows and all(nlp.lbg[i] == 0 and nlp.ubg[i] == np.inf for i in rows)
        g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()[rows]
        # the NLP's guess is the simulated gait: its smallest demanded row is the margin less
        # the requirement (to the NLP's slightly different RK4 grid)
        assert g.min() == pytest.approx(m - need - CLEARANCE.nlp_slack, abs=2e-4)
        assert bool(g.min() < 0) == broken


def test_declared_margins_override_the_naming_rule(walker):
    problem, _, _ = walker
    model = get_family("compass_gait").build(problem)
    phase = model.phases[0]
    spec = Margin(MarginKind.CLEARANCE, "min_clearance", "m", active_after=0.5)
    phase.margins = {"N_foot1": spec}  # only this one, with its own rule
    hs = HybridSystem(model)
    assert hs.margin_specs == {"swing:min_N_foot1": spec, "heel_strike:impulse_foot2": IMPULSE}
    phase.margins = {"no_such_output": spec}
    with pytest.raises(ValueError, match="no_such_output"):
        HybridSystem(model)


@pytest.fixture(scope="module")
def paper_gait():
    problem = load_problem("humanlike_6link")
    hs = gait_system(problem)
    fp = find_fixed_point(problem)
    assert fp.converged and fp.valid
    return problem, hs, fp


def _trailing_toe_force(hs, fp) -> float:
    """The 6-link walker's trailing toe normal force (N) at the fixed point's section state
    (the state right after the foot-strike impact): the event that ends phase I."""
    x = hs.section_to_full.np(fp.state, fp.parameters).ravel()
    mode = hs.refresh_indicators("I", x, fp.parameters, dict(hs.model.initial_mode))
    g = hs.events["I"].np(x, fp.parameters, np.array(hs.mode_vector(mode))).ravel()
    return float(g[[e.name for e in hs.event_list["I"]].index("toe_off")])


def test_a_phase_whose_guard_is_crossed_when_it_begins_is_invalid(paper_gait):
    """Phase I (double support) ends when the trailing toe's normal force falls to zero. A
    gait whose impact leaves that force negative has the toe pulling the ground: the margin
    ``foot_strike:toe_off_ahead`` is that force right after the impact, and a negative one
    makes the gait invalid, naming the guard."""
    problem, hs, fp = paper_gait
    key = "foot_strike:toe_off_ahead"
    assert hs.margin_specs[key] == GUARD_AHEAD
    n_toe = _trailing_toe_force(hs, fp)
    assert n_toe > 0  # the paper's gait: the trailing toe still pushes after foot strike
    run = Simulator(problem, hs).run(fp.state, fp.parameters, steps=1, record=False)
    # the state right after the step's last impact, in the mode phase I begins with
    names = [e.name for e in hs.event_list["I"]]
    after_impact = float(hs.events["I"].np(run.final_state, fp.parameters, np.array(
        hs.mode_vector(run.final_mode))).ravel()[names.index("toe_off")])
    assert run.steps[0].margins[key] == pytest.approx(after_impact, rel=1e-12)
    # the section keeps the independent coordinates only (the fixed point's state: 2e-9 off)
    assert after_impact == pytest.approx(n_toe, rel=1e-6)
    assert validity_failure(fp.margins, problem, hs) is None
    why = validity_failure({**fp.margins, key: -n_toe}, problem, hs)
    assert why is not None and why.startswith(key) and "already crossed" in why


def test_the_nlp_keeps_each_ending_guard_on_its_near_side(paper_gait):
    """The shooting NLP holds every segment's directional ending guard on the side before
    its crossing, at the segment's first state and at its samples, whatever the guess does;
    at the guess (the simulated gait) the first segment's row is the trailing toe force."""
    problem, hs, fp = paper_gait
    nlp = ShootingNLP(problem, fp.state, fp.parameters, hs=hs)
    g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()
    for k, s in enumerate(nlp.specs):
        ev = hs.event_list[s.phase][s.event]
        if ev.kind != GUARD or ev.direction == 0 or ev.arm_above > 0:
            continue  # a mode switch, or a guard counted only once armed
        assert s.signs[s.event] == -ev.direction and s.ahead
        rows = [i for i, n in enumerate(nlp.g_names) if n == f"ahead[{k}]:{ev.name}"]
        assert len(rows) == 1 and nlp.lbg[rows[0]] == GUARD_AHEAD.nlp_slack
        if k == 0:
            assert g[rows[0]] == pytest.approx(_trailing_toe_force(hs, fp), rel=1e-9)


def test_the_nlp_holds_every_guard_the_simulator_checks_where_a_phase_begins(paper_gait):
    """Phase II's first segment ends on a knee's mode switch, not on heel strike: the NLP
    still holds every directional guard of a phase at the phase's first state, as the
    simulator checks it (``<transition>:<guard>_ahead``); at the guess the rows equal the
    simulator's margins."""
    problem, hs, fp = paper_gait
    nlp = ShootingNLP(problem, fp.state, fp.parameters, hs=hs)
    g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()
    margins = Simulator(problem, hs).run(fp.state, fp.parameters, steps=1,
                                         record=True).steps[0].margins
    begun = [(k, nlp.specs[k - 1].transition if k else nlp.specs[-1].transition)
             for k in range(len(nlp.specs))]
    begun = [(k, tr) for k, tr in begun if tr is not None]
    assert {nlp.specs[k].phase for k, _ in begun} == set(hs.event_list)
    switch_first = 0
    for k, tr in begun:
        s = nlp.specs[k]
        checked = [(i, ev, key) for i, ev, key in hs.guards_ahead[tr] if key in margins]
        assert checked, tr
        switch_first += not hs.event_list[s.phase][s.event].directional_guard
        for _, ev, key in checked:
            rows = [j for j, n in enumerate(nlp.g_names) if n == f"ahead[{k}]:{ev.name}"]
            assert len(rows) == 1 and margins[key] > 0
            assert g[rows[0]] == pytest.approx(margins[key], rel=1e-6, abs=1e-9)
    assert switch_first >= 1  # the case the rule is for: phase II begins with a switch


def test_the_nlp_holds_the_mode_flags_the_simulator_reads_at_a_phase_start(paper_gait):
    """The simulator sets a mode flag (a knee's flexing or extending damper) from the sign
    of its event at each phase's first state; the NLP holds that sign there, so that its
    fixed modes are the simulator's from the first RK4 step on."""
    problem, hs, fp = paper_gait
    nlp = ShootingNLP(problem, fp.state, fp.parameters, hs=hs)
    g = ca.Function("g", [nlp.w], [nlp.g])(nlp.w0).full().ravel()
    first = ca.Function("x_first", [nlp.w], [X[:, 0] for X in nlp.X]).call([nlp.w0])
    checked = 0
    for k, s in enumerate(nlp.specs):
        if k and nlp.specs[k - 1].phase == s.phase:
            continue  # a segment after a mode switch inside its phase
        x0 = first[k].full().ravel()
        mode = dict(zip(hs.mode_keys, s.mode, strict=True))
        read = hs.refresh_indicators(s.phase, x0, fp.parameters, mode)
        assert read == mode  # the guess (the simulated gait) begins each phase so
        evs = hs.event_list[s.phase]
        for i, sign in s.first_signs.items():
            assert evs[i].indicator and sign == (1.0 if mode[evs[i].indicator] else -1.0)
            rows = [j for j, n in enumerate(nlp.g_names) if n == f"first_sign[{k}]:{evs[i].name}"]
            assert len(rows) == 1 and g[rows[0]] > 0
            checked += 1
    assert checked >= 2  # the swing knee's rate in phase I, the trailing knee's in III


def test_a_guard_zero_at_its_phase_start_by_construction_is_not_crossed():
    """The kneed walker's new swing knee is locked straight at heel strike, so the guard of
    its knee strike (the knee angle) is zero when the swing phase begins, to rounding: the
    knee flexes first and strikes later, and the gait stays valid."""
    from pdw_casadi.model.margins import GUARD_ROUNDOFF

    problem = load_problem("kneed_walker")
    hs = gait_system(problem)
    fp = find_fixed_point(problem)
    assert fp.converged
    ahead = {k: v for k, v in fp.margins.items() if hs.margin_specs.get(k) is GUARD_AHEAD}
    assert "heel_strike:knee_strike_ahead" in ahead
    assert abs(ahead["heel_strike:knee_strike_ahead"]) <= GUARD_ROUNDOFF
    assert fp.valid and validity_failure(fp.margins, problem, hs) is None
