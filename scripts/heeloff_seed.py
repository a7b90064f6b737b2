"""A first heel-off gait of the forefoot-rocker walker, to start its fit from.

    python scripts/heeloff_seed.py --out seed.json [--rounds 10] [--max-iter 50]

The fit follows the event pattern of its starting gait, so a walker whose gaits all keep the
stance heel down until the other heel strikes cannot be fitted into heel off directly. This
script finds a gait with heel off in two stages, from the ankle walker's shipped gait
(``problems/humanlike_6link_ankle.toml``) carried to the forefoot-rocker family:

1. rounds of the fit NLP (:class:`~pdw_casadi.fit.driver.FitSolver`: the curves of
   ``--gait``, the timing target, every validity margin and the stability bound, all
   compliance free within the problem's bounds) with ``--weight`` times the heel-off event
   at the end of phase II (the stance foot's centre-of-pressure distance from its toe times
   its normal force, N m) added to the objective, each round re-planned at the previous
   answer's fixed point, until that margin is below ``--threshold``;
2. natural-parameter continuation of the fixed point (Newton) in ``k_clutch`` in steps of
   ``--step`` N m/rad until the fixed point's step has the toe-rocker phase II_toe.

It writes a JSON file with ``fixed_point`` (section state) and ``compliance``, which
``pdw-fit --state FILE --compliance FILE`` read. The stability bound holds in every NLP
round; the heel off of the seed is brief (it appears at the end of single support).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import casadi as ca

from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.fixed_point import find_fixed_point
from pdw_casadi.gait_data import load_gait_curves
from pdw_casadi.problem import load_problem
from pdw_casadi.shooting import ShootingNLP
from pdw_casadi.simulate import Simulator


def start_problem():
    """The forefoot-rocker walker at the ankle walker's shipped gait and compliance."""
    ankle = load_problem("humanlike_6link_ankle")
    return load_problem("humanlike_6link_heeloff").replace(
        compliance=dict(ankle.compliance), slope=ankle.slope).with_state(ankle.state_vector())


def heel_off_margin(nlp) -> ca.MX:
    """The heel-off event (N m) at the last RK4 sample of the NLP's last phase-II segment."""
    k = max(i for i, s in enumerate(nlp.specs) if s.phase == "II")
    names = nlp.output_names("II")
    events = [e.name for e in nlp.hs.event_list["II"]]
    return nlp.Y[k][len(names) - len(events) + events.index("heel_off"), -1]


def push_round(pb, x, p, human, opts: FitOptions, weight: float):
    """One round of the fit NLP from the fixed point (x, p) with ``weight`` (1/(N m)) times
    the heel-off margin added to its objective: (section state, parameters, margin N m)."""
    nlp = ShootingNLP(pb, x, p, free=tuple(pb.compliance_names), headroom_s=0.06)
    margin = ca.Function("margin", [nlp.w], [heel_off_margin(nlp)])
    out = FitSolver(nlp, human, opts, log=lambda m: None,
                    extra=lambda n: weight * heel_off_margin(n)).solve(nlp.w0)
    u = nlp.unpack(out["w"])
    return u["xs"], u["p"], float(margin(out["w"])), out["status"]


def has_heel_off(sim, x, p) -> bool:
    run = sim.run(x, p, steps=1, record=False)
    return run.failure is None and any(n == "II_toe" for n, _ in run.steps[0].phases)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="JSON file to write")
    ap.add_argument("--gait", default="female_fast.csv", help="gait-curve file of the fit")
    ap.add_argument("--rounds", type=int, default=10, help="NLP rounds at most (default 10)")
    ap.add_argument("--max-iter", type=int, default=60, help="IPOPT iterations per round")
    ap.add_argument("--weight", type=float, default=0.05,
                    help="weight (1/(N m)) of the heel-off margin in the objective")
    ap.add_argument("--threshold", type=float, default=0.05,
                    help="heel-off margin (N m) that ends the NLP rounds (default 0.05)")
    ap.add_argument("--step", type=float, default=0.01,
                    help="k_clutch continuation step (N m/rad, default 0.01)")
    ap.add_argument("--max-steps", type=int, default=200, help="continuation steps at most")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    pb = start_problem()
    sim = Simulator(pb)
    fp = find_fixed_point(pb, fallback=False)
    x, p = fp.state, fp.parameters
    human = load_gait_curves(args.gait)
    opts = FitOptions(timing_weight=1.0, max_iter=args.max_iter, verbose=False)
    for rnd in range(args.rounds):
        x, p, margin, status = push_round(pb, x, p, human, opts, args.weight)
        fp = find_fixed_point(pb, x, p, fallback=False)
        print(f"round {rnd}: {status}, heel-off margin {margin:.4g} N m, fixed point "
              f"{fp.converged}, rho {fp.spectral_radius:.3g}, valid {fp.valid}", flush=True)
        if not fp.converged:
            print("the round's answer has no fixed point", file=sys.stderr)
            return 1
        x = fp.state
        if margin < args.threshold:
            break
    i = list(pb.parameter_names).index("k_clutch")
    for n in range(args.max_steps):
        if has_heel_off(sim, x, p):
            break
        q = p.copy()
        q[i] += args.step
        fp = find_fixed_point(pb, x, q, fallback=False, max_iter=15)
        if not fp.converged:
            print(f"continuation step {n}: no fixed point at k_clutch {q[i]:.4g}",
                  file=sys.stderr)
            return 1
        x, p = fp.state, q
    else:
        print("no heel off within the continuation steps", file=sys.stderr)
        return 1
    run = sim.run(x, p, steps=1, record=False)
    phases = {n: d for n, d in run.steps[0].phases}
    out = {"fixed_point": dict(zip(pb.state_names, map(float, x), strict=True)),
           "compliance": dict(zip(pb.compliance_names, map(float, p[:-1]), strict=True)),
           "slope": float(p[-1]), "phases_s": phases,
           "spectral_radius": float(find_fixed_point(pb, x, p, fallback=False).spectral_radius),
           "wall_time_s": time.perf_counter() - t0}
    args.out.write_text(json.dumps(out, indent=2))
    print(f"heel-off gait: phases {', '.join(f'{k} {1e3 * v:.1f} ms' for k, v in phases.items())}"
          f"; k_clutch {p[i]:.4g} N m/rad; written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
