"""The walking animation: steps placed end to end down the slope, feet on the ground, and
the GIF written by ``pdw-simulate --animate``."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from pdw_casadi.cli import simulate_main
from pdw_casadi.report.animation import walk_frames

FPS = 25


@pytest.fixture(scope="module")
def compass_walk(compass_steps):
    pb, hs, p, res = compass_steps
    return pb, hs, res, walk_frames(hs, res, p, fps=FPS)


def test_walk_frames_place_steps_end_to_end(compass_walk):
    pb, hs, res, fr = compass_walk
    n = np.array([np.sin(pb.slope), np.cos(pb.slope)])  # ground normal
    downhill = np.array([np.cos(pb.slope), -np.sin(pb.slope)])
    assert set(fr.step) == {0, 1, 2} and len(fr) == pytest.approx(
        FPS * sum(s.step_time for s in res.steps), abs=2)
    # the stance foot of step k rests on the ground where the earlier steps put it
    lengths = [s.step_length for s in res.steps]
    for k in range(3):
        foot = fr.points["foot1"][fr.step == k]
        np.testing.assert_allclose(foot @ n, 0.0, atol=1e-9)
        np.testing.assert_allclose(foot @ downhill, sum(lengths[:k]), atol=1e-9)
    # the hip stays above the ground; the swing foot dips below it only around mid-stance
    # (the rigid compass gait's foot scuffing, ignored by the model as in the literature)
    # and is back on the ground at heel strike (the last frame is the last heel strike)
    assert (fr.points["hip"] @ n).min() > 0.5
    assert fr.points["foot2"][-1] @ n == pytest.approx(0.0, abs=1e-9)
    assert fr.points["foot2"][-1] @ downhill == pytest.approx(sum(lengths), abs=1e-9)
    # the hip moves continuously across the leg swaps: no jump of a step length
    hip = fr.points["hip"]
    speed = max(s.step_length / s.step_time for s in res.steps)
    assert np.linalg.norm(np.diff(hip, axis=0), axis=1).max() < 3 * speed / FPS
    assert (hip[-1] - hip[0]) @ downhill > 2 * min(lengths)


def test_simulate_animate_writes_a_gif(tmp_path, compass_walk):
    _, _, _, fr = compass_walk
    gif = tmp_path / "anim" / "walk.gif"
    assert simulate_main(["--problem", "compass_gait", "--steps", "3", "--out",
                          str(tmp_path / "run"), "--animate", str(gif), "--fps",
                          str(FPS)]) == 0
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == len(fr)
