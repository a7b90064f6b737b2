"""The homotopies' step rule (the prosthesis design's mass homotopy, the design continuation's
lambda): a rejected solve is never repeated at the same point."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from pdw_casadi.gait.design import next_homotopy_step


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
