"""``pdw-cohort``: fit every curve file of a study, one tidy table (see
:mod:`pdw_casadi.studies.cohort`)."""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from pdw_casadi.cli.common import common_parser, fit_arguments, fit_options, load_cli_problem
from pdw_casadi.cli.contract import (
    NoGait,
    Outputs,
    Parser,
    UsageError,
    check_input_file,
    connect_scheduler,
    int_range,
    open_interval,
    run,
)
from pdw_casadi.studies.cohort import (
    BODIES,
    KINDS,
    CohortOptions,
    plan_cohort,
    read_bodies,
    read_study,
    run_cohort,
)
from pdw_casadi.studies.fit_run import FitOptions

DEFAULTS = CohortOptions()
FIT_DEFAULTS = FitOptions()


def _dask_slots(address: str) -> int | None:
    """Worker threads of the Dask cluster at ``address`` (None if it cannot say)."""
    try:
        # deferred: dask.distributed is optional (pdw-casadi[dask]); only --scheduler needs it
        from distributed import Client

        with Client(address, timeout="5s", set_as_default=False) as client:
            return int(sum(client.nthreads().values())) or None
    except Exception:  # only the progress bar's "running" count depends on it
        return None


class Bar:
    """The progress bar over the fits: done (this run and earlier), failed, running, time
    left (tqdm's estimate from the fits finished in this run)."""

    def __init__(self, total: int, slots: int | None, quiet: bool, outputs: Outputs):
        # deferred: tqdm, only when the command runs (fast --help)
        from tqdm import tqdm

        self.total, self.slots, self.outputs = total, slots, outputs
        self.done = self.failed = self.rejected = self.skipped = self.started = 0
        self.bar = None if quiet else tqdm(total=total, unit="fit", desc="pdw-cohort",
                                           file=sys.stderr, dynamic_ncols=True)
        self._note()

    def _note(self) -> None:
        n = self.done + self.skipped
        fits = self.outputs.dir / "fits"
        if n and fits not in self.outputs.committed:  # saved in place as each fit ends
            self.outputs.committed.append(fits)
        note = (f"{n} of {self.total} fits complete in {self.outputs.dir / 'fits'}; run the "
                f"same command again to resume the rest")
        self.outputs.notes[:] = [note]

    def __call__(self, event: str, key: str, rec: dict) -> None:
        if event.startswith("body"):
            status = rec.get("status")
            rho = rec.get("spectral_radius")
            line = (f"body of {key}: {status}" + (f", spectral radius {rho:.4f}"
                                                   if isinstance(rho, float) else "")
                    + (f" ({rec.get('reason')})" if rec.get("reason") else "")
                    + (" (saved earlier)" if event == "body-skip" else
                       f", {rec.get('wall_time_s', 0.0):.0f} s"))
            self.write(line)
            return
        status = rec["row"].get("status")
        if event == "skip":
            self.skipped += 1
            if self.bar is not None:  # counted, but not in the rate behind the time left
                self.bar.initial = self.bar.n = self.bar.last_print_n = self.skipped
        else:
            self.done += 1
            if self.bar is not None:
                self.bar.update(1)
        self.failed += status == "failed"
        self.rejected += status == "rejected"
        if status != "accepted" and event != "skip":
            self.write(f"{key}: {status}: {rec['row'].get('reason')}")
        self._note()
        self.refresh()

    def refresh(self) -> None:
        if self.bar is None:
            return
        left = self.total - self.done - self.skipped
        running = left if self.slots is None else min(self.slots, left)
        self.bar.set_postfix_str(f"failed {self.failed}, rejected {self.rejected}, "
                                 f"running {running}", refresh=True)

    def write(self, line: str) -> None:
        if self.bar is not None:
            self.bar.write(line, file=sys.stderr)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def cohort_main(argv: Sequence[str] | None = None) -> int:
    """``pdw-cohort STUDY... --out DIR``: fit every curve file of a study into one table.

    STUDY: curve files, directories (their ``*.csv``), glob patterns or study tables (CSV
    with a ``file`` column and optional ``subject_id``, ``condition``, ``mass_kg``,
    ``height_m``, ``sex``, ``speed_m_s``). Fits run on a local process pool (``--workers``,
    default one per CPU) or a Dask cluster (``--scheduler``), the same results either way.
    Writes ``fits/<fit_id>/result.json`` (and ``curves.csv``, ``ipopt.log``) as each fit ends, then
    ``cohort.csv`` (and ``cohort.parquet`` with pyarrow), ``r2_by_subject.png`` and
    ``compliance.png``. Run again, the command skips the fits already complete. Exit code 1
    (with the table written) when a fit found no stable valid gait.
    """
    parser = Parser(prog="pdw-cohort", parents=[common_parser(out_default="cohort")],
                    description="Fit every curve file of a study (symmetric or per side, "
                                "each subject on their own body) into one table.")
    parser.add_argument("study", nargs="+", metavar="STUDY",
                        help="curve files, directories, glob patterns or a study table")
    parser.add_argument("--kind", choices=KINDS, default=DEFAULTS.kind,
                        help="which fits: each file as its header says (auto), the "
                             "one-curve files (symmetric) or the per-side files (sides) "
                             "(default: %(default)s)")
    parser.add_argument("--body", choices=BODIES, default=DEFAULTS.body,
                        help="own: each subject with body data on their own de Leva body; "
                             "paper: everyone on the problem's body (default: %(default)s)")
    parser.add_argument("--bodies", metavar="FILE",
                        help="subjects' body data: CSV with subject_id, mass_kg, height_m "
                             "and optional sex (e.g. data/anthropometry/subjects.csv); a "
                             "study table's own columns take precedence")
    parser.add_argument("--body-max-radius", type=open_interval("--body-max-radius", 0, 1),
                        default=DEFAULTS.body_max_radius, metavar="R",
                        help="largest spectral radius of a subject's body gait, the start "
                             "of their fits (default: %(default)s)")
    fit_arguments(parser, FIT_DEFAULTS, title="fit (as pdw-fit)")
    parser.add_argument("--workers", type=int_range("--workers", 1, 256), metavar="K",
                        help="processes of the local pool (default: one per CPU, "
                             f"{os.cpu_count() or 1} here)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler to run the fits on (e.g. tcp://host:8786); "
                             "overrides --workers")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    outputs = Outputs(args.out)

    def body() -> int:
        bodies = None
        if args.bodies is not None:
            bodies = read_bodies(check_input_file(Path(args.bodies), "--bodies"))
        entries, left_out = read_study(args.study, args.kind, bodies)
        fit = fit_options(args, verbose=False)
        if fit.atlas:
            check_input_file(Path(fit.atlas), "--atlas")
        options = CohortOptions(problem=args.problem, kind=args.kind, body=args.body,
                                fit=fit, body_max_radius=args.body_max_radius)
        reference = load_cli_problem(args)
        plan = plan_cohort(entries, options, reference=reference)
        outputs.check()
        slots = None
        if args.scheduler is not None:
            connect_scheduler(args.scheduler)  # the address answers before anything is written
            slots = _dask_slots(args.scheduler)
            workers = 1
        else:
            workers = args.workers or os.cpu_count() or 1
            slots = workers
        return _run(plan, outputs, workers, args.scheduler, slots, args.quiet, left_out)

    return run(outputs, body)


def _run(plan, outputs: Outputs, workers: int, scheduler: str | None, slots, quiet: bool,
         left_out: list[str]) -> int:
    # deferred: the cohort's figures, only when the command runs (fast --help)
    from pdw_casadi.report.cohort import plot_cohort

    # validated and locked: a second run into the same folder is refused. Each fit's record
    # is saved in place, atomically, as it ends (an interrupted study keeps its finished
    # fits and a second run resumes from them); the table and figures are staged and moved
    # into place when the run completes
    stage = outputs.create()
    out = outputs.dir
    where = f"on the Dask cluster at {scheduler}" if scheduler else (
        f"on {workers} processes" if workers > 1 else "in this process")
    bodies = f", {len(plan.bodies)} subjects' bodies first" if plan.bodies else ""
    print(f"pdw-cohort: {plan.n_fits} fits {where}{bodies}"
          + (f" ({len(left_out)} files of another kind left out)" if left_out else ""),
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    bar = Bar(plan.n_fits, slots, quiet, outputs)
    try:
        table = run_cohort(plan, out, workers=workers, scheduler=scheduler, progress=bar,
                           table_dir=stage)
    finally:
        bar.close()
    outputs.wrote(out / "cohort.csv")
    if (stage / "cohort.parquet").exists():
        outputs.wrote(out / "cohort.parquet")
    for p in plot_cohort(table, stage):
        outputs.wrote(out / p.name)
    counts = table["status"].value_counts().to_dict()
    line = (f"{len(table)} fits: {counts.get('accepted', 0)} accepted, "
            f"{counts.get('rejected', 0)} rejected, {counts.get('failed', 0)} failed "
            f"({bar.skipped} complete from an earlier run); "
            f"{time.perf_counter() - t0:.0f} s")
    print(line)
    print(f"wrote {', '.join(str(p) for p in outputs.written)}")
    bad = table[table["status"] != "accepted"]
    if len(bad):
        raise NoGait(f"{len(bad)} of {len(table)} fits found no stable valid gait: "
                     + "; ".join(f"{r.fit_id} ({r.status}: {r.reason})"
                                 for r in bad.head(3).itertuples())
                     + ("; ..." if len(bad) > 3 else "") + f" (see {out / 'cohort.csv'})")
    return 0


__all__ = ["cohort_main", "UsageError"]
