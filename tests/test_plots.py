"""Plot functions: they draw on the caller's axes (``ax=``) and return the Figure, write the
format of the file's extension, and keep their legends off the data."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.report.plots import plot_angles, plot_fit, plot_limit_cycle, plot_stick


@pytest.fixture(scope="module")
def walk(compass_steps):
    _, hs, p, res = compass_steps
    return hs, res.trajectory, p


def _renderer(fig):
    FigureCanvasAgg(fig).draw()
    return fig.canvas.get_renderer()


def test_plots_draw_on_the_given_axes_and_return_their_figure(walk):
    hs, traj, p = walk
    fig = Figure()
    axes = fig.subplots(2, 1)
    assert plot_stick(hs, traj, p, ax=axes) is fig
    assert all(len(ax.lines) > 0 for ax in axes)
    own = plot_limit_cycle(traj, legs=(("q_st",), ("q_sw",)))
    assert isinstance(own, Figure) and own is not fig and len(own.axes) == 1
    with pytest.raises(ValueError, match="needs 2 axes"):
        plot_stick(hs, traj, p, ax=axes[0])


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF"),
                                           (".svg", b"<?xml")])
def test_the_file_format_follows_the_extension(walk, tmp_path, suffix, magic):
    _, traj, _ = walk
    path = tmp_path / f"angles{suffix}"
    plot_angles(traj, path)
    assert path.read_bytes().startswith(magic)


def test_legends_sit_outside_the_data(walk):
    _, traj, _ = walk
    human = load_gait_curves("female_fast.csv").resample(101)
    model = pd.DataFrame({"cycle_pct": human.cycle_pct, "knee_deg": human.knee_deg + 5,
                          "hip_deg": human.hip_deg - 5})
    figs = [plot_angles(traj), plot_limit_cycle(traj, legs=(("q_st",), ("q_sw",))),
            plot_fit(human, {"shifted": model}, scores={"shifted": {"r2_knee": 0.5}})]
    n_legends = 0
    for fig in figs:
        r = _renderer(fig)
        for ax in fig.axes:
            leg = ax.get_legend()
            if leg is None:
                continue
            n_legends += 1
            box, data = leg.get_window_extent(r), ax.get_window_extent(r)
            inter_w = min(box.x1, data.x1) - max(box.x0, data.x0)
            inter_h = min(box.y1, data.y1) - max(box.y0, data.y0)
            assert inter_w <= 1 or inter_h <= 1, (fig.axes.index(ax), box, data)
            # and inside the figure (constrained layout made room for it)
            assert box.x1 <= fig.bbox.x1 + 1 and box.y0 >= fig.bbox.y0 - 1
    assert n_legends == 4
    assert np.isfinite(figs[2].axes[0].get_ylim()).all()
