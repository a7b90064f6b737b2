"""Write a per-leg (stride) fit's report: summary.json, curves.csv, fit.png, table.md.

The report of the per-leg fit (:func:`pdw_casadi.fit.core.fit_sides`): R^2 per leg and curve of the
re-simulated stride and of its symmetric start, each leg's compliance, the step-length and
step-time asymmetry (%, 100 (L - R) / mean), the stride's spectral radius (the verdict,
<= max_radius^2) and its per-step equivalent (its square root), validity and the
re-simulation deviation; ``fit.png`` draws each leg's knee and hip over its own gait cycle
against its side's human curve (+/- SD where the file has one). The fit is run by
:func:`pdw_casadi.studies.fit_run.run_fit`; this module renders its
:class:`~pdw_casadi.studies.fit_run.FitSidesRun`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.fit.result import Candidate, FitResult
from pdw_casadi.model.gait_data import CYCLE_POINTS, SIDES
from pdw_casadi.model.units import COMPLIANCE_PREFIXES, summary_units
from pdw_casadi.report.fit_report import answer_status, solve_table, uncertified_note
from pdw_casadi.report.plots import plot_fit

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.fit_run import FitSidesRun

JOINTS = ("knee", "hip", "thigh")


def _unit(name: str) -> str:
    """`` (N m/rad)`` for a compliance name, by its prefix."""
    return next((f" ({u})" for p, u in COMPLIANCE_PREFIXES if name.startswith(p)), "")


def _f(v, fmt="{:.3f}") -> str:
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else fmt.format(v)


def plot_stride_fit(sides, models: dict, path, scores: dict | None = None,
                    title: str | None = None) -> Figure:
    """Knee and hip flexion (deg, flexion positive) of each leg (rows: left, right) over its
    own gait cycle (%) against its side's human curve (+/- SD where given): ``models`` =
    {label: {side: curves frame}}, ``scores`` = {label: {side: {r2_knee, ...}}}; one legend
    per row (its labels name the leg), ``title`` above all (default: the curve file's
    name)."""
    fig = Figure(figsize=(14, 10.5), layout="constrained")
    axes = fig.subplots(2, 2, squeeze=False)
    for row, side in zip(axes, SIDES, strict=True):
        plot_fit(sides.side(side).resample(CYCLE_POINTS),
                 {f"{label} ({side} leg)": m[side] for label, m in models.items()},
                 None, scores={f"{label} ({side} leg)": s[side]
                               for label, s in (scores or {}).items()}, ax=list(row))
        row[0].set_title(f"{side} leg: knee (human: {side} side)")
        row[1].set_title(f"{side} leg: hip, model thigh from the slope normal")
    if title:  # else each row's plot_fit named the curve file
        fig.suptitle(title, fontsize=11)
    fig.savefig(Path(path), dpi=120)
    return fig


def _table(res: FitResult, cand: Candidate | None, comp: dict | None,
           start_comp: dict, ok: bool) -> str:
    lines = ["| gait | leg | knee R^2 | hip R^2 | thigh R^2 |", "|---|---|---|---|---|"]
    rows = [("symmetric start: " + res.start["label"], res.start["scores"])]
    if cand is not None:
        rows.append(("this stride fit" + ("" if ok else " (NOT ACCEPTED)"), cand.scores))
    for name, scores in rows:
        for s in SIDES:
            d = (scores or {}).get(s, {})
            lines.append(f"| {name} | {s} | {_f(d.get('r2_knee'))} | {_f(d.get('r2_hip'))} | "
                         f"{_f(d.get('r2_thigh'))} |")
    text = "\n".join(lines) + "\n"
    if cand is None:
        return text
    rep, fp = cand.report, cand.fixed_point
    text += ("\n| compliance | start left | start right | left | right |\n"
             "|---|---|---|---|---|\n" + "".join(
                 f"| {k}{_unit(k)} | {_f(start_comp['left'][k], '{:.5g}')} | "
                 f"{_f(start_comp['right'][k], '{:.5g}')} | {_f(comp['left'][k], '{:.5g}')} | "
                 f"{_f(comp['right'][k], '{:.5g}')} |\n" for k in comp["left"]))
    legs = rep["legs"]
    text += (
        "\n| stride | value |\n|---|---|\n"
        f"| step length L / R (m) | {legs['left']['step_length_m']:.4f} / "
        f"{legs['right']['step_length_m']:.4f} |\n"
        f"| step time L / R (s) | {legs['left']['step_time_s']:.4f} / "
        f"{legs['right']['step_time_s']:.4f} |\n"
        f"| step-length asymmetry (%) | {rep['step_length_asymmetry_pct']:+.3f} |\n"
        f"| step-time asymmetry (%) | {rep['step_time_asymmetry_pct']:+.3f} |\n"
        f"| stride spectral radius (<= {res.options.accepted_radius(cand.steps):.4f}) | "
        f"{fp.spectral_radius:.4f} |\n"
        f"| per-step equivalent (its square root) | {np.sqrt(fp.spectral_radius):.4f} |\n"
        f"| valid | {'yes' if cand.valid else 'no'} |\n"
        f"| re-simulation deviation ({res.options.resim_steps} steps) | "
        f"{cand.resimulation_deviation:.2e} |\n")
    return text


def write_fit_stride_report(run: FitSidesRun, out: Path) -> dict:
    """Write the report files of the per-leg fit ``run`` into ``out``; the summary."""
    out = Path(out)
    problem, sides, opts, res = run.problem, run.sides, run.options, run.result
    cand, ok = run.candidate, run.accepted
    grid = sides.left.resample(CYCLE_POINTS).cycle_pct
    cols: dict = {"cycle_pct": grid}
    models: dict = {}
    scores: dict = {}
    if res.start["curves"] is not None:
        models["symmetric start"] = res.start["curves"]
        scores["symmetric start"] = res.start["scores"]
    if cand is not None:
        models["stride fit"] = cand.report["curves"]
        scores["stride fit"] = cand.scores
    for s in SIDES:
        h = sides.side(s).resample(CYCLE_POINTS)
        for j in JOINTS:
            for kind in ("deg", "sd_deg"):
                v = getattr(h, f"{j}_{kind}", None)
                if v is not None:
                    cols[f"human_{s}_{j}_{kind}"] = v
        for label, m in models.items():
            key = "fit" if label == "stride fit" else "start"
            for j in JOINTS:
                cols[f"{key}_{s}_{j}_deg"] = m[s][f"{j}_deg"].to_numpy()
    pd.DataFrame(cols).to_csv(out / "curves.csv", index=False)
    plot_stride_fit(sides, models, out / "fit.png", scores,
                    title=f"Per-leg fit of {problem.name} to {Path(str(sides.source)).name}")
    start_comp = run.start_compliance
    summary: dict = {
        "gait_file": str(sides.source), "problem": problem.name, "targets": list(res.targets),
        "fit": "stride", "side": opts.side, "free": list(res.free),
        "start": {"label": res.start["label"], "scores": res.start["scores"],
                  "compliance": start_comp},
        "max_radius": opts.max_radius, "stride_max_radius": opts.accepted_radius(2),  # 2 steps
        "stable": False, "valid": False, "accepted": ok,
        "solver": {"solves": [s.to_dict() for s in res.solves],
                   "status": answer_status(cand, res.solves),
                   "iterations": int(sum(s.iterations for s in res.solves)),
                   "wall_time_s": res.wall_time_s, "notes": res.notes}}
    comp = run.compliance
    if cand is not None:
        fp, rep = cand.fixed_point, cand.report
        legs = {s: {**cand.scores[s], "compliance": comp[s], **rep["legs"][s]} for s in SIDES}
        summary.update({
            "legs": legs, "slope": run.slope,
            "step_length_asymmetry_pct": rep["step_length_asymmetry_pct"],
            "step_time_asymmetry_pct": rep["step_time_asymmetry_pct"],
            "double_support_pct": rep["double_support_pct"], "speed_m_s": rep["speed_m_s"],
            "stride_time_s": rep["stride_time_s"], "stride_length_m": rep["stride_length_m"],
            "fixed_point": dict(zip(fp.state_names, map(float, cand.state), strict=True)),
            "eigenvalues": [[float(e.real), float(e.imag)] for e in fp.eigenvalues],
            "stride_spectral_radius": fp.spectral_radius,
            "step_spectral_radius_equivalent": float(np.sqrt(fp.spectral_radius)),
            "stable": bool(cand.stable), "valid": bool(cand.valid), "failure": fp.failure,
            "margins": fp.margins, "resimulation_deviation": cand.resimulation_deviation,
            "resimulation_steps": opts.resim_steps, "objective": cand.objective,
            "certified": cand.certified})
    head = (f"# Per-leg fit of {problem.name} to {Path(str(sides.source)).name}\n\n"
            f"Objective: the sum over both legs of 1 - R^2 of knee and {res.targets[1]}, each "
            f"leg over its own gait cycle against its side's curves ({CYCLE_POINTS} points); free: "
            f"{', '.join(res.free)}.\n\n")
    (out / "table.md").write_text(head + _table(res, cand, comp, start_comp, ok)
                                  + "\n## Solve\n\n" + solve_table(cand, res.solves))
    if cand is None:
        summary["headline"] = "no stride fit: " + "; ".join(res.notes or ["the solve failed"])
    else:
        verdict = "stable, valid" if ok else "NOT ACCEPTED (unstable or invalid)"
        r2 = "   ".join(f"{s}: " + "  ".join(f"{k} {v:.3f}" for k, v in cand.scores[s].items())
                        for s in SIDES)
        summary["headline"] = (
            f"{r2}   step-length / step-time asymmetry "
            f"{cand.report['step_length_asymmetry_pct']:+.2f} / "
            f"{cand.report['step_time_asymmetry_pct']:+.2f} %   stride radius "
            f"{cand.fixed_point.spectral_radius:.4f} ({verdict})" + uncertified_note(cand))
    summary["units"] = summary_units(summary, run.system)
    # here the legs are the physical legs, not the step's stance and swing roles
    summary["units"]["legs"] = (
        "left, right: the physical legs; R^2 dimensionless, names carry their unit "
        "(step_length_m, step_time_s, *_pct); compliance " + ", ".join(
            f"{p}* {u}" for p, u in COMPLIANCE_PREFIXES))
    write_json(out / "summary.json", summary)
    return summary
