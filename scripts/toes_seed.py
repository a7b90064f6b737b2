"""A search for heel-off gaits of the toe-foot walker (humanlike_toes), and what stops them.

    python scripts/toes_seed.py --out seeds.json [--problem humanlike_toes] [--samples 200]
        [--seed 0] [--newton 20] [--continue KEY TO NUM]

The toe walker's phases follow its contacts, so a compliance far from a gait fails in its
first step. This script samples the compliance values of :data:`RANGES` (uniformly, within
the problem's bounds) at the section state of ``--problem`` (its shipped gait), simulates one
step from each and tallies how every step ended, and how the steps whose stance heel lifted
in single support (phase II_mtp) ended: the failure that stopped them, or a whole step. For
every whole step with heel off it solves for the fixed point (Newton on the exact step map,
at most ``--newton`` iterations, from the step's end state) and records its phases, gait
timing (heel off, toe off, stance, double support per period, % of the cycle), spectral
radius, eigenvalues and validity, best (stable, valid, heel off in 25-40 %) first. With
``--continue KEY TO NUM`` it instead follows the problem's fixed point in one compliance
value (spectral radius, eigenvalues and the stance heel's load along the way).
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import time
from pathlib import Path

import numpy as np

from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.gait.stability import RADIUS_BOUND
from pdw_casadi.gait.timing import gait_timing, phase_contacts
from pdw_casadi.model.problem import load_problem

#: the compliance keys sampled and their ranges: the stance ankle's plantarflexing torque
#: (quasi-stiffness, its rest angle, the clutch spring) moves the centre of pressure towards
#: the MTP joint, the MTP spring sets how the toes carry it
RANGES = {"k_clutch": (10.0, 200.0), "phi_clutch": (1.45, 1.70), "ankle_rest": (-0.2, 0.6),
          "k_ankle": (0.0, 40.0), "k_mtp": (1.0, 50.0), "mtp_rest": (-0.4, 0.0),
          "c_mtp": (0.005, 0.1)}


def timing(step, family="humanlike_toes") -> dict:
    """Heel off, toe off, stance (% of the cycle) and the double-support periods (% each)."""
    t = gait_timing(step.phases, step.step_length, phase_contacts(family))
    return {"heel_off_pct": t.heel_off_pct, "toe_off_pct": t.toe_off_pct,
            "stance_pct": t.stance_pct, "double_support_pct": list(t.double_support_pct)}


def score(r) -> tuple:
    """Sort key: stable and valid first, then heel off inside 25-40 %, then rho."""
    ho = r["timing"].get("heel_off_pct") or 50.0
    stable = r["rho"] <= RADIUS_BOUND and r["valid"]
    return (not stable, abs(float(np.clip(ho, 25, 40)) - ho), r["rho"])


def continuation(pb, sim, key: str, stop: float, num: int) -> list[dict]:
    """Natural-parameter continuation of ``pb``'s fixed point in compliance ``key`` up to
    ``stop`` in ``num`` steps (Newton from the previous point): per point the spectral
    radius, the eigenvalues, validity, phases and the smallest heel load of the stance foot
    in single support (N m; heel off where it reaches zero)."""
    x, p = pb.state_vector(), pb.parameter_vector()
    i = list(pb.parameter_names).index(key)
    rows = []
    for v in np.linspace(p[i], stop, num):
        q = p.copy()
        q[i] = v
        fp = find_fixed_point(pb, x, q, fallback=False, max_iter=15)
        if not fp.converged:
            rows.append({key: float(v), "converged": False})
            break
        x, p = fp.state, q
        run = sim.run(x, p, steps=1, record=True)
        traj = run.trajectory
        single = traj[traj.phase.isin(["II", "II_stop"])]
        load = single.heelload_foot1.min() if "heelload_foot1" in single else float("nan")
        rows.append({key: float(v), "converged": True, "rho": float(fp.spectral_radius),
                     "eigenvalues": [[float(e.real), float(e.imag)] for e in fp.eigenvalues],
                     "valid": bool(fp.valid), "failure": fp.failure,
                     "phases": [n for n, _ in run.steps[0].phases],
                     "min_heel_load_Nm": float(load)})
        print(f"{key} {v:.4g}: rho {fp.spectral_radius:.3g}, valid {fp.valid}, heel load "
              f"{load:.3g} N m, phases {', '.join(rows[-1]['phases'])}", flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="JSON file to write")
    ap.add_argument("--problem", default="humanlike_toes", help="the start (its gait)")
    ap.add_argument("--samples", type=int, default=200, help="compliance samples")
    ap.add_argument("--seed", type=int, default=0, help="random seed")
    ap.add_argument("--newton", type=int, default=20, help="Newton iterations at most")
    ap.add_argument("--range", nargs=3, action="append", default=[],
                    metavar=("KEY", "LO", "HI"),
                    help="sample only the keys given so (repeatable), the others at the "
                         "problem's values")
    ap.add_argument("--continue", dest="cont", nargs=3, metavar=("KEY", "TO", "NUM"),
                    help="instead: continue the problem's fixed point in compliance KEY up "
                         "to TO in NUM steps")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    pb = load_problem(args.problem)
    sim = Simulator(pb)
    if args.cont:
        key, stop, num = args.cont[0], float(args.cont[1]), int(args.cont[2])
        rows = continuation(pb, sim, key, stop, num)
        args.out.write_text(json.dumps({"problem": args.problem, "continuation": rows,
                                        "wall_time_s": time.perf_counter() - t0}, indent=2))
        return 0
    rng = np.random.default_rng(args.seed)
    bounds = pb.compliance_bounds
    ranges = ({k: (float(lo), float(hi)) for k, lo, hi in args.range} if args.range
              else RANGES)
    ends, found, all_ends = collections.Counter(), [], collections.Counter()
    for k in range(args.samples):
        comp = {}
        for key, (lo, hi) in ranges.items():
            blo, bhi = bounds.get(key, (lo, hi))
            comp[key] = float(rng.uniform(max(lo, blo), min(hi, bhi)))
        q = pb.replace(compliance=comp)
        run = sim.run(q.state_vector(), q.parameter_vector(), steps=1, record=False)
        phases = [n for n, _ in run.steps[0].phases]
        all_ends[run.failure.reason if run.failure else "whole step"] += 1
        if "II_mtp" not in phases:
            continue
        ends[run.failure.reason if run.failure else "whole step"] += 1
        if run.failure is not None:
            continue
        fp = find_fixed_point(q, run.steps[0].x_section_end, q.parameter_vector(),
                              fallback=False, max_iter=args.newton)
        if not fp.converged:
            ends["whole step, Newton did not converge"] += 1
            continue
        step = sim.run(fp.state, fp.parameters, steps=1, record=False).steps[0]
        r = {"compliance": {**q.compliance}, "slope": q.slope,
             "fixed_point": dict(zip(q.state_names, map(float, fp.state), strict=True)),
             "phases_s": dict(step.phases), "timing": timing(step),
             "rho": float(fp.spectral_radius), "valid": bool(fp.valid), "failure": fp.failure,
             "eigenvalues": [[float(e.real), float(e.imag)] for e in fp.eigenvalues]}
        found.append(r)
        print(f"sample {k}: rho {r['rho']:.3g}, valid {r['valid']} ({r['failure']}), phases "
              f"{', '.join(r['phases_s'])}, timing {r['timing']}", flush=True)
    found.sort(key=score)
    args.out.write_text(json.dumps({"problem": args.problem, "samples": args.samples,
                                    "seed": args.seed, "heel_off_step_ends": dict(ends),
                                    "step_ends": dict(all_ends),
                                    "gaits": found,
                                    "wall_time_s": time.perf_counter() - t0}, indent=2))
    print(f"how the steps ended: {dict(all_ends.most_common())}")
    print(f"{sum(ends.values())} of {args.samples} samples lifted the stance heel in single "
          f"support; how their step ended: {dict(ends.most_common())}; {len(found)} fixed "
          f"points; written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
