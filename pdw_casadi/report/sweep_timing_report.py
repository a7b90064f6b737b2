"""The lines of ``pdw-sweep --timing``: the gait timing of every point of a sweep.

The timing is computed by :func:`pdw_casadi.studies.sweep_timing.sweep_timing`; this module
renders it, one line per point. Nothing here solves or simulates.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from pdw_casadi.model.units import Units

if TYPE_CHECKING:  # the workflow's result type only: rendering needs no simulator
    from pdw_casadi.studies.sweep_timing import PointTiming


def sweep_timing_lines(points: Sequence[PointTiming], parameter: str, units: Units) -> list[str]:
    """One line per sweep point: the swept value (named as the column of ``sweep.csv``,
    with its unit, e.g. ``r_toe_m``), valid, stable, the spectral radius (-), double
    support of each period and stance (% of the gait cycle) and the phase durations (ms);
    a point that did not converge says why, one whose step fails says so."""
    swept = units.column(parameter)
    lines = []
    for pt in points:
        head = f"{swept} = {pt.value:.6g}: "
        if not pt.converged:
            lines.append(head + f"not converged ({pt.failure})")
            continue
        t = pt.timing
        if t is None:
            lines.append(head + "its step fails")
            continue
        phases = " / ".join(f"{n} {1e3 * d:.1f}" for n, d in t.phase_durations_s)
        # point feet exchange support at once: no double-support period
        ds = (", ".join(f"{v:.2f}" for v in t.double_support_pct) + " %"
              if t.double_support_pct else "none")
        lines.append(head + f"valid {pt.valid}, stable {pt.stable}, rho "
                     f"{pt.spectral_radius:.4f}, double support {ds}, stance "
                     f"{t.stance_pct:.2f} %, phases {phases} ms")
    return lines
