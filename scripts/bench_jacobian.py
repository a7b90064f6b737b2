"""Time the fit NLP's constraint Jacobian: built and evaluated by CasADi from the MX graph
(``FitOptions(jacobian="casadi")``) against the one assembled from the shooting structure
(``"structured"``, pdw_casadi.nlp.jacobian), in the same run, at the bundled file's first
start (humanlike 6-link walker, all compliance free). Prints the median of ``--repeat``
evaluations of IPOPT's ``jac_g`` function (stability row included) and the build time of
the FitSolver (CPU time of this process: robust on a shared machine), and the largest
difference of the two Jacobians.

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
    out = {}
    for kind in ("casadi", "structured"):
        t0 = time.process_time()
        fs = FitSolver(nlp, human, FitOptions(verbose=False, jacobian=kind), log=None)
        build = time.process_time() - t0
        w = nlp.w0 * (1 + 1e-6 * rng.standard_normal(nlp.w0.size)) if not out else out["w"]
        x = np.r_[w, fs.err(w).full().ravel()]
        fs.jac_g(x, [])  # first call: lazy compilation, caches
        times = []
        for _ in range(args.repeat):
            t0 = time.process_time()
            J = fs.jac_g(x, [])[1]
            times.append(time.process_time() - t0)
        out.update({kind: (build, float(np.median(times)), J), "w": w})
        print(f"{kind:10s}: build {build:6.2f} s, jac_g median {np.median(times):.3f} s "
              f"({args.repeat} calls)", flush=True)
    a, b = out["casadi"][2].full(), out["structured"][2].full()
    print(f"largest difference {np.abs(a - b).max():.1e} (largest entry {np.abs(a).max():.1e}); "
          f"ratios casadi / structured: build {out['casadi'][0] / out['structured'][0]:.1f}, "
          f"jac_g {out['casadi'][1] / out['structured'][1]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
