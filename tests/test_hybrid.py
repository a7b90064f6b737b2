"""Transitions keyed by (phase, guard): a phase may end on different guards, each with its
own transition."""

from __future__ import annotations

import numpy as np
import pytest

from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.hybrid import GUARD, Event, HybridSystem, make_transition
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.walkers import get_family


def _compass_with_passing_guard():
    """The compass gait whose swing phase also ends when the legs pass each other
    (q_sw - q_st through 0 upward), continuing in the same phase without an impact."""
    problem = load_problem("compass_gait")
    model = get_family("compass_gait").build(problem)
    q = model.system.q
    phase = model.phases[0]
    phase.events = [*phase.events, Event("passing", q[1] - q[0], +1, GUARD,
                                         "the swing leg passes the stance leg")]
    model.transitions[0].guard = "heel_strike"
    model.transitions.append(make_transition(model.system, "passing", "swing", "swing", None,
                                             guard="passing"))
    return problem, model


def test_a_phase_ends_in_the_transition_of_the_guard_it_reaches():
    problem, model = _compass_with_passing_guard()
    hs = HybridSystem(model)
    assert set(hs.transitions) == {("swing", "heel_strike"), ("swing", "passing")}
    x0, p = problem.state_vector(), problem.parameter_vector()
    res = Simulator(problem, hs).run(x0, p, steps=1, record=True)
    assert res.failure is None
    guards = res.events[res.events["kind"] == "guard"]["event"].tolist()
    assert guards == ["passing", "heel_strike"]
    # the passing transition is the identity: the step is the plain compass gait's, up to
    # the RK4 grid restarting at the passing instant (h = 5e-4 s, 4th order)
    plain = Simulator(problem).run(x0, p, steps=1, record=False)
    assert [ph for ph, _ in res.steps[0].phases] == ["swing", "swing"]
    assert res.steps[0].step_time == pytest.approx(plain.steps[0].step_time, abs=1e-9)
    np.testing.assert_allclose(res.steps[0].x_section_end, plain.steps[0].x_section_end,
                               atol=1e-8)


def test_ambiguous_transitions_are_refused():
    _, model = _compass_with_passing_guard()
    model.transitions[0].guard = None  # two guards in the phase: the transition must say
    with pytest.raises(ValueError, match="must name the guard"):
        HybridSystem(model)
    model.transitions[0].guard = "passing"
    with pytest.raises(ValueError, match="two transitions leave phase 'swing'"):
        HybridSystem(model)
