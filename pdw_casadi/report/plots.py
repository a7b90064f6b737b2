"""Figures of a simulated gait: joint angles over time and stick-figure snapshots.

Every function returns a matplotlib :class:`~matplotlib.figure.Figure`: drawn on the
caller's axes (``ax=``, one Axes or a sequence, as the function says) or on a new figure
that belongs to no pyplot window (so importing or calling these never changes the backend,
and a notebook shows the returned figure). With ``path`` the figure is also written there,
in the format of the file's extension (PNG, PDF, SVG). Legends sit outside the data. Angles
are in degrees, time in seconds, lengths in metres.

Leg naming: the model relabels its legs at every foot strike (leg 1 is always the stance
leg at the start of a step). The angle plot follows the *physical* legs instead: leg A is
the model's leg 1 in even steps (0, 2, ...) and its leg 2 in odd steps, so each curve is
continuous across steps.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.cm import ScalarMappable
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.lines import Line2D
from matplotlib.patches import Arc
from matplotlib.textpath import text_to_path

from pdw_casadi.model.faces import WalkerFaces, faces_from_trajectory

__all__ = ["link_angles", "phase_spans", "physical_leg_angles", "plot_angles", "plot_fit",
           "plot_limit_cycle", "plot_stick", "plot_sweep", "plot_walker", "snapshot_rows"]

LEG_COLORS = {"A": "tab:blue", "B": "tab:red"}
#: name prefixes of a foot's drawn points: a link between two of them is drawn as the sole
FOOT_POINTS = ("toe", "heel", "mtp")
JOINT_LABELS = {"knee": "knee flexion [deg]", "hip": "hip: thigh from slope normal [deg]"}


#: a legend to the right of its axes, outside the data
OUTSIDE_RIGHT = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}
#: a legend below its axes, outside the data
OUTSIDE_BELOW = {"loc": "upper center", "bbox_to_anchor": (0.5, -0.16), "borderaxespad": 0.0}


def _axes(ax, nrows: int, ncols: int, figsize, **kw) -> tuple[Figure, list]:
    """The figure and its ``nrows`` x ``ncols`` axes (row-major): the caller's ``ax`` (an
    Axes or a sequence of that many), or a new figure with constrained layout."""
    n = nrows * ncols
    if ax is None:
        fig = Figure(figsize=figsize, layout="constrained")
        return fig, list(fig.subplots(nrows, ncols, squeeze=False, **kw).ravel())
    axes = list(np.ravel(np.asarray(ax, dtype=object)))
    if len(axes) != n:
        raise ValueError(f"ax: this figure needs {n} axes, got {len(axes)}")
    return axes[0].figure, axes


def _save(fig: Figure, path, dpi: int) -> Figure:
    """Write ``fig`` to ``path`` (format from its extension) when a path is given."""
    if path is not None:
        fig.savefig(Path(path), dpi=dpi)
    return fig


def _faces(trajectory, faces: WalkerFaces | None) -> WalkerFaces:
    return faces if faces is not None else faces_from_trajectory(trajectory)


def phase_spans(trajectory: pd.DataFrame) -> list[tuple[int, str, float, float]]:
    """Contiguous (step, phase, t_start, t_end) runs of the trajectory, in time order (s).

    A run is a stretch of rows with the same ``step`` (the simulator's step index) and
    phase: consecutive steps of a one-phase walker are separate runs. A phase starts at the
    end of the previous one (the trajectory's first row of a phase is one integration step
    after its start); the first phase of the trajectory starts at the start of its step,
    taken as the first recorded time minus one sample.
    """
    if trajectory is None or trajectory.empty:
        return []
    t = trajectory["t"].to_numpy()
    key = list(zip(_run_steps(trajectory), trajectory["phase"].to_numpy(), strict=True))
    spans = []
    start = 0
    t_prev = t[0] - (t[1] - t[0]) if len(t) > 1 else t[0]
    t_prev = max(t_prev, 0.0)
    for i in range(1, len(t) + 1):
        if i == len(t) or key[i] != key[start]:
            spans.append((int(key[start][0]), str(key[start][1]), float(t_prev), float(t[i - 1])))
            t_prev = t[i - 1]
            start = i
    return spans


def _run_steps(trajectory: pd.DataFrame) -> np.ndarray:
    """The step index of each row, as recorded by the simulator (every row of a step,
    including the state at its last event, carries the step's index)."""
    return trajectory["step"].to_numpy().astype(int)


def physical_leg_angles(trajectory: pd.DataFrame,
                        joints=("knee", "hip")) -> dict[str, dict[str, np.ndarray]]:
    """Joint angles (deg) of the physical legs A and B (see the module docstring), for the
    ``joints`` that the trajectory has (``<joint>1_deg``, ``<joint>2_deg`` columns)."""
    odd = (_run_steps(trajectory) % 2) == 1
    out: dict[str, dict[str, np.ndarray]] = {"A": {}, "B": {}}
    for joint in joints:
        if f"{joint}1_deg" not in trajectory or f"{joint}2_deg" not in trajectory:
            continue
        one = trajectory[f"{joint}1_deg"].to_numpy()
        two = trajectory[f"{joint}2_deg"].to_numpy()
        out["A"][joint] = np.where(odd, two, one)
        out["B"][joint] = np.where(odd, one, two)
    return out


def _shade_phases(axes, spans, label_ax, faces: WalkerFaces) -> None:
    total = spans[-1][3] - spans[0][2] if spans else 0.0
    for _step, phase, t0, t1 in spans:
        for ax in axes:
            ax.axvspan(t0, t1, color=faces.phase_color(phase), zorder=0, lw=0)
            ax.axvline(t0, color="0.6", lw=0.6, zorder=1)
        if t1 - t0 < 0.03 * total:
            continue  # too short to label legibly (impact phases last a few ms)
        label_ax.annotate(phase, xy=((t0 + t1) / 2, 1.0), xycoords=("data", "axes fraction"),
                          xytext=(0, 2), textcoords="offset points", ha="center", va="bottom",
                          fontsize=8, color="0.25")


def plot_angles(trajectory: pd.DataFrame, path=None, title: str | None = None,
                faces: WalkerFaces | None = None, *, ax=None) -> Figure:
    """Joint angles of both legs against time (one panel per joint of the walker: knee
    flexion, thigh minus shank, deg; hip, thigh from the slope normal, deg, as in the
    paper), phases shaded and labelled, steps separated. ``faces``: the walker's names
    (:func:`pdw_casadi.model.faces.walker_faces`); default: read off the trajectory. ``ax``: one
    Axes per joint. Returns the figure (also written to ``path`` if given).
    """
    faces = _faces(trajectory, faces)
    joints = [j for j in faces.joints if trajectory is not None
              and f"{j}1_deg" in trajectory] or ["hip"]
    fig, axes = _axes(ax, len(joints), 1, (10, 3 * len(joints) + 0.5), sharex=True)
    if trajectory is None or trajectory.empty:
        axes[0].text(0.5, 0.5, "no trajectory recorded", ha="center",
                     transform=axes[0].transAxes)
    else:
        t = trajectory["t"].to_numpy()
        legs = physical_leg_angles(trajectory, joints)
        spans = phase_spans(trajectory)
        _shade_phases(axes, spans, axes[0], faces)
        for leg, angles in legs.items():
            for ax, joint in zip(axes, joints, strict=True):
                ax.plot(t, angles[joint], color=LEG_COLORS[leg], lw=1.4,
                        label=f"leg {leg}" + (" (stance in step 0)" if leg == "A" else ""))
        if spans[-1][3] > spans[0][2]:
            axes[0].set_xlim(spans[0][2], spans[-1][3])
        axes[0].legend(fontsize=8, **OUTSIDE_RIGHT)
    for ax, joint in zip(axes, joints, strict=True):
        ax.set_ylabel(JOINT_LABELS.get(joint, f"{joint} [deg]"))
        ax.grid(True, lw=0.4, alpha=0.6)
    axes[-1].set_xlabel("time [s]")
    caption = faces.phase_caption()
    head = title or "Joint angles"
    fig.suptitle(head + (f"\nshaded: {caption}" if caption else ""), fontsize=9)
    return _save(fig, path, 120)


def _full_state(row: pd.Series, q_names, nx: int) -> np.ndarray:
    q = [row[n] for n in q_names]
    qd = [row["d" + n] for n in q_names]
    x = np.zeros(nx)
    x[: 2 * len(q)] = np.concatenate([q, qd])
    if "damping_work_J" in row:
        x[-1] = row["damping_work_J"]
    return x


def snapshot_rows(trajectory: pd.DataFrame, step: int | None = None, n: int = 8) -> list[int]:
    """Row indices of ``n`` snapshots of one step: evenly spaced in time, always including
    the step's first row and the end of every phase (toe-off, heel strike, foot strike)."""
    steps = _run_steps(trajectory)
    if step is None:
        step = int(steps.min())
    sel = trajectory.index[steps == step].to_numpy()
    if sel.size == 0:
        return []
    t = trajectory.loc[sel, "t"].to_numpy()
    ph = trajectory.loc[sel, "phase"].to_numpy()
    keys = {0, sel.size - 1}
    keys |= {i for i in range(sel.size - 1) if ph[i] != ph[i + 1]}
    picks = set(keys)
    extra = max(n - len(picks), 0)
    for target in np.linspace(t[0], t[-1], extra + 2)[1:-1]:
        free = [i for i in range(sel.size) if i not in picks]
        if not free:
            break
        picks.add(min(free, key=lambda i: abs(t[i] - target)))
    return [int(sel[i]) for i in sorted(picks)]


def _draw_walker(ax, pts: dict[str, np.ndarray], links, color, lw=1.6, alpha=1.0) -> None:
    for a, b in links:
        foot = a.startswith(FOOT_POINTS) and b.startswith(FOOT_POINTS)
        ax.plot([pts[a][0], pts[b][0]], [pts[a][1], pts[b][1]], color=color,
                lw=lw * (1.8 if foot else 1.0), alpha=alpha, solid_capstyle="round")
    for name in ("knee1", "knee2", "ankle1", "ankle2"):
        if name in pts:
            ax.plot(*pts[name], "o", ms=3.2, color=color, alpha=alpha, mfc="white", mew=1.0)
    if "hip" in pts:
        ax.plot(*pts["hip"], "o", ms=6.5, color=color, alpha=alpha)


def plot_stick(hs, trajectory: pd.DataFrame, p, path=None, n: int = 8,
               step: int | None = None, title: str | None = None, *, ax=None) -> Figure:
    """Stick-figure snapshots of one step (default: the first in ``trajectory``).

    Top: the snapshots where they are (the stance toe stays at the origin during a step),
    coloured by time. Bottom: the same snapshots side by side along the slope (a film strip,
    each labelled with its time and phase). Feet are drawn thick, knees and ankles as open
    circles, the hip as a dot; the sloped ground y = -x tan(gamma) is the black line.
    ``p``: the parameter vector (compliance..., slope) used for the simulation (the slope
    is its entry ``slope``: the walker's parameter names). ``ax``: two Axes (overlay, film
    strip). Returns the figure (also written to ``path`` if given).
    """
    p = np.asarray(p, dtype=float).ravel()
    gamma = float(p[hs.model.parameter_names.index("slope")])
    fig, (ax_o, ax_f) = _axes(ax, 2, 1, (12, 8), gridspec_kw={"height_ratios": [1.4, 1.0]})
    rows = [] if trajectory is None or trajectory.empty else snapshot_rows(trajectory, step, n)
    if not rows:
        ax_o.text(0.5, 0.5, "no trajectory recorded", ha="center", transform=ax_o.transAxes)
        return _save(fig, path, 110)
    q_names = list(hs.model.q_names)
    names = list(hs.point_names)
    links = list(hs.model.links)
    snaps = []
    for r in rows:
        row = trajectory.loc[r]
        P = hs.points(_full_state(row, q_names, hs.nx), p).full()
        snaps.append((float(row["t"]), str(row["phase"]), dict(zip(names, P.T, strict=True))))
    t0, t1 = snaps[0][0], snaps[-1][0]
    cmap = LinearSegmentedColormap.from_list(
        "viridis_dark", matplotlib.colormaps["viridis"](np.linspace(0.0, 0.85, 64)))
    tang = np.array([np.cos(gamma), -np.sin(gamma)])

    # overlay at true positions
    allpts = np.array([pt for _, _, pts in snaps for pt in pts.values()])
    for t, _ph, pts in snaps:
        c = cmap((t - t0) / (t1 - t0 if t1 > t0 else 1.0))
        _draw_walker(ax_o, pts, links, c)
    xlo, xhi = allpts[:, 0].min() - 0.15, allpts[:, 0].max() + 0.15
    xs = np.array([xlo, xhi])
    ax_o.plot(xs, -xs * np.tan(gamma), color="k", lw=1.2)
    ax_o.fill_between(xs, -xs * np.tan(gamma), -xs * np.tan(gamma) - 0.05, color="0.85")
    sm = ScalarMappable(cmap=cmap, norm=Normalize(t0, max(t1, t0 + 1e-9)))
    fig.colorbar(sm, ax=ax_o, label="time t [s]", fraction=0.03, pad=0.01)
    ax_o.set_aspect("equal", adjustable="datalim")
    ax_o.set_xlabel("x [m]")
    ax_o.set_ylabel("y [m]")
    ax_o.set_title("snapshots at their true positions (stance toe at the origin)", fontsize=9)

    # film strip: snapshot k shifted by k * spacing along the slope
    width = max(float(np.ptp(np.array(list(pts.values())) @ tang)) for _, _, pts in snaps)
    spacing = 1.2 * width
    for k, (t, ph, pts) in enumerate(snaps):
        shift = k * spacing * tang
        moved = {name: pt + shift for name, pt in pts.items()}
        c = cmap((t - t0) / (t1 - t0 if t1 > t0 else 1.0))
        _draw_walker(ax_f, moved, links, c)
        top = max(pt[1] for pt in moved.values())
        ax_f.text(moved["hip"][0], top + 0.06, f"t = {t:.3f} s\n{ph}", ha="center",
                  va="bottom", fontsize=7)
    xf = np.array([xlo, xhi + (len(snaps) - 1) * spacing * tang[0]])
    ax_f.plot(xf, -xf * np.tan(gamma), color="k", lw=1.2)
    ax_f.set_aspect("equal")
    ax_f.set_xlabel(f"x [m] (snapshots shifted by {spacing:.2f} m along the slope)")
    ax_f.set_ylabel("y [m]")
    ax_f.set_title("film strip (simulation time, phase)", fontsize=9)
    for ax in (ax_o, ax_f):
        ax.grid(True, lw=0.4, alpha=0.5)
    fig.suptitle(title or f"One step on a slope of {gamma:.4f} rad "
                 f"({np.degrees(gamma):.2f} deg)", fontsize=10)
    return _save(fig, path, 110)


def _angle_from_vertical(v) -> float:
    """The absolute angle (rad) of the direction ``v`` from the downward vertical,
    counter-clockwise positive: ``v`` is a positive multiple of (sin q, -cos q)."""
    return float(np.arctan2(v[0], -v[1]))


def link_angles(hs, x, p, tol: float = 1e-9) -> dict[tuple[str, str], str]:
    """The coordinate each drawn link of the walker is the absolute angle of, at the full
    state ``x`` (the integrated state [q; dq; ...], rad and rad/s) and parameters ``p``:
    {(proximal, distal): name of the coordinate} for every link (a pair of
    ``hs.model.links``) whose unit vector from proximal to distal end is
    (sin q, -cos q) for one of the walker's coordinates q (to ``tol`` rad), the convention of
    docs/model.md. Links that are no coordinate's (none on the 6-link walker) are left
    out."""
    q_names = list(hs.model.q_names)
    q = np.asarray(x, dtype=float).ravel()[: len(q_names)]
    pts = dict(zip(hs.point_names, np.asarray(hs.points(x, p)).T, strict=True))
    out = {}
    for a, b in hs.model.links:
        for prox, dist in ((a, b), (b, a)):
            ang = _angle_from_vertical(pts[dist] - pts[prox])
            name = next((n for n, v in zip(q_names, q, strict=True)
                         if abs(np.angle(np.exp(1j * (v - ang)))) < tol), None)
            if name is not None:
                out[(prox, dist)] = name
                break
    return out


def plot_walker(hs, section_state, p, path=None, title: str | None = None, *,
                ax=None) -> Figure:
    """The walker at a Poincare section state, labelled: its links, its drawn points by
    name (toes, heels, ankles, knees, the hip with the upper-body mass), the absolute angle
    of every link that is a coordinate (from the downward vertical, counter-clockwise
    positive: a dotted vertical at the link's proximal end and an arc to the link, with the
    coordinate's name and value in degrees), the slope angle gamma between the horizontal
    and the ground, and gravity.

    ``section_state``: the section state (``problem.state_vector()``: rad, rad/s), mapped
    to the full state by the walker's own ``section_to_full``; ``p``: the parameter vector
    (compliance..., slope in rad: ``problem.parameter_vector()``). Positions in metres, the
    stance toe at the origin. Each point is drawn as a marker whose ``gid`` is its name
    (``"hip"``, ``"toe1"``, ...). ``ax``: one Axes. Returns the figure (also written to
    ``path`` if given).
    """
    p = np.asarray(p, dtype=float).ravel()
    gamma = float(p[hs.model.parameter_names.index("slope")])
    x = np.asarray(hs.section_to_full(section_state, p), dtype=float).ravel()
    pts = dict(zip(hs.point_names, np.asarray(hs.points(x, p)).T, strict=True))
    angles = link_angles(hs, x, p)
    q = dict(zip(hs.model.q_names, x, strict=False))
    fig, (ax,) = _axes(ax, 1, 1, (8.0, 6.8))
    allpts = np.array(list(pts.values()))
    (x_min, y_min), (x_max, y_max) = allpts.min(axis=0), allpts.max(axis=0)
    span = float(max(x_max - x_min, y_max - y_min))
    r_arc = 0.09 * span

    def leg_of(name: str) -> str:
        return "2" if name.endswith("2") else "1" if name.endswith("1") else ""

    colors = {"1": "tab:blue", "2": "tab:red", "": "0.15"}
    side = {"1": 1.0, "2": -1.0, "": 0.0}  # labels of leg 1 to the right, of leg 2 left
    # the ground, and the slope angle gamma at a ground point behind the walker
    xlo, xhi = x_min - 0.5 * span, x_max + 0.2 * span
    xs = np.array([xlo, xhi])
    ax.plot(xs, -xs * np.tan(gamma), color="k", lw=1.2)
    ax.fill_between(xs, -xs * np.tan(gamma), -xs * np.tan(gamma) - 0.06 * span, color="0.88")
    xo = x_min - 0.08 * span
    yo = -xo * np.tan(gamma)
    r_g = 0.22 * span
    ax.plot([xo, xo - 1.15 * r_g], [yo, yo], color="0.3", lw=0.8, ls="--")
    ax.add_patch(Arc((xo, yo), 2 * r_g, 2 * r_g, theta1=180.0 - np.degrees(gamma),
                     theta2=180.0, color="k", lw=0.9))
    ax.annotate(f"slope $\\gamma$ = {gamma:.4f} rad ({np.degrees(gamma):.2f}°)",
                xy=(xo - 1.15 * r_g, yo + r_g * np.sin(gamma)), xytext=(0, 10),
                textcoords="offset points", ha="left", va="bottom", fontsize=8)
    # the links and the points
    for a, b in hs.model.links:
        leg = leg_of(a) or leg_of(b)
        foot = a.startswith(FOOT_POINTS) and b.startswith(FOOT_POINTS)
        ax.plot([pts[a][0], pts[b][0]], [pts[a][1], pts[b][1]], color=colors[leg],
                lw=4.0 if foot else 2.4, solid_capstyle="round", zorder=2)
    for name, pt in pts.items():
        leg, hip = leg_of(name), name == "hip"
        ax.plot(*pt, "o", ms=13 if hip else 5, color=colors[leg],
                mfc=colors[leg] if hip else "white", mew=1.2, zorder=3, gid=name)
        if hip:
            off, ha, va = (0, 12), "center", "bottom"
        elif name.startswith("toe"):
            off, ha, va = (6, 6), "left", "bottom"
        elif name.startswith(FOOT_POINTS):
            off, ha, va = (-6, -9), "right", "top"
        elif name.startswith("ankle"):
            off, ha, va = (8, 7), "left", "bottom"
        else:
            off, ha, va = (9 * side[leg], 0), "left" if side[leg] > 0 else "right", "center"
        ax.annotate("hip, upper body $m_h$" if hip else name, xy=pt, xytext=off,
                    textcoords="offset points", fontsize=8, color=colors[leg], ha=ha, va=va,
                    zorder=4)
    # the absolute angles: a dotted downward vertical at the proximal end, an arc to the link
    for (prox, dist), name in angles.items():
        origin = pts[prox]
        color = colors[leg_of(prox) or leg_of(dist)]
        value = float(q[name])
        r = 0.9 * r_arc if prox.startswith(FOOT_POINTS) else r_arc
        ax.plot([origin[0], origin[0]], [origin[1], origin[1] - 1.3 * r], color=color,
                lw=0.8, ls=":", zorder=1)
        lo, hi = sorted((-90.0, -90.0 + np.degrees(value)))
        ax.add_patch(Arc(tuple(origin), 2 * r, 2 * r, theta1=lo, theta2=hi, color=color,
                         lw=0.9, zorder=1))
        mid = np.radians((lo + hi) / 2)
        at = origin + r * np.array([np.cos(mid), np.sin(mid)])
        sign = 1.0 if value >= 0 else -1.0
        label = (name[0] + "_{" + name[1:] + "}") if len(name) > 1 else name
        ax.annotate(f"${label}$ = {np.degrees(value):+.1f}°", xy=at,
                    xytext=(5 * sign, -3), textcoords="offset points", fontsize=8,
                    color=color, ha="left" if sign > 0 else "right", va="top",
                    bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 0.3})
    # gravity, top right
    gx, gy = x_max + 0.08 * span, y_max
    ax.annotate("", xy=(gx, gy - 0.16 * span), xytext=(gx, gy),
                arrowprops={"arrowstyle": "-|>", "color": "k", "lw": 1.0})
    ax.annotate("gravity", xy=(gx, gy - 0.08 * span), xytext=(5, 0),
                textcoords="offset points", fontsize=8, va="center")
    handles = [Line2D([], [], color=colors["1"], lw=2.4,
                      label="leg 1: stance (leading) at the section"),
               Line2D([], [], color=colors["2"], lw=2.4,
                      label="leg 2: swing (trailing) at the section"),
               Line2D([], [], color="0.3", lw=0.9, ls=":",
                      label="absolute angle: from the downward vertical,\n"
                            "counter-clockwise positive")]
    fig.legend(handles=handles, fontsize=8, ncols=2, loc="outside lower center")
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(min(y_min, -xhi * np.tan(gamma)) - 0.12 * span, y_max + 0.1 * span)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m] (horizontal, downhill)")
    ax.set_ylabel("y [m] (vertical)")
    ax.grid(True, lw=0.4, alpha=0.4)
    ax.set_title(title or "The walker at its Poincaré section state", fontsize=10)
    return _save(fig, path, 120)


def _instants(seg: pd.DataFrame, faces: WalkerFaces) -> dict[str, int]:
    """Row positions (in ``seg``, one step) of the key instants and their labels: the start
    (just after the section transition, ``<label>+``), every transition inside the step
    (an impact gives ``<label>-`` / ``<label>+``, a smooth switch one mark) and the end
    (``<label>-`` of the section transition)."""
    return {label: row for label, (row, _) in _instants_meaning(seg, faces).items()}


def _words(transition: str) -> str:
    return transition.replace("_", " ")


def _instants_meaning(seg: pd.DataFrame, faces: WalkerFaces) -> dict[str, tuple[int, str]]:
    """:func:`_instants` with what each label means (the figure's key): ``+`` just after,
    ``-`` just before an impact, no sign the instant of a smooth switch."""
    sec = faces.section_transition
    sec_label = faces.instant_label(sec.name) if sec else "section"
    sec_words = _words(sec.name) if sec else "the section transition"
    rows = {f"{sec_label}+": (0, f"just after {sec_words} (start of the step)")}
    ph = seg["phase"].astype(str).to_numpy()
    for i in np.flatnonzero(ph[1:] != ph[:-1]):
        tr = faces.transition_from(ph[i], ph[i + 1])
        label = faces.instant_label(tr.name) if tr else f"{ph[i]}->{ph[i + 1]}"
        words = _words(tr.name) if tr else f"phase {ph[i]} to {ph[i + 1]}"
        if tr is not None and tr.impact:
            rows[f"{label}-"] = (int(i), f"just before {words}")
            rows[f"{label}+"] = (int(i) + 1, f"just after {words}")
        else:
            rows[label] = (int(i), words)
    rows[f"{sec_label}-"] = (len(seg) - 1, f"just before {sec_words} (end of the step)")
    return rows


#: marker of each key instant on the limit-cycle figure, in the order the step meets them
INSTANT_MARKERS = ("o", "^", "s", "D", "v", "P", "X", "*", "p", "h")
#: candidate label offsets (points) around a marked point, nearest first
_LABEL_OFFSETS = tuple((r * dx, r * dy) for r in (4, 9, 15, 22)
                       for dx, dy in ((1, 1), (1, -1), (-1, 1), (-1, -1), (1, 0), (-1, 0),
                                      (0, 1), (0, -1)))


def _label_box(px, py, ox, oy, w, h, scale):
    """The display box (x0, y0, x1, y1) of a label of w x h points, offset (ox, oy) points
    from (px, py) and aligned away from the point."""
    x = px + ox * scale
    y = py + oy * scale
    x0 = x if ox > 0 else x - w * scale if ox < 0 else x - w * scale / 2
    y0 = y if oy > 0 else y - h * scale if oy < 0 else y - h * scale / 2
    return x0, y0, x0 + w * scale, y0 + h * scale


def _overlap(a, b) -> float:
    return max(0.0, min(a[2], b[2]) - max(a[0], b[0])) * max(0.0, min(a[3], b[3]) - max(a[1], b[1]))


def _place_labels(ax, points, fontsize: float = 8.0) -> None:
    """Write each label of ``points`` ((x, y, text), data units) beside its point where it
    overlaps no label already placed and no marked point and lies nearer its own point than
    any other, inside the axes if it can (the nearest such place; else the least bad one,
    with a leader line when it is far). Instants of a step often fall on one spot (foot
    strike and toe-off are milliseconds apart, an impact keeps the angle): written at one
    fixed offset, their labels were printed on top of each other. Positions are read from
    the axes as laid out when this runs."""
    fig = ax.figure
    scale = fig.dpi / 72.0
    prop = FontProperties(size=fontsize)
    to_px = ax.transData.transform
    frame = ax.get_window_extent()
    frame = (frame.x0, frame.y0, frame.x1, frame.y1)
    pix = [tuple(to_px((x, y))) for x, y, _ in points]
    dot = 4.0 * scale  # half the size of a marker, display units
    gap = 2.5 * scale
    dots = [(px - dot, py - dot, px + dot, py + dot) for px, py in pix]
    placed: list[tuple] = []
    # a line's full height, as a Text lays it out (ascent of "l", descent of "p")
    _, h, _ = text_to_path.get_text_width_height_descent("lp", prop, ismath=False)
    for (x, y, text), (px, py) in zip(points, pix, strict=True):
        w, _, _ = text_to_path.get_text_width_height_descent(text, prop, ismath=False)
        w, h = w + 1.0, h + 1.0  # a point of air around the glyphs
        best = None
        for ox, oy in _LABEL_OFFSETS:
            box = _label_box(px, py, ox, oy, w, h, scale)
            outside = box[0] < frame[0] or box[1] < frame[1] or box[2] > frame[2] \
                or box[3] > frame[3]
            # a label nearer another marked point than its own reads as that point's
            cx, cy = (box[0] + box[2]) / 2, (box[1] + box[3]) / 2
            own = np.hypot(cx - px, cy - py)
            nearer = any(np.hypot(cx - qx, cy - qy) < own - 1e-9 for qx, qy in pix)
            # labels that touch read as one ("a-a+"): keep a gap between labels
            padded = (box[0] - gap, box[1] - gap, box[2] + gap, box[3] + gap)
            # worst a label on a label, then one outside the axes (on the tick labels),
            # then one nearer another point, then one on a marker
            crowded = any(_overlap(padded, other) > 0 for other in placed)
            cost = (1e7 if crowded else 0.0) + (1e6 if outside else 0.0) \
                + (1e3 if nearer else 0.0) + sum(_overlap(box, other) for other in dots)
            if best is None or cost < best[0]:
                best = (cost, ox, oy, box)
            if cost == 0.0:
                break
        _, ox, oy, box = best
        far = abs(ox) > 9 or abs(oy) > 9
        ax.annotate(text, (x, y), textcoords="offset points", xytext=(ox, oy),
                    ha="left" if ox > 0 else "right" if ox < 0 else "center",
                    va="bottom" if oy > 0 else "top" if oy < 0 else "center",
                    fontsize=fontsize, zorder=5,
                    arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "0.45",
                                "shrinkA": 0, "shrinkB": 3} if far else None)
        placed.append(box)


def plot_limit_cycle(trajectory: pd.DataFrame, path=None, legs=None, title: str | None = None,
                     faces: WalkerFaces | None = None, *, walker: str | None = None,
                     ax=None) -> Figure:
    """The paper's Fig. 4: phase portraits of each segment of one leg over two steps, in deg
    (absolute angle from the vertical, counter-clockwise positive: the segment's distal end
    ahead) against deg/s.

    ``trajectory`` holds (at least) two steps from a fixed point; the physical leg is leg 1
    (stance) in step 0 and leg 2 (swing) in step 1. ``legs``: its coordinate names per
    step, one per segment (default: the walker's, from ``faces``), e.g. (shank, thigh)
    ``(("q1", "q2"), ("q4", "q3"))``. Key instants of each step are marked (one marker shape
    per instant) and labelled with the walker's transition labels, which the legend
    explains: ``+`` just after an impact, ``-`` just before, no sign a smooth switch (the
    6-link walker: the paper's a+ after foot strike, b toe-off, c- / c+ heel strike, a-
    before foot strike). The title names ``walker`` (default: the walker family of
    ``faces``; ``title`` replaces it). ``ax``: one Axes per segment. Returns the figure
    (also written to ``path`` if given).
    """
    faces = _faces(trajectory, faces)
    legs = tuple(tuple(leg) for leg in (legs or faces.legs))
    if not legs:
        raise ValueError("plot_limit_cycle needs the leg coordinates (legs= or faces=)")
    n_seg = len(legs[0])
    segments = faces.leg_segments if len(faces.leg_segments) == n_seg else \
        tuple(f"segment {i + 1}" for i in range(n_seg))
    own_figure = ax is None
    fig, axes = _axes(ax, 1, n_seg, (5 * n_seg + 3.5, 4.6))
    colors = ("tab:blue", "tab:orange")
    steps = _run_steps(trajectory)
    key: dict[str, tuple[str, str]] = {}  # label -> (marker, meaning), first seen first
    labels: list[list] = [[] for _ in axes]
    for k, names in enumerate(legs):
        seg = trajectory[steps == k]
        if seg.empty:
            continue
        role = "stance" if k == 0 else "swing"
        marks = _instants_meaning(seg, faces)
        for lab, (_, meaning) in marks.items():
            key.setdefault(lab, (INSTANT_MARKERS[len(key) % len(INSTANT_MARKERS)], meaning))
        for j, (ax, name) in enumerate(zip(axes, names, strict=True)):
            # degrees, as fit.png and the angle plot: a reader compares the figures
            q, dq = np.degrees(seg[name].to_numpy()), np.degrees(seg["d" + name].to_numpy())
            ax.plot(q, dq, color=colors[k % 2], lw=1.4, label=f"step {k + 1} ({role})")
            for lab, (i, _) in marks.items():
                ax.plot(q[i], dq[i], key[lab][0], color="k", mfc="white", mew=1.0, ms=5,
                        zorder=4)
                labels[j].append((q[i], dq[i], lab))
    for i, (ax, what) in enumerate(zip(axes, segments, strict=True)):
        ax.set_xlabel("absolute angle (deg, from the vertical; + distal end ahead)")
        ax.set_ylabel("angular velocity (deg/s)")
        ax.set_title(f"({chr(ord('a') + i)}) {what}" if n_seg > 1 else what)
        ax.grid(alpha=0.3)
        ax.margins(0.08)  # room for the labels of instants at the edge of the cycle
    handles, _ = axes[0].get_legend_handles_labels()
    handles += [Line2D([], [], ls="", marker=m, color="k", mfc="white", mew=1.0, ms=5,
                       label=f"{lab}: {meaning}") for lab, (m, meaning) in key.items()]
    axes[-1].legend(handles=handles, fontsize=8, **OUTSIDE_RIGHT)
    name = walker or faces.family
    fig.suptitle(title or (f"{name}: " if name else "") + "limit cycle of one leg over two "
                 "steps (deg, deg/s)")
    # labels last: their places are found on the axes as laid out with legend and title
    fig.draw_without_rendering()
    for ax, points in zip(axes, labels, strict=True):
        _place_labels(ax, points)
    if own_figure:
        # the labels' places hold for this layout: keep it (a second constrained-layout
        # pass on saving would cost as much as the first and could move the axes)
        fig.set_layout_engine("none")
    return _save(fig, path, 120)


#: y-axis labels of the fit figure: the sign convention of the human data and the model
#: alike (flexion positive: the knee bent, the thigh's distal end ahead of the hip)
FIT_LABELS = {"knee": "knee flexion (deg, + flexion)", "hip": "hip flexion (deg, + flexion)"}
#: line style of each gait event on the fit figure (the event names of
#: :meth:`pdw_casadi.gait.timing.GaitTiming.markers`); others cycle through EXTRA_EVENT_STYLES
EVENT_STYLES = {"heel strike": "-", "foot flat": ":", "heel off": "-.", "toe off": "--"}
EXTRA_EVENT_STYLES = ((0, (5, 1, 1, 1, 1, 1)), (0, (3, 3)), (0, (8, 2)))
#: colours of the events' sources that are not a model's (a model's events take its curve's
#: colour, human events the human curve's black): colours no model curve takes among the
#: first four (models draw C0, C1, ...)
EVENT_COLORS = ("tab:purple", "tab:brown", "tab:olive", "tab:cyan")


def _event_styles(markers: dict, curve_colors: dict | None = None) -> dict[str, tuple[str, object]]:
    """label -> (colour, line style) of each gait-event marker ("<source> <event>", e.g.
    "human toe off", "fit heel off"): the colour says whose event it is (human: black),
    the line style which event, so that two events a few % apart (the fit's heel off and
    toe off) stay distinguishable. ``curve_colors``: model label -> its curve's colour, for
    the events of a source that is a model."""
    curve_colors = curve_colors or {}
    colors: dict[str, str] = {}
    styles: dict[str, object] = {}
    out = {}
    for label in markers:
        # "<source> <event>" or "<source>: <event>"; a source may have spaces of its own
        known = next((e for e in EVENT_STYLES if label.endswith(" " + e)), None)
        if known is not None:
            source, event = label[:-len(known)].rstrip(" :"), known
        else:
            source, _, event = label.partition(" ")
        if source not in colors:
            others = sum(c not in ("human", *curve_colors) for c in colors)
            colors[source] = "k" if source == "human" else curve_colors.get(
                source, EVENT_COLORS[others % len(EVENT_COLORS)])
        if event not in styles:
            extra = sum(e not in EVENT_STYLES for e in styles)
            styles[event] = EVENT_STYLES.get(
                event, EXTRA_EVENT_STYLES[extra % len(EXTRA_EVENT_STYLES)])
        out[label] = (colors[source], styles[event])
    return out


def _curves_name(human) -> str:
    """The file name of the human curves (their name when they came from no file)."""
    source = getattr(human, "source", None)
    return Path(str(source)).name if source is not None else str(getattr(human, "name", "?"))


def plot_fit(human, models: dict, path=None, scores: dict | None = None, *,
             markers: dict | None = None, walker: str | None = None,
             title: str | None = None, ax=None) -> Figure:
    """The paper's Fig. 5: knee (a) and hip (b) flexion (deg, flexion positive) over the gait
    cycle (%), human mean +/- SD and one curve per model.

    ``scores``: label -> {"r2_knee", "r2_hip"} of each model, shown in its legend entry.
    ``markers``: "<source> <event>" -> % of the cycle (e.g. "human toe off", "fit heel
    off"), drawn as vertical lines on both panels: the colour says the source (human:
    black; a model label: its curve's colour), the line style the event. One legend for
    the figure, to the right of the hip panel; each entry appears once. The title names the
    curve file and ``walker`` (default; ``title`` replaces it). ``ax``: two Axes. Returns
    the figure (also written to ``path``).
    """
    fig, axes = _axes(ax, 1, 2, (13.5, 5.0))
    pct = human.cycle_pct
    events = {k: v for k, v in (markers or {}).items() if v is not None}
    # each model its colour of the default cycle, named so that its events can share it
    curve_colors = {label: f"C{i % 10}" for i, label in enumerate(models)}
    styles = _event_styles(events, curve_colors)
    for ax, name, mean, sd in ((axes[0], "knee", human.knee_deg, human.knee_sd_deg),
                               (axes[1], "hip", human.hip_deg, human.hip_sd_deg)):
        if sd is not None:
            ax.fill_between(pct, mean - sd, mean + sd, color="0.85", label="human +/- SD")
        ax.plot(pct, mean, color="k", lw=1.8, label="human mean")
        for label, model in models.items():
            # the same label on both panels: the legend takes each entry once
            ax.plot(model["cycle_pct"], model[f"{name}_deg"], lw=1.5, color=curve_colors[label],
                    label=label + _r2_tag((scores or {}).get(label, {})))
        for label, pct_m in events.items():
            color, ls = styles[label]
            ax.axvline(pct_m, color=color, ls=ls, lw=1.3, alpha=0.9, zorder=1.5,
                       label=f"{label} ({pct_m:.1f} %)")
        ax.set_xlabel("gait cycle (%)")
        ax.set_ylabel(FIT_LABELS[name])
        ax.set_xlim(0, 100)
        ax.grid(alpha=0.3)
    handles: dict = {}
    for a in axes:  # a curve only one panel has (an SD band) still gets its entry
        for h, lab in zip(*a.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    axes[-1].legend(list(handles.values()), list(handles), fontsize=8, **OUTSIDE_RIGHT)
    axes[0].set_title("(a) knee")
    axes[1].set_title("(b) hip (model: thigh from the slope normal)")
    head = f"Fit of {walker} to {_curves_name(human)}" if walker else \
        f"Knee and hip over the gait cycle: {_curves_name(human)}"
    fig.suptitle(title or head, fontsize=11)
    return _save(fig, path, 120)


def _r2_tag(score: dict) -> str:
    """The R^2 of a model's legend entry ("" without scores): one entry serves both panels,
    so it names the joint of each value."""
    parts = [f"{joint} {score[f'r2_{joint}']:.3f}" for joint in ("knee", "hip")
             if score.get(f"r2_{joint}") is not None]
    return "\nR$^2$: " + ", ".join(parts) if parts else ""


#: short labels of sweep events on the bifurcation figure
EVENT_LABELS = {"fold": "LP", "period_doubling": "PD", "neimark_sacker": "NS",
                "boundary": "BND", "branch_end": "END"}


def plot_sweep(table: pd.DataFrame, events, parameter: str, path=None,
               title: str | None = None, *, ax=None) -> Figure:
    """Bifurcation figure of a sweep: step length (m), speed (m/s) and spectral radius of
    dP/dx against the parameter. Stable stretches solid, unstable dashed (a stretch is
    stable when both its end points are), points breaking the gait pattern as grey crosses,
    located events as dotted vertical lines labelled LP (fold), PD (period doubling), NS
    (Neimark-Sacker), BND (gait-pattern boundary), END (branch lost). ``ax``: three Axes.
    Returns the figure (also written to ``path`` if given)."""
    fig, axes = _axes(ax, 3, 1, (9.5, 8), sharex=True)
    ok = table[table["converged"].astype(bool)]
    quantities = (("step_length_m", "step length [m]"), ("speed_m_s", "speed [m/s]"),
                  ("spectral_radius", "spectral radius of dP/dx [-]"))
    for branch, part in ok.groupby("branch", sort=True):
        # the start (branch 0) joins both directions: draw each branch from the start
        start = ok[ok["branch"] == 0]
        part = pd.concat([start, part]) if branch != 0 else part
        part = part.sort_values(parameter, kind="stable")
        x = part[parameter].to_numpy()
        good = (part["stable"].astype(bool) & part["valid"].astype(bool)).to_numpy()
        for ax, (col, _) in zip(axes, quantities, strict=True):
            y = part[col].to_numpy()
            for k in range(len(x) - 1):
                stable = good[k] and good[k + 1]
                ax.plot(x[k:k + 2], y[k:k + 2], color="tab:blue" if stable else "tab:red",
                        ls="-" if stable else "--", lw=1.6)
            ax.plot(x[good], y[good], "o", color="tab:blue", ms=3)
            ax.plot(x[~good], y[~good], "o", color="tab:red", ms=3, mfc="white")
    bad = ok[~ok["valid"].astype(bool)]
    for ax, (col, label) in zip(axes, quantities, strict=True):
        if not bad.empty:
            ax.plot(bad[parameter], bad[col], "x", color="0.4", ms=6, label="gait pattern broken")
        ax.set_ylabel(label)
        ax.grid(True, lw=0.4, alpha=0.6)
    axes[2].axhline(1.0, color="k", lw=0.8)
    for e in events:
        for ax in axes:
            ax.axvline(e.value, color="0.3", ls=":", lw=1.0)
        axes[0].annotate(EVENT_LABELS.get(e.kind, e.kind), xy=(e.value, 1.0),
                         xycoords=("data", "axes fraction"), xytext=(0, 2),
                         textcoords="offset points", ha="center", va="bottom", fontsize=8)
    handles = [Line2D([], [], color="tab:blue", lw=1.6, label="stable, valid"),
               Line2D([], [], color="tab:red", ls="--", lw=1.6, label="unstable or invalid")]
    axes[0].legend(handles=handles, fontsize=8, **OUTSIDE_RIGHT)
    axes[2].set_xlabel(parameter)
    fig.suptitle(title or f"Sweep over {parameter}", fontsize=10)
    return _save(fig, path, 120)


def plot_leg_curves(curves: dict, path=None, title: str | None = None, *,
                    ax=None) -> Figure:
    """Knee (left panel) and hip (right panel) angle (deg) over each physical leg's gait
    cycle (%), one line per leg: ``curves`` = {"left": frame, "right": frame} from
    :func:`pdw_casadi.gait.stride.stride_report`. ``ax``: two Axes. Returns the figure (also
    written to ``path``)."""
    fig, axes = _axes(ax, 1, 2, (10, 4.2))
    for a, name in zip(axes, ("knee", "hip"), strict=True):
        for side, frame in curves.items():
            a.plot(frame["cycle_pct"], frame[f"{name}_deg"], lw=1.5,
                   ls="-" if side == "left" else "--", label=f"{side} leg")
        a.set_xlabel("gait cycle of the leg (%)")
        a.set_ylabel(f"{name} angle (deg)")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return _save(fig, path, 120)
