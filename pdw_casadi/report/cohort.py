"""Figures of a cohort table (:mod:`pdw_casadi.studies.cohort`): R^2 per subject, and each
compliance value against body mass (or, without body data, walking speed).

Both functions return a matplotlib :class:`~matplotlib.figure.Figure` that belongs to no
pyplot window and, with ``path``, write it there. Fits that were not accepted are drawn
hollow (they are in the table with their reason, and are not hidden here either); fits
without a gait are left out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pdw_casadi.report.plots import OUTSIDE_RIGHT
from pdw_casadi.studies.cohort import compliance_column

__all__ = ["compliance_names", "plot_cohort", "plot_compliance", "plot_r2_by_subject"]

#: the curves drawn per subject
CURVES = (("r2_knee", "knee"), ("r2_hip", "hip"), ("r2_thigh", "thigh"))
MARKERS = {"symmetric": "o", "sides": "s"}


def _label(row: pd.Series) -> str:
    return " ".join(str(v) for v in (row.get("condition"), row.get("kind"),
                                     f"({row['body']} body)" if row.get("body") else None)
                    if v not in (None, "") and not (isinstance(v, float) and np.isnan(v)))


def plot_r2_by_subject(table: pd.DataFrame, path=None) -> Figure:
    """R^2 of knee, hip (and thigh) per subject: one panel per curve, one marker per fit
    (x: the subject, colour: condition, kind and body of the fit; hollow: not accepted)."""
    curves = [(c, n) for c, n in CURVES if c in table.columns and table[c].notna().any()]
    fig = Figure(figsize=(4.2 * max(len(curves), 1) + 2.5, 4.2), layout="constrained")
    axes = fig.subplots(1, max(len(curves), 1), squeeze=False)[0]
    subjects = list(dict.fromkeys(table["subject_id"].astype(str)))
    x_of = {s: i for i, s in enumerate(subjects)}
    kinds = {_label(r): r.get("kind") for _, r in table.iterrows()}
    groups = list(kinds)
    width = 0.6 / max(len(groups), 1)
    colors = {g: f"C{i % 10}" for i, g in enumerate(groups)}
    for ax, (col, name) in zip(axes, curves, strict=False):
        for _, r in table.iterrows():
            v = r.get(col)
            if v is None or pd.isna(v):
                continue
            g = _label(r)
            x = x_of[str(r["subject_id"])] + (groups.index(g) - (len(groups) - 1) / 2) * width
            ok = r.get("status") == "accepted"
            ax.plot([x], [v], MARKERS.get(r.get("kind"), "o"), color=colors[g],
                    mfc=colors[g] if ok else "none", ms=7)
        ax.set_xticks(range(len(subjects)), subjects, rotation=45 if len(subjects) > 8 else 0)
        ax.set_title(f"{name} R^2")
        ax.set_ylabel("R^2 (1 = the human curve)")
        ax.grid(alpha=0.3)
    handles = [axes[-1].plot([], [], MARKERS.get(kinds[g], "o"), color=colors[g], label=g)[0]
               for g in groups]
    handles.append(axes[-1].plot([], [], "o", color="0.4", mfc="none",
                                 label="hollow: not accepted")[0])
    axes[-1].legend(handles=handles, fontsize=8, **OUTSIDE_RIGHT)
    if path is not None:
        fig.savefig(Path(path), dpi=120)
    return fig


def compliance_names(table: pd.DataFrame) -> list[str]:
    """The compliance keys with a column in the table (symmetric or per side)."""
    names = []
    for c in table.columns:
        for unit in ("_N_m_per_rad", "_N_m_s_per_rad", "_rad", "_m"):
            if c.endswith(unit) and c.startswith(("k_", "c_", "theta_", "phi_", "ankle_rest",
                                                  "r_")):
                base = c[: -len(unit)]
                for side in ("_left", "_right"):
                    if base.endswith(side):
                        base = base[: -len(side)]
                if base not in names:
                    names.append(base)
                break
    return names


def plot_compliance(table: pd.DataFrame, path=None, x: str | None = None) -> Figure:
    """Each compliance value (one panel each) against ``x``: ``mass_kg`` (body mass) when
    the study gives it, else ``human_speed_m_s`` when given, else the fitted gait's
    ``speed_m_s``. Symmetric fits: circles; per-side fits: the left (triangle up) and the
    right leg (triangle down). Hollow: not accepted."""
    if x is None:
        x = next((c for c in ("mass_kg", "human_speed_m_s", "speed_m_s")
                  if c in table.columns and table[c].notna().any()), "speed_m_s")
    names = compliance_names(table)
    n = max(len(names), 1)
    ncols = min(n, 3)
    nrows = -(-n // ncols)
    fig = Figure(figsize=(4.2 * ncols, 3.4 * nrows), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    xlabel = {"mass_kg": "body mass [kg]", "human_speed_m_s": "walking speed [m/s]",
              "speed_m_s": "the fitted gait's speed [m/s]"}.get(x, x)
    for ax, name in zip(axes, names, strict=False):
        sym, unit = compliance_column(name), compliance_column(name)[len(name) + 1:]
        for _, r in table.iterrows():
            ok = r.get("status") == "accepted"
            xv = r.get(x)
            if xv is None or pd.isna(xv):
                continue
            points = [(sym, "o", "C0")] if r.get("kind") != "sides" else [
                (compliance_column(name, "left"), "^", "C1"),
                (compliance_column(name, "right"), "v", "C3")]
            for col, marker, color in points:
                v = r.get(col)
                if v is None or pd.isna(v):
                    continue
                ax.plot([xv], [v], marker, color=color, mfc=color if ok else "none", ms=7)
        ax.set_title(name)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(f"{name} [{unit.replace('_per_', '/').replace('_', ' ')}]"
                      if unit else name)
        ax.grid(alpha=0.3)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    handles = [axes[0].plot([], [], m, color=c, label=lab)[0] for m, c, lab in (
        ("o", "C0", "symmetric fit"), ("^", "C1", "per side: left leg"),
        ("v", "C3", "per side: right leg"))]
    handles.append(axes[0].plot([], [], "o", color="0.4", mfc="none",
                                label="hollow: not accepted")[0])
    fig.legend(handles=handles, loc="outside lower center", ncols=4, fontsize=8)
    if path is not None:
        fig.savefig(Path(path), dpi=120)
    return fig


def plot_cohort(table: pd.DataFrame, out: Path) -> list[Path]:
    """``r2_by_subject.png`` and ``compliance.png`` of the table into ``out``; the paths
    (a study without any gait draws nothing)."""
    out = Path(out)
    have = table[[c for c in ("r2_knee", "r2_hip") if c in table.columns]].notna()
    if have.empty or not have.any().any():
        return []
    paths = [out / "r2_by_subject.png"]
    plot_r2_by_subject(table, paths[0])
    if compliance_names(table):
        paths.append(out / "compliance.png")
        plot_compliance(table, paths[1])
    return paths
