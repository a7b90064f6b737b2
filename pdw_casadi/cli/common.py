"""What every command shares: the parent parser, the problem with its overrides, the
parsers of numbers and tolerances, and the checks made before any output exists."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from pdw_casadi.cli.contract import (
    Outputs,
    UsageError,
    finite_float,
    int_range,
    output_path,
)
from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.model.problem import Problem, check_bounds, load_overrides, load_problem

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
    g.add_argument("--problem", default="humanlike_6link", metavar="NAME_OR_PATH",
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


def gait_file(source: str, flag: str = "--gait"):
    from pdw_casadi.model.gait_data import load_gait_curves

    return load_gait_curves(source)


def check_curve_walker(problem: Problem, what: str):
    """The walker's faces; a clear error when it has no knee and hip outputs."""
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
        from pdw_casadi.model.system import gait_system
        from pdw_casadi.report.opensim import skeleton

        skeleton(problem, gait_system(problem))


def write_exports(args: argparse.Namespace, outputs: Outputs, export) -> None:
    """Run ``export()`` (-> :class:`pdw_casadi.report.opensim.OpenSimExport`) when
    ``--export opensim`` was given and register its files; a gait the export cannot
    simulate (it falls within the two steps) is a warning, not an error."""
    import sys

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
