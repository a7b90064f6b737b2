"""A gait of the rolling-foot walker at nonzero toe and heel radii, to ship and to fit from.

    python scripts/arc_seed.py --r-toe 0.05 --r-heel 0.05 --out seed.json [--n-min 10]

The start is the ankle walker's shipped gait (``problems/humanlike_6link_ankle.toml``)
carried to the rolling-foot walker at r_toe = r_heel = 0, where it is the same gait
(``--r-toe 0 --r-heel 0`` writes that start). At its compliance the gait leaves its validity
margins within micrometres of radius (the phase-I stance normal force sits on its 5 N
bound), so this script carries it to the radii by the design continuation
(:func:`pdw_casadi.gait.design.continue_design`): the radii move linearly from 0 to the targets,
the fixed point and every other compliance value (relative change, least norm) are the
unknowns, and a validity margin that would break is held at its requirement + 10 %
(``DesignOptions.hold_margins``). The end point, its compliance put back inside the
problem's bounds, is re-solved by Newton
(:func:`pdw_casadi.gait.fixed_point.find_fixed_point`) and written as JSON: ``fixed_point``,
``compliance``, ``slope`` (``pdw-fit --state FILE --compliance FILE`` read them), the
spectral radius, validity, gait timing and the margins held on the way.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from pdw_casadi.gait.design import DesignOptions, continue_design
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.gait.poincare import PoincareMap
from pdw_casadi.gait.timing import fixed_point_timing
from pdw_casadi.model.problem import load_problem

RADII = ("r_toe", "r_heel")


def start_problem():
    """The rolling-foot walker at the ankle walker's shipped gait and compliance, radii 0."""
    ankle = load_problem("humanlike_6link_ankle")
    return load_problem("humanlike_6link_arc").replace(
        compliance={**ankle.compliance, "r_toe": 0.0, "r_heel": 0.0},
        slope=ankle.slope).with_state(ankle.state_vector())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--r-toe", type=float, required=True, help="toe arc radius to reach (m)")
    ap.add_argument("--r-heel", type=float, required=True, help="heel arc radius to reach (m)")
    ap.add_argument("--n-min", type=int, default=10, help="continuation steps at least")
    ap.add_argument("--out", type=Path, required=True, help="JSON file to write")
    args = ap.parse_args(argv)

    pb = start_problem()
    names = pb.parameter_names
    theta0 = pb.parameter_vector()
    theta1 = theta0.copy()
    theta1[names.index("r_toe")], theta1[names.index("r_heel")] = args.r_toe, args.r_heel
    # every compliance value but the radii is free (relative change); the slope is held
    free = [[i] for i, n in enumerate(names) if n not in (*RADII, "slope") and theta0[i] != 0]
    pmap = PoincareMap(pb)
    opts = DesignOptions(hold_margins=True, n_min=args.n_min)
    path = continue_design(pmap, pb.state_vector(), theta0, theta1, free, options=opts)
    lam = path.path[-1][0]
    print(f"continuation reached lambda = {lam:.4f} ({len(path.path)} points, "
          f"{path.wall_time_s:.0f} s); held: {sorted(path.held)}")
    x, theta = path.last.state, path.last.theta.copy()
    # the design does not know the fit's bounds: a value that drifted past one (ankle_rest
    # starts on its 0.6 rad bound) is put back on it before the fixed point is re-solved
    for i, n in enumerate(names[:-1]):
        lo, hi = pb.compliance_bounds.get(n, (-np.inf, np.inf))
        theta[i] = min(max(theta[i], lo), hi)
    fp = find_fixed_point(pb, x, theta, tol=1e-10)
    t = fixed_point_timing(pb, fp.state, theta)
    comp, slope = pb.split_parameters(theta)
    out = {"lambda": lam, "reached": path.reached, "wall_time_s": path.wall_time_s,
           "held": {k: list(v) for k, v in path.held.items()},
           "fixed_point": fp.state_dict(), "compliance": comp, "slope": slope,
           "converged": fp.converged, "spectral_radius": fp.spectral_radius,
           "valid": fp.valid, "failure": fp.failure, "margins": fp.margins,
           "double_support_pct": list(t.double_support_pct) if t else None,
           "stance_pct": t.stance_pct if t else None,
           "phase_durations_s": dict(t.phase_durations_s) if t else None}
    args.out.write_text(json.dumps(out, indent=2, default=float))
    print(json.dumps({k: out[k] for k in ("reached", "spectral_radius", "valid", "failure",
                                          "double_support_pct", "stance_pct",
                                          "phase_durations_s")}, default=float))
    return 0 if fp.converged else 1


if __name__ == "__main__":
    sys.exit(main())
