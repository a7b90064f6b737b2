"""Time the fit NLP's constraint Jacobian: built and evaluated by CasADi from the MX graph
(``FitOptions(jacobian="casadi")``) against the one assembled from the shooting structure
(``"structured"``, pdw_casadi.nlp.jacobian) on one thread and with its intervals on one
thread per core (``FitOptions.threads``), in the same run, at the bundled file's first start
(humanlike 6-link walker, all compliance free). Prints the build time of the FitSolver (CPU
time of this process) and the median of ``--repeat`` evaluations of IPOPT's ``jac_g``
function (stability row included), in wall time and in CPU time of the process (threads
show in the wall time only), and the largest difference of the Jacobians.

    python scripts/bench_jacobian.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fit.starts import select_starts
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.shooting import ShootingNLP


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    problem = load_problem("humanlike_6link")
    human = load_gait_curves("female_fast.csv")
    st = select_starts(problem, human, FitOptions(verbose=False))[0]
    fp = find_fixed_point(problem, st.state, st.parameters, max_iter=30, fallback=False)
    nlp = ShootingNLP(problem, fp.state, fp.parameters, free=tuple(problem.compliance_names),
                      sample_stride=2)
    rng = np.random.default_rng(0)
    out, w = {}, None
    for kind, threads in (("casadi", 1), ("structured", 1), ("structured", None)):
        label = f"{kind}, {'1 thread' if threads == 1 else 'threads per core'}"
        t0 = time.process_time()
        fs = FitSolver(nlp, human, FitOptions(verbose=False, jacobian=kind, threads=threads),
                       log=None)
        build = time.process_time() - t0
        if w is None:
            w = nlp.w0 * (1 + 1e-6 * rng.standard_normal(nlp.w0.size))
        x = np.r_[w, fs.err(w).full().ravel()]
        fs.jac_g(x, [])  # first call: lazy compilation, caches
        walls, cpus = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            J = fs.jac_g(x, [])[1]
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        out[label] = (build, float(np.median(walls)), float(np.median(cpus)), J)
        print(f"{label:30s}: build {build:6.2f} s CPU, jac_g median {np.median(walls):.3f} s "
              f"wall, {np.median(cpus):.3f} s CPU ({args.repeat} calls)", flush=True)
    ref = out["casadi, 1 thread"]
    for label, (build, wall, _cpu, J) in out.items():
        if label.startswith("casadi"):
            continue
        diff = np.abs(ref[3].full() - J.full()).max()
        print(f"{label}: largest difference to casadi's {diff:.1e}"
              f" (largest entry {np.abs(ref[3].full()).max():.1e}); ratios casadi / this: build "
              f"{ref[0] / build:.1f}, jac_g wall {ref[1] / wall:.1f}")
    one, many = out["structured, 1 thread"], out["structured, threads per core"]
    print(f"threads per core against 1 thread: jac_g wall x{many[1] / one[1]:.2f}, "
          f"bit-identical: {bool((one[3].full() == many[3].full()).all())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
