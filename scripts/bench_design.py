"""Benchmark the prosthesis design: the shipped 30 % design's problem in this process.

The problem of ``data/designs/humanlike_6link_prosthesis30.toml``, as its command poses it
(``pdw-design --lighter 0.3 --max-solves 30 --free-sound k_ankle,c_ankle,k_knee,c_knee_flex,
c_knee_ext,c_knee_stance,theta_eq,theta_dis --accept-verified --symmetry-tol 0.9``): from the
atlas gait, the right shank and foot 30 % lighter, all eight compliance values of both legs
free. Per homotopy step: the mass reduction, IPOPT status and iterations, which iterate
answered, wall time, the re-simulated stride radius and asymmetries, accepted. At the end:
the whole design's wall time (the compile cache as it is: run once to warm it), the verdict
(reached, stable, valid, symmetric), the prosthetic leg's compliance against the shipped
file's, and the load average, beside the goal (<= 120 s warm).

    python scripts/bench_design.py
    python scripts/bench_design.py --set step_tol=1e-3 --set near_start=true   # a variant
    python scripts/bench_design.py --lighter 0.009 --max-solves 2             # its first steps
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from bench_fit import parse_set

from pdw_casadi.gait.stride import physical_parameter_names, physical_parameter_vector
from pdw_casadi.model.problem import load_problem
from pdw_casadi.studies.prosthesis import (
    NLP_FREE,
    DesignNLPOptions,
    atlas_problem,
    design_prosthesis_nlp,
)

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "data" / "designs" / "humanlike_6link_prosthesis30.toml"
GOAL_S = 120.0  # the whole 30 % design, warm


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lighter", type=float, default=0.3, help="mass reduction (-)")
    ap.add_argument("--max-solves", type=int, default=30)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a DesignNLPOptions field (VALUE as JSON)")
    args = ap.parse_args(argv)
    options = DesignNLPOptions(max_solves=args.max_solves, symmetry_tol_pct=0.9,
                               accept_verified=True, free_sound=NLP_FREE,
                               **parse_set(args.set, DesignNLPOptions))
    print(f"load average {os.getloadavg()[0]:.2f} before the run")
    t0 = time.perf_counter()
    atlas = atlas_problem()
    res = design_prosthesis_nlp(atlas, lighter=args.lighter, options=options,
                                log=None)
    wall = time.perf_counter() - t0
    print("| % lighter | start | status | iterations | answer | IPOPT s | stride radius | "
          "asymmetry length / time % | accepted |")
    print("|---|---|---|---|---|---|---|---|---|")
    for s in res.solves:
        print(f"| {100 * s.lighter:.2f} | {'warm' if s.warm else 'cold'} | {s.status} | "
              f"{s.iterations} | "
              f"{s.answered_with or 'IPOPT'} | {s.wall_time_s:.1f} | {s.stride_radius:.4f} | "
              f"{s.step_length_asymmetry_pct:.3f} / {s.step_time_asymmetry_pct:.3f} | "
              f"{s.accepted} |")
    reached = 100 * res.path[-1][0]
    print(f"whole design {wall:.1f} s (goal <= {GOAL_S:g} s warm), {len(res.solves)} solves, "
          f"{sum(s.iterations for s in res.solves)} iterations; reached {reached:.2f} % "
          f"lighter; verdict {res.reached}; stride radius {res.fixed_point.spectral_radius:.4f}")
    start = dict(zip(physical_parameter_names(atlas), physical_parameter_vector(atlas),
                     strict=True))

    def least_change(values: dict) -> float:
        """The design's objective: squared relative changes from the start's compliance
        (both legs' keys; the NLP's own scale, at least 0.01 in SI units)."""
        return sum(((v - start[k]) / max(abs(start[k]), 1e-2)) ** 2
                   for k, v in values.items())

    got = {**{f"right.{k}": v for k, v in res.compliance.items()},
           **{f"left.{k}": v for k, v in res.sound_compliance.items()}}
    print(f"least-change objective of the design {least_change(got):.5f}")
    if args.lighter == 0.3 and SHIPPED.exists():
        shipped = load_problem(SHIPPED)
        names = physical_parameter_names(shipped)
        ref = physical_parameter_vector(shipped)
        worst = max(abs(v / ref[names.index(k)] - 1) for k, v in got.items()
                    if k.startswith("right.") and abs(ref[names.index(k)]) > 1e-9)
        mine = {k: float(ref[names.index(k)]) for k in got}
        print(f"prosthetic compliance against the shipped file's: largest relative change "
              f"{100 * worst:.2f} %; the shipped design's least-change objective "
              f"{least_change(mine):.5f}")
    print(f"load average {os.getloadavg()[0]:.2f} after the run")
    return 0 if res.reached and wall <= GOAL_S else 1


if __name__ == "__main__":
    sys.exit(main())
