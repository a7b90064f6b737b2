"""Benchmark a 40-point slope sweep of the humanlike 6-link walker: serial vs 2 workers.

The grid covers the branch of the paper's gait (Table 3 compliance) between its
gait-pattern boundary (~0.14746 rad) and its fold (~0.14852 rad): 40 slopes from 0.1476 to
0.1485 rad, each solved on its own from the tangent prediction of the Table-2 fixed point
(``mode="grid"``: independent points, what spreads over the workers), followed by the
location of the bifurcations between neighbours (serial in both runs). The walker's
functions are loaded once before timing (compilation / cache loading excluded); the pool's
worker processes are forked inside the timed run. The two tables must be identical.

    python scripts/bench_sweep.py [--workers 2] [--num 40]
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np
import pandas as pd

from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.sweep import sweep
from pdw_casadi.model.problem import load_problem

GRID = (0.1476, 0.1485)  # rad


def _cpu() -> float:
    """CPU seconds used so far by this process and its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def timed(problem, grid, workers):
    """(wall s, CPU s, result): CPU time shows how much of the machine the run really got
    when other processes share the cores."""
    t0, c0 = time.perf_counter(), _cpu()
    res = sweep(problem, grid, mode="grid", workers=workers)
    return time.perf_counter() - t0, _cpu() - c0, res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--num", type=int, default=40)
    args = ap.parse_args()
    problem = load_problem("humanlike_6link")
    PoincareMap(problem).evaluate(problem.state_vector())  # warm-up: load compiled code
    grid = np.linspace(*GRID, args.num)

    load = os.getloadavg()[0]
    t_serial, c_serial, serial = timed(problem, grid, 1)
    t_pool, c_pool, pooled = timed(problem, grid, args.workers)
    pd.testing.assert_frame_equal(serial.table, pooled.table, check_exact=True)
    assert [e.to_dict() for e in serial.events] == [e.to_dict() for e in pooled.events]

    table = serial.table
    print(f"{args.num}-point slope sweep of humanlike_6link, slope {GRID[0]} .. {GRID[1]} rad "
          f"(grid mode; {int(table['converged'].sum())} of {len(table)} points converged, "
          f"{len(serial.events)} event(s) located)")
    print(f"serial:             {t_serial:6.1f} s wall, {c_serial:6.1f} s CPU")
    print(f"{args.workers} workers:          {t_pool:6.1f} s wall, {c_pool:6.1f} s CPU   "
          f"(identical table: yes)")
    print(f"ratio serial/pool:  {t_serial / t_pool:6.2f}x; target < 60 s: "
          f"serial {'met' if t_serial < 60 else 'NOT met'}, "
          f"{args.workers} workers {'met' if t_pool < 60 else 'NOT met'}")
    print(f"{os.cpu_count()} CPUs; 1-min load average {load:.2f} before the runs, "
          f"{os.getloadavg()[0]:.2f} after (other processes on the machine slow both runs)")
    for e in serial.events:
        print(f"  {e.kind} at slope {e.value:.8f} rad: {e.reason}")


if __name__ == "__main__":
    main()
