"""The homotopies' step rule (the prosthesis design's mass homotopy, the design continuation's
lambda): a rejected solve is never repeated at the same point."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from pdw_casadi.gait.design import next_homotopy_step
from pdw_casadi.studies.prosthesis import STOP_TOL, homotopy_level, homotopy_step_after


@given(done=st.floats(0.0, 0.99), nominal=st.floats(1e-3, 0.25), rejections=st.integers(1, 12))
def test_rejected_steps_try_a_new_point_each_time(done, nominal, rejections):
    """As the loops use it (point = min(done + step, end)): after each rejected solve the
    next point lies strictly between the last accepted one and the point just tried, also
    where the nominal step reaches past the end."""
    end, max_step = 1.0, 0.25
    step = nominal
    point = min(done + step, end)
    for _ in range(rejections):
        step = next_homotopy_step(point - done, False, max_step)
        nxt = min(done + step, end)
        assert done < nxt < point
        assert abs((nxt - done) - (point - done) / 2) < 1e-15
        point = nxt


def test_accepted_steps_double_up_to_the_largest_step():
    assert next_homotopy_step(0.003, True, 0.1) == 0.006
    assert next_homotopy_step(0.08, True, 0.1) == 0.1


@given(first=st.floats(1e-3, 0.05), stops=st.lists(st.floats(0.01, 0.29), max_size=4),
       outcomes=st.lists(st.booleans(), min_size=60, max_size=60))
def test_the_mass_homotopy_lands_on_every_stop(first, stops, outcomes):
    """The design loop's rule (studies/prosthesis.py): whatever solves are accepted or
    rejected, every accepted point lies on the way to the end, no solve passes a stop it
    has not reached, and a run that reaches the end has landed on every stop exactly."""
    lighter, max_step = 0.3, 0.1
    done, step, path = 0.0, first, [0.0]
    for ok in outcomes:
        level, stopped = homotopy_level(done, step, lighter, stops)
        ahead = [s for s in stops if s > done + STOP_TOL]
        assert done < level <= lighter
        assert all(level <= s + STOP_TOL for s in ahead)
        assert stopped == (level < min(done + step, lighter))
        step = homotopy_step_after(step, level - done, stopped, ok, max_step)
        if ok:
            done = level
            path.append(level)
        if done >= lighter or step < 1e-9:
            break
    if done >= lighter:
        assert all(any(abs(p - s) <= STOP_TOL for p in path) for s in stops)


def test_a_stop_does_not_shorten_the_next_step():
    """At 0.09 with the step 0.04 and a stop at 0.1: the solve lands on 0.1 and the next
    step doubles the 0.04, not the 0.01 the stop left."""
    level, stopped = homotopy_level(0.09, 0.04, 0.3, (0.1, 0.2))
    assert (level, stopped) == (0.1, True)
    assert homotopy_step_after(0.04, level - 0.09, stopped, True, 0.1) == 0.08
    # rejected, the step tried is halved as always
    assert homotopy_step_after(0.04, level - 0.09, stopped, False, 0.1) == (level - 0.09) / 2
    assert homotopy_level(0.1, 0.08, 0.3, (0.1, 0.2)) == (0.18, False)
    assert homotopy_level(0.18, 0.08, 0.3, (0.1, 0.2)) == (0.2, True)
