"""Write a fit's report: summary.json, curves.csv, fit.png, limit_cycle.png, table.md.

The fit and its references are computed by :func:`pdw_casadi.studies.fit_run.run_fit`; this
module renders its :class:`~pdw_casadi.studies.fit_run.FitRun` into the report files.
``table.md`` holds the R^2 and spectral radius of the fit and its references, the solve
(IPOPT's status of the solve the gait came from, certified optimal or not), the fitted
compliance and slope with their units beside the problem file's, and the gait timing.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.gait.timing import timing_table
from pdw_casadi.model.gait_data import CYCLE_POINTS
from pdw_casadi.model.units import Units, summary_units
from pdw_casadi.report.plots import plot_fit, plot_limit_cycle

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.fit_run import FitRun


def _scores(d: dict) -> dict:
    return {k: d[k] for k in ("r2_knee", "r2_hip", "r2_thigh") if k in d}


def answer_status(cand, solves) -> str | None:
    """IPOPT's status of the solve the reported gait came from (the last solve's when there
    is no gait): a later round that stopped short does not relabel an earlier round's
    converged answer, nor a failed first round a converged warm restart."""
    if cand is not None and cand.solver_status:
        return cand.solver_status
    return solves[-1].status if solves else None


def uncertified_note(cand) -> str:
    """The headline's plain word on an answer that IPOPT did not certify ("" otherwise)."""
    if cand.certified:
        return ""
    return ("; NOT CERTIFIED OPTIMAL: IPOPT stopped short of convergence, this is its best "
            "feasible iterate, checked on the simulator (a better fit may exist)")


def _f(v, fmt="{:.3f}") -> str:
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else fmt.format(v)


def solve_table(cand, solves) -> str:
    """The markdown table of the answer's solve (table.md): IPOPT's status of the solve the
    gait came from (:func:`answer_status`), whether the answer is certified optimal
    (:attr:`~pdw_casadi.fit.result.Candidate.certified`; "-" without a gait) and the IPOPT
    iterations of all solves."""
    status = answer_status(cand, solves)
    if cand is None:
        certified = "- (no gait)"
    elif cand.certified:
        certified = "yes" if cand.solver_status is not None else "yes (no NLP solve)"
    else:
        # plain words, as in the headline: a reader of the table alone must see it
        if cand.polished_from is not None:
            how = (f"an IPOPT iterate (iteration {cand.polished_from}) polished on the "
                   "simulator, not the NLP's optimum")
        else:
            how = ("IPOPT stopped short of convergence; this is its best feasible iterate, "
                   "checked on the simulator")
        certified = f"NO: {how} (a better fit may exist)"
    return ("| solve | value |\n|---|---|\n"
            f"| solver status (IPOPT, the solve this gait came from) | {status or '-'} |\n"
            f"| certified optimal | {certified} |\n"
            f"| IPOPT iterations (all solves) | {sum(s.iterations for s in solves)} |\n")


def compliance_table(fitted: Mapping[str, float], reference: Mapping[str, float],
                     unit: Callable[[str], str | None],
                     free: Collection[str] | None = None) -> str:
    """The markdown table of the fitted parameters (table.md): one row per name of
    ``fitted`` (compliance values, then the slope) with the fit's value, the problem file's
    (``reference``), the unit (``unit(name)``: stiffness ``k_*`` N m/rad, damping ``c_*``
    N m s/rad, angles rad) and whether the fit varied it (``free``: the NLP's free names;
    None: all)."""
    lines = ["| parameter | this fit | problem file | unit | free in the fit |",
             "|---|---|---|---|---|"]
    for name, value in fitted.items():
        lines.append(f"| {name} | {_f(value, '{:.5g}')} | "
                     f"{_f(reference.get(name), '{:.5g}')} | {unit(name) or '-'} | "
                     f"{'yes' if free is None or name in free else 'no'} |")
    return "\n".join(lines) + "\n"


def _table(rows: list[tuple[str, dict]]) -> str:
    lines = ["| gait | knee R^2 | hip R^2 | thigh R^2 | spectral radius | stable |",
             "|---|---|---|---|---|---|"]
    for name, d in rows:
        stable = d.get("stable")
        lines.append(f"| {name} | {_f(d.get('r2_knee'))} | {_f(d.get('r2_hip'))} | "
                     f"{_f(d.get('r2_thigh'))} | {_f(d.get('spectral_radius'), '{:.4f}')} | "
                     f"{'-' if stable is None else ('yes' if stable else 'no')} |")
    return "\n".join(lines) + "\n"


def write_fit_report(run: FitRun, out: Path) -> dict:
    """Write the report files of ``run`` into ``out``; the summary."""
    out = Path(out)
    problem, human, opts, res = run.problem, run.human, run.options, run.result
    cand, ok = run.candidate, run.accepted
    table3, comparison = run.reference, run.comparison
    comparison_name, paper = run.comparison_problem, run.paper_reported
    h = human.resample(CYCLE_POINTS)
    curves = pd.DataFrame({"cycle_pct": h.cycle_pct, "human_knee_deg": h.knee_deg,
                           "human_hip_deg": h.hip_deg})
    if h.thigh_deg is not None:
        curves["human_thigh_deg"] = h.thigh_deg
    for joint in ("knee", "hip", "thigh"):  # the human SD, as fit.png draws it
        if getattr(h, f"{joint}_sd_deg", None) is not None:
            curves[f"human_{joint}_sd_deg"] = getattr(h, f"{joint}_sd_deg")
    models, scores = {}, {}
    for label, d in (("fit", {"curves": cand.curves} if cand else {}),
                     ("table3", table3), ("comparison", comparison or {})):
        c = d.get("curves")
        if c is None:
            continue
        for col in ("knee_deg", "hip_deg", "thigh_deg"):
            curves[f"{label}_{col}"] = c[col].to_numpy()
    curves.to_csv(out / "curves.csv", index=False)
    names = {"fit": "this fit", "table3": f"{problem.name}, problem file's compliance",
             "comparison": f"comparison walker ({comparison_name})"}
    if cand is not None:
        models[names["fit"]] = cand.curves
        scores[names["fit"]] = cand.scores
    for key, d in (("table3", table3), ("comparison", comparison or {})):
        if d.get("curves") is not None:
            models[names[key]] = d["curves"]
            scores[names[key]] = _scores(d)
    fit_timing = run.fit_timing
    norms, norms_source = run.human_timing, run.human_timing_source
    markers = {"human toe off": norms["toe_off_pct"]}
    if fit_timing is not None:
        markers.update({f"fit {k}": v for k, v in fit_timing.markers().items()})
    plot_fit(h, models, out / "fit.png", scores=scores, markers=markers, walker=problem.name)

    summary: dict = {"gait_file": str(human.source), "problem": problem.name,
                     "targets": list(res.targets), "paper_reported": paper,
                     "stable": False, "valid": False}
    comp = {"table3": {**_scores(table3), "spectral_radius": table3["spectral_radius"],
                       "stable": table3["stable"], "valid": table3["valid"]},
            "comparison_walker": None if comparison is None else {
                **_scores(comparison), "spectral_radius": comparison["spectral_radius"],
                "stable": comparison["stable"], "problem": comparison_name}}
    summary["comparison"] = comp
    solver = {"solves": [s.to_dict() for s in res.solves],
              "status": answer_status(cand, res.solves),
              "iterations": int(sum(s.iterations for s in res.solves)),
              "wall_time_s": res.wall_time_s, "starts": res.starts_frame().to_dict("records"),
              "notes": res.notes}
    summary["solver"] = solver
    if cand is not None:
        fp = cand.fixed_point
        compliance, slope = problem.split_parameters(cand.parameters)
        summary.update(cand.scores)
        summary.update({
            "compliance": compliance, "slope": slope,
            "fixed_point": dict(zip(fp.state_names, map(float, cand.state), strict=True)),
            "eigenvalues": [[float(e.real), float(e.imag)] for e in fp.eigenvalues],
            "spectral_radius": fp.spectral_radius, "stable": bool(fp.stable),
            "stability_margin": 1.0 - fp.spectral_radius, "max_radius": opts.max_radius,
            "valid": bool(cand.valid), "failure": fp.failure, "margins": fp.margins,
            "step_time_s": fp.step_time_s, "step_length_m": fp.step_length_m,
            "speed_m_s": fp.step_length_m / fp.step_time_s,
            "resimulation_deviation": cand.resimulation_deviation,
            "resimulation_steps": opts.resim_steps, "accepted": ok,
            "certified": cand.certified,
            "timing": None if fit_timing is None else fit_timing.to_dict()})
        plot_limit_cycle(run.limit_cycle, out / "limit_cycle.png", faces=run.faces,
                         title=f"{problem.name}, fitted compliance: one leg over two steps "
                               "(deg, deg/s)")
    rows = [("paper, reported (its own four subjects)", paper)] if paper else []
    rows.append(("problem file's compliance, re-run here",
                 {**_scores(table3), "spectral_radius": table3["spectral_radius"],
                  "stable": table3["stable"]}))
    if cand is not None:
        rows.append(("this fit", {**cand.scores,
                                  "spectral_radius": cand.fixed_point.spectral_radius,
                                  "stable": cand.fixed_point.stable}))
    if comparison is not None:
        rows.append((f"comparison walker ({comparison_name})",
                     {**_scores(comparison), "spectral_radius": comparison["spectral_radius"],
                      "stable": comparison["stable"]}))
    head = (f"# Fit of {problem.name} to {Path(str(human.source)).name}\n\n"
            f"Objective: knee and {res.targets[1]} R^2 ({CYCLE_POINTS}-point gait cycle, "
            f"docs/model.md of pdw-casadi).\n\n")
    summary["timing_human"] = {"values": norms, "source": norms_source}
    timings = {"this fit": fit_timing, "problem file's compliance": table3.get("timing")}
    if comparison is not None:
        timings["comparison walker"] = comparison.get("timing")
    text = head + _table(rows) + "\n## Solve\n\n" + solve_table(cand, res.solves)
    if cand is not None:
        free = set(opts.free or problem.compliance_names) | (
            {"slope"} if opts.free_slope else set())  # the NLP's free names (fit.core)
        text += ("\n## Compliance and slope\n\n" + compliance_table(
            {**summary["compliance"], "slope": summary["slope"]},
            {**problem.compliance, "slope": problem.slope}, Units(run.system).of, free))
    (out / "table.md").write_text(text + "\n## Gait timing\n\n" + timing_table(timings, human))
    if cand is None:
        summary["headline"] = "no fit: " + "; ".join(res.notes or ["every start failed"])
    else:
        verdict = "stable, valid" if ok else "NOT ACCEPTED (unstable or invalid)"
        summary["headline"] = (
            f"r2_knee = {cand.scores['r2_knee']:.3f}  r2_hip = {cand.scores['r2_hip']:.3f}"
            + (f"  r2_thigh = {cand.scores['r2_thigh']:.3f}" if "r2_thigh" in cand.scores
               else "")
            + f"   spectral radius {cand.fixed_point.spectral_radius:.4f} ({verdict}); "
            f"problem file's compliance: r2_knee = {table3.get('r2_knee', float('nan')):.3f} "
            f"r2_hip = {table3.get('r2_hip', float('nan')):.3f}" + uncertified_note(cand))
    summary["units"] = summary_units(summary, run.system)
    write_json(out / "summary.json", summary)
    return summary
