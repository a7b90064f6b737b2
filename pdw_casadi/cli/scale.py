"""``pdw-scale``: a problem file for a subject's body (de Leva 1996 segment table)."""

from __future__ import annotations

import sys
import time

from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    check_output_file,
    open_interval,
    output_path,
    run,
)
from pdw_casadi.gait.fixed_point import find_fixed_point
from pdw_casadi.model.problem import DEFAULT_PROBLEM, ProblemError, load_problem
from pdw_casadi.studies.scaling import (
    BODY_MAX_RADIUS,
    HEIGHT_RANGE_M,
    MASS_RANGE_KG,
    SEXES,
    check_scalable,
    problem_toml,
    reference_height,
    reference_mass,
    scale_problem,
    scaled_state,
    stable_subject_walker,
    subject_row,
)


def scale_main(argv=None) -> int:
    """``pdw-scale``: a problem file for a subject's body (see the module docstring).

    ``--mass KG --height M [--sex female|male]`` or ``--subject ID`` (a bundled subject);
    ``--body deleva`` (default: the de Leva 1996 body, reached by continuation from the
    uniformly scaled reference, compliance adapted, then the nearest gait with spectral
    radius <= ``--max-radius``: :func:`~pdw_casadi.studies.scaling.stable_subject_walker`)
    or ``--body uniform`` (the reference scaled by the exact law only). Writes ``--out
    FILE.toml`` with the gait found as its initial state; exit code 1 (nothing written)
    when the continuation does not reach the subject or no stable valid gait is found there.
    """
    parser = Parser(prog="pdw-scale", description="Scale the walker to a subject's body "
                    "(de Leva 1996 segment table).")
    parser.add_argument("--mass", type=open_interval("--mass", *MASS_RANGE_KG), metavar="KG",
                        help="body mass, kg ({:g}..{:g})".format(*MASS_RANGE_KG))
    parser.add_argument("--height", type=open_interval("--height", *HEIGHT_RANGE_M),
                        metavar="M", help="height, m ({:g}..{:g})".format(*HEIGHT_RANGE_M))
    parser.add_argument("--sex", choices=SEXES, default="female")
    parser.add_argument("--subject", metavar="ID",
                        help="a bundled subject (mass, height and sex from "
                             "data/anthropometry/subjects.csv), e.g. WBDS09")
    parser.add_argument("--body", choices=("deleva", "uniform"), default="deleva")
    parser.add_argument("--max-radius", type=open_interval("--max-radius", 0.0, 1.0),
                        default=BODY_MAX_RADIUS, metavar="R",
                        help="de Leva body: the largest spectral radius of the gait written "
                             "(default: %(default)s)")
    parser.add_argument("--problem", default=DEFAULT_PROBLEM,
                        help="reference problem (default: %(default)s)")
    parser.add_argument("--out", type=output_path("--out"), required=True, metavar="FILE.toml")
    args = parser.parse_args(argv)
    outputs = Outputs(args.out)  # one file, staged beside it

    def body() -> int:
        check_output_file(args.out, "--out", (".toml",))
        if args.subject:
            if args.mass is not None or args.height is not None:
                raise ProblemError("give either --subject or --mass and --height")
            who = subject_row(args.subject)
        elif args.mass is None or args.height is None:
            raise ProblemError("give --mass and --height (or --subject ID)")
        else:
            who = {"mass_kg": args.mass, "height_m": args.height, "sex": args.sex}
        ref = load_problem(args.problem)
        check_scalable(ref)
        print(f"scaling {ref.name} to {who['mass_kg']:g} kg, {who['height_m']:g} m, "
              f"{who['sex']} ({args.body})...", file=sys.stderr)
        t0 = time.perf_counter()
        if args.body == "uniform":
            fp0 = find_fixed_point(ref)
            if not fp0.converged:
                raise NoGait(f"no fixed point of {ref.name} near its initial state")
            s = who["height_m"] / reference_height(ref, who["sex"])
            m = who["mass_kg"] / reference_mass(ref)
            pb = scale_problem(ref, s, m, name=args.out.stem).with_state(scaled_state(
                ref, fp0.state, s))
            rho, lam, note = fp0.spectral_radius, 1.0, "uniform scaling law (exact)"
        else:
            res = stable_subject_walker(who["mass_kg"], who["height_m"], who["sex"], ref,
                                        max_radius=args.max_radius,
                                        log=lambda line: print(line, file=sys.stderr))
            cont = res.continued
            lam = cont.path[-1][0] if cont is not None else 1.0
            if res.problem is None:
                raise NoGait(f"{res.reason} (best of {ref.name}'s reference gaits; nothing "
                             f"written)")
            pb, rho = res.problem.replace(name=args.out.stem), res.spectral_radius
        if args.body != "uniform" and cont is None:
            note = (f"the shipped stable {who['sex']} de Leva body's gait carried by the "
                    f"scaling law (exact); stable, valid")
        elif args.body != "uniform":
            held = ", ".join(f"{k} held at {v:.4g} from lambda {lam_:g}"
                             for k, (lam_, v) in cont.held.items()) or "none held"
            stab = (f"; then the nearest gait with rho <= {args.max_radius:g} (the fit's "
                    f"stability row on the walker's own curves; the continued gait had rho "
                    f"{res.rho_continued:.4f})" if res.stabilised else "")
            note = (f"continuation in the body from the uniformly scaled reference ({cont.start}"
                    f" gait), {len(cont.path)} points, compliance adapted; validity margins: "
                    f"{held}{stab}; stable, valid")
        header = (f"# {who['mass_kg']:g} kg, {who['height_m']:g} m, {who['sex']}: written by "
                  f"pdw-scale from {ref.name}\n# body: {args.body} (de Leva 1996, J. Biomech. "
                  f"29:1223, adjusted Zatsiorsky-Seluyanov; foot geometry from the reference)"
                  f"\n# gait: {note}; spectral radius {rho:.4f}\n")
        outputs.wrote(outputs.staged(args.out)).write_text(problem_toml(pb, header))
        print(f"wrote {args.out} (spectral radius {rho:.4f}, lambda {lam:g}, "
              f"{time.perf_counter() - t0:.1f} s)")
        return 0

    return run(outputs, body)
