"""Benchmark the first run on a fresh machine: compiling everything a fit calls.

Each variant runs in a process of its own with an empty compile cache and compiles the
libraries of ``pdw_casadi.fit.fit_libraries`` (the walker, the Poincare map's sensitivities,
the shooting intervals, the stability row's chain), then times warm work on them (CPU time):
a fixed point with its exact Jacobian and 20 simulated steps.

- baseline: every library at ``-O1``, one after another (the policy before the
  optimisation levels of ``pdw_casadi.engine.compile``);
- levels: ``HOT`` (-Og) for hot loops, ``PLAIN`` (-O0) for straight-line code, one after
  another;
- levels, side by side: the same, one compiler per core (``build_libraries``, what
  ``pdw-fit`` does on a first run).

    python scripts/bench_compile.py [--problem humanlike_6link]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

VARIANTS = {"baseline": ("O1", 1), "levels": ("levels", 1),
            "levels, side by side": ("levels", 0)}


def child(problem_name: str, policy: str, workers: int) -> dict:
    """Compile and time in this process (PDW_CACHE is the caller's empty directory)."""
    import pdw_casadi.engine.compile as compile_module

    if policy == "O1":
        library, path = compile_module._library, compile_module._cache_path

        def as_before(funs, flags, so=None):
            return library(funs, ("-O1",), path(funs, ("-O1",)))

        compile_module._library = as_before
    from pdw_casadi.engine.compile import build_libraries
    from pdw_casadi.fit import FitOptions, fit_libraries
    from pdw_casadi.gait.fixed_point import find_fixed_point
    from pdw_casadi.gait.simulate import simulate
    from pdw_casadi.model.problem import load_problem

    problem = load_problem(problem_name)
    t = time.perf_counter()
    items = fit_libraries(problem, FitOptions())
    build = time.perf_counter() - t
    t = time.perf_counter()
    n = build_libraries(items, workers=workers or None)
    compile_s = time.perf_counter() - t
    find_fixed_point(problem)  # loads the libraries
    fp, sim = [], []
    for k in range(3):
        x0 = problem.state_vector() * (1 + 1e-4 * k)
        t = time.process_time()
        res = find_fixed_point(problem.with_state(x0))
        fp.append(time.process_time() - t)
        t = time.process_time()
        simulate(problem, steps=20)
        sim.append(time.process_time() - t)
    return {"libraries": n, "symbolic_s": build, "compile_s": compile_s,
            "fixed_point_cpu_s": min(fp), "simulate20_cpu_s": min(sim),
            "spectral_radius": res.spectral_radius}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="humanlike_6link")
    ap.add_argument("--child", nargs=2, metavar=("POLICY", "WORKERS"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.problem, args.child[0], int(args.child[1]))))
        return 0
    rows = {}
    for label, (policy, workers) in VARIANTS.items():
        with tempfile.TemporaryDirectory(prefix="pdw-bench-compile-") as cache:
            env = {**os.environ, "PDW_CACHE": cache}
            out = subprocess.run([sys.executable, __file__, "--problem", args.problem,
                                  "--child", policy, str(workers)],
                                 env=env, capture_output=True, text=True, check=True)
            rows[label] = json.loads(out.stdout.strip().splitlines()[-1])
        r = rows[label]
        print(f"{label:22s} {r['libraries']:3d} libraries: compile {r['compile_s']:6.1f} s "
              f"(symbolic {r['symbolic_s']:4.1f} s); warm fixed point "
              f"{r['fixed_point_cpu_s']:.3f} s CPU, 20 steps {r['simulate20_cpu_s']:.3f} s "
              f"CPU; rho {r['spectral_radius']:.12f}", flush=True)
    base = rows["baseline"]
    for label, r in rows.items():
        print(f"{label:22s} compile x{r['compile_s'] / base['compile_s']:.2f}, fixed point "
              f"x{r['fixed_point_cpu_s'] / base['fixed_point_cpu_s']:.2f}, 20 steps "
              f"x{r['simulate20_cpu_s'] / base['simulate20_cpu_s']:.2f} of the baseline")
    return 0


if __name__ == "__main__":
    sys.exit(main())
