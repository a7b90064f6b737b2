"""The report of ``pdw-seed``: the JSON file of a seed search, with the units of its values,
and the lines the command prints when the search ends.

The searches are :mod:`pdw_casadi.studies.seed_run`; this module renders their
:class:`~pdw_casadi.studies.seed_run.SeedRun`. Nothing here solves.
"""

from __future__ import annotations

import collections
import json
from pathlib import Path
from typing import TYPE_CHECKING

from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.model.system import gait_system
from pdw_casadi.model.units import Units

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.studies.seed_run import SeedRun

#: the file each search writes into ``--out``
SEED_FILES = {"arc": "seed.json", "heeloff": "seed.json", "toes": "scan.json",
              "toes-continuation": "continuation.json"}
#: the values of a gait's timing (% of the gait cycle)
TIMING_PCT = "% of the gait cycle"


def seed_file(run: SeedRun) -> str:
    """The name of the file ``run`` is written to (:data:`SEED_FILES`)."""
    return SEED_FILES[run.search]


def seed_units(run: SeedRun) -> dict:
    """The ``units`` block of a seed record: the section state (rad, rad/s), compliance,
    slope, margins and times by name (the walker's units), phase durations in s, timing in
    % of the gait cycle, heel loads in N m; a scan's gaits and a continuation's points entry
    by entry (``gaits[].compliance``, ``continuation[].rho``)."""
    units = Units(gait_system(run.problem))
    rec = run.record
    if run.search == "toes":
        gait = rec["gaits"][0] if rec["gaits"] else {
            "compliance": dict(run.problem.compliance), "slope": run.problem.slope,
            "fixed_point": dict(run.problem.initial_state)}
        out = {"wall_time_s": "s", "samples": "count", "heel_off_step_ends": "count",
               "step_ends": "count"}
        out.update({f"gaits[].{k}": v for k, v in units.summary(gait).items() if k != "legs"})
        out.update({"gaits[].phases_s": "s", "gaits[].timing": TIMING_PCT,
                    "gaits[].rho": "dimensionless (spectral radius)",
                    "gaits[].eigenvalues": "dimensionless ([re, im])"})
        return out
    if run.search == "toes-continuation":
        key = next(iter(rec["continuation"][0])) if rec["continuation"] else None
        out = {"wall_time_s": "s", "continuation[].rho": "dimensionless (spectral radius)",
               "continuation[].eigenvalues": "dimensionless ([re, im])",
               "continuation[].min_heel_load_Nm": "N m"}
        if key is not None and (u := units.of(key)) is not None:
            out[f"continuation[].{key}"] = u
        return out
    out = {k: v for k, v in units.summary(rec).items() if k != "legs"}
    out.update({k: "s" for k in ("phases_s", "phase_durations_s") if k in rec})
    out.update({k: TIMING_PCT for k in ("double_support_pct", "stance_pct") if k in rec})
    if "lambda" in rec:
        out["lambda"] = "dimensionless (0: radii 0, 1: the radii asked for)"
        out["held"] = "per validity margin: [lambda where its hold began, held value in " \
                      "the margin's unit]"
    return out


def write_seed(run: SeedRun, out: Path) -> Path:
    """Write the record of ``run`` with its ``units`` block into ``out``
    (:func:`seed_file`); returns the file's path."""
    path = Path(out) / seed_file(run)
    write_json(path, {**run.record, "units": seed_units(run)})
    return path


def seed_lines(run: SeedRun, written: Path) -> list[str]:
    """The lines a seed search ends with (``written``: where its file is)."""
    rec = run.record
    if run.search == "arc":
        keys = ("reached", "spectral_radius", "valid", "failure", "double_support_pct",
                "stance_pct", "phase_durations_s")
        return [json.dumps({k: rec[k] for k in keys}, default=float)]
    if run.search == "heeloff":
        phases = ", ".join(f"{k} {1e3 * v:.1f} ms" for k, v in rec["phases_s"].items())
        return [f"heel-off gait: {phases}; rho {rec['spectral_radius']:.3g}, valid "
                f"{rec['valid']} ({rec['failure']}); written to {written}"]
    if run.search == "toes":
        ends = collections.Counter(rec["heel_off_step_ends"])
        all_ends = collections.Counter(rec["step_ends"])
        return [f"how the steps ended: {dict(all_ends.most_common())}",
                f"{sum(ends.values())} of {rec['samples']} samples lifted the stance heel in "
                f"single support; how their step ended: {dict(ends.most_common())}; "
                f"{len(rec['gaits'])} fixed points; written to {written}"]
    rows = rec["continuation"]
    return [f"{sum(r['converged'] for r in rows)} of {len(rows)} points converged; written "
            f"to {written}"]
