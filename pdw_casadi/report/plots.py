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
from matplotlib.lines import Line2D

from pdw_casadi.model.faces import WalkerFaces, faces_from_trajectory

__all__ = ["phase_spans", "physical_leg_angles", "plot_angles", "plot_fit", "plot_limit_cycle",
           "plot_stick", "plot_sweep", "snapshot_rows"]

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


def _instants(seg: pd.DataFrame, faces: WalkerFaces) -> dict[str, int]:
    """Row positions (in ``seg``, one step) of the key instants and their labels: the start
    (just after the section transition, ``<label>+``), every transition inside the step
    (an impact gives ``<label>-`` / ``<label>+``, a smooth switch one mark) and the end
    (``<label>-`` of the section transition)."""
    sec = faces.section_transition
    sec_label = faces.instant_label(sec.name) if sec else "section"
    rows = {f"{sec_label}+": 0}
    ph = seg["phase"].astype(str).to_numpy()
    for i in np.flatnonzero(ph[1:] != ph[:-1]):
        tr = faces.transition_from(ph[i], ph[i + 1])
        label = faces.instant_label(tr.name) if tr else f"{ph[i]}->{ph[i + 1]}"
        if tr is not None and tr.impact:
            rows[f"{label}-"], rows[f"{label}+"] = int(i), int(i) + 1
        else:
            rows[label] = int(i)
    rows[f"{sec_label}-"] = len(seg) - 1
    return rows


def plot_limit_cycle(trajectory: pd.DataFrame, path=None, legs=None, title: str | None = None,
                     faces: WalkerFaces | None = None, *, ax=None) -> Figure:
    """The paper's Fig. 4: phase portraits of each segment of one leg over two steps.

    ``trajectory`` holds (at least) two steps from a fixed point; the physical leg is leg 1
    (stance) in step 0 and leg 2 (swing) in step 1. ``legs``: its coordinate names per
    step, one per segment (default: the walker's, from ``faces``), e.g. (shank, thigh)
    ``(("q1", "q2"), ("q4", "q3"))``. Key instants of each step are marked with the
    walker's transition labels (the 6-link walker: the paper's a+ after foot strike, b
    toe-off, c- / c+ heel strike, a- before foot strike). Angles in rad, rates in rad/s.
    ``ax``: one Axes per segment. Returns the figure (also written to ``path`` if given).
    """
    faces = _faces(trajectory, faces)
    legs = tuple(tuple(leg) for leg in (legs or faces.legs))
    if not legs:
        raise ValueError("plot_limit_cycle needs the leg coordinates (legs= or faces=)")
    n_seg = len(legs[0])
    segments = faces.leg_segments if len(faces.leg_segments) == n_seg else \
        tuple(f"segment {i + 1}" for i in range(n_seg))
    fig, axes = _axes(ax, 1, n_seg, (5 * n_seg + 1.5, 4.2))
    colors = ("tab:blue", "tab:orange")
    steps = _run_steps(trajectory)
    for k, names in enumerate(legs):
        seg = trajectory[steps == k]
        if seg.empty:
            continue
        role = "stance" if k == 0 else "swing"
        marks = _instants(seg, faces)
        for ax, name in zip(axes, names, strict=True):
            ax.plot(seg[name], seg["d" + name], color=colors[k % 2], lw=1.4,
                    label=f"step {k + 1} ({role})")
            for lab, i in marks.items():
                xv, yv = seg[name].iloc[i], seg["d" + name].iloc[i]
                ax.plot(xv, yv, "o", color="k", ms=3.5)
                ax.annotate(lab, (xv, yv), textcoords="offset points", xytext=(4, 4),
                            fontsize=8)
    for i, (ax, what) in enumerate(zip(axes, segments, strict=True)):
        ax.set_xlabel("absolute angle (rad)")
        ax.set_ylabel("angular velocity (rad/s)")
        ax.set_title(f"({chr(ord('a') + i)}) {what}" if n_seg > 1 else what)
        ax.grid(alpha=0.3)
    axes[-1].legend(fontsize=8, **OUTSIDE_RIGHT)
    if title:
        fig.suptitle(title)
    return _save(fig, path, 120)


def plot_fit(human, models: dict, path=None, scores: dict | None = None, *,
             markers: dict | None = None, ax=None) -> Figure:
    """The paper's Fig. 5: knee (a) and hip (b) over the gait cycle, human mean +/- SD and
    one curve per model (deg against % of the cycle); R^2 in the legends (below the
    panels) when given; ``markers``: label -> % of the cycle, drawn as vertical lines (gait
    events; labels starting with "human" dashed). ``ax``: two Axes. Returns the figure
    (also written to ``path``)."""
    fig, axes = _axes(ax, 1, 2, (11, 5.2))
    pct = human.cycle_pct
    for ax, name, mean, sd in ((axes[0], "knee", human.knee_deg, human.knee_sd_deg),
                               (axes[1], "hip", human.hip_deg, human.hip_sd_deg)):
        if sd is not None:
            ax.fill_between(pct, mean - sd, mean + sd, color="0.85", label="human +/- SD")
        ax.plot(pct, mean, color="k", lw=1.8, label="human mean")
        for label, model in models.items():
            r2 = (scores or {}).get(label, {}).get(f"r2_{name}")
            tag = f" (R$^2$ = {r2:.3f})" if r2 is not None else ""
            ax.plot(model["cycle_pct"], model[f"{name}_deg"], lw=1.5, label=label + tag)
        for i, (label, pct_m) in enumerate((markers or {}).items()):
            if pct_m is not None:
                ax.axvline(pct_m, color=f"C{(i + 3) % 10}", lw=0.9, alpha=0.8,
                           ls="--" if label.startswith("human") else ":",
                           label=f"{label} ({pct_m:.1f} %)")
        ax.set_xlabel("gait cycle (%)")
        ax.set_ylabel(f"{name} angle (deg)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, **OUTSIDE_BELOW)
    axes[0].set_title("(a) knee")
    axes[1].set_title("(b) hip (model thigh from the slope normal)")
    return _save(fig, path, 120)


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
