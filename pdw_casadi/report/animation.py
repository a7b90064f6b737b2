"""The walker walking down the slope: an animated GIF of a simulation.

Within a step the model's coordinates put the stance toe (foot) at the origin; at every
foot strike the legs swap and the new stance foot is placed at the origin again. To walk
on, step k is drawn shifted along the slope by the sum of the earlier step lengths,
offset_k = sum_{j<k} L_j (cos gamma, -sin gamma): the new stance foot lands where the old
swing foot struck. The figure is derived from the one model (its named ``points`` and
``links``, as :func:`pdw_casadi.report.plots.plot_stick`), never from a second copy of the
kinematics. Frames are sampled in simulation time (real time at ``fps``), matplotlib's
``FuncAnimation`` draws them and the pillow writer saves the GIF.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pdw_casadi.report.plots import FOOT_POINTS

#: joints drawn as open circles (when the walker has them)
JOINTS = ("knee1", "knee2", "ankle1", "ankle2")


@dataclass
class WalkFrames:
    """World positions of the walker's named points at the animation frames.

    ``time``: simulation time of each frame (s); ``step``: the step each frame belongs to;
    ``points``: name -> array (frames, 2) of (x, y) in m, ground y = -x tan(slope);
    ``links``: pairs of point names drawn as segments; ``slope``: rad.
    """

    time: np.ndarray
    step: np.ndarray
    points: dict[str, np.ndarray]
    links: list[tuple[str, str]]
    slope: float

    def __len__(self) -> int:
        return len(self.time)


def walk_frames(hs, result, p, fps: float = 25.0) -> WalkFrames:
    """Sample a recorded simulation (``SimulationResult`` with a trajectory) at ``fps``
    frames per simulated second and place each step at its position down the slope."""
    traj = result.trajectory
    if traj is None or traj.empty:
        raise ValueError("the simulation has no recorded trajectory (run with record=True)")
    p = np.asarray(p, dtype=float).ravel()
    gamma = float(p[hs.model.parameter_names.index("slope")])
    downhill = np.array([np.cos(gamma), -np.sin(gamma)])
    lengths = [s.step_length for s in result.steps]
    offsets = np.vstack([np.zeros(2)] + [np.nansum(lengths[:k + 1]) * downhill
                                         for k in range(len(lengths))])
    t = traj["t"].to_numpy()
    frame_t = np.arange(t[0], t[-1], 1.0 / fps)
    frame_t = np.append(frame_t, t[-1]) if frame_t[-1] < t[-1] else frame_t
    rows = np.clip(np.searchsorted(t, frame_t, side="right") - 1, 0, len(t) - 1)
    q_names = list(hs.model.q_names)
    q = traj[q_names].to_numpy()[rows]
    qd = traj[["d" + n for n in q_names]].to_numpy()[rows]
    steps = traj["step"].to_numpy()[rows].astype(int)
    x = np.zeros((hs.nx, len(rows)))
    x[: 2 * len(q_names)] = np.hstack([q, qd]).T
    names = list(hs.point_names)
    pts = {n: np.empty((len(rows), 2)) for n in names}
    for i in range(len(rows)):
        P = np.asarray(hs.points(x[:, i], p)) + offsets[steps[i]][:, None]
        for j, n in enumerate(names):
            pts[n][i] = P[:, j]
    return WalkFrames(frame_t, steps, pts, list(hs.model.links), gamma)


def animate_walk(hs, result, p, path, fps: float = 25.0, title: str | None = None,
                 dpi: int = 80) -> Path:
    """Write an animated GIF of the walker over all simulated steps (feet, knees, hip and
    the sloped ground visible). Returns the path written."""
    path = Path(path)
    frames = walk_frames(hs, result, p, fps)
    allpts = np.concatenate(list(frames.points.values()))
    xlo, xhi = allpts[:, 0].min() - 0.2, allpts[:, 0].max() + 0.2
    ylo, yhi = allpts[:, 1].min() - 0.1, allpts[:, 1].max() + 0.15
    # a figure of its own canvas, outside pyplot: the user's backend is left alone
    fig = Figure(figsize=(min(12.0, 2.0 + 2.2 * (xhi - xlo)), 4.0), layout="tight")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    xs = np.array([xlo, xhi])
    ground = -xs * np.tan(frames.slope)
    ax.fill_between(xs, ground, ground - 0.1, color="0.85", lw=0)
    ax.plot(xs, ground, color="k", lw=1.2)
    segs = []
    for a, b in frames.links:
        foot = a.startswith(FOOT_POINTS) and b.startswith(FOOT_POINTS)
        (line,) = ax.plot([], [], color="tab:blue", lw=4.0 if foot else 2.2,
                          solid_capstyle="round")
        segs.append((line, a, b))
    joints = [n for n in JOINTS if n in frames.points]
    (joint_marks,) = ax.plot([], [], "o", ms=5, color="tab:blue", mfc="white", mew=1.2)
    (hip_mark,) = ax.plot([], [], "o", ms=9, color="tab:blue")
    label = ax.text(0.01, 0.97, "", transform=ax.transAxes, va="top", fontsize=9)
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(min(ylo, ground.min() - 0.1), yhi)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"Passive walking down a slope of {np.degrees(frames.slope):.2f} deg",
                 fontsize=10)

    def draw(i):
        P = {n: v[i] for n, v in frames.points.items()}
        for line, a, b in segs:
            line.set_data([P[a][0], P[b][0]], [P[a][1], P[b][1]])
        if joints:
            joint_marks.set_data([P[n][0] for n in joints], [P[n][1] for n in joints])
        hip_mark.set_data([P["hip"][0]], [P["hip"][1]])
        label.set_text(f"t = {frames.time[i]:.2f} s   step {frames.step[i] + 1}")
        return [s[0] for s in segs] + [joint_marks, hip_mark, label]

    anim = FuncAnimation(fig, draw, frames=len(frames), interval=1000.0 / fps, blit=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    anim.save(path, writer=PillowWriter(fps=fps), dpi=dpi)
    return path
