"""The report of a parameter sweep: its rows as they are found, ``events.json``,
``sweep.png`` and the lines ``pdw-sweep`` prints.

The sweep is computed by :func:`pdw_casadi.studies.sweep_run.run_sweep`; this module renders
its rows (:class:`SweepRows`: appended to a CSV file one by one, every column with its unit,
:class:`~pdw_casadi.model.units.Units`) and its :class:`~pdw_casadi.studies.sweep_run.SweepRun`
(:func:`write_sweep_report`, :func:`sweep_lines`). Nothing here solves.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.model.system import gait_system
from pdw_casadi.model.units import Units
from pdw_casadi.report.plots import plot_sweep

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no solver
    from pdw_casadi.model.problem import Problem
    from pdw_casadi.studies.sweep_run import SweepRun


def sweep_units(problem: Problem) -> Units:
    """The units of the names in a sweep of ``problem``'s gait (its walker's, or the
    per-leg walker's when its legs differ)."""
    return Units(gait_system(problem))


class SweepRows:
    """The rows of a sweep appended to the CSV file ``path`` as each is found (an
    interrupted sweep keeps them), each column named with its unit (``units``:
    :func:`sweep_units`); ``count``: the rows written so far."""

    def __init__(self, path: Path, units: Units):
        self.path, self.units = Path(path), units
        self.columns: list[str] = []
        self.count = 0

    def append(self, row: dict) -> None:
        """Append one row (a :func:`~pdw_casadi.gait.sweep.point_row`) to the file."""
        # the first row (the start, a converged gait) fixes the columns; later rows that
        # lack some (a failed point has no margins) get empty cells
        if not self.columns:
            self.columns.extend(row)
        frame = self.units.frame(pd.DataFrame([row]).reindex(columns=self.columns))
        frame.to_csv(self.path, mode="a", header=not self.path.exists(), index=False)
        self.count += 1


def sweep_summary(run: SweepRun, units: Units) -> dict:
    """The content of ``events.json``: the sweep's result (grid, events, stable valid
    ranges), the walker's name, compliance and slope (rad), and the units of its values
    (grid, start and event values in the swept parameter's unit)."""
    problem = run.problem
    summary = {**run.result.to_dict(), "problem": problem.name,
               "compliance": dict(problem.compliance), "slope": problem.slope}
    unit = units.of(run.request.parameter)  # grid, start and event values are in its unit
    summary["units"] = {**units.summary(summary), "start_value": unit, "grid": unit,
                        "events[].value": unit, "events[].bracket": unit}
    return summary


def write_sweep_report(run: SweepRun, out: Path, units: Units) -> tuple[Path, Path]:
    """Write ``events.json`` (:func:`sweep_summary`) and ``sweep.png`` (step length in m,
    speed in m/s and spectral radius against the parameter,
    :func:`~pdw_casadi.report.plots.plot_sweep`) into ``out``; returns their paths."""
    out = Path(out)
    events, figure = out / "events.json", out / "sweep.png"
    write_json(events, sweep_summary(run, units))
    parameter = run.request.parameter
    plot_sweep(run.result.table, run.result.events, parameter, figure,
               title=f"{run.problem.name}: sweep over {parameter}")
    return events, figure


def sweep_lines(run: SweepRun) -> list[str]:
    """The lines that sum a sweep up: how many points converged and are stable and valid,
    each located event (value and bracket in the parameter's unit, and why), and the
    stable valid ranges of the parameter (or that there is none)."""
    req, res = run.request, run.result
    table = res.table
    lines = [f"{len(table)} points ({int(table['converged'].sum())} converged, "
             f"{int((table['stable'] & table['valid']).sum())} stable and valid)"]
    lines += [f"  {e.kind:16s} {req.parameter} = {e.value:.8g}  (bracket "
              f"{min(e.bracket):.8g} .. {max(e.bracket):.8g}): {e.reason}"
              for e in res.events]
    ranges = res.stable_ranges()
    lines += [f"stable valid gait: {req.parameter} in [{r['from']:.8g}, {r['to']:.8g}] "
              f"(ends: {r['from_event'] or 'last point'}, {r['to_event'] or 'last point'})"
              for r in ranges]
    if not ranges:
        lines.append(f"no stable valid gait found over {req.parameter} = {req.start:g} .. "
                     f"{req.stop:g}")
    return lines
