"""The report of a prosthetic-leg design: the lines ``pdw-design`` prints and the designed
walker's problem file.

The design is computed by :func:`pdw_casadi.studies.design_run.run_design`; this module
renders its :class:`~pdw_casadi.studies.design_run.DesignRun`: how far the design got, the
step lengths and times per leg with their asymmetry, the stride's spectral radius, validity,
the compliance (and mass distribution) found, each NLP solve and the wall time, and the
designed walker as TOML (:func:`~pdw_casadi.model.problem.problem_toml`, which
``pdw-fixed-point --problem FILE.toml`` re-solves on the stride map). Nothing here solves.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from pdw_casadi.model.problem import problem_toml

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.design_run import DesignRun

#: the first line of a designed walker's problem file
HEADER = "# written by pdw-design\n"


def design_headline(run: DesignRun, where: str) -> list[str]:
    """The first lines of a design's report: where it started (``where``: a problem file or
    an atlas entry), its target and method, and how far it got: the mass reduction (%)
    reached and in how many NLP solves (continuation: the homotopy parameter lambda, -, and
    its points), and whether the target was met."""
    req, res = run.request, run.result
    if req.method == "nlp":
        reached = f"{100 * res.path[-1][0]:.2f} % lighter in {len(res.solves)} NLP solves"
    else:
        reached = f"lambda = {res.path[-1][0]:.4f} ({len(res.path)} points)"
    return [f"start: {where}; target: right shank+foot {100 * req.lighter:g} % "
            f"lighter; method {req.method}",
            f"reached {reached}: right shank+foot {100 * run.lighter_reached:.2f} % "
            f"lighter; target met (stable, valid, symmetric): {res.reached}"]


def design_gait_lines(run: DesignRun) -> list[str]:
    """The rest of a design's report, for a design that ends at a stride fixed point
    (:attr:`~pdw_casadi.studies.design_run.DesignRun.has_gait`): step lengths (m) and times
    (s) per leg with their asymmetry (%), stance and double support (% of the gait cycle),
    the stride's spectral radius (-) against the verdict's, validity, the compliance and
    mass distribution found (SI units), the slope (rad), each NLP solve and the wall time
    (s)."""
    res, opts = run.result, run.request.options
    rep, fp = res.report, res.fixed_point
    legs = rep["legs"]
    lines = [
        f"step length L/R {legs['left']['step_length_m']:.5f} / "
        f"{legs['right']['step_length_m']:.5f} m (asymmetry "
        f"{rep['step_length_asymmetry_pct']:.2e} %)",
        f"step time   L/R {legs['left']['step_time_s']:.5f} / "
        f"{legs['right']['step_time_s']:.5f} s "
        f"(asymmetry {rep['step_time_asymmetry_pct']:.2e} %)",
        f"stance % L/R {legs['left']['stance_pct']:.2f} / {legs['right']['stance_pct']:.2f}, "
        f"double support {rep['double_support_pct']:.2f} %",
        f"stride spectral radius {fp.spectral_radius:.4f} (per step {res.step_radius:.4f}); "
        f"stable (stride <= {opts.max_stride_radius:g}, per step <= "
        f"{opts.max_step_radius:g}): {run.stable}; valid: {fp.valid}",
        "prosthetic-leg compliance: " + ", ".join(f"{k} = {v:.4f}"
                                                  for k, v in res.compliance.items())]
    if res.sound_compliance:
        lines.append("sound-leg compliance (adapted): " + ", ".join(
            f"{k} = {v:.4f}" for k, v in res.sound_compliance.items()))
    if res.mass_distribution:
        lines.append("prosthetic-leg mass distribution: " + ", ".join(
            f"{k} = {v:.5g}" for k, v in res.mass_distribution.items()))
    lines.append(f"slope {res.problem.slope:.5f} rad")
    lines += [f"  NLP {100 * sv.lighter:6.2f} % lighter: {sv.status} ({sv.iterations} iter, "
              f"{sv.wall_time_s:.1f} s"
              + (sv.answered_with and f"; {sv.answered_with}")
              + f"), stride radius {sv.stride_radius:.4f}, "
              f"asymmetry length/time {sv.step_length_asymmetry_pct:.3f} / "
              f"{sv.step_time_asymmetry_pct:.3f} %, valid {sv.valid}, "
              f"{'accepted' if sv.accepted else 'rejected'}" for sv in res.solves]
    lines.append(f"wall time {run.wall_time_s:.1f} s")
    return lines


def write_designed_walker(run: DesignRun, path: Path) -> Path:
    """Write the designed walker (its prosthetic leg, compliance and gait's section state as
    initial state) to ``path`` as a problem TOML file; returns ``path``."""
    path = Path(path)
    path.write_text(problem_toml(run.result.problem, HEADER))
    return path
