"""Design a prosthetic leg's compliance: right shank and foot lighter, gait made symmetric.

Starts from a stable gait of the bundled atlas (``--entry``, default the walker's own gait
at spectral radius 0.83) and runs the stride-NLP design
:func:`pdw_casadi.studies.prosthesis.design_prosthesis_nlp` (equal step lengths and times,
stride spectral radius <= ``DesignNLPOptions.max_stride_radius``, least relative change of
the prosthetic leg's compliance; mass homotopy, every step re-simulated); ``--method
continuation`` runs the min-norm Newton continuation
:func:`pdw_casadi.studies.prosthesis.design_prosthesis` instead (symmetry without a stability
condition). Prints how far the design got, the step lengths and times per leg with their
asymmetry, the stride's spectral radius, validity, the compliance found and the wall time.
``--out FILE.toml`` writes the designed walker as a problem file (``pdw-fixed-point
--problem FILE.toml`` re-solves it on the stride map).

    pdw-design --lighter 0.3
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    check_input_file,
    check_output_file,
    finite_float,
    int_range,
    open_interval,
    output_path,
    positive_float,
    run,
)
from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.problem import load_problem
from pdw_casadi.studies.prosthesis import (
    NLP_FREE,
    START_ENTRY,
    DesignNLPOptions,
    atlas_problem,
    design_prosthesis,
    design_prosthesis_nlp,
    lighter_mass,
)
from pdw_casadi.studies.scaling import problem_toml

#: the design's settings (pdw-design passes only what its flags change)
DEFAULTS = DesignNLPOptions()


def design_main(argv=None) -> int:
    """``pdw-design``: the prosthetic leg's design (module docstring); the contract of
    :mod:`pdw_casadi.cli.contract`: everything checked before the solves, one-line errors."""
    ap = Parser(prog="pdw-design", description=__doc__.splitlines()[0])
    ap.add_argument("--lighter", type=open_interval("--lighter", 0.0, 1.0), default=0.3,
                    help="fraction by which the right shank and foot are lighter")
    ap.add_argument("--entry", default=START_ENTRY,
                    help="label of the atlas entry to start from (default: %(default)s)")
    ap.add_argument("--method", choices=("nlp", "continuation"), default="nlp",
                    help="stride NLP with the stability row (default) or the min-norm "
                         "Newton continuation")
    ap.add_argument("--first-step", type=open_interval("--first-step", 0.0, 1.0),
                    default=DesignNLPOptions.first_step,
                    help="first mass homotopy step of the NLP design (default: %(default)s)")
    ap.add_argument("--no-hold", action="store_true",
                    help="continuation: symmetry conditions only (do not hold the first "
                         "phase's duration)")
    ap.add_argument("--out", type=output_path("--out"), metavar="FILE.toml",
                    help="write the designed walker to this TOML file")
    ap.add_argument("--start", metavar="FILE.toml",
                    help="NLP: start from this problem file instead of an atlas entry: a "
                         "walker written by --out (continues its design: its lighter leg, "
                         "compliance and gait) or a symmetric walker (its gait near its "
                         "initial state)")
    ap.add_argument("--diagnose", action="store_true",
                    help="NLP: after every solve, log what binds (rows and bounds by "
                         "|multiplier|) and the IPOPT inf_pr/inf_du trend")
    ap.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000),
                    default=DesignNLPOptions.max_iter,
                    help="IPOPT iterations per NLP solve (default: %(default)s)")
    ap.add_argument("--mass-distribution", default="",
                    help="NLP: comma-separated body values of the prosthetic leg designed "
                         "beside its compliance (among l_sc,J_s,l_fc,J_f; bounds in "
                         "DesignNLPOptions.mass_distribution_bounds)")
    ap.add_argument("--mass-bounds", default="",
                    help="NLP: bounds of the designed mass distribution as multiples of the "
                         "sound leg's values, e.g. l_fc=0.1:4,J_f=0.05:3 (others: "
                         "DesignNLPOptions.mass_distribution_bounds)")
    ap.add_argument("--max-step", type=open_interval("--max-step", 0.0, 1.0),
                    default=DesignNLPOptions.max_step,
                    help="NLP: largest mass homotopy step (default: %(default)s)")
    ap.add_argument("--max-solves", type=int_range("--max-solves", 1, 100000),
                    default=DesignNLPOptions.max_solves,
                    help="NLP: at most this many NLP solves (default: %(default)s)")
    ap.add_argument("--free-slope", action="store_true",
                    help="NLP: the slope free too (the walker's energy supply)")
    ap.add_argument("--symmetry-tol", type=finite_float("--symmetry-tol"),
                    default=DesignNLPOptions.symmetry_tol_pct,
                    help="NLP: largest accepted |step-length| and |step-time| asymmetry, %% "
                         f"below the verdict's {DEFAULTS.symmetry_verdict_pct:g} %% "
                         "(default: %(default)s: equal steps)")
    ap.add_argument("--t-min", type=positive_float("--t-min", 1.0),
                    default=DesignNLPOptions.t_min_s,
                    help="NLP: shortest gait segment, s (default: %(default)s)")
    ap.add_argument("--family",
                    help="carry the start walker into this family, whose compliance keys "
                         "extend it (e.g. humanlike_6link_ankle: the prosthetic foot's rest "
                         "angle, loading damper and clutch spring); its extra keys' values "
                         "in --extension")
    ap.add_argument("--extension", default="",
                    help="with --family: KEY=VALUE,... for the family's extra compliance "
                         "keys (SI units), on both legs at the start")
    ap.add_argument("--free", default=",".join(NLP_FREE),
                    help="NLP: comma-separated compliance keys of the prosthetic leg to "
                         "design (default: %(default)s)")
    ap.add_argument("--free-sound", default="",
                    help="NLP: comma-separated compliance keys of the sound (left) leg that "
                         "adapt too (default: none; the sound leg keeps its compliance)")
    ap.add_argument("--accept-verified", action="store_true",
                    help="NLP: accept a solve that stopped at the iteration limit when its "
                         "answer re-simulates as stable, valid and symmetric (below "
                         f"{DEFAULTS.symmetry_verdict_pct:g} %%)")
    args = ap.parse_args(argv)
    outputs = Outputs(args.out or Path("."))  # only --out FILE.toml, staged beside it

    def body() -> int:
        if args.out is not None:
            check_output_file(args.out, "--out", (".toml",))
        if args.start:
            check_input_file(Path(args.start), "--start")
        base = load_problem(args.start) if args.start else atlas_problem(args.entry)
        if args.family:
            extra = {}
            for item in (i for i in args.extension.split(",") if i):
                key, _, val = item.partition("=")
                try:
                    extra[key] = finite_float("--extension")(val)
                except argparse.ArgumentTypeError:
                    ap.error(f"--extension: {item!r} is not KEY=VALUE with a number (finite)")
            try:
                base = base.in_family(args.family, extra)
            except (ProblemError, KeyError) as exc:
                ap.error(f"--family {args.family}: {exc}")
        elif args.extension:
            ap.error("--extension needs --family")
        free = tuple(k for k in args.free.split(",") if k)
        unknown = [k for k in free if k not in base.compliance]
        if unknown or not free:
            ap.error(f"--free: {', '.join(unknown) or 'no key given'}; the {base.family} "
                     f"walker's compliance keys: {', '.join(base.compliance)}")
        free_sound = tuple(k for k in args.free_sound.split(",") if k)
        unknown = [k for k in free_sound if k not in base.compliance]
        if unknown:
            ap.error(f"--free-sound: {', '.join(unknown)}; the {base.family} walker's "
                     f"compliance keys: {', '.join(base.compliance)}")
        t0 = time.perf_counter()
        dist = tuple(k for k in args.mass_distribution.split(",") if k)
        bounds = dict(DesignNLPOptions().mass_distribution_bounds)
        unknown = [k for k in dist if k not in bounds]
        if unknown:
            ap.error(f"--mass-distribution: {', '.join(unknown)} not among {', '.join(bounds)}")
        for item in (i for i in args.mass_bounds.split(",") if i):
            key, _, rng = item.partition("=")
            if key not in dist or rng.count(":") != 1:
                ap.error(f"--mass-bounds: {item!r} is not KEY=LO:HI with KEY among the "
                         f"--mass-distribution keys ({', '.join(dist) or 'none given'})")
            try:
                lo, hi = (finite_float("--mass-bounds")(v) for v in rng.split(":"))
            except argparse.ArgumentTypeError:
                ap.error(f"--mass-bounds: {item!r}: LO and HI must be finite numbers")
            if not 0.0 < lo < hi:
                ap.error(f"--mass-bounds: {item!r} needs 0 < LO < HI")
            bounds[key] = (lo, hi)
        # the verdict asks for asymmetries below symmetry_verdict_pct: the NLP's tolerance
        # must lie inside it
        try:
            DesignNLPOptions(symmetry_tol_pct=args.symmetry_tol).check_symmetry_tol()
        except ProblemError as exc:
            ap.error(f"--symmetry-tol: {exc}")
        nlp_only = [flag for flag, given in (
            ("--start", args.start), ("--diagnose", args.diagnose),
            ("--mass-distribution", dist), ("--free-slope", args.free_slope),
            ("--symmetry-tol", args.symmetry_tol != DesignNLPOptions.symmetry_tol_pct),
            ("--free", free != NLP_FREE), ("--free-sound", free_sound),
            ("--accept-verified", args.accept_verified))
            if given]
        if args.method == "continuation" and nlp_only:
            ap.error(f"{', '.join(nlp_only)}: options of --method nlp only")
        if args.method == "nlp":
            res = design_prosthesis_nlp(base, lighter=args.lighter, free=free,
                                        options=DesignNLPOptions(first_step=args.first_step,
                                                                diagnose=args.diagnose,
                                                                max_iter=args.max_iter,
                                                                mass_distribution=dist,
                                                                mass_distribution_bounds=bounds,
                                                                free_slope=args.free_slope,
                                                                free_sound=free_sound,
                                                                accept_verified=args.accept_verified,
                                                                t_min_s=args.t_min,
                                                                symmetry_tol_pct=args.symmetry_tol,
                                                                max_step=args.max_step,
                                                                max_solves=args.max_solves))
            reached = f"{100 * res.path[-1][0]:.2f} % lighter in {len(res.solves)} NLP solves"
        else:
            res = design_prosthesis(base, lighter=args.lighter, hold_first_phase=not args.no_hold)
            reached = f"lambda = {res.path[-1][0]:.4f} ({len(res.path)} points)"
        took = time.perf_counter() - t0
        rep, fp = res.report, res.fixed_point
        where = args.start or f"atlas entry {args.entry}"
        print(f"start: {where}; target: right shank+foot {100 * args.lighter:g} % "
              f"lighter; method {args.method}")
        print(f"reached {reached}: right shank+foot {100 * (1 - lighter_mass(res.problem)):.2f} % "
              f"lighter; target met (stable, valid, symmetric): {res.reached}")
        if rep is None:
            raise NoGait("no stride fixed point of the simulator at the last answer")
        legs = rep["legs"]
        print(f"step length L/R {legs['left']['step_length_m']:.5f} / "
              f"{legs['right']['step_length_m']:.5f} m (asymmetry "
              f"{rep['step_length_asymmetry_pct']:.2e} %)")
        print(f"step time   L/R {legs['left']['step_time_s']:.5f} / "
              f"{legs['right']['step_time_s']:.5f} s "
              f"(asymmetry {rep['step_time_asymmetry_pct']:.2e} %)")
        print(f"stance % L/R {legs['left']['stance_pct']:.2f} / {legs['right']['stance_pct']:.2f}, "
              f"double support {rep['double_support_pct']:.2f} %")
        print(f"stride spectral radius {fp.spectral_radius:.4f} (per step {res.step_radius:.4f}); "
              f"stable (stride <= {DEFAULTS.max_stride_radius:g}, per step <= "
              f"{DEFAULTS.max_step_radius:g}): {fp.spectral_radius <= DEFAULTS.max_stride_radius}; "
              f"valid: {fp.valid}")
        print("prosthetic-leg compliance:", ", ".join(f"{k} = {v:.4f}"
                                                     for k, v in res.compliance.items()))
        if res.sound_compliance:
            print("sound-leg compliance (adapted):", ", ".join(
                f"{k} = {v:.4f}" for k, v in res.sound_compliance.items()))
        if res.mass_distribution:
            print("prosthetic-leg mass distribution:", ", ".join(
                f"{k} = {v:.5g}" for k, v in res.mass_distribution.items()))
        print(f"slope {res.problem.slope:.5f} rad")
        for sv in res.solves:
            print(f"  NLP {100 * sv.lighter:6.2f} % lighter: {sv.status} ({sv.iterations} iter, "
                  f"{sv.wall_time_s:.1f} s), stride radius {sv.stride_radius:.4f}, "
                  f"asymmetry length/time {sv.step_length_asymmetry_pct:.3f} / "
                  f"{sv.step_time_asymmetry_pct:.3f} %, valid {sv.valid}, "
                  f"{'accepted' if sv.accepted else 'rejected'}")
        print(f"wall time {took:.1f} s")
        if args.out:
            outputs.wrote(outputs.staged(args.out)).write_text(
                problem_toml(res.problem, "# written by pdw-design\n"))
            print(f"wrote {args.out}")
        return 0


    return run(outputs, body)
