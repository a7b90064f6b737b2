"""The report of a walker scaled to a subject: the problem file ``pdw-scale`` writes and the
line it prints.

The scaling is :func:`pdw_casadi.studies.scale_run.run_scale`; this module renders its
:class:`~pdw_casadi.studies.scale_run.ScaleRun`: the scaled walker as TOML with a header
naming the subject, the body and how its gait was found. Nothing here solves.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from pdw_casadi.model.problem import problem_toml

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.scale_run import ScaleRun


def scale_header(run: ScaleRun) -> str:
    """The problem file's header: the subject (kg, m, sex), the reference, the body and
    its source, how the gait was found and its spectral radius (-)."""
    who = run.subject
    return (f"# {who['mass_kg']:g} kg, {who['height_m']:g} m, {who['sex']}: written by "
            f"pdw-scale from {run.reference.name}\n# body: {run.body} (de Leva 1996, J. "
            f"Biomech. 29:1223, adjusted Zatsiorsky-Seluyanov; foot geometry from the "
            f"reference)\n# gait: {run.note}; spectral radius {run.spectral_radius:.4f}\n")


def write_scaled_walker(run: ScaleRun, path: Path,
                        toml: Callable[..., str] = problem_toml) -> Path:
    """Write the scaled walker (its gait as initial state) to ``path`` as a problem TOML
    file (``toml``: the renderer, default
    :func:`~pdw_casadi.model.problem.problem_toml`); returns ``path``."""
    path = Path(path)
    path.write_text(toml(run.problem, scale_header(run)))
    return path


def starting_line(reference: str, who: dict, body: str) -> str:
    """The line on stderr before the scaling: reference, subject (kg, m, sex), body."""
    return (f"scaling {reference} to {who['mass_kg']:g} kg, {who['height_m']:g} m, "
            f"{who['sex']} ({body})...")


def wrote_line(run: ScaleRun, path: Path) -> str:
    """The line ``pdw-scale`` ends on: the file, the spectral radius (-), lambda (-) and the
    wall time (s)."""
    return (f"wrote {path} (spectral radius {run.spectral_radius:.4f}, lambda "
            f"{run.reached:g}, {run.wall_time_s:.1f} s)")
