"""How well conditioned is the fixed point at a fit's answer? The simulator's view of the NLP.

    python scripts/fixed_point_conditioning.py FILE [--max-iter N] [--set KEY=VALUE ...]
        [--save answer.npz]

Runs the fit's first start on the curve file ``FILE`` (the humanlike 6-link walker,
``pdw-fit`` defaults, one round) and takes the NLP's answer, or, when the solve stops short,
its best feasible iterate (``FitOptions.keep_best_feasible``). At that section state x
(rad, rad/s) and parameters p it prints what decides whether the simulator finds the same
gait:

- the simulator's residual |P(x) - x| (the NLP's RK4 grid against the event-driven map);
- the exact-AD Jacobian J = dP/dx: its spectral radius, the smallest singular value of
  I - J and ||(I - J)^-1|| (how far one Newton step moves x per unit residual), the largest
  entry of J and Henrici's departure from normality (||J||_F^2 - sum |l_i|^2)^(1/2) /
  ||J||_F (0: normal; near 1: eigenvalues say little about a step's growth);
- along the Newton step x + t d, d = (I - J)^-1 (P(x) - x), t in [0, 1]: the spectral
  radius, the change of J per step in t and whether the simulator's event plan stays the
  same;
- Newton on the simulator's map from x (the fixed point the fit's check looks for).

A well-conditioned answer moves by about the residual times ||(I - J)^-1|| and keeps its
radius; an ill-conditioned one (I - J nearly singular, J strongly non-normal) turns a
discretisation difference of 1e-7 into a different verdict.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.core import StepFit
from pdw_casadi.fit.starts import select_starts
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareError, PoincareMap
from pdw_casadi.gait.simulate import Segment
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fit import parse_set  # noqa: E402


def plan_of(res) -> tuple:
    """The simulator's event plan of one step: its segments' phases, knee modes and RK4
    step counts, and its transitions, in order."""
    return tuple((it.phase, it.mode, it.n) if isinstance(it, Segment) else it.name
                 for it in res.sim.steps[0].plan.items)


def rho(J: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(J))))


def henrici(J: np.ndarray) -> float:
    """Henrici's relative departure from normality of J (0: normal)."""
    fro2 = float(np.sum(J * J))
    lam2 = float(np.sum(np.abs(np.linalg.eigvals(J)) ** 2))
    return float(np.sqrt(max(fro2 - lam2, 0.0) / fro2))


def conditioning(pmap: PoincareMap, x, p, samples: int = 10) -> dict:
    """The conditioning figures of the module docstring at section state x, parameters p."""
    r = pmap.evaluate(x, p)
    J = r.dx
    n = J.shape[0]
    res = r.x_next - x
    A = np.eye(n) - J
    sv = np.linalg.svd(A, compute_uv=False)
    d = np.linalg.solve(A, res)
    out = {"residual": float(np.max(np.abs(res))), "rho": rho(J),
           "sigma_min_I_minus_J": float(sv[-1]), "inv_norm": float(1.0 / sv[-1]),
           "max_entry": float(np.max(np.abs(J))), "henrici": henrici(J),
           "newton_step": float(np.max(np.abs(d))), "path": []}
    plan0, J_prev = plan_of(r), J
    for k in range(1, samples + 1):
        t = k / samples
        try:
            rk = pmap.evaluate(x + t * d, p)
        except PoincareError as e:
            out["path"].append({"t": t, "failure": str(e)})
            break
        out["path"].append({"t": t, "rho": rho(rk.dx), "dJ": float(np.max(np.abs(
            rk.dx - J_prev))), "same_plan": plan_of(rk) == plan0,
            "residual": float(np.max(np.abs(rk.x_next - x - t * d)))})
        J_prev = rk.dx
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file")
    ap.add_argument("--max-iter", type=int, default=None, help="IPOPT's iteration limit")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a FitOptions field (repeatable)")
    ap.add_argument("--samples", type=int, default=10, help="points along the Newton step")
    ap.add_argument("--save", type=Path, help="write x, p of the answer to this .npz")
    args = ap.parse_args(argv)
    over = parse_set(args.set)
    if args.max_iter is not None:
        over["max_iter"] = args.max_iter
    opts = FitOptions(verbose=False, keep_best_feasible=True, rounds=1, **over)
    problem = load_problem("humanlike_6link")
    human = load_gait_curves(args.file)
    start = select_starts(problem, human, opts)[0]
    fp0 = find_fixed_point(problem, start.state, start.parameters, max_iter=30,
                           fallback=False)
    if not fp0.converged:
        print(f"the start {start.label} has no fixed point")
        return 1
    fit = StepFit(problem, human, opts, 0, start.label, fp0.spectral_radius,
                  log=lambda m: None)
    nlp = fit.nlp(fp0.state, fp0.parameters)
    out = fit.solver(nlp).solve(nlp.w0)
    u = nlp.unpack(out["w"])
    x, p = u["xs"], u["p"]
    which = ("IPOPT's answer" if out["fallback_iteration"] is None else
             f"best feasible iterate (iteration {out['fallback_iteration']})")
    print(f"{Path(args.file).name}: start {start.label}; {out['status']} after "
          f"{out['iterations']} iterations ({out['wall_time_s']:.1f} s); {which}, "
          f"objective {out['objective']:.5f}")
    if args.save:
        np.savez(args.save, x=x, p=p)
    pmap = PoincareMap(problem)
    c = conditioning(pmap, x, p, args.samples)
    print(f"simulator residual |P(x) - x|       {c['residual']:.2e}")
    print(f"spectral radius of J                {c['rho']:.4f}")
    print(f"sigma_min(I - J), ||(I - J)^-1||    {c['sigma_min_I_minus_J']:.3e}, "
          f"{c['inv_norm']:.1f}")
    print(f"largest |J_ij|, Henrici departure   {c['max_entry']:.1f}, {c['henrici']:.3f}")
    print(f"Newton step |d|                     {c['newton_step']:.2e} "
          f"({c['newton_step'] / max(c['residual'], 1e-300):.0f} x the residual)")
    print("along x + t d:   t    rho     |dJ| per step   same plan   |P - x - t d|")
    for s in c["path"]:
        if "failure" in s:
            print(f"              {s['t']:.2f}  simulator failure: {s['failure']}")
        else:
            print(f"              {s['t']:.2f}  {s['rho']:.4f}  {s['dJ']:.2e}        "
                  f"{str(s['same_plan']):5s}       {s['residual']:.2e}")
    fp = find_fixed_point(problem, x, p, max_iter=15, fallback=False)
    print(f"Newton on the simulator's map from x: converged {fp.converged}, "
          f"rho {fp.spectral_radius:.4f}" + ("" if fp.converged else
                                             f" ({fp.failure or 'no convergence'})"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
