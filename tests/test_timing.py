"""Gait timing (pdw_casadi.gait.timing) against the simulator's own event times."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import (
    HUMAN_NORMS,
    gait_timing,
    human_timing,
    phase_contacts,
    step_timing,
    timing_table,
)
from pdw_casadi.model.problem import load_problem


def _guards(events, step, name):
    rows = events[(events.kind == "guard") & (events.step == step) & (events.event == name)]
    assert len(rows) == 1, (step, name)
    return float(rows.t.iloc[0])


def test_6link_phase_percentages_match_event_times(problem):
    """At a fixed point, leg A (leg 2 in step 0, leg 1 in step 1, leg 2 in step 2) lands at
    step 0's heel strike, is flat at its foot strike, lifts its heel at step 1's heel strike
    (of leg B) and its toe at step 2's toe-off; leg B leaves at step 1's toe-off."""
    fp = find_fixed_point(problem)
    assert fp.converged
    res = Simulator(problem).run(fp.state, fp.parameters, steps=3, record=False)
    assert res.failure is None
    ev = res.events
    hs0, hs1, hs2 = (_guards(ev, k, "heel_strike") for k in range(3))
    fs0 = _guards(ev, 0, "foot_strike")
    to1, to2 = _guards(ev, 1, "toe_off"), _guards(ev, 2, "toe_off")
    T = hs2 - hs0
    t = step_timing(problem.family, res.steps[1])

    def pct(x):
        return 100 * (x - hs0) / T

    tol = 1e-6  # %: the fixed point repeats to 1e-10 in the state
    assert t.cycle_time_s == pytest.approx(T, abs=1e-8)
    assert t.foot_flat_pct == pytest.approx(pct(fs0), abs=tol)
    assert t.heel_off_pct == pytest.approx(pct(hs1), abs=tol)
    assert t.toe_off_pct == pytest.approx(pct(to2), abs=tol)
    assert t.stance_pct == pytest.approx(pct(to2), abs=tol)
    assert t.swing_pct == pytest.approx(100 - pct(to2), abs=tol)
    assert len(t.double_support_pct) == 2
    assert t.double_support_pct[0] == pytest.approx(pct(to1), abs=tol)
    assert t.double_support_pct[1] == pytest.approx(pct(to2) - pct(hs1), abs=tol)
    assert t.cadence_steps_min == pytest.approx(120 / T, rel=1e-8)
    sl = res.steps[1].step_length
    assert t.speed_m_s == pytest.approx(2 * sl / T, rel=1e-8)


def test_point_foot_walkers_exchange_support_instantly():
    """Compass gait: stance is exactly the step (50 %), no double support, no foot flat or
    heel off; the cycle is the time between two heel strikes of one leg."""
    pb = load_problem("compass_gait")
    fp = find_fixed_point(pb)
    res = Simulator(pb).run(fp.state, fp.parameters, steps=2, record=False)
    ev = res.events
    T = _guards(ev, 1, "heel_strike") - _guards(ev, 0, "heel_strike") + res.steps[0].step_time
    t = step_timing(pb.family, res.steps[0], res.steps[1])
    assert t.cycle_time_s == pytest.approx(T, rel=1e-9)
    assert t.stance_pct == pytest.approx(50.0, abs=1e-6)
    assert t.double_support_pct == ()
    assert t.foot_flat_pct is None and t.heel_off_pct is None
    assert t.toe_off_pct == pytest.approx(50.0, abs=1e-6)
    json.dumps(t.to_dict(), allow_nan=False)  # JSON-ready with its units, no NaN


@settings(max_examples=50, deadline=None)
@given(st.floats(1e-4, 0.3), st.floats(0.05, 1.0), st.floats(1e-4, 0.3))
def test_6link_timing_algebra(t1, t2, t3):
    """Stance = step + phase I + phase III; each double support = phase I + phase III; toe
    off = 50 % + one double support; the heel lifts at 50 % (the other heel strikes)."""
    t = gait_timing([("I", t1), ("II", t2), ("III", t3)], 0.5, phase_contacts("humanlike_6link"))
    T = 2 * (t1 + t2 + t3)
    assert t.stance_pct == pytest.approx(100 * (T / 2 + t1 + t3) / T)
    assert t.double_support_pct == pytest.approx((100 * (t1 + t3) / T,) * 2)
    assert t.toe_off_pct == pytest.approx(50 + t.double_support_pct[0])
    assert t.heel_off_pct == pytest.approx(50)
    assert t.foot_flat_pct == pytest.approx(100 * t3 / T)


def test_curve_file_timing_columns_override_the_norms(tmp_path):
    from pdw_casadi.model.gait_data import load_gait_curves

    src = load_gait_curves("female_fast.csv").to_frame()
    src["toe_off_pct"] = 58.5
    path = tmp_path / "own.csv"
    src.to_csv(path, index=False)
    values, source = human_timing(load_gait_curves(path))
    assert values["toe_off_pct"] == 58.5 and values["stance_pct"] == 58.5
    assert values["swing_pct"] == pytest.approx(41.5)
    assert "toe_off_pct" in source
    assert human_timing(None)[0]["toe_off_pct"] == HUMAN_NORMS["toe_off_pct"]
    table = timing_table({"x": gait_timing([("I", 0.01), ("II", 0.5), ("III", 0.02)], 0.6,
                                           phase_contacts("humanlike_6link"))})
    # toe off = 50 % + (0.01 + 0.02) / 1.06 of the cycle, beside the human 60 %
    assert "| toe off (% cycle) | 52.8 | 60.0 |" in table


def test_fit_timing_term_is_the_simulators_stance(problem):
    """The stance % that pdw-fit --timing puts in the objective, from the NLP's own segment
    durations, is the simulator's stance % at the starting gait."""
    import casadi as ca

    from pdw_casadi.fit.driver import stance_pct_expr
    from pdw_casadi.nlp.shooting import ShootingNLP

    fp = find_fixed_point(problem)
    nlp = ShootingNLP(problem, fp.state, fp.parameters, free=("c_ankle",))
    stance = float(ca.Function("s", [nlp.w], [stance_pct_expr(nlp)])(nlp.w0))
    run = Simulator(problem).run(fp.state, fp.parameters, steps=1, record=False)
    assert stance == pytest.approx(step_timing(problem.family, run.steps[0]).stance_pct,
                                   abs=1e-9)
