"""Console scripts of the toolkit.

Each command is a ``*_main(argv=None)`` function registered in :data:`COMMANDS` and exposed
as a console script in ``pyproject.toml`` (``pdw-simulate`` -> :func:`simulate_main`). All of
them keep the contract of :mod:`pdw_casadi.cli_contract`: every argument, file, number,
bound and address is checked before the output directory is created; bad input is one line
``error: ...`` and exit code 2 with nothing written; "ran, but no gait" is exit code 1 with
a ``no gait: <reason>`` line; never a traceback; Ctrl-C ends with one line naming what is on
disk. They share:

- :func:`common_parser`: the parent argparse parser with ``--problem``, ``--state``,
  ``--compliance`` and ``--out``;
- :func:`load_cli_problem`: the problem with the ``--state`` / ``--compliance`` overrides
  applied (overrides obey the problem's ``compliance_bounds``);
- :func:`pdw_casadi.jsonio.write_json`: JSON output with numpy scalars/arrays, paths and
  non-finite floats (written as ``null``) handled.

Adding a command: write ``foo_main(argv=None)`` that builds a :class:`Parser` with
``parents=[common_parser()]``, validates in a ``body()`` before ``outputs.create()`` and
returns ``run(outputs, body)``; add it to :data:`COMMANDS` (``python -m pdw_casadi.cli foo
...`` then works too).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn

import numpy as np

from .cli_contract import (
    USER_ERRORS,
    NoGait,
    Outputs,
    Parser,
    UsageError,
    check_input_file,
    check_output_file,
    connect_scheduler,
    fail,
    finite_float,
    int_range,
    open_interval,
    run,
    user_errors,
)
from .errors import NoStartGait, ProblemError
from .jsonio import write_json
from .problem import Problem, check_bounds, load_overrides, load_problem
from .timing import fixed_point_timing, simulation_timing, timing_or_none

__all__ = ["COMMANDS", "USER_ERRORS", "common_parser", "fit_main", "fixed_point_main",
           "load_cli_problem", "load_fit_start", "main", "simulate_main", "sweep_main"]

#: the largest --steps of pdw-simulate (every step's trajectory is kept and written)
MAX_STEPS = 1000
#: the most trajectory samples pdw-simulate keeps in memory (about 0.4 kB each)
MAX_SAMPLES = 1_000_000
#: accepted |P(x) - x| tolerances of the fixed points (below: rounding noise of one step)
TOL_RANGE = (1e-14, 1e-3)


# --------------------------------------------------------------------------------------------
# shared helpers
# --------------------------------------------------------------------------------------------
def _fail(message: object, code: int = 2) -> NoReturn:
    """Print ``error: <message>`` (one line) to stderr and exit with ``code``."""
    fail(message, code)


def _parse(parser: argparse.ArgumentParser, argv) -> tuple[argparse.Namespace, Outputs]:
    """The parsed arguments of a command and its output directory (not created yet)."""
    args = parser.parse_args(argv)
    return args, Outputs(args.out)


def _parallel_arguments(parser: argparse.ArgumentParser, what: str) -> None:
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
    g.add_argument("--out", type=Path, required=out_default is None, metavar="DIR",
                   default=None if out_default is None else Path(out_default),
                   help="output directory (created if missing)"
                        + ("" if out_default is None else " (default: %(default)s)"))
    return parent


#: the block's expected user errors become one ``error:`` line and exit code 2
_errors = user_errors


def _positive_int(text: str) -> int:
    return int_range("value", 1)(text)


def _tol(flag: str = "--tol") -> Callable[[str], float]:
    lo, hi = TOL_RANGE

    def parse(text: str) -> float:
        v = finite_float(flag)(text)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{flag} must lie in [{lo:g}, {hi:g}], "
                                             f"got {text!r}")
        return v
    parse.__name__ = "tolerance"
    return parse


def _one_leg_set(problem: Problem) -> None:
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


def _gait_file(source: str, flag: str = "--gait"):
    from .gait_data import load_gait_curves

    return load_gait_curves(source)


def _check_curve_walker(problem: Problem, what: str):
    """The walker's faces; a clear error when it has no knee and hip outputs."""
    from .faces import walker_faces

    faces = walker_faces(problem)
    if not faces.has_gait_curves:
        missing = [j for j in ("knee", "hip") if j not in faces.joints]
        raise UsageError(f"{what} needs knee and hip curves, but {problem.name} "
                         f"({problem.family}) has no {' or '.join(missing)} "
                         f"(joints: {', '.join(faces.joints) or 'none'})")
    return faces


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
        "timing": timing_or_none(lambda: simulation_timing(problem.family, result)),
    }


def _divergence(result) -> str | None:
    f = result.failure
    if f is not None and f.reason == "numerical_divergence":
        return (f"numerical divergence in step {f.step}, phase {f.phase}, at t = "
                f"{f.time:.4f} s: {f.detail}")
    return None


def simulate_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-simulate``: simulate N steps and write trajectory, events, summary and plots.

    Writes to ``--out``: ``trajectory.csv`` (one row per integration step: time, step,
    phase, coordinates, velocities and outputs), ``events.csv`` (guards, mode switches,
    failure), ``summary.json`` (phases, step time/length, speed, Poincare states, residual
    ||F(x0) - x0||, energy balance, failure, margins, problem, compliance, slope, timing
    per step and per cycle of two steps: :mod:`pdw_casadi.timing`),
    ``angles.png`` and ``stick.png``; with ``--animate FILE.gif`` also an animation of the
    walker over all steps (:mod:`pdw_casadi.animation`). A walker that falls is a result, not
    an error: the outputs are written, ``failure`` says why, a warning goes to stderr, exit
    code 0. A numerical divergence (non-finite or absurd states, a broken energy balance:
    the step size is too large for the walker's stiffness) is not a fall: the outputs are
    written and the exit code is 1. Long runs show a progress bar on stderr.
    """
    parser = Parser(
        prog="pdw-simulate", parents=[common_parser()],
        description="Simulate steps of a passive walker from its section state.")
    parser.add_argument("--steps", type=int_range("--steps", 1, MAX_STEPS), default=1,
                        metavar="N", help=f"number of steps, 1..{MAX_STEPS} "
                                          "(default: %(default)s)")
    parser.add_argument("--snapshots", type=int_range("--snapshots", 2, 100), default=8,
                        metavar="K",
                        help="stick-figure snapshots of the first step, 2..100 "
                             "(default: %(default)s)")
    parser.add_argument("--animate", type=Path, metavar="FILE.gif",
                        help="also write an animated GIF of the walker walking down the slope "
                             "over all simulated steps")
    parser.add_argument("--fps", type=int_range("--fps", 1, 100), default=25, metavar="F",
                        help="frames per simulated second of the animation, 1..100 (default: "
                             "%(default)s)")
    args, outputs = _parse(parser, argv)

    def body() -> int:
        problem = load_cli_problem(args)
        outputs.check()
        if args.animate is not None:
            check_output_file(args.animate, "--animate", (".gif",))
        from tqdm import tqdm

        from .faces import walker_faces
        from .plots import plot_angles, plot_stick
        from .simulate import Simulator
        from .units import summary_units, with_units

        if problem.asymmetric:  # legs differ: parameters alternate with the stance leg
            from .stride import stride_simulator

            sim, p_steps = stride_simulator(problem)
        else:
            sim, p_steps = Simulator(problem), None
        faces = walker_faces(problem, sim.hs)
        p = p_steps[0] if p_steps else problem.parameter_vector()
        out = outputs.create()
        with tqdm(total=args.steps, unit="step", desc="pdw-simulate", file=sys.stderr,
                  disable=args.steps < 10) as bar:
            result = sim.run(problem.state_vector(), p, steps=args.steps, record=True,
                             progress=lambda k: bar.update(k - bar.n),
                             max_samples=MAX_SAMPLES, p_steps=p_steps)
        traj = result.trajectory
        if traj is None:
            import pandas as pd

            traj = pd.DataFrame()
        with_units(traj, sim.hs).to_csv(outputs.wrote(out / "trajectory.csv"), index=False)
        with_units(result.events, sim.hs).to_csv(outputs.wrote(out / "events.csv"),
                                                 index=False)
        summary = simulation_summary(problem, result, args.steps)
        summary["units"] = summary_units(summary, sim.hs)
        write_json(outputs.wrote(out / "summary.json"), summary)
        plot_angles(traj, outputs.wrote(out / "angles.png"),
                    title=f"{problem.name}: joint angles", faces=faces)
        plot_stick(sim.hs, traj, p, outputs.wrote(out / "stick.png"), n=args.snapshots)
        if args.animate is not None and not traj.empty:
            from .animation import animate_walk

            animate_walk(sim.hs, result, p, outputs.wrote(args.animate), fps=args.fps,
                         title=f"{problem.name}: {result.completed_steps} steps down a slope "
                               f"of {problem.slope:.4f} rad")
        print(f"wrote {out} ({summary['completed_steps']} of {args.steps} steps)")
        diverged = _divergence(result)
        if diverged:
            raise NoGait(diverged)
        if result.failure is not None:
            f = result.failure
            print(f"warning: simulation stopped in step {f.step}, phase {f.phase}, at "
                  f"t = {f.time:.4f} s: {f.reason}"
                  + (f" ({f.detail})" if f.reason == "sample_limit" else ""), file=sys.stderr)
        return 0

    return run(outputs, body)


def fixed_point_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fixed-point``: find a periodic gait, its eigenvalues and validity margins.

    Writes ``summary.json`` (fixed_point, residual, iterations, eigenvalues as [re, im],
    spectral_radius, stable, step_time_s, step_length_m, speed_m_s, margins, valid,
    failure, distance_from_initial, timing: stance/swing/double support %, cadence, gait
    events, :mod:`pdw_casadi.timing`; identical for identical runs) and ``limit_cycle.png``
    (paper's Fig. 4); the wall time goes to stdout only. Exit code 1 when Newton (and its
    IPOPT fallback) found no fixed point.
    """
    parser = Parser(
        prog="pdw-fixed-point", parents=[common_parser()],
        description="Newton on the Poincare map with its exact AD Jacobian.")
    parser.add_argument("--tol", type=_tol(), default=1e-10,
                        help=f"|P(x) - x| to reach, in [{TOL_RANGE[0]:g}, {TOL_RANGE[1]:g}] "
                             "(default: %(default)s)")
    parser.add_argument("--stride", action="store_true",
                        help="solve on the stride map (two steps, one per physical leg); "
                             "always so when the problem's legs differ")
    args, outputs = _parse(parser, argv)

    def body() -> int:
        problem = load_cli_problem(args)
        outputs.check()
        from .faces import walker_faces
        from .fixed_point import find_fixed_point
        from .plots import plot_limit_cycle
        from .simulate import Simulator
        from .system import hybrid_system
        from .units import summary_units

        stride = args.stride or problem.asymmetric
        faces = None if stride else walker_faces(problem)
        out = outputs.create()
        print(f"solving for a fixed point of {problem.name} (slope {problem.slope} rad)...",
              file=sys.stderr)
        if stride:  # the two-step map: parameters follow the physical legs
            from .stride import StrideMap, find_stride_fixed_point

            smap = StrideMap(problem)
            res = find_stride_fixed_point(problem, tol=args.tol, smap=smap)
        else:
            res = find_fixed_point(problem, tol=args.tol, verbose=True)
        summary = res.to_dict()
        wall = summary.pop("wall_time_s", None)  # timings are not part of the result
        summary["distance_from_initial"] = float(
            np.linalg.norm(res.state - problem.state_vector()))
        summary["problem"] = problem.name
        summary["initial_state"] = dict(problem.initial_state)
        if res.converged and not stride:
            summary["timing"] = timing_or_none(lambda: fixed_point_timing(
                problem, res.state, res.parameters))
        if stride:
            summary["map"] = "stride (left-stance step, then right-stance step)"
            if res.converged:
                summary.update(_stride_outputs(smap, res, out, outputs))
        summary["units"] = summary_units(summary, smap.hs if stride else hybrid_system(problem))
        write_json(outputs.wrote(out / "summary.json"), summary)
        if res.converged and not stride:
            sim = Simulator(problem)
            two = sim.run(res.state, res.parameters, steps=2, record=True)
            plot_limit_cycle(two.trajectory, outputs.wrote(out / "limit_cycle.png"),
                             faces=faces,
                             title=f"{problem.name}: limit cycle of one leg over two steps")
        ev = ", ".join(f"{e.real:+.4f}{e.imag:+.4f}i" for e in res.eigenvalues)
        print(f"converged={res.converged} residual={res.residual:.2e} "
              f"iterations={res.iterations} spectral radius={res.spectral_radius:.4f} "
              f"({'stable' if res.stable else 'NOT stable'}) valid={res.valid}"
              f"{'' if res.valid else ' (' + str(res.failure) + ')'}")
        print(f"eigenvalues: {ev}")
        print(f"wrote {out}" + (f" ({wall:.2f} s)" if wall is not None else ""))
        if not res.converged:
            why = (f"|P(x) - x| = {res.residual:.3g} > {args.tol:g}"
                   f"{', ' + str(res.failure) if res.failure else ''}"
                   if math.isfinite(res.residual) else
                   f"the walker fails in the first step from it: {res.failure}")
            raise NoGait(f"no fixed point of {problem.name} near its initial state ({why}); "
                         f"the summary is in {out / 'summary.json'}")
        return 0

    return run(outputs, body)


def _stride_outputs(smap, res, out: Path, outputs) -> dict:
    """Per-leg report of a stride fixed point for ``summary.json`` (``stride``; per leg its
    step, stance and swing and the timing of its own gait cycle) and the per-leg knee/hip
    curves in ``leg_curves.csv`` and ``leg_curves.png``."""
    import pandas as pd

    from .plots import plot_leg_curves
    from .stride import stride_report, stride_timing

    rep = stride_report(smap, res.state, res.parameters)
    timing = timing_or_none(lambda: stride_timing(smap, res.state, res.parameters))
    if timing is not None:  # each physical leg's own gait cycle
        for side, t in timing.items():
            rep["legs"][side]["timing"] = t.to_dict()
    curves = rep.pop("curves")
    frame = pd.concat([c.assign(leg=side) for side, c in curves.items()], ignore_index=True)
    frame.to_csv(outputs.wrote(out / "leg_curves.csv"), index=False)
    plot_leg_curves(curves, outputs.wrote(out / "leg_curves.png"),
                    title=f"{smap.problem.name}: knee and hip per leg")
    rep["step_spectral_radius_equivalent"] = float(np.sqrt(res.spectral_radius))
    print(f"step length L/R {rep['legs']['left']['step_length_m']:.4f} / "
          f"{rep['legs']['right']['step_length_m']:.4f} m "
          f"(asymmetry {rep['step_length_asymmetry_pct']:+.3f} %), step time L/R "
          f"{rep['legs']['left']['step_time_s']:.4f} / {rep['legs']['right']['step_time_s']:.4f}"
          f" s (asymmetry {rep['step_time_asymmetry_pct']:+.3f} %)")
    return {"stride": rep}


def _fit_output(outputs: Outputs, opts) -> Path:
    """Create a fit's output folder and point IPOPT's log at a fresh ``ipopt.log`` in it."""
    out = outputs.create()
    outputs.notes.append(f"the report files are written only at the end, into {out}")
    log_file = out / "ipopt.log"
    log_file.unlink(missing_ok=True)
    opts.log_file = str(log_file)
    return out


def fit_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-fit --gait FILE``: fit the compliance and a stable periodic gait to human curves.

    One multiple-shooting IPOPT NLP per start (see :mod:`pdw_casadi.fit`), verified by a
    20-step re-simulation and the exact-AD spectral radius. Writes ``summary.json``,
    ``curves.csv``, ``fit.png`` (Fig. 5 with the problem's own compliance and, for a walker
    that has one, its comparison walker; the gait events marked), ``limit_cycle.png``
    (Fig. 4) and ``table.md`` (R^2, then the gait timing beside human values).
    ``--timing [W]`` adds the timing target (:class:`~pdw_casadi.fit.FitOptions`
    ``timing_weight``).
    Exit code 1 when no stable valid gait was found (the outputs then describe the best
    candidate and say so). The walker needs knee and hip outputs and something to fit
    (compliance values, or ``--free-slope``).
    """
    parser = Parser(
        prog="pdw-fit", parents=[common_parser(out_default="fit")],
        description="Fit compliance and a stable periodic gait to human knee/hip curves.")
    parser.add_argument("--gait", required=True, metavar="FILE",
                        help="gait-curve CSV (a path or a bundled name such as female_fast.csv)")
    parser.add_argument("--multistart", type=int_range("--multistart", 1, 1000), default=1,
                        metavar="N",
                        help="starts: the problem's own gait, then the N - 1 gait-atlas "
                             "entries whose curves fit best (default: %(default)s)")
    parser.add_argument("--atlas", metavar="FILE",
                        help="gait atlas of the further starts (default: the bundled one "
                             "of the problem; 'none': no atlas)")
    parser.add_argument("--free-slope", action="store_true",
                        help="let the slope be an unknown too (0.05..0.25 rad)")
    parser.add_argument("--hip-target", choices=("hip", "thigh"), default="hip",
                        help="hip curve in the objective: the paper's hip (thigh + slope) "
                             "or the thigh from the vertical (default: %(default)s)")
    parser.add_argument("--max-radius", type=open_interval("--max-radius", 0.0, 1.0),
                        default=0.91, metavar="R",
                        help="largest accepted spectral radius, in (0, 1) "
                             "(default: %(default)s)")
    parser.add_argument("--timing", type=open_interval("--timing", 0.0, 1000.0), nargs="?",
                        const=1.0, default=0.0, metavar="W",
                        help="also fit the timing: add W ((stance %% - human toe-off %%) / "
                             "10 %%)^2 to the objective (human toe off: the gait file's "
                             "toe_off_pct column, else 60 %%, Perry & Burnfield); R^2 is "
                             "unchanged (default W when given: 1)")
    parser.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000), default=300,
                        help="IPOPT iterations per solve (default: %(default)s)")
    parser.add_argument("--rounds", type=int_range("--rounds", 1, 100), default=2,
                        help="NLP solves per start: a further one is built at the answer only "
                             "when the objective's sample brackets moved (default: %(default)s)")
    _parallel_arguments(parser, "the multistart")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress lines (the IPOPT log is still written to "
                             "DIR/ipopt.log)")
    g = parser.add_argument_group(
        "per-leg fit", "a curve file with per-side columns (knee_left_mean_deg, ...; or "
        "--gait-right) fits each leg to its side on the stride")
    g.add_argument("--gait-right", metavar="FILE",
                   help="the right side's curve file; --gait is then the left side's")
    g.add_argument("--side", choices=("both", "left", "right"), default=None,
                   help="per-leg fit: whose compliance is free (default: both)")
    g.add_argument("--stride-start", choices=("fit", "atlas"), default="fit",
                   help="per-leg fit: start from the symmetric fit to the mean of both "
                        "sides, or from the atlas gait that fits that mean best (no extra "
                        "solve) (default: %(default)s)")
    args, outputs = _parse(parser, argv)

    def body() -> int:
        from .gait_data import SideCurves, load_gait_file, load_side_curves

        if args.gait_right is not None:
            human = load_side_curves(args.gait, args.gait_right)
        else:
            human = load_gait_file(args.gait)
        problem = load_cli_problem(args)
        if isinstance(human, SideCurves):
            return _fit_stride_body(args, outputs, problem, human)
        if args.side is not None:
            raise UsageError(f"--side needs per-side curves (columns such as "
                             f"knee_left_mean_deg, or --gait-right); {human.source} has one "
                             f"curve set")
        _one_leg_set(problem)
        if args.hip_target == "thigh" and human.thigh_deg is None:
            raise UsageError(f"--hip-target thigh needs a thigh column in the gait file "
                             f"{human.source} (it has none); use --hip-target hip")
        _check_curve_walker(problem, "pdw-fit")
        if not problem.compliance and not args.free_slope:
            raise UsageError(f"{problem.name} ({problem.family}) has no compliance values "
                             f"to fit; add --free-slope to fit the slope")
        outputs.check()
        from .fit import FitOptions
        from .fit_report import fit_and_report

        atlas = None if args.atlas is None else ("" if args.atlas == "none" else args.atlas)
        if atlas:
            check_input_file(Path(atlas), "--atlas")
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
        opts = FitOptions(hip_target=args.hip_target, free_slope=args.free_slope,
                          max_radius=args.max_radius, multistart=args.multistart,
                          atlas=atlas, max_iter=args.max_iter, rounds=args.rounds,
                          timing_weight=args.timing,
                          verbose=not args.quiet)
        from .fit import check_targets

        check_targets(problem, human, opts)
        out = _fit_output(outputs, opts)
        summary = fit_and_report(problem, human, opts, out, workers=args.workers,
                                 scheduler=args.scheduler,
                                 log=lambda m: print(m, file=sys.stderr, flush=True))
        for name in ("summary.json", "curves.csv", "fit.png", "limit_cycle.png", "table.md",
                     "ipopt.log"):
            outputs.wrote(out / name)
        print(summary["headline"])
        print(f"wrote {out}")
        if not (summary["stable"] and summary["valid"]):
            raise NoGait(f"no stable valid gait: {summary['headline']}")
        return 0

    return run(outputs, body)


def _fit_stride_body(args, outputs: Outputs, problem: Problem, sides) -> int:
    """pdw-fit with per-side curves: each leg fitted to its side on the stride
    (:mod:`pdw_casadi.fit.stride_fit`); the report of :mod:`pdw_casadi.fit_stride_report`."""
    from .fit.stride_fit import StrideFitOptions, check_stride_targets
    from .fit_stride_report import fit_stride_and_report
    from .stride import StrideMap

    if args.timing:
        raise UsageError("--timing is a one-step fit's target; a per-leg fit has none")
    if args.workers > 1 or args.scheduler is not None or args.multistart > 1:
        raise UsageError("--multistart, --workers and --scheduler are one-step fit options "
                         "(a per-leg fit solves one stride NLP)")
    if args.hip_target == "thigh" and (sides.left.thigh_deg is None):
        raise UsageError(f"--hip-target thigh needs thigh columns in {sides.source}")
    _check_curve_walker(problem, "pdw-fit")
    if not problem.compliance:
        raise UsageError(f"{problem.name} ({problem.family}) has no compliance values to fit "
                         f"per leg")
    try:
        StrideMap(problem)
    except ProblemError as exc:
        raise UsageError(str(exc)) from None
    outputs.check()
    atlas = None if args.atlas is None else ("" if args.atlas == "none" else args.atlas)
    if atlas:
        check_input_file(Path(atlas), "--atlas")
    opts = StrideFitOptions(hip_target=args.hip_target, free_slope=args.free_slope,
                            max_radius=args.max_radius, atlas=atlas, max_iter=args.max_iter,
                            rounds=args.rounds, verbose=not args.quiet,
                            side=args.side or "both", start=args.stride_start)
    check_stride_targets(problem, sides, opts)
    out = _fit_output(outputs, opts)
    summary = fit_stride_and_report(problem, sides, opts, out,
                                    log=lambda m: print(m, file=sys.stderr, flush=True))
    for name in ("summary.json", "curves.csv", "fit.png", "table.md", "ipopt.log"):
        outputs.wrote(out / name)
    print(summary["headline"])
    print(f"wrote {out}")
    if not summary["accepted"]:
        raise NoGait(f"no stable valid stride: {summary['headline']}")
    return 0


def load_fit_start(problem: Problem, path: Path) -> Problem:
    """``problem`` with compliance, slope and section state taken from a fit summary.

    The summary (JSON) holds ``compliance`` (problem compliance names -> values), ``slope``
    (rad) and ``fixed_point`` (section-state names -> values, rad and rad/s). The
    compliance obeys the problem's ``compliance_bounds``.
    """
    path = check_input_file(path, "--from-fit")
    try:
        raw = json.loads(Path(path).read_text())
    except UnicodeDecodeError:
        raise ProblemError(f"{path}: not a fit summary (not UTF-8 text)") from None
    except ValueError as exc:
        raise ProblemError(f"{path}: not valid JSON: {exc}") from None
    if not isinstance(raw, dict):
        kind = {list: "a list", str: "a string", bool: "a boolean", type(None): "null",
                int: "a number", float: "a number"}.get(type(raw), type(raw).__name__)
        raise ProblemError(f"{path}: a fit summary must be a JSON object with the keys "
                           f"compliance, slope and fixed_point; got {kind}")
    missing = [k for k in ("compliance", "slope", "fixed_point") if k not in raw]
    if missing:
        raise ProblemError(f"{path}: a fit summary needs the keys compliance, slope and "
                           f"fixed_point; missing: {', '.join(missing)}")
    if not isinstance(raw["compliance"], dict) or not isinstance(raw["fixed_point"], dict):
        raise ProblemError(f"{path}: 'compliance' and 'fixed_point' must be tables")
    if isinstance(raw["slope"], bool) or not isinstance(raw["slope"], int | float) \
            or not math.isfinite(raw["slope"]):
        raise ProblemError(f"{path}: 'slope' must be a finite number (rad), got "
                           f"{raw['slope']!r}")
    for table in ("compliance", "fixed_point"):
        for k, v in raw[table].items():
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise ProblemError(f"{path}: '{table}.{k}' must be a finite number, got "
                                   f"{v!r}")
    try:
        new = problem.replace(compliance=raw["compliance"], slope=float(raw["slope"])) \
            .with_state(raw["fixed_point"])
        check_bounds(new, raw["compliance"], path)
        return new
    except ProblemError as exc:
        text = str(exc)
        raise ProblemError(text if text.startswith(str(path)) else f"{path}: {text}") from None


def sweep_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-sweep``: follow a periodic gait over a parameter; bifurcations and boundaries.

    Starts from the fixed point of the problem (its initial state; or ``--from-fit``), covers
    ``--num`` values from ``--from`` to ``--to`` of ``--param`` (the slope in rad, or a
    compliance name in its unit, within the problem's compliance_bounds) and writes to
    ``--out``: ``sweep.csv`` (one row per point: parameter, section state, step time, step
    length, speed, spectral radius, eigenvalues, margins, stable, valid, R^2 with
    ``--gait``), ``events.json`` (located bifurcations and gait-pattern boundaries, stable
    valid ranges) and ``sweep.png`` (step length, speed and spectral radius against the
    parameter). Rows are appended to ``sweep.partial.csv`` as each is found, which becomes
    ``sweep.csv`` when the sweep completes: an interrupted or failed run leaves the
    ``sweep.csv`` of an earlier run untouched and its own rows in ``sweep.partial.csv``.
    ``--workers K`` spreads independent work (grid points, the two directions from an
    interior start) over K processes; ``--scheduler ADDRESS`` over a Dask cluster (checked
    to answer before anything is written). Exit code 1 when the start has no gait.
    """
    parser = Parser(
        prog="pdw-sweep", parents=[common_parser()],
        description="Parameter sweep of a periodic gait by continuation, with bifurcations.")
    parser.add_argument("--param", default="slope", metavar="NAME",
                        help="parameter to sweep: slope (rad) or a compliance name; for a "
                             "walker whose legs differ also one leg's value, e.g. "
                             "right.k_ankle or right.m_s (default: %(default)s)")
    parser.add_argument("--from", dest="start", type=finite_float("--from"), required=True,
                        metavar="A", help="first value of the grid (unit of the parameter)")
    parser.add_argument("--to", dest="stop", type=finite_float("--to"), required=True,
                        metavar="B", help="last value of the grid")
    parser.add_argument("--num", type=int_range("--num", 2, 10000), default=25, metavar="N",
                        help="grid values from A to B, 2..10000 (default: %(default)s)")
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
    _parallel_arguments(parser, "independent work")
    parser.add_argument("--tol", type=_tol(), default=1e-10,
                        help=f"|P(x) - x| of every fixed point, in [{TOL_RANGE[0]:g}, "
                             f"{TOL_RANGE[1]:g}] (default: %(default)s)")
    args, outputs = _parse(parser, argv)

    def body() -> int:
        import pandas as pd

        from .continuation import parameter_index

        if args.start == args.stop:
            raise UsageError(f"--from and --to must differ, got {args.start:g} twice")
        if args.refit:
            if args.gait is None:
                raise UsageError("--refit needs --gait FILE (the curves to refit to)")
            if args.param != "slope":
                raise UsageError("--refit sweeps the slope (the compliance is refitted)")
        problem = load_cli_problem(args)
        if problem.asymmetric and (args.gait or args.refit or args.from_fit):
            raise UsageError(f"{problem.name}: its legs differ; --gait, --refit and "
                             f"--from-fit need a walker with one set of values for both legs "
                             f"(its gait is swept on the stride map without them)")
        if args.from_fit is not None:
            problem = load_fit_start(problem, args.from_fit)
        parameter_index(problem, args.param)  # an unknown name fails before any work
        for flag, v in (("--from", args.start), ("--to", args.stop)):
            check_bounds(problem, {args.param: v}, f"{flag} {v:g}")
        human = None
        if args.gait is not None:
            human = _gait_file(args.gait)  # a bad file is a user error now, not mid-sweep
            _check_curve_walker(problem, "--gait")
        outputs.check()
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
        from tqdm import tqdm

        from .plots import plot_sweep
        from .sweep import SweepSettings, sweep
        from .system import gait_system
        from .units import Units

        units = Units(gait_system(problem))

        corrector = None
        if args.refit:
            from .fit import FitOptions, RefitCorrector

            corrector = RefitCorrector(problem, human, FitOptions(verbose=False))
        out = outputs.create()
        csv_path, partial = out / "sweep.csv", out / "sweep.partial.csv"
        partial.unlink(missing_ok=True)  # a previous interrupted run's rows
        columns: list[str] = []
        found = [0]

        def note() -> None:
            rows = (f"{found[0]} rows found so far are in {partial}" if found[0]
                    else "no sweep rows found yet")
            outputs.notes[:] = [rows + (f" ({csv_path} of an earlier run untouched)"
                                        if csv_path.exists() else "")]

        note()

        def append(row: dict) -> None:
            # the first row (the start, a converged gait) fixes the columns; later rows that
            # lack some (a failed point has no margins) get empty cells
            if not columns:
                columns.extend(row)
            frame = units.frame(pd.DataFrame([row]).reindex(columns=columns))
            frame.to_csv(partial, mode="a", header=not partial.exists(), index=False)
            found[0] += 1
            note()

        grid = np.linspace(args.start, args.stop, args.num)
        print(f"sweeping {args.param} of {problem.name} from {args.start:g} to {args.stop:g} "
              f"({args.num} values, {args.mode})...", file=sys.stderr)
        try:
            with tqdm(total=args.num, unit="pt", desc="pdw-sweep", file=sys.stderr) as bar:
                res = sweep(problem, grid, parameter=args.param, mode=args.mode,
                            corrector=corrector, workers=args.workers,
                            scheduler=args.scheduler, gait=args.gait,
                            settings=SweepSettings(tol=args.tol, predictor=args.predictor),
                            on_row=append, progress=bar.update)
        except NoStartGait as exc:
            partial.unlink(missing_ok=True)
            raise NoGait(str(exc)) from None
        partial.replace(csv_path)
        outputs.notes.clear()
        outputs.wrote(csv_path)
        summary = {**res.to_dict(), "problem": problem.name,
                   "compliance": dict(problem.compliance), "slope": problem.slope}
        unit = units.of(args.param)  # grid, start and event values are in the parameter's
        summary["units"] = {**units.summary(summary), "start_value": unit, "grid": unit,
                            "events[].value": unit, "events[].bracket": unit}
        write_json(outputs.wrote(out / "events.json"), summary)
        plot_sweep(res.table, res.events, args.param, outputs.wrote(out / "sweep.png"),
                   title=f"{problem.name}: sweep over {args.param}")
        table = res.table
        print(f"{len(table)} points ({int(table['converged'].sum())} converged, "
              f"{int((table['stable'] & table['valid']).sum())} stable and valid)")
        for e in res.events:
            print(f"  {e.kind:16s} {args.param} = {e.value:.8g}  (bracket "
                  f"{min(e.bracket):.8g} .. {max(e.bracket):.8g}): {e.reason}")
        ranges = res.stable_ranges()
        if ranges:
            for r in ranges:
                print(f"stable valid gait: {args.param} in [{r['from']:.8g}, {r['to']:.8g}] "
                      f"(ends: {r['from_event'] or 'last point'}, "
                      f"{r['to_event'] or 'last point'})")
        else:
            print(f"no stable valid gait found over {args.param} = {args.start:g} .. "
                  f"{args.stop:g}")
        print(f"wrote {out}")
        return 0

    return run(outputs, body)


#: command name -> main function (for ``python -m pdw_casadi.cli COMMAND ...``)
COMMANDS: dict[str, Callable[[Sequence[str] | None], int]] = {
    "simulate": simulate_main,
    "fixed-point": fixed_point_main,
    "fit": fit_main,
    "sweep": sweep_main,
    "scale": lambda argv=None: _scale_main(argv),
}


def _scale_main(argv):
    from .scaling import scale_main

    return scale_main(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Dispatch ``python -m pdw_casadi.cli COMMAND [options]`` to a command's main."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        _fail(f"usage: python -m pdw_casadi.cli {{{','.join(COMMANDS)}}} [options]; "
              f"got {argv[0] if argv else 'no command'!r}")
    return COMMANDS[argv[0]](argv[1:])


if __name__ == "__main__":
    sys.exit(main())
