"""Benchmark the fit: ``fit_gait`` of the humanlike 6-link walker (all eight compliance
values free, slope fixed, ``pdw-fit`` defaults) on the bundled ``female_fast.csv`` and on
each subject's own curves (``data/subjects``, built by ``scripts/make_subject_curves.py``).

Per file: wall time (compiled functions warmed up first, so compilation is not timed),
IPOPT status and iterations, knee/hip/thigh R^2, spectral radius of the simulator's fixed
point, re-simulation deviation, and the Table-3 compliance's R^2 on the same file. Targets
checked per file: wall <= 60 s, Solve_Succeeded, rho <= 0.9, valid, re-simulation < 1e-6,
knee R^2 and mean(knee, hip) R^2 above Table 3's. For scale, the time of one exact fixed
point with eigenvalues is measured in the same run (ratio column).

    python scripts/bench_fit.py [FILE ...]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from pdw_casadi.fit import FitOptions, fit_gait, reference_gait
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.shooting import ShootingNLP

ROOT = Path(__file__).resolve().parents[1]
GOAL_S = 60.0


def files() -> list[str]:
    if len(sys.argv) > 1:
        return sys.argv[1:]
    return ["female_fast.csv", *sorted(str(p) for p in (ROOT / "data" / "subjects").glob(
        "*.csv"))]


def main() -> int:
    problem = load_problem("humanlike_6link")
    fp = find_fixed_point(problem)  # warm-up: simulator and sensitivity libraries
    human0 = load_gait_curves("female_fast.csv")
    nlp = ShootingNLP(problem, fp.state, fp.parameters, free=tuple(problem.compliance_names))
    FitSolver(nlp, human0, FitOptions(verbose=False)).row.value(nlp.w0)  # interval libraries
    t0 = time.perf_counter()
    find_fixed_point(problem)
    t_fp = time.perf_counter() - t0
    print(f"one fixed point + eigenvalues: {t_fp:.3f} s")
    head = (f"{'file':22s} {'wall s':>7s} {'x fp':>6s} {'status':16s} {'iter':>4s} "
            f"{'knee':>6s} {'hip':>6s} {'thigh':>6s} {'rho':>6s} {'resim':>8s} | "
            f"{'T3 knee':>7s} {'T3 hip':>6s} {'T3 thigh':>8s} | targets")
    print(head)
    all_met = True
    for f in files():
        human = load_gait_curves(f)
        t3 = reference_gait(problem, human)
        t0 = time.perf_counter()
        res = fit_gait(problem, human, FitOptions(verbose=False), log=lambda m: None)
        wall = time.perf_counter() - t0
        b = res.best or (res.candidates[0] if res.candidates else None)
        last = res.solves[-1] if res.solves else None
        name = Path(f).name
        if b is None or last is None:
            print(f"{name:22s} {wall:7.1f}  no candidate: {res.notes}")
            all_met = False
            continue
        s = b.scores
        checks = {
            "time": wall <= GOAL_S,
            "ipopt": all(x.status == "Solve_Succeeded" for x in res.solves),
            "stable": b.stable and b.fixed_point.spectral_radius <= 0.9,
            "valid": b.valid and b.resimulation_deviation < 1e-6,
            "knee>T3": s["r2_knee"] > t3["r2_knee"],
            "mean>T3": (s["r2_knee"] + s["r2_hip"]) > (t3["r2_knee"] + t3["r2_hip"]),
        }
        all_met &= all(checks.values())
        missed = [k for k, v in checks.items() if not v]
        iters = "+".join(str(x.iterations) for x in res.solves)
        print(f"{name:22s} {wall:7.1f} {wall / t_fp:6.0f} {last.status:16s} {iters:>4s} "
              f"{s['r2_knee']:6.3f} {s['r2_hip']:6.3f} {s.get('r2_thigh', float('nan')):6.3f} "
              f"{b.fixed_point.spectral_radius:6.4f} {b.resimulation_deviation:8.1e} | "
              f"{t3['r2_knee']:7.3f} {t3['r2_hip']:6.3f} {t3.get('r2_thigh', float('nan')):8.3f}"
              f" | {'all met' if not missed else 'missed: ' + ', '.join(missed)}", flush=True)
    return 0 if all_met else 1


if __name__ == "__main__":
    sys.exit(main())
