"""Benchmark seeking a walker's periodic gait from human curves: a prescribed gait pattern,
its kinematic guess, and the fit's NLP on it, timed (an experiment towards
``pdw-fixed-point --seek``).

The pattern is given phase by phase as PHASE:DURATION_S:GUARD (the guard that ends the
phase); the guess (:func:`pdw_casadi.gait.kinematic.kinematic_guess`) follows the curves'
knee and thigh angles, the pattern's switches and modes are read off it
(:func:`pdw_casadi.nlp.pattern.pattern_from_guess`), and the fit's NLP
(:class:`pdw_casadi.fit.driver.FitSolver`: the curve objective, the walker's compliance
free, by default without the stability row) is solved from it. Printed: the pattern, the
solve's progress every ``--every`` iterations, its status, and, if the answer is nearly
periodic, the simulator's fixed point near it (spectral radius, valid).

    python scripts/bench_seek.py --problem humanlike_6link --gait female_fast.csv \\
        --phase I:0.06:toe_off --phase II:0.55:heel_strike --phase III:0.06:foot_strike
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from bench_fit import parse_set

from pdw_casadi.fit import FitOptions
from pdw_casadi.fit.driver import FitSolver
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.kinematic import GuessPhase
from pdw_casadi.gait.simulate import Simulator
from pdw_casadi.model.gait_data import load_gait_curves
from pdw_casadi.model.problem import load_problem
from pdw_casadi.nlp.pattern import pattern_from_guess
from pdw_casadi.nlp.shooting import ShootingNLP


def phase_arg(text: str) -> GuessPhase:
    """PHASE:DURATION_S:GUARD -> a :class:`GuessPhase` (its instants set by the pattern)."""
    try:
        phase, duration, guard = text.split(":")
        return GuessPhase(phase, float(duration), 0, guard)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected PHASE:DURATION_S:GUARD, got {text!r}") \
            from exc


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="humanlike_6link")
    ap.add_argument("--gait", default="female_fast.csv")
    ap.add_argument("--phase", type=phase_arg, action="append", required=True)
    ap.add_argument("--every", type=int, default=10, help="print every N-th iteration")
    ap.add_argument("--validity", action="append", default=[], metavar="KEY=VALUE",
                    help="a validity margin of the solve (e.g. min_normal_force=-1e4, N: the "
                         "margins relaxed, a first stage)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a FitOptions field (VALUE as JSON)")
    args = ap.parse_args(argv)
    pb = load_problem(args.problem)
    if args.validity:
        relaxed = {k: float(v) for k, _, v in (item.partition("=") for item in args.validity)}
        pb = pb.replace(validity={**pb.validity, **relaxed})
        print(f"validity margins: {dict(pb.validity)}")
    sim = Simulator(pb)
    hs, p = sim.hs, pb.parameter_vector()
    human = load_gait_curves(args.gait)
    q0 = hs.section_to_full(pb.state_vector(), p).full().ravel()
    specs, nodes = pattern_from_guess(hs, p, human, args.phase, q0, sim.h)
    print("pattern: " + ", ".join(
        f"{s.phase}->{hs.event_list[s.phase][s.event].name} {1000 * s.duration0:.1f} ms"
        for s in specs))
    opts = FitOptions(**{"stability_constraint": False, "max_iter": 300,
                         **parse_set(args.set)})
    xs = hs.full_to_section(nodes[0][:, 0]).full().ravel()
    nlp = ShootingNLP(pb, xs, p, free=tuple(pb.compliance_names), segments=specs,
                      nodes=nodes, sample_stride=opts.sample_stride)
    print(f"NLP: {nlp.w0.size} unknowns, {nlp.lbg.size} rows; largest violation at the guess "
          f"{max(v for _, v in nlp.violations(nlp.w0)):.3g} "
          f"({nlp.violations(nlp.w0)[0][0]})")
    count = [0]

    def log(line: str) -> None:
        count[0] += 1
        if line.startswith("iter") and (count[0] - 1) % args.every:
            return
        print(line)

    t0 = time.perf_counter()
    out = FitSolver(nlp, human, opts, log=log).solve(nlp.w0)
    print(f"{out['status']} after {out['iterations']} iterations, "
          f"{time.perf_counter() - t0:.1f} s")
    u = nlp.unpack(out["w"])
    worst = nlp.violations(out["w"])
    print(f"largest violation at the answer {worst[0][1]:.3g} ({worst[0][0]})" if worst
          else "the answer holds every row")
    print("durations (ms): " + ", ".join(f"{1000 * t:.1f}" for t in u["T"]))
    print("compliance: " + ", ".join(f"{n} {v:.4g}" for n, v in
                                     zip(pb.parameter_names, u["p"], strict=True)))
    if not worst or worst[0][1] < 1e-3:
        fp = find_fixed_point(pb, x0=u["xs"], p=u["p"])
        print(f"fixed point: converged {fp.converged}, spectral radius "
              f"{fp.spectral_radius:.4f}, valid {fp.valid}")
    return 0 if not worst or worst[0][1] < 1e-6 else 1


if __name__ == "__main__":
    np.set_printoptions(precision=4, suppress=True)
    sys.exit(main())
