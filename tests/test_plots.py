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
    assert n_legends == 3  # plot_fit: one legend for both panels
    assert np.isfinite(figs[2].axes[0].get_ylim()).all()


def test_the_fit_figure_has_one_legend_a_title_and_labelled_events():
    """fit.png: the title names the curve file and the walker, the axes say the sign
    convention, one legend serves both panels (each model once, with both R^2) and each gait
    event is one legend entry whose line style says the event and colour the source."""
    human = load_gait_curves("female_fast.csv").resample(101)
    model = pd.DataFrame({"cycle_pct": human.cycle_pct, "knee_deg": human.knee_deg + 5,
                          "hip_deg": human.hip_deg - 5})
    markers = {"human toe off": 60.0, "fit foot flat": 0.8, "fit heel off": 50.0,
               "fit toe off": 51.1}
    fig = plot_fit(human, {"this fit": model}, markers=markers, walker="humanlike_6link",
                   scores={"this fit": {"r2_knee": 0.857, "r2_hip": 0.805}})
    title = fig._suptitle.get_text()
    assert "female_fast.csv" in title and "humanlike_6link" in title
    assert [ax.get_ylabel() for ax in fig.axes] == ["knee flexion (deg, + flexion)",
                                                    "hip flexion (deg, + flexion)"]
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 1 and not fig.legends
    texts = [t.get_text() for t in legends[0].get_texts()]
    assert len(texts) == len(set(texts)) == 3 + len(markers)
    assert "this fit\nR$^2$: knee 0.857, hip 0.805" in texts
    for label, pct in markers.items():
        assert texts.count(f"{label} ({pct:.1f} %)") == 1
    lines = {t.get_text(): h for t, h in zip(legends[0].get_texts(),
                                              legends[0].legend_handles, strict=True)}
    style = {k.split(" (")[0]: (h.get_color(), h.get_linestyle()) for k, h in lines.items()
             if k.split(" (")[0] in markers}
    # the same event in the same style, the same source in the same colour
    assert style["human toe off"][1] == style["fit toe off"][1]
    assert style["human toe off"][0] != style["fit toe off"][0]
    assert len({style[k][1] for k in ("fit foot flat", "fit heel off", "fit toe off")}) == 3
    assert len({style[k][0] for k in ("fit foot flat", "fit heel off", "fit toe off")}) == 1
    # each event is drawn on both panels
    for ax in fig.axes:
        assert sum(len(line.get_xdata()) == 2 and line.get_xdata()[0] == 50.0
                   for line in ax.lines) == 1


def _label_boxes(fig):
    r = _renderer(fig)
    return [[t.get_window_extent(r) for t in ax.texts] for ax in fig.axes]


def test_the_limit_cycle_is_in_degrees_with_a_key_and_labels_that_do_not_overlap(walk):
    _, traj, _ = walk
    fig = plot_limit_cycle(traj, legs=(("q_st",), ("q_sw",)), walker="compass_gait")
    ax = fig.axes[0]
    assert "deg" in ax.get_xlabel() and ax.get_ylabel() == "angular velocity (deg/s)"
    assert "compass_gait" in fig._suptitle.get_text()
    step0 = traj[traj["step"] == 0]
    np.testing.assert_allclose(ax.lines[0].get_xdata(), np.degrees(step0["q_st"]))
    np.testing.assert_allclose(ax.lines[0].get_ydata(), np.degrees(step0["dq_st"]))
    key = [t.get_text() for t in ax.get_legend().get_texts()]
    assert key[:2] == ["step 1 (stance)", "step 2 (swing)"]
    assert key[2:] == ["section+: just after the section transition (start of the step)",
                       "section-: just before the section transition (end of the step)"]
    for boxes in _label_boxes(fig):
        assert boxes and not any(a.overlaps(b) for i, a in enumerate(boxes)
                                 for b in boxes[i + 1:])


def test_the_six_link_limit_cycle_key_explains_the_papers_labels(table2_step, problem):
    from pdw_casadi.model.faces import walker_faces

    fig = plot_limit_cycle(table2_step.trajectory, faces=walker_faces(problem))
    assert fig._suptitle.get_text().startswith(problem.family)
    key = [t.get_text() for t in fig.axes[-1].get_legend().get_texts()]
    assert key[1:] == ["a+: just after foot strike (start of the step)", "b: toe off",
                       "c-: just before heel strike", "c+: just after heel strike",
                       "a-: just before foot strike (end of the step)"]
    markers = [h.get_marker() for h in fig.axes[-1].get_legend().legend_handles[1:]]
    assert len(set(markers)) == 5  # one shape per instant: the key tells them apart
    for ax, boxes in zip(fig.axes, _label_boxes(fig), strict=True):
        assert [t.get_text() for t in ax.texts] == ["a+", "b", "c-", "c+", "a-"]
        assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def test_the_walker_diagram_draws_the_chain_of_the_model_page():
    """plot_walker (the docs' walker figure): the drawn points are those of the chain of
    docs/model.md at the section state of ``humanlike_6link.toml``, computed here from the
    problem's lengths alone: stance toe at the origin, both feet flat on the slope, each
    link at the absolute angle (from the downward vertical, counter-clockwise) of its
    coordinate, which the figure labels."""
    from pdw_casadi.model.problem import load_problem
    from pdw_casadi.model.system import hybrid_system
    from pdw_casadi.report.plots import link_angles, plot_walker

    problem = load_problem("humanlike_6link")
    hs = hybrid_system(problem)
    p = problem.parameter_vector()
    fig = Figure()
    ax = fig.subplots()
    assert plot_walker(hs, problem.state_vector(), p, ax=ax) is fig
    drawn = {line.get_gid(): np.array([line.get_xdata()[0], line.get_ydata()[0]])
             for line in ax.lines if line.get_gid()}
    x = np.asarray(hs.section_to_full(problem.state_vector(), p)).ravel()
    q = dict(zip(hs.model.q_names, x, strict=False))
    a, gamma = problem.anthropometry, problem.slope

    def d(angle):  # the unit vector of a link from its proximal end (docs/model.md)
        return np.array([np.sin(angle), -np.cos(angle)])

    toe1 = np.array([q["x_t1"], q["y_t1"]])
    ankle1 = toe1 - a["l_ft"] * d(q["qf1"])
    knee1 = ankle1 - a["l_s"] * d(q["q1"])
    hip = knee1 - a["l_t"] * d(q["q2"])
    knee2 = hip + a["l_t"] * d(q["q3"])
    ankle2 = knee2 + a["l_s"] * d(q["q4"])
    toe2 = ankle2 + a["l_ft"] * d(q["qf2"])
    chain = {"toe1": toe1, "ankle1": ankle1, "knee1": knee1, "hip": hip, "knee2": knee2,
             "ankle2": ankle2, "toe2": toe2, "heel1": ankle1 - a["l_fh"] * d(q["qf1"]),
             "heel2": ankle2 - a["l_fh"] * d(q["qf2"])}
    assert set(drawn) == set(chain)
    for name, point in chain.items():
        np.testing.assert_allclose(drawn[name], point, atol=1e-12, err_msg=name)
    n = np.array([np.sin(gamma), np.cos(gamma)])  # the ground's normal: heights P . n
    assert np.allclose(drawn["toe1"], 0.0)
    for name in ("toe1", "heel1", "toe2"):
        assert abs(drawn[name] @ n) < 1e-12, name  # the feet on the ground
    assert abs(q["qf1"] - (np.pi / 2 - gamma)) < 1e-12  # the stance foot flat
    assert drawn["hip"] @ n > 0.7  # the hip well above the ground
    # every link is labelled with its coordinate, whose value it is drawn at
    assert link_angles(hs, x, p) == {("heel1", "toe1"): "qf1", ("knee1", "ankle1"): "q1",
                                     ("hip", "knee1"): "q2", ("hip", "knee2"): "q3",
                                     ("knee2", "ankle2"): "q4", ("heel2", "toe2"): "qf2"}
    labels = " ".join(t.get_text() for t in ax.texts)
    for name in ("q_{1}", "q_{2}", "q_{3}", "q_{4}", "q_{f1}", "q_{f2}"):
        value = np.degrees(q[name.replace("_{", "").replace("}", "")])
        assert f"${name}$ = {value:+.1f}°" in labels, name
    assert f"slope $\\gamma$ = {gamma:.4f} rad" in labels
