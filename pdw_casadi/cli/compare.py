"""``pdw-compare``: one gait fitted by several walkers, one table of their timing and curves."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from pdw_casadi.cli.common import check_curve_walker, gait_file
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    int_range,
    output_path,
    run,
)
from pdw_casadi.model.problem import load_problem
from pdw_casadi.report.compare_report import compare_table, compare_text, write_compare_report
from pdw_casadi.studies.compare_run import (
    ANKLE_STUDY,
    TIMING_SUFFIX,
    CompareFit,
    CompareRequest,
    check_compare,
    compare_rows,
    run_compare,
)

DEFAULTS = CompareRequest()
#: how long a fit's process may take to end after the signal that ended this run (s)
FIT_EXIT_GRACE_S = 10.0


def compare_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-compare --out DIR``: fit one gait with several walkers and tabulate.

    Fits the curve file ``--gait`` with every walker of ``--problems`` (default: the
    ankle-extension study, :data:`~pdw_casadi.studies.compare_run.ANKLE_STUDY`), each as
    ``pdw-fit --gait FILE --problem P --out DIR/P[_timing] --quiet --rounds N --max-iter N
    [--timing]`` in a process of its own, one after the other; a fit already in
    ``DIR/P[_timing]`` is read, not run again (``--rerun`` to redo; ``--table-only``: run
    nothing). Each fit's folder is whole as soon as its fit ends (an interrupted comparison
    keeps the fits done; the same command again runs the rest). Then writes ``study.csv``
    and ``study.md`` (:mod:`pdw_casadi.report.compare_report`): per fit the double support
    of each period, stance, heel off and toe off (% of the gait cycle), cadence (steps/min),
    speed (m/s), knee/hip/thigh R^2, spectral radius, stable, valid, the phase durations
    (ms), the tightest validity margins and the compliance
    (:mod:`pdw_casadi.studies.compare_run`). Exit code 0 with the table (a fit that found
    no stable valid gait is a row); 1 when no fit left a summary.
    """
    parser = Parser(prog="pdw-compare",
                    description="Fit one gait with several walkers (pdw-fit each) and "
                                "tabulate their timing, curves and stability.")
    _compare_arguments(parser)
    args = parser.parse_args(argv)
    outputs = Outputs(args.out)

    def body() -> int:
        request = _checked(args)
        outputs.check()
        rows = compare_rows(request, args.out) if request.table_only else None
        if rows is not None and not rows:
            raise UsageError(f"--table-only: no fit summary in {args.out} "
                             f"({', '.join(f.label for f in request.fits())})")
        out = outputs.create()

        def fit(one: CompareFit, folder: Path) -> None:
            _fit_process(request, one, folder)
            if (folder / "summary.json").exists():  # whole: pdw-fit moved it into place
                outputs.committed.append(folder)
            outputs.notes[:] = [f"the fits done are in {outputs.dir}; the same command "
                                f"again runs the rest"]

        done = run_compare(request, args.out, fit)
        if not done.rows:
            raise NoGait(f"no fit left a summary in {outputs.dir} "
                         f"({', '.join(f.label for f in request.fits())})")
        table = compare_table(done.rows)
        for path in write_compare_report(table, out):
            outputs.wrote(path)
        print(compare_text(table))
        read = len(done.rows) - len(done.ran)
        print(f"wrote {outputs.dir} ({len(done.ran)} fit{'' if len(done.ran) == 1 else 's'} "
              f"run, {read} read)")
        return 0

    return run(outputs, body)


def _compare_arguments(parser: Parser) -> None:
    parser.add_argument("--out", type=output_path("--out"), required=True, metavar="DIR",
                        help="output directory (created if missing): the fits in "
                             f"DIR/P[{TIMING_SUFFIX}], and study.csv and study.md, one row "
                             "per fit: double support of each period, stance, heel off and "
                             "toe off (%% of the gait cycle), cadence (steps/min), speed "
                             "(m/s), knee/hip/thigh R^2, spectral radius, stable, valid, "
                             "phase durations (ms), the tightest validity margins (margin "
                             "minus its minimum: N, m or N s) and the compliance (study.csv)")
    parser.add_argument("--gait", default=DEFAULTS.gait, metavar="FILE",
                        help="gait-curve CSV to fit (default: %(default)s)")
    parser.add_argument("--problems", nargs="+", default=list(ANKLE_STUDY),
                        metavar="NAME_OR_PATH",
                        help="the walkers: bundled problem names or problem TOML files "
                             "(default: the ankle-extension study, " + ", ".join(ANKLE_STUDY)
                             + ")")
    parser.add_argument("--timing", action="store_true",
                        help="also fit each walker with pdw-fit --timing (the stance %% "
                             f"target; folder P{TIMING_SUFFIX})")
    parser.add_argument("--only-timing", action="store_true",
                        help="only the fits with --timing")
    parser.add_argument("--rounds", type=int_range("--rounds", 1, 100),
                        default=DEFAULTS.rounds, metavar="N",
                        help="pdw-fit --rounds (default: %(default)s)")
    parser.add_argument("--max-iter", type=int_range("--max-iter", 1, 100000),
                        default=DEFAULTS.max_iter, metavar="N",
                        help="pdw-fit --max-iter (default: %(default)s)")
    parser.add_argument("--rerun", action="store_true",
                        help="fit again where a fit is in DIR already")
    parser.add_argument("--table-only", action="store_true",
                        help="run nothing: tabulate the fits already in DIR")


def _checked(args) -> CompareRequest:
    """The request of the parsed flags, checked against the walkers and the curve file
    before any output (a walker without knee and hip curves, a bad curve file, two walkers
    in one folder are bad input)."""
    if args.table_only and args.rerun:
        raise UsageError("--table-only runs nothing; it takes no --rerun")
    request = CompareRequest(gait=args.gait, problems=tuple(args.problems),
                             timing=args.timing, only_timing=args.only_timing,
                             rerun=args.rerun, table_only=args.table_only,
                             rounds=args.rounds, max_iter=args.max_iter)
    check_compare(request)
    if not request.table_only:
        gait_file(request.gait)  # a bad file is a user error now, not in every fit
        for name in request.problems:
            check_curve_walker(load_problem(name), "pdw-compare")
    return request


def fit_command(request: CompareRequest, fit: CompareFit, folder: Path) -> list[str]:
    """The ``pdw-fit`` arguments of one fit of the comparison."""
    return ["--gait", request.gait, "--problem", fit.problem, "--out", str(folder), "--quiet",
            "--rounds", str(request.rounds), "--max-iter", str(request.max_iter),
            *(["--timing"] if fit.timing else [])]


def _fit_process(request: CompareRequest, fit: CompareFit, folder: Path) -> int:
    """Run one fit as ``pdw-fit`` in a process of its own (its output passes through); its
    exit code. A signal that ends this run reaches the fit too (the terminal sends Ctrl-C
    to both; a SIGTERM is passed on), and the run waits for the fit to end its own run."""
    command = fit_command(request, fit, folder)
    print("$ pdw-fit " + " ".join(command), flush=True)
    proc = subprocess.Popen([sys.executable, "-m", "pdw_casadi.cli", "fit", *command])
    try:
        return proc.wait()
    except KeyboardInterrupt as exc:
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(getattr(exc, "signum", signal.SIGINT))
        try:
            proc.wait(timeout=FIT_EXIT_GRACE_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        raise
