"""Benchmark the full fit: ``fit_gait`` of the humanlike 6-link walker to the bundled
female_fast curves (all eight compliance values free, slope fixed), as ``pdw-fit`` runs it.

Prints the wall time of the fit (compiled functions warmed up first, so compilation is not
timed), against the issue's goal (60 s) and limit (600 s), with the fit's R^2 and spectral
radius, and for scale the time of one exact fixed-point solve with eigenvalues (the unit the
paper's global search repeats thousands of times) in the same run.
"""

from __future__ import annotations

import sys
import time

from pdw_casadi.fit import FitOptions, fit_gait
from pdw_casadi.fixed_point import find_fixed_point
from pdw_casadi.gait_data import load_gait_curves
from pdw_casadi.problem import load_problem
from pdw_casadi.shooting import ShootingNLP

GOAL_S, LIMIT_S = 60.0, 600.0


def main() -> int:
    problem = load_problem("humanlike_6link")
    human = load_gait_curves("female_fast.csv")
    fp = find_fixed_point(problem)  # warm-up: simulator and sensitivity libraries
    ShootingNLP(problem, fp.state, fp.parameters)  # warm-up: interval libraries
    t0 = time.perf_counter()
    fp = find_fixed_point(problem)
    t_fp = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = fit_gait(problem, human, FitOptions(verbose=False), log=lambda m: print("  " + m))
    t_fit = time.perf_counter() - t0
    best = res.best or (res.candidates[0] if res.candidates else None)
    print(f"fixed point + eigenvalues : {t_fp:8.3f} s")
    print(f"fit (pdw-fit default)     : {t_fit:8.1f} s   goal {GOAL_S:.0f} s, limit {LIMIT_S:.0f} s"
          f"  -> {'met' if t_fit < GOAL_S else ('within limit' if t_fit < LIMIT_S else 'OVER')}")
    print(f"fit / one fixed point     : {t_fit / t_fp:8.0f}x")
    if best is not None:
        s = best.scores
        print(f"r2_knee {s['r2_knee']:.4f}  r2_hip {s['r2_hip']:.4f}  "
              f"r2_thigh {s.get('r2_thigh', float('nan')):.4f}  spectral radius "
              f"{best.fixed_point.spectral_radius:.4f}  stable {best.stable}  valid {best.valid}"
              f"  resimulation deviation {best.resimulation_deviation:.2e}")
    return 0 if t_fit < LIMIT_S else 1


if __name__ == "__main__":
    sys.exit(main())
