"""What every command shares: the parent parser, the problem with its overrides, the
parsers of numbers and tolerances, and the checks made before any output exists."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path

from pdw_casadi.cli.contract import (
    Outputs,
    UsageError,
    finite_float,
    int_range,
    open_interval,
    output_path,
)
from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.engine.jsonio import write_json
from pdw_casadi.model.problem import (
    DEFAULT_PROBLEM,
    Problem,
    check_bounds,
    load_overrides,
    load_problem,
)
from pdw_casadi.model.system import gait_system

#: the largest --steps of pdw-simulate (every step's trajectory is kept and written)
MAX_STEPS = 1000
#: the most trajectory samples pdw-simulate keeps in memory (about 0.4 kB each)
MAX_SAMPLES = 1_000_000
#: accepted |P(x) - x| tolerances of the fixed points (below: rounding noise of one step)
TOL_RANGE = (1e-14, 1e-3)

def parse_command(parser: argparse.ArgumentParser, argv) -> tuple[argparse.Namespace, Outputs]:
    """The parsed arguments of a command and its output directory (not created yet)."""
    args = parser.parse_args(argv)
    return args, Outputs(args.out)


def parallel_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    """--workers K and --scheduler ADDRESS (a Dask scheduler overrides --workers)."""
    parser.add_argument("--workers", type=int_range("--workers", 1, 256), default=1,
                        metavar="K", help=f"processes for {what} (default: %(default)s)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help=f"Dask scheduler for {what} (e.g. tcp://host:8786); overrides "
                             "--workers")


def common_parser(out_default: str | None = None) -> argparse.ArgumentParser:
    """Parent parser shared by every command: --problem, --state, --compliance, --out
    (required unless the command gives ``out_default``)."""
    parent = argparse.ArgumentParser(add_help=False)
    g = parent.add_argument_group("problem and output")
    g.add_argument("--problem", default=DEFAULT_PROBLEM, metavar="NAME_OR_PATH",
                   help="bundled problem name or path to a problem TOML "
                        "(default: %(default)s)")
    g.add_argument("--state", type=Path, metavar="FILE",
                   help="JSON/TOML table of section-state overrides (rad, rad/s), e.g. "
                        "{\"q1\": 0.25}; a summary.json of this toolkit also works")
    g.add_argument("--compliance", type=Path, metavar="FILE",
                   help="JSON/TOML table of compliance overrides, e.g. {\"k_knee\": 120}; "
                        "the problem's compliance_bounds apply")
    g.add_argument("--out", type=output_path("--out"), required=out_default is None, metavar="DIR",
                   default=None if out_default is None else Path(out_default),
                   help="output directory (created if missing)"
                        + ("" if out_default is None else " (default: %(default)s)"))
    return parent




def max_iter_argument(parser, default: int) -> None:
    """--max-iter N: IPOPT iterations per NLP solve (``default``: the options dataclass's)."""
    parser.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000), default=default,
                        help="IPOPT iterations per solve (default: %(default)s)")


def fit_arguments(parser: argparse.ArgumentParser, defaults=None, timing: bool = False,
                  title: str | None = None):
    """The fit's flags (pdw-fit, pdw-cohort), their defaults read from ``defaults`` (a
    :class:`~pdw_casadi.studies.fit_run.FitOptions`; default: ``FitOptions()``): starts, targets,
    stability, IPOPT, the per-leg fit's ``--side`` and ``--stride-start`` in their own
    group; ``timing``: also ``--timing [W]``; ``title``: the group of the fit's flags
    (None: the parser's own options). :func:`fit_options` turns the parsed flags into the
    options. Returns the per-leg group (for a command's further per-leg flags)."""
    # deferred: the fit stack, only for the commands that fit (pdw-fit, pdw-cohort)
    from pdw_casadi.studies.fit_run import FitOptions

    d = defaults or FitOptions()
    lo, hi = d.slope_bounds
    top = parser
    parser = parser if title is None else parser.add_argument_group(title)
    parser.add_argument("--multistart", type=int_range("--multistart", 1, 1000),
                        default=d.multistart, metavar="N",
                        help="starts: the problem's own gait, then the N - 1 gait-atlas "
                             "entries whose curves fit best (default: %(default)s)")
    parser.add_argument("--atlas", metavar="FILE",
                        help="gait atlas of the further starts (default: the bundled one "
                             "of the problem; 'none': no atlas)")
    parser.add_argument("--free-slope", action="store_true",
                        help=f"let the slope be an unknown too ({lo:g}..{hi:g} rad)")
    parser.add_argument("--hip-target", choices=("hip", "thigh"), default=d.hip_target,
                        help="hip curve in the objective: the paper's hip (thigh + slope) "
                             "or the thigh from the vertical (default: %(default)s)")
    parser.add_argument("--max-radius", type=open_interval("--max-radius", 0.0, 1.0),
                        default=d.max_radius, metavar="R",
                        help="largest accepted spectral radius per step, in (0, 1) "
                             "(default: %(default)s)")
    if timing:
        parser.add_argument("--timing", type=open_interval("--timing", 0.0, 1000.0),
                            nargs="?", const=1.0, default=d.timing_weight, metavar="W",
                            help="also fit the timing: add W ((stance %% - human toe-off %%) "
                                 "/ 10 %%)^2 to the objective (human toe off: the gait "
                                 "file's toe_off_pct column, else 60 %%, Perry & Burnfield);"
                                 " R^2 is unchanged (default W when given: 1)")
    floor = "none" if d.knee_floor is None else d.knee_floor
    parser.add_argument("--knee-floor", type=_knee_floor, default=floor, metavar="F",
                        help="keep knee R^2 at or above F: 'reference' (the problem file's "
                             "own compliance on the same curves), a number, or 'none' "
                             "(default: %(default)s)")
    max_iter_argument(parser, d.max_iter)
    parser.add_argument("--rounds", type=int_range("--rounds", 1, 100), default=d.rounds,
                        help="NLP solves per start: a further one is built at the answer only "
                             "when the objective's sample brackets moved (default: %(default)s)")
    g = top.add_argument_group(
        "per-leg fit", "a curve file with per-side columns (knee_left_mean_deg, ...) "
        "fits each leg to its side on the stride")
    g.add_argument("--side", choices=("both", "left", "right"), default=None,
                   help=f"per-leg fit: whose compliance is free (default: "
                        f"{d.side})")
    g.add_argument("--stride-start", choices=("fit", "atlas"),
                   default=d.start,
                   help="per-leg fit: start from the symmetric fit to the mean of both "
                        "sides, or from the atlas gait that fits that mean best (no extra "
                        "solve) (default: %(default)s)")
    return g


def _knee_floor(text: str) -> str | float:
    """--knee-floor: 'reference', 'none' or a finite number below 1."""
    if text in ("reference", "none"):
        return text
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v < 1.0):
        raise argparse.ArgumentTypeError(f"--knee-floor must be 'reference', 'none' or a "
                                         f"number below 1, got {text!r}")
    return v


def fit_options(args: argparse.Namespace, per_leg: bool = True, **extra):
    """The fit's settings of flags parsed by :func:`fit_arguments` (``--atlas none``: no
    atlas): a :class:`~pdw_casadi.studies.fit_run.FitOptions` (``per_leg``: with ``--side`` and
    ``--stride-start``; else the per-leg settings at their defaults), with ``extra``
    settings of the caller's (e.g. ``verbose``)."""
    # deferred: the fit stack, only for the commands that fit (pdw-fit, pdw-cohort)
    from pdw_casadi.studies.fit_run import FitOptions

    atlas = None if args.atlas is None else ("" if args.atlas == "none" else args.atlas)
    values = dict(hip_target=args.hip_target, free_slope=args.free_slope,
                  max_radius=args.max_radius, multistart=args.multistart, atlas=atlas,
                  max_iter=args.max_iter, rounds=args.rounds,
                  knee_floor=None if args.knee_floor == "none" else args.knee_floor,
                  timing_weight=getattr(args, "timing", FitOptions.timing_weight), **extra)
    if not per_leg:
        return FitOptions(**values)
    return FitOptions(**values, side=args.side or FitOptions.side, start=args.stride_start)


def positive_int(text: str) -> int:
    return int_range("value", 1)(text)


def tolerance(flag: str = "--tol") -> Callable[[str], float]:
    lo, hi = TOL_RANGE

    def parse(text: str) -> float:
        v = finite_float(flag)(text)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{flag} must lie in [{lo:g}, {hi:g}], "
                                             f"got {text!r}")
        return v
    parse.__name__ = "tolerance"
    return parse


def require_one_leg_set(problem: Problem) -> None:
    """Refuse (before any output) a problem whose legs differ, for commands that work on the
    one-step map only."""
    if problem.asymmetric:
        raise UsageError(f"{problem.name}: its legs differ; this command works on walkers "
                         f"with one set of values for both legs (pdw-simulate, "
                         f"pdw-fixed-point and pdw-sweep solve asymmetric walkers on the "
                         f"stride map)")


def load_cli_problem(args: argparse.Namespace) -> Problem:
    """The problem named by ``--problem`` with ``--compliance`` and ``--state`` applied.

    Compliance overrides must lie within the problem's ``compliance_bounds`` (the same
    limits the problem file's own values obey)."""
    problem = load_problem(args.problem)
    comp_file = getattr(args, "compliance", None)
    if comp_file is not None:
        values = load_overrides(comp_file, "compliance")
        try:
            problem = problem.replace(compliance=values)
            check_bounds(problem, values, comp_file)
        except ProblemError as exc:  # name the override file, not only the problem
            text = str(exc)
            raise ProblemError(text if text.startswith(str(comp_file))
                               else f"{comp_file}: {text}") from None
    state_file = getattr(args, "state", None)
    if state_file is not None:
        values = load_overrides(state_file, "state")
        try:
            problem = problem.with_state(values)
        except ProblemError as exc:
            raise ProblemError(f"{state_file}: {exc}") from None
    return problem


def load_gait_problem(args: argparse.Namespace, outputs: Outputs) -> Problem:
    """The problem of a command that writes a walker's gait (pdw-simulate,
    pdw-fixed-point): :func:`load_cli_problem`, then, before any output exists, its
    ``--export`` formats and the output directory checked (not created)."""
    problem = load_cli_problem(args)
    check_exports(args, problem)
    outputs.check()
    return problem


def write_summary(outputs: Outputs, out: Path, summary: dict, hs) -> Path:
    """Write ``summary.json`` into ``out`` with the units of its keys (of the walker ``hs``,
    :func:`~pdw_casadi.model.units.summary_units`); registered with ``outputs``."""
    # deferred: pandas (via model.units), only when a command needs it (all import this module)
    from pdw_casadi.model.units import summary_units

    summary["units"] = summary_units(summary, hs)
    path = outputs.wrote(out / "summary.json")
    write_json(path, summary)
    return path


def gait_file(source: str, flag: str = "--gait"):
    # deferred: pandas (via model.gait_data), only when a command needs it (all import this module)
    from pdw_casadi.model.gait_data import load_gait_curves

    return load_gait_curves(source)


def check_curve_walker(problem: Problem, what: str):
    """The walker's faces; a clear error when it has no knee and hip outputs."""
    # deferred: pandas (via model.faces), only when a command needs it (all import this module)
    from pdw_casadi.model.faces import walker_faces

    faces = walker_faces(problem)
    if not faces.has_gait_curves:
        missing = [j for j in ("knee", "hip") if j not in faces.joints]
        raise UsageError(f"{what} needs knee and hip curves, but {problem.name} "
                         f"({problem.family}) has no {' or '.join(missing)} "
                         f"(joints: {', '.join(faces.joints) or 'none'})")
    return faces




#: formats of ``--export`` (docs/opensim.md)
EXPORT_FORMATS = ("opensim",)


def export_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """--export FORMAT (repeatable): also write ``what`` for another program."""
    parser.add_argument("--export", choices=EXPORT_FORMATS, action="append", default=[],
                        metavar="FORMAT",
                        help=f"also write {what} for another program: opensim (the model "
                             f"NAME.osim, its motion NAME.mot in degrees, the ground "
                             f"reactions NAME_grf.sto with NAME_external_loads.xml, the "
                             f"joint torques and an inverse-dynamics setup; docs/opensim.md)")


def check_exports(args: argparse.Namespace, problem: Problem) -> None:
    """Before any output: the walker of ``problem`` can be written in every ``--export``
    format (a ProblemError otherwise)."""
    if "opensim" in args.export:
        # deferred: the OpenSim export (report layer), imported only for --export opensim
        from pdw_casadi.report.opensim import skeleton

        skeleton(problem, gait_system(problem))


def write_exports(args: argparse.Namespace, outputs: Outputs, export) -> None:
    """Run ``export()`` (-> :class:`pdw_casadi.report.opensim.OpenSimExport`) when
    ``--export opensim`` was given and register its files; a gait the export cannot
    simulate (it falls within the two steps) is a warning, not an error."""
    if "opensim" not in args.export:
        return
    try:
        ex = export()
    except ProblemError as exc:
        print(f"warning: no OpenSim export: {exc}", file=sys.stderr)
        return
    for path in ex.to_dict().values():
        outputs.wrote(Path(path))
    print(f"wrote OpenSim files {ex.model.name}, {ex.motion.name}, {ex.forces.name}, "
          f"{ex.external_loads.name} ({len(ex.samples.time)} frames) in "
          f"{outputs.final(ex.model).parent}")
