"""Design a prosthetic leg's compliance: right shank and foot lighter, gait made symmetric.

Starts from a stable gait of the bundled atlas (``--entry``, default the walker's own gait
at spectral radius 0.83) and runs :func:`pdw_casadi.prosthesis.design_prosthesis`; prints
how far the continuation got, the step lengths and times per leg with their asymmetry, the stride's
spectral radius, validity, the compliance found and the wall time. ``--out FILE.toml``
writes the designed walker as a problem file (``pdw-fixed-point --problem FILE.toml``
re-solves it on the stride map).

    python scripts/prosthesis_design.py --lighter 0.3
"""

from __future__ import annotations

import argparse
import time

from pdw_casadi.prosthesis import START_ENTRY, atlas_problem, design_prosthesis, lighter_mass
from pdw_casadi.scaling import problem_toml


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lighter", type=float, default=0.3,
                    help="fraction by which the right shank and foot are lighter")
    ap.add_argument("--entry", default=START_ENTRY,
                    help="label of the atlas entry to start from (default: %(default)s)")
    ap.add_argument("--no-hold", action="store_true",
                    help="symmetry conditions only (do not hold the first phase's duration)")
    ap.add_argument("--out", help="write the designed walker to this TOML file")
    args = ap.parse_args(argv)
    base = atlas_problem(args.entry)
    t0 = time.perf_counter()
    res = design_prosthesis(base, lighter=args.lighter, hold_first_phase=not args.no_hold)
    took = time.perf_counter() - t0
    rep, fp = res.report, res.fixed_point
    legs = rep["legs"]
    print(f"start: atlas entry {args.entry}; target: right shank+foot {100 * args.lighter:g} % "
          f"lighter")
    print(f"reached lambda = {res.path[-1][0]:.4f} ({len(res.path)} points): right shank+foot "
          f"{100 * (1 - lighter_mass(res.problem)):.2f} % lighter; full target reached: "
          f"{res.reached}")
    print(f"step length L/R {legs['left']['step_length_m']:.5f} / "
          f"{legs['right']['step_length_m']:.5f} m (asymmetry "
          f"{rep['step_length_asymmetry_pct']:.2e} %)")
    print(f"step time   L/R {legs['left']['step_time_s']:.5f} / "
          f"{legs['right']['step_time_s']:.5f} s "
          f"(asymmetry {rep['step_time_asymmetry_pct']:.2e} %)")
    print(f"stance % L/R {legs['left']['stance_pct']:.2f} / {legs['right']['stance_pct']:.2f}, "
          f"double support {rep['double_support_pct']:.2f} %")
    print(f"stride spectral radius {fp.spectral_radius:.4f} (per step {res.step_radius:.4f}); "
          f"stable (per step <= 0.9): {res.step_radius <= 0.9}; valid: {fp.valid}")
    print("prosthetic-leg compliance:", ", ".join(f"{k} = {v:.4f}"
                                                 for k, v in res.compliance.items()))
    print(f"wall time {took:.1f} s")
    if args.out:
        with open(args.out, "w") as f:
            f.write(problem_toml(res.problem, "# written by scripts/prosthesis_design.py\n"))
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
