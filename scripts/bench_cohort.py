"""Scale-out of a cohort, measured in one run: the single fits one after the other, then the
same study as a cohort on 1 and on 2 local workers and on a Dask LocalCluster given by its
address (2 worker processes, 1 thread each).

Every cohort run writes into a fresh directory (nothing resumed), and the three tables must
be identical in every result column (only the run's own wall and CPU times differ). Before
timing, one fit is run to load the walker's compiled functions into this process (the pool
forks from it; the Dask workers load them from the shared compile cache). CPU seconds are
reported beside the wall times: on shared cores they show how much of the machine the run
really got.

    python scripts/bench_cohort.py data/subjects --kind symmetric \
        --problem kneed_walker --free-slope --max-iter 30 --json bench.json
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import pandas as pd

from pdw_casadi.fit.options import FitOptions
from pdw_casadi.model.problem import load_problem
from pdw_casadi.studies.cohort import (
    CohortOptions,
    fit_tasks,
    plan_cohort,
    read_study,
    result_columns,
    run_cohort,
    run_fit_task,
)


def cohort_run(plan, out: Path, **kw) -> tuple[float, pd.DataFrame]:
    t0 = time.perf_counter()
    table = run_cohort(plan, out, **kw)
    return time.perf_counter() - t0, table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", nargs="+")
    ap.add_argument("--kind", default="symmetric")
    ap.add_argument("--problem", default="humanlike_6link")
    ap.add_argument("--free-slope", action="store_true")
    ap.add_argument("--max-iter", type=int, default=FitOptions.max_iter)
    ap.add_argument("--rounds", type=int, default=FitOptions.rounds)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()

    entries, _ = read_study(args.study, args.kind)
    fit = FitOptions(verbose=False, free_slope=args.free_slope, max_iter=args.max_iter,
                     rounds=args.rounds)
    plan = plan_cohort(entries, CohortOptions(problem=args.problem, kind=args.kind,
                                              body="paper", fit=fit),
                       reference=load_problem(args.problem))
    tasks, _ = fit_tasks(plan, {})
    print(f"{len(tasks)} fits of {args.problem} (max_iter {args.max_iter}, rounds "
          f"{args.rounds}); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs",
          flush=True)
    run_fit_task(tasks[0])  # warm-up: the walker's compiled functions loaded here

    singles = []
    t0 = time.perf_counter()
    for t in tasks:
        rec = run_fit_task(t)
        singles.append(rec["row"])
        print(f"  single {t.entry.fit_id}: {rec['row']['status']}, "
              f"{rec['row']['wall_time_s']:.1f} s wall, {rec['row']['cpu_time_s']:.1f} s CPU",
              flush=True)
    t_single = time.perf_counter() - t0
    single_sum = sum(r["wall_time_s"] for r in singles)
    single_cpu = sum(r["cpu_time_s"] for r in singles)

    from dask.distributed import LocalCluster

    results = {}
    with tempfile.TemporaryDirectory(prefix="bench-cohort-") as tmp:
        tmp = Path(tmp)
        results["1 worker"] = cohort_run(plan, tmp / "w1", workers=1)
        print(f"  cohort, 1 worker: {results['1 worker'][0]:.1f} s", flush=True)
        results[f"{args.workers} workers"] = cohort_run(plan, tmp / "w2",
                                                        workers=args.workers)
        print(f"  cohort, {args.workers} workers: "
              f"{results[f'{args.workers} workers'][0]:.1f} s", flush=True)
        with LocalCluster(processes=True, n_workers=args.workers, threads_per_worker=1,
                          dashboard_address=None) as cluster:
            key = f"Dask LocalCluster ({args.workers} workers) by address"
            results[key] = cohort_run(plan, tmp / "dask", scheduler=cluster.scheduler_address)
            print(f"  cohort, {key}: {results[key][0]:.1f} s", flush=True)
    tables = [t[result_columns(t)] for _, t in results.values()]
    for t in tables[1:]:
        pd.testing.assert_frame_equal(tables[0], t, check_exact=True)
    single_rows = pd.DataFrame(singles)
    status = tables[0]["status"].value_counts().to_dict()

    print(f"\n| run | wall time (s) | vs the sum of single fits | fits' CPU (s) |\n"
          f"|---|---|---|---|\n"
          f"| single fits, one after the other (sum of their wall times) | {single_sum:.1f} | "
          f"1.00 | {single_cpu:.1f} |")
    report = {"fits": len(tasks), "problem": args.problem, "max_iter": args.max_iter,
              "rounds": args.rounds, "status": status, "cpus": os.cpu_count(),
              "single_sum_s": single_sum, "single_cpu_s": single_cpu,
              "single_loop_s": t_single, "runs": {}}
    for key, (wall, table) in results.items():
        cpu = float(table["cpu_time_s"].sum())
        print(f"| cohort, {key} | {wall:.1f} | {single_sum / wall:.2f} | {cpu:.1f} |")
        report["runs"][key] = {"wall_s": wall, "fits_cpu_s": cpu,
                               "fits_wall_s": float(table["wall_time_s"].sum())}
    print(f"\nstatus: {status}; the three cohort tables are identical in every result "
          f"column; single-fit statuses {single_rows['status'].value_counts().to_dict()}; "
          f"load average now {os.getloadavg()[0]:.1f}")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
