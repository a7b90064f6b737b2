"""Console scripts of the toolkit.

Each command is a ``*_main(argv=None)`` function registered in :data:`COMMANDS` and exposed
as a console script in ``pyproject.toml`` (``pdw-simulate`` -> :func:`simulate_main`). They
share:

- :func:`common_parser`: the parent argparse parser with ``--problem``, ``--state``,
  ``--compliance`` and ``--out``;
- :func:`load_cli_problem`: the problem with the ``--state`` / ``--compliance`` overrides
  applied;
- :func:`_fail`: expected errors (bad problem, override or gait file, unwritable output)
  become one line ``error: ...`` on stderr and exit code 2, never a traceback;
- :func:`_write_json`: JSON output with numpy scalars/arrays, paths and non-finite floats
  (written as ``null``) handled.

Adding a command: write ``foo_main(argv=None)`` that builds its parser with
``parents=[common_parser()]``, runs its body inside ``with _errors():``, and add it to
:data:`COMMANDS` (``python -m pdw_casadi.cli foo ...`` then works too).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NoReturn

import numpy as np

from .fit.objective import CurveError
from .gait_data import GaitDataError
from .problem import Problem, ProblemError, load_overrides, load_problem

#: exceptions that are the user's input, reported as ``error: ...`` with exit code 2
USER_ERRORS = (ProblemError, GaitDataError, CurveError, OSError)


# --------------------------------------------------------------------------------------------
# shared helpers
# --------------------------------------------------------------------------------------------
def _fail(message: object, code: int = 2) -> NoReturn:
    """Print ``error: <message>`` (one line) to stderr and exit with ``code``."""
    text = " ".join(str(message).split()) or "unknown error"
    print(f"error: {text}", file=sys.stderr)
    raise SystemExit(code)


@contextlib.contextmanager
def _errors() -> Iterator[None]:
    """Turn the expected user errors raised inside the block into :func:`_fail`."""
    try:
        yield
    except USER_ERRORS as exc:
        if isinstance(exc, OSError) and exc.filename is not None:
            _fail(f"{exc.filename}: {exc.strerror or exc}")
        _fail(exc)


def _jsonable(obj):
    """``obj`` with numpy types, tuples, paths and non-finite floats made JSON-safe."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating | float):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, Path):
        return str(obj)
    if hasattr(obj, "to_dict"):
        return _jsonable(obj.to_dict())
    return obj


def _write_json(path: Path | str, data) -> Path:
    """Write ``data`` as indented JSON (strict: NaN and inf become null)."""
    path = Path(path)
    path.write_text(json.dumps(_jsonable(data), indent=2, allow_nan=False) + "\n")
    return path


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
                   help="JSON/TOML table of compliance overrides, e.g. {\"k_knee\": 120}")
    g.add_argument("--out", type=Path, required=out_default is None, metavar="DIR",
                   default=None if out_default is None else Path(out_default),
                   help="output directory (created if missing)"
                        + ("" if out_default is None else " (default: %(default)s)"))
    return parent


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def load_cli_problem(args: argparse.Namespace) -> Problem:
    """The problem named by ``--problem`` with ``--compliance`` and ``--state`` applied."""
    problem = load_problem(args.problem)
    comp_file = getattr(args, "compliance", None)
    if comp_file is not None:
        values = load_overrides(comp_file, "compliance")
        try:
            problem = problem.replace(compliance=values)
        except ProblemError as exc:  # name the override file, not only the problem
            raise ProblemError(f"{comp_file}: {exc}") from None
    state_file = getattr(args, "state", None)
    if state_file is not None:
        values = load_overrides(state_file, "state")
        try:
            problem = problem.with_state(values)
        except ProblemError as exc:
            raise ProblemError(f"{state_file}: {exc}") from None
    return problem


def _out_dir(path: Path) -> Path:
    path.mkdir(parents=True, exist_ok=True)
    return path


# --------------------------------------------------------------------------------------------
# pdw-simulate
# --------------------------------------------------------------------------------------------
def simulation_summary(problem: Problem, result, steps_requested: int | None = None) -> dict:
    """The summary.json content of a simulation (SI units; see :func:`simulate_main`)."""
    names = list(problem.state_names)
    done = [s for s in result.steps if s.x_section_end is not None]
    first = done[0] if done else None
    poincare = [dict(zip(names, map(float, row), strict=True))
                for row in np.atleast_2d(result.poincare_states) if len(row)]
    residual = None
    if first is not None:
        residual = float(np.linalg.norm(first.x_section_end - first.x_section_start))
    energy = [float(s.energy_residual_J) for s in done]
    margins: dict[str, float] = {}
    for s in result.steps:
        for k, v in s.margins.items():
            margins[k] = min(float(v), margins.get(k, math.inf))
    step_time = first.step_time if first else None
    step_length = first.step_length if first else None
    speed = step_length / step_time if first and step_time else None
    return {
        "problem": {"name": problem.name, "family": problem.family,
                    "source": problem.source, "title": problem.title},
        "slope": problem.slope,
        "compliance": dict(problem.compliance),
        "initial_state": dict(problem.initial_state),
        "steps_requested": steps_requested,
        "completed_steps": len(done),
        "phases": [[{"name": n, "duration_s": d} for n, d in s.phases] for s in result.steps],
        "step_time_s": step_time,
        "step_length_m": step_length,
        "speed_m_s": speed,
        "poincare_states": poincare,
        "residual": residual,
        "energy_balance_J": energy,
        "energy_balance_max_abs_J": max((abs(e) for e in energy), default=None),
        "failure": result.failure.to_dict() if result.failure else None,
        "steps": [s.to_dict() for s in result.steps],
        "margins": margins,
        "units": {"angles": "rad", "rates": "rad/s", "time": "s", "length": "m",
                  "energy": "J", "speed": "m/s"},
    }


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-simulate``: simulate N steps and write trajectory, events, summary and plots.

    Writes to ``--out``: ``trajectory.csv`` (one row per integration step: time, phase,
    coordinates, velocities and outputs), ``events.csv`` (guards, mode switches, failure),
    ``summary.json`` (phases, step time/length, speed, Poincare states, residual
    ||F(x0) - x0||, energy balance, failure, margins, problem, compliance, slope),
    ``angles.png`` and ``stick.png``; with ``--animate FILE.gif`` also an animation of the
    walker over all steps (:mod:`pdw_casadi.animation`). A walker that falls is a result, not
    an error: the outputs are written, ``failure`` says why, a warning goes to stderr, exit
    code 0.
    """
    parser = argparse.ArgumentParser(
        prog="pdw-simulate", parents=[common_parser()],
        description="Simulate steps of a passive walker from its section state.")
    parser.add_argument("--steps", type=_positive_int, default=1, metavar="N",
                        help="number of steps (default: %(default)s)")
    parser.add_argument("--snapshots", type=_positive_int, default=8, metavar="K",
                        help="stick-figure snapshots of the first step (default: %(default)s)")
    parser.add_argument("--animate", type=Path, metavar="FILE.gif",
                        help="also write an animated GIF of the walker walking down the slope "
                             "over all simulated steps")
    parser.add_argument("--fps", type=_positive_int, default=25, metavar="F",
                        help="frames per simulated second of the animation (default: "
                             "%(default)s)")
    args = parser.parse_args(argv)
    with _errors():
        problem = load_cli_problem(args)
        out = _out_dir(args.out)
        from .plots import plot_angles, plot_stick
        from .simulate import Simulator

        sim = Simulator(problem)
        p = problem.parameter_vector()
        result = sim.run(problem.state_vector(), p, steps=args.steps, record=True)
        traj = result.trajectory
        if traj is None:
            import pandas as pd

            traj = pd.DataFrame()
        traj.to_csv(out / "trajectory.csv", index=False)
        result.events.to_csv(out / "events.csv", index=False)
        summary = simulation_summary(problem, result, args.steps)
        _write_json(out / "summary.json", summary)
        plot_angles(traj, out / "angles.png", title=f"{problem.name}: joint angles")
        plot_stick(sim.hs, traj, p, out / "stick.png", n=args.snapshots)
        if args.animate is not None and not traj.empty:
            from .animation import animate_walk

            animate_walk(sim.hs, result, p, args.animate, fps=args.fps,
                         title=f"{problem.name}: {result.completed_steps} steps down a slope "
                               f"of {problem.slope:.4f} rad")
    if result.failure is not None:
        f = result.failure
        print(f"warning: simulation stopped in step {f.step}, phase {f.phase}, at "
              f"t = {f.time:.4f} s: {f.reason}", file=sys.stderr)
    print(f"wrote {out} ({summary['completed_steps']} of {args.steps} steps)")
    return 0


def fixed_point_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fixed-point``: find a periodic gait, its eigenvalues and validity margins.

    Writes ``summary.json`` (fixed_point, residual, iterations, eigenvalues as [re, im],
    spectral_radius, stable, step_time_s, step_length_m, speed_m_s, margins, valid,
    failure, distance_from_initial, wall_time_s) and ``limit_cycle.png`` (paper's Fig. 4).
    """
    parser = argparse.ArgumentParser(
        prog="pdw-fixed-point", parents=[common_parser()],
        description="Newton on the Poincare map with its exact AD Jacobian.")
    parser.add_argument("--tol", type=float, default=1e-10,
                        help="|P(x) - x| to reach (default: %(default)s)")
    args = parser.parse_args(argv)
    with _errors():
        import numpy as np

        from .fixed_point import find_fixed_point
        from .plots import plot_limit_cycle
        from .simulate import Simulator

        problem = load_cli_problem(args)
        out = _out_dir(args.out)
        print(f"solving for a fixed point of {problem.name} (slope {problem.slope} rad)...",
              file=sys.stderr)
        res = find_fixed_point(problem, tol=args.tol, verbose=True)
        summary = res.to_dict()
        summary["distance_from_initial"] = float(
            np.linalg.norm(res.state - problem.state_vector()))
        summary["problem"] = problem.name
        summary["initial_state"] = dict(problem.initial_state)
        _write_json(out / "summary.json", summary)
        if res.converged:
            sim = Simulator(problem)
            two = sim.run(res.state, res.parameters, steps=2, record=True)
            legs = getattr(sim.hs.model, "limit_cycle_legs", None) or (("q1", "q2"),
                                                                         ("q4", "q3"))
            plot_limit_cycle(two.trajectory, out / "limit_cycle.png", legs=legs,
                             title=f"{problem.name}: limit cycle of one leg over two steps")
    ev = ", ".join(f"{e.real:+.4f}{e.imag:+.4f}i" for e in res.eigenvalues)
    print(f"converged={res.converged} residual={res.residual:.2e} iterations={res.iterations} "
          f"spectral radius={res.spectral_radius:.4f} "
          f"({'stable' if res.stable else 'NOT stable'}) valid={res.valid}"
          f"{'' if res.valid else ' (' + str(res.failure) + ')'}")
    print(f"eigenvalues: {ev}")
    print(f"wrote {out}")
    return 0 if res.converged else 1


def fit_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fit --gait FILE``: fit the compliance and a stable periodic gait to human curves.

    One multiple-shooting IPOPT NLP per start (see :mod:`pdw_casadi.fit`), verified by a
    20-step re-simulation and the exact-AD spectral radius. Writes ``summary.json``,
    ``curves.csv``, ``fit.png`` (Fig. 5 with the Table-3 walker and the comparison walker),
    ``limit_cycle.png`` (Fig. 4) and ``table.md``. Exit code 1 when no stable valid gait was
    found (the outputs then describe the best candidate and say so).
    """
    parser = argparse.ArgumentParser(
        prog="pdw-fit", parents=[common_parser(out_default="fit")],
        description="Fit compliance and a stable periodic gait to human knee/hip curves.")
    parser.add_argument("--gait", required=True, metavar="FILE",
                        help="gait-curve CSV (a path or a bundled name such as female_fast.csv)")
    parser.add_argument("--multistart", type=_positive_int, default=1, metavar="N",
                        help="start from the N gait-atlas entries whose curves fit best "
                             "(default: %(default)s)")
    parser.add_argument("--atlas", metavar="FILE",
                        help="gait atlas to start from (default: the bundled one of the "
                             "problem; 'none': start from the problem's own compliance)")
    parser.add_argument("--free-slope", action="store_true",
                        help="let the slope be an unknown too (0.05..0.25 rad)")
    parser.add_argument("--hip-target", choices=("hip", "thigh"), default="hip",
                        help="hip curve in the objective: the paper's hip (thigh + slope) "
                             "or the thigh from the vertical (default: %(default)s)")
    parser.add_argument("--max-radius", type=float, default=0.91, metavar="R",
                        help="largest accepted spectral radius (default: %(default)s)")
    parser.add_argument("--max-iter", type=_positive_int, default=300,
                        help="IPOPT iterations per solve (default: %(default)s)")
    parser.add_argument("--rounds", type=_positive_int, default=2,
                        help="NLP solves per start: a further one is built at the answer only "
                             "when the objective's sample brackets moved (default: %(default)s)")
    parser.add_argument("--workers", type=_positive_int, default=1,
                        help="processes for the multistart (default: 1)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler for the multistart (e.g. tcp://host:8786)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress lines (the IPOPT log is still written to "
                             "DIR/ipopt.log)")
    args = parser.parse_args(argv)
    with _errors():
        from .fit import FitOptions
        from .fit_report import fit_and_report
        from .gait_data import load_gait_curves

        human = load_gait_curves(args.gait)
        problem = load_cli_problem(args)
        if not 0 < args.max_radius < 1:
            _fail(f"--max-radius must be in (0, 1), got {args.max_radius}")
        atlas = None if args.atlas is None else ("" if args.atlas == "none" else args.atlas)
        if atlas and not Path(atlas).is_file():
            _fail(f"--atlas {atlas}: no such file")
        opts = FitOptions(hip_target=args.hip_target, free_slope=args.free_slope,
                          max_radius=args.max_radius, multistart=args.multistart,
                          atlas=atlas, max_iter=args.max_iter, rounds=args.rounds,
                          verbose=not args.quiet)
        from .fit import check_targets

        check_targets(problem, human, opts)
        out = _out_dir(args.out)
        log_file = out / "ipopt.log"
        log_file.unlink(missing_ok=True)
        opts.log_file = str(log_file)
        summary = fit_and_report(problem, human, opts, out, workers=args.workers,
                                 scheduler=args.scheduler,
                                 log=lambda m: print(m, file=sys.stderr, flush=True))
    print(summary["headline"])
    print(f"wrote {out}")
    return 0 if summary["stable"] and summary["valid"] else 1


def load_fit_start(problem: Problem, path: Path) -> Problem:
    """``problem`` with compliance, slope and section state taken from a fit summary.

    The summary (JSON) holds ``compliance`` (problem compliance names -> values), ``slope``
    (rad) and ``fixed_point`` (section-state names -> values, rad and rad/s).
    """
    try:
        raw = json.loads(Path(path).read_text())
    except ValueError as exc:
        raise ProblemError(f"{path}: not valid JSON: {exc}") from None
    missing = [k for k in ("compliance", "slope", "fixed_point") if k not in (raw or {})]
    if not isinstance(raw, dict) or missing:
        raise ProblemError(f"{path}: a fit summary needs the keys compliance, slope and "
                           f"fixed_point; missing: {', '.join(missing)}")
    if not isinstance(raw["compliance"], dict) or not isinstance(raw["fixed_point"], dict):
        raise ProblemError(f"{path}: 'compliance' and 'fixed_point' must be tables")
    if isinstance(raw["slope"], bool) or not isinstance(raw["slope"], int | float):
        raise ProblemError(f"{path}: 'slope' must be a number (rad), got {raw['slope']!r}")
    try:
        return problem.replace(compliance=raw["compliance"], slope=float(raw["slope"])) \
            .with_state(raw["fixed_point"])
    except ProblemError as exc:
        raise ProblemError(f"{path}: {exc}") from None


def sweep_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-sweep``: follow a periodic gait over a parameter; bifurcations and boundaries.

    Starts from the fixed point of the problem (its initial state; or ``--from-fit``), covers
    ``--num`` values from ``--from`` to ``--to`` of ``--param`` (the slope in rad, or a
    compliance name in its unit) and writes to ``--out``: ``sweep.csv`` (one row per point,
    appended as each is found: parameter, section state, step time, step length, speed,
    spectral radius, eigenvalues, margins, stable, valid, R^2 with ``--gait``),
    ``events.json`` (located bifurcations and gait-pattern boundaries, stable valid ranges)
    and ``sweep.png`` (step length, speed and spectral radius against the parameter).
    ``--workers K`` spreads independent work (grid points, the two directions from an
    interior start) over K processes; ``--scheduler ADDRESS`` over a Dask cluster.
    """
    parser = argparse.ArgumentParser(
        prog="pdw-sweep", parents=[common_parser()],
        description="Parameter sweep of a periodic gait by continuation, with bifurcations.")
    parser.add_argument("--param", default="slope", metavar="NAME",
                        help="parameter to sweep: slope (rad) or a compliance name "
                             "(default: %(default)s)")
    parser.add_argument("--from", dest="start", type=float, required=True, metavar="A",
                        help="first value of the grid (unit of the parameter)")
    parser.add_argument("--to", dest="stop", type=float, required=True, metavar="B",
                        help="last value of the grid")
    parser.add_argument("--num", type=_positive_int, default=25, metavar="N",
                        help="grid values from A to B, >= 2 (default: %(default)s)")
    parser.add_argument("--mode", choices=("continuation", "grid"), default="continuation",
                        help="continuation from the start, or every grid value solved on its "
                             "own from the start (default: %(default)s)")
    parser.add_argument("--predictor", choices=("tangent", "secant"), default="tangent",
                        help="continuation predictor (default: %(default)s)")
    parser.add_argument("--from-fit", type=Path, metavar="FILE",
                        help="start from a fit summary.json (compliance, slope, fixed_point)")
    parser.add_argument("--gait", metavar="FILE",
                        help="gait-curve CSV: add R^2 of knee and hip to every row")
    parser.add_argument("--refit", action="store_true",
                        help="refit the compliance to --gait at every point (a full pdw-fit "
                             "per point, warm-started from the neighbour; slow)")
    parser.add_argument("--workers", type=_positive_int, default=1, metavar="K",
                        help="processes for independent work (default: %(default)s)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler address (e.g. tcp://host:8786); overrides "
                             "--workers")
    parser.add_argument("--tol", type=float, default=1e-10,
                        help="|P(x) - x| of every fixed point (default: %(default)s)")
    args = parser.parse_args(argv)
    with _errors():
        import numpy as np
        import pandas as pd
        from tqdm import tqdm

        from .continuation import parameter_index
        from .plots import plot_sweep
        from .sweep import SweepSettings, sweep

        if args.num < 2:
            raise ProblemError(f"--num must be >= 2, got {args.num}")
        if args.start == args.stop:
            raise ProblemError(f"--from and --to must differ, got {args.start} twice")
        if args.scheduler is not None:
            try:
                import distributed  # noqa: F401
            except ImportError:
                raise ProblemError("--scheduler needs dask.distributed: "
                                   "pip install 'pdw-casadi[dask]'") from None
        problem = load_cli_problem(args)
        if args.from_fit is not None:
            problem = load_fit_start(problem, args.from_fit)
        if args.gait is not None:
            from .gait_data import load_gait_curves
            from .system import hybrid_system

            load_gait_curves(args.gait)  # a bad file is a user error now, not mid-sweep
            if "III" not in hybrid_system(problem).phase_names:
                raise ProblemError(f"--gait needs a walker with a heel-strike phase III; "
                                   f"{problem.name} ({problem.family}) has none")
        parameter_index(problem, args.param)  # an unknown name fails before any work
        out = _out_dir(args.out)
        csv_path = out / "sweep.csv"
        csv_path.unlink(missing_ok=True)
        columns: list[str] = []

        def append(row: dict) -> None:
            # the first row (the start, a converged gait) fixes the columns; later rows that
            # lack some (a failed point has no margins) get empty cells
            if not columns:
                columns.extend(row)
            frame = pd.DataFrame([row]).reindex(columns=columns)
            frame.to_csv(csv_path, mode="a", header=not csv_path.exists(), index=False)

        grid = np.linspace(args.start, args.stop, args.num)
        print(f"sweeping {args.param} of {problem.name} from {args.start} to {args.stop} "
              f"({args.num} values, {args.mode})...", file=sys.stderr)
        corrector = None
        if args.refit:
            if args.gait is None:
                raise ProblemError("--refit needs --gait FILE (the curves to refit to)")
            if args.param != "slope":
                raise ProblemError("--refit sweeps the slope (the compliance is refitted)")
            from .fit import FitOptions, RefitCorrector
            from .gait_data import load_gait_curves

            corrector = RefitCorrector(problem, load_gait_curves(args.gait),
                                       FitOptions(verbose=False))
        with tqdm(total=args.num, unit="pt", desc="pdw-sweep", file=sys.stderr) as bar:
            res = sweep(problem, grid, parameter=args.param, mode=args.mode,
                        corrector=corrector, workers=args.workers,
                        scheduler=args.scheduler, gait=args.gait,
                        settings=SweepSettings(tol=args.tol, predictor=args.predictor),
                        on_row=append, progress=bar.update)
        summary = {**res.to_dict(), "problem": problem.name,
                   "compliance": dict(problem.compliance), "slope": problem.slope,
                   "units": {"slope": "rad", "time": "s", "length": "m", "speed": "m/s"}}
        _write_json(out / "events.json", summary)
        plot_sweep(res.table, res.events, args.param, out / "sweep.png",
                   title=f"{problem.name}: sweep over {args.param}")
    table = res.table
    print(f"{len(table)} points ({int(table['converged'].sum())} converged, "
          f"{int((table['stable'] & table['valid']).sum())} stable and valid)")
    for e in res.events:
        print(f"  {e.kind:16s} {args.param} = {e.value:.8g}  (bracket {min(e.bracket):.8g} .. "
              f"{max(e.bracket):.8g}): {e.reason}")
    ranges = res.stable_ranges()
    if ranges:
        for r in ranges:
            print(f"stable valid gait: {args.param} in [{r['from']:.8g}, {r['to']:.8g}] "
                  f"(ends: {r['from_event'] or 'last point'}, {r['to_event'] or 'last point'})")
    else:
        print(f"no stable valid gait found over {args.param} = {args.start} .. {args.stop}")
    print(f"wrote {out}")
    return 0


#: command name -> main function (for ``python -m pdw_casadi.cli COMMAND ...``)
COMMANDS: dict[str, Callable[[Sequence[str] | None], int]] = {
    "simulate": simulate_main,
    "fixed-point": fixed_point_main,
    "fit": fit_main,
    "sweep": sweep_main,
}


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``python -m pdw_casadi.cli COMMAND [options]`` to a command's main."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        _fail(f"usage: python -m pdw_casadi.cli {{{','.join(COMMANDS)}}} [options]; "
              f"got {argv[0] if argv else 'no command'!r}")
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    sys.exit(main())
