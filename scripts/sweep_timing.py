"""The gait timing of every converged point of a pdw-sweep table.

    python scripts/sweep_timing.py --problem humanlike_6link_arc sweep_dir/sweep.csv

For each converged row it simulates one step from the row's section state with the row's
parameters (``param:<name>`` columns) and prints the swept value, valid, stable, the
spectral radius, double support per period and stance (% of the cycle) and the phase
durations (ms) of the periodic gait (:func:`pdw_casadi.gait.timing.fixed_point_timing`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.timing import fixed_point_timing
from pdw_casadi.model.problem import load_problem
from pdw_casadi.model.units import with_units


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep", type=Path, help="sweep.csv written by pdw-sweep")
    ap.add_argument("--problem", required=True, help="the sweep's problem")
    args = ap.parse_args(argv)
    pb = load_problem(args.problem)
    tab = pd.read_csv(args.sweep)
    sim = Simulator(pb)
    hs = sim.hs
    def columns(names):  # the sweep table's headers carry units
        return list(with_units(pd.DataFrame(columns=list(names)), hs).columns)

    state_cols = columns(pb.state_names)
    par_cols = columns(f"param:{n}" for n in pb.parameter_names)
    swept = tab.columns[0]
    for _, row in tab.iterrows():
        if not row["converged"]:
            print(f"{swept} = {row[swept]:.6g}: not converged ({row['failure']})")
            continue
        t = fixed_point_timing(pb, row[state_cols].to_numpy(float),
                               row[par_cols].to_numpy(float), sim)
        if t is None:
            print(f"{swept} = {row[swept]:.6g}: its step fails")
            continue
        phases = " / ".join(f"{n} {1e3 * d:.1f}" for n, d in t.phase_durations_s)
        ds = (", ".join(f"{v:.2f}" for v in t.double_support_pct) + " %"
              if t.double_support_pct else "none")  # point feet exchange support at once
        print(f"{swept} = {row[swept]:.6g}: valid {bool(row['valid'])}, stable "
              f"{bool(row['stable'])}, rho {row['spectral_radius']:.4f}, double support "
              f"{ds}, stance {t.stance_pct:.2f} %, phases {phases} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
