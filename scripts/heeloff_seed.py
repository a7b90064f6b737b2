"""A first heel-off gait of the forefoot-rocker walker, to start its fit from.

    python scripts/heeloff_seed.py --out seed.json [--stability] [--rounds 12]
        [--max-iter 50] [--lengthen-ms 15]

The fit follows the event pattern of its starting gait, so a walker whose gaits all keep the
stance heel down until the other heel strikes cannot be fitted into heel off directly. This
script finds a fixed point with heel off in three stages, from the ankle walker's shipped
gait (``problems/humanlike_6link_ankle.toml``) carried to the forefoot-rocker family; every
NLP has all validity margins and the periodicity as constraints and all compliance free
within the problem's bounds (:class:`~pdw_casadi.nlp.shooting.ShootingNLP`):

1. *push*: rounds of the NLP minimising the heel-off event at the end of phase II (the stance
   foot's centre-of-pressure distance from its toe times its normal force, N m), each round
   re-planned at the previous answer's fixed point, until it is below ``--threshold``. With
   ``--stability`` the NLP is the fit's (:class:`~pdw_casadi.fit.driver.FitSolver`: curves
   of ``--gait``, timing target, stability bound) with ``--weight`` times the event added;
2. *cross*: natural-parameter continuation of the fixed point (Newton) in ``k_clutch``, steps
   of ``--step`` N m/rad, until the fixed point's step has the toe-rocker phase II_toe;
3. *lengthen*: rounds of the NLP maximising the duration of II_toe, until it lasts
   ``--lengthen-ms`` (0: skip), each answer's fixed point found by Newton (IPOPT fallback).

It writes a JSON file with ``fixed_point`` (section state), ``compliance`` and ``slope``
(``pdw-fit --state FILE --compliance FILE`` read the first two), the phase durations, the
spectral radius and the validity of the seed.
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
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.driver import IPOPT_TOL
from pdw_casadi.nlp.shooting import ShootingNLP


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


def toe_rocker_time(nlp) -> ca.MX:
    """The duration (s) of phase II_toe in the NLP's step."""
    return sum(nlp.T[k] for k, s in enumerate(nlp.specs) if s.phase == "II_toe")


def solve(nlp, objective, max_iter: int):
    """IPOPT (L-BFGS) on the NLP's constraints with ``objective``: the unpacked answer."""
    lo, hi = nlp.bounds()
    solver = ca.nlpsol("seed", "ipopt", {"x": nlp.w, "f": objective, "g": nlp.g},
                       {"ipopt": {"hessian_approximation": "limited-memory",
                                  "max_iter": max_iter, "print_level": 0, "sb": "yes",
                                  "tol": IPOPT_TOL, "mu_strategy": "adaptive"},
                        "print_time": False})
    sol = solver(x0=nlp.w0, lbx=lo, ubx=hi, lbg=nlp.lbg, ubg=nlp.ubg)
    return nlp.unpack(sol["x"].full()), solver.stats()["return_status"]


def push_round(pb, x, p, args, human=None):
    """One push round from the fixed point (x, p): (section state, parameters, status)."""
    nlp = ShootingNLP(pb, x, p, free=tuple(pb.compliance_names), headroom_s=0.05)
    if human is None:
        u, status = solve(nlp, heel_off_margin(nlp), args.max_iter)
        return u["xs"], u["p"], status
    opts = FitOptions(timing_weight=1.0, max_iter=args.max_iter, verbose=False)
    out = FitSolver(nlp, human, opts, log=lambda m: None,
                    extra=lambda n: args.weight * heel_off_margin(n)).solve(nlp.w0)
    u = nlp.unpack(out["w"])
    return u["xs"], u["p"], out["status"]


def phases_of(sim, x, p) -> dict[str, float]:
    run = sim.run(x, p, steps=1, record=False)
    return {} if run.failure is not None else dict(run.steps[0].phases)


def margin_of(sim, x, p) -> float:
    """The heel-off event's smallest value in phase II of the step from x (N m)."""
    run = sim.run(x, p, steps=1, record=True)
    ii = run.trajectory[run.trajectory.phase == "II"]
    return float((ii.cop_foot1_from_toe * ii.N_foot1).min())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="JSON file to write")
    ap.add_argument("--stability", action="store_true",
                    help="push with the fit's NLP (curves, timing, stability bound)")
    ap.add_argument("--gait", default="female_fast.csv", help="curves of --stability")
    ap.add_argument("--weight", type=float, default=1.0,
                    help="weight (1/(N m)) of the heel-off margin with --stability")
    ap.add_argument("--rounds", type=int, default=12, help="NLP rounds per stage at most")
    ap.add_argument("--max-iter", type=int, default=50, help="IPOPT iterations per round")
    ap.add_argument("--threshold", type=float, default=0.05,
                    help="heel-off margin (N m) that ends the push (default 0.05)")
    ap.add_argument("--step", type=float, default=0.01,
                    help="k_clutch continuation step (N m/rad, default 0.01)")
    ap.add_argument("--max-steps", type=int, default=500, help="continuation steps at most")
    ap.add_argument("--lengthen-ms", type=float, default=15.0,
                    help="II_toe duration (ms) the lengthening stage aims at (0: skip)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    pb = start_problem()
    sim = Simulator(pb)
    human = load_gait_curves(args.gait) if args.stability else None
    fp = find_fixed_point(pb, fallback=False)
    x, p = fp.state, fp.parameters
    for rnd in range(args.rounds):
        x, p, status = push_round(pb, x, p, args, human)
        fp = find_fixed_point(pb, x, p, fallback=False)
        if not fp.converged:
            print(f"push round {rnd}: the answer has no fixed point", file=sys.stderr)
            return 1
        x = fp.state
        margin = margin_of(sim, x, p)
        print(f"push round {rnd}: {status}, heel-off margin {margin:.4g} N m, rho "
              f"{fp.spectral_radius:.3g}, valid {fp.valid}", flush=True)
        if margin < args.threshold:
            break
    i = list(pb.parameter_names).index("k_clutch")
    for n in range(args.max_steps):
        if "II_toe" in phases_of(sim, x, p):
            break
        q = p.copy()
        q[i] += args.step
        fp = find_fixed_point(pb, x, q, fallback=False, max_iter=15)
        if not fp.converged:
            print(f"cross step {n}: no fixed point at k_clutch {q[i]:.4g}", file=sys.stderr)
            return 1
        x, p = fp.state, q
    else:
        print("no heel off within the continuation steps", file=sys.stderr)
        return 1
    print(f"cross: heel off at k_clutch {p[i]:.6g} N m/rad", flush=True)
    for rnd in range(args.rounds if args.lengthen_ms > 0 else 0):
        if phases_of(sim, x, p).get("II_toe", 0.0) >= 1e-3 * args.lengthen_ms:
            break
        nlp = ShootingNLP(pb, x, p, free=tuple(pb.compliance_names), headroom_s=0.08)
        u, status = solve(nlp, -100.0 * toe_rocker_time(nlp), args.max_iter)
        fp = find_fixed_point(pb, u["xs"], u["p"], fallback=True)
        ph = phases_of(sim, fp.state, u["p"]) if fp.converged else {}
        print(f"lengthen round {rnd}: {status}, fixed point {fp.converged}, II_toe "
              f"{1e3 * ph.get('II_toe', 0.0):.1f} ms, rho {fp.spectral_radius:.3g}",
              flush=True)
        if "II_toe" not in ph:
            break  # keep the last gait with heel off
        x, p = fp.state, u["p"]
    fp = find_fixed_point(pb, x, p, fallback=False)
    phases = phases_of(sim, x, p)
    out = {"fixed_point": dict(zip(pb.state_names, map(float, x), strict=True)),
           "compliance": dict(zip(pb.compliance_names, map(float, p[:-1]), strict=True)),
           "slope": float(p[-1]), "phases_s": phases,
           "spectral_radius": float(fp.spectral_radius), "valid": bool(fp.valid),
           "failure": fp.failure, "wall_time_s": time.perf_counter() - t0}
    args.out.write_text(json.dumps(out, indent=2))
    print(f"heel-off gait: {', '.join(f'{k} {1e3 * v:.1f} ms' for k, v in phases.items())}; "
          f"rho {fp.spectral_radius:.3g}, valid {fp.valid} ({fp.failure}); written to "
          f"{args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
