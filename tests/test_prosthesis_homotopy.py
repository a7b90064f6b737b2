"""The prosthesis design's mass homotopy: a rejected solve is never repeated at the same mass."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from pdw_casadi.prosthesis import next_mass_step


@given(done=st.floats(0.0, 0.29), nominal=st.floats(1e-3, 0.1),
       rejections=st.integers(1, 12))
def test_rejected_steps_try_a_new_lighter_level_each_time(done, nominal, rejections):
    """After each rejected solve the next level lies strictly between the last accepted one
    and the level just tried, also where the nominal step reaches past the target (30 %)."""
    lighter, max_step = 0.3, 0.1
    step = nominal
    level = min(done + step, lighter)
    for _ in range(rejections):
        step = next_mass_step(level - done, step, False, max_step)
        nxt = min(done + step, lighter)
        assert done < nxt < level
        assert abs((nxt - done) - (level - done) / 2) < 1e-15
        level = nxt


def test_accepted_steps_double_up_to_the_largest_step():
    assert next_mass_step(0.003, 0.003, True, 0.1) == 0.006
    assert next_mass_step(0.08, 0.08, True, 0.1) == 0.1
    # capped by the target: the nominal step keeps growing, the level stays the target
    assert next_mass_step(0.011, 0.1, True, 0.1) == 0.1
