"""The figure of a prosthetist's study (:mod:`pdw_casadi.studies.prosthetist`)."""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure

from pdw_casadi.report.plots import OUTSIDE_RIGHT
from pdw_casadi.studies.prosthesis import NLP_FREE
from pdw_casadi.studies.prosthetist import PROSTHETIC, SOUND


def plot_prosthetist_study(table: pd.DataFrame, path=None, title: str | None = None) -> Figure:
    """Two panels over the prosthetic leg's mass reduction (%): (a) each designed
    compliance value of both legs relative to the fitted sound leg's (the row at 0 %), the
    prosthetic leg solid, the sound leg dashed; (b) the knee and hip R^2 of each leg against
    the sound side's human curves and the per-step spectral radius. ``table``:
    :attr:`~pdw_casadi.studies.prosthetist.ProsthetistStudy.table`; ``path``: also saved."""
    rows = table[table["converged"].astype(bool)].sort_values("lighter_pct")
    base = rows[rows["lighter_pct"] == 0.0].iloc[0]
    fig = Figure(figsize=(12.5, 4.4), layout="constrained")
    ax_c, ax_r = fig.subplots(1, 2)
    x = rows["lighter_pct"]
    for i, key in enumerate(NLP_FREE):
        ref = base[f"{SOUND}.{key}"]
        if ref == 0:
            continue
        ax_c.plot(x, rows[f"{PROSTHETIC}.{key}"] / ref, "o-", color=f"C{i}", label=key)
        ax_c.plot(x, rows[f"{SOUND}.{key}"] / ref, "o--", color=f"C{i}", mfc="none")
    ax_c.axhline(1.0, color="0.5", lw=0.8)
    ax_c.set_xlabel("prosthetic shank and foot lighter by (%)")
    ax_c.set_ylabel("compliance / fitted sound leg's (-)")
    ax_c.set_title(f"(a) designed compliance: {PROSTHETIC} (prosthetic) solid, "
                   f"{SOUND} (sound) dashed", fontsize=10)
    ax_c.legend(fontsize=8, ncols=2)
    ax_c.grid(alpha=0.3)
    for leg, style, name in ((SOUND, "--", "sound"), (PROSTHETIC, "-", "prosthetic")):
        ax_r.plot(x, rows[f"r2_knee_{leg}"], style, marker="o", color="C0",
                  label=f"knee R^2, {name} ({leg}) leg")
        ax_r.plot(x, rows[f"r2_hip_{leg}"], style, marker="s", color="C1",
                  label=f"hip R^2, {name} ({leg}) leg")
    ax_r.plot(x, rows["step_radius"], "-", marker="^", color="k",
              label="spectral radius per step")
    ax_r.set_xlabel("prosthetic shank and foot lighter by (%)")
    ax_r.set_ylabel("R^2 against the sound side's curves; radius (-)")
    ax_r.set_title("(b) the gait: each leg against the sound side, and its stability",
                   fontsize=10)
    ax_r.legend(fontsize=8, **OUTSIDE_RIGHT)
    ax_r.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
