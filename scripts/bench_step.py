"""Benchmark one step from Table 2: pdw_casadi Simulator vs the numpy/scipy baseline.

Both walk the humanlike 6-link walker (Table 3 compliance, slope 0.1484) one step from the
Table 2 section state. The CasADi simulator is warmed up once (compilation / cache loading
excluded) and timed best of 5; the baseline ``tests/numpy_walker.py`` (solve_ivp RK45,
rtol 1e-9) is timed best of 3. Exits 1 if the end states differ by more than 1e-6.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import numpy_walker  # noqa: E402

from pdw_casadi.gait.simulate import Simulator  # noqa: E402
from pdw_casadi.model.problem import load_problem  # noqa: E402


def best_of(fn, n):
    best, out = float("inf"), None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> int:
    problem = load_problem("humanlike_6link")
    x0, p = problem.state_vector(), problem.parameter_vector()
    sim = Simulator(problem)
    sim.run(x0, p, steps=1, record=False)  # warm-up: compilation / cache loading
    t_ours, res = best_of(lambda: sim.run(x0, p, steps=1, record=False), 5)
    x_ours = res.steps[0].x_section_end

    params = numpy_walker.load_params()
    model = numpy_walker.Model(params)
    t_base, out = best_of(
        lambda: numpy_walker.simulate_step(x0, params, model, diagnostics=False), 3)
    x_base = out["x7_end"]

    diff = float(np.max(np.abs(np.asarray(x_ours) - x_base)))
    print(f"pdw_casadi Simulator.run (best of 5): {t_ours * 1e3:9.2f} ms")
    print(f"numpy/scipy baseline     (best of 3): {t_base * 1e3:9.2f} ms")
    print(f"max |x_end(ours) - x_end(baseline)| = {diff:.3e}")
    print(f"speed-up baseline/ours = {t_base / t_ours:.1f}x (target >= 20x)")
    if diff > 1e-6:
        print("end states disagree by more than 1e-6")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
