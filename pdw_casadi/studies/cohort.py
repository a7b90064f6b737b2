"""A study fitted as one cohort: every curve file of every subject, one tidy table.

A study is a list of :class:`StudyEntry` (a curve file with its subject id, condition,
kind of fit and optional body data), read from curve files, directories, glob patterns or a
study table (:func:`read_study`). :func:`plan_cohort` turns it into fit tasks and
:func:`run_cohort` runs them through :func:`pdw_casadi.engine.parallel.map_tasks` (in this
process, on a local process pool or on a Dask cluster), then writes the table.

Each fit is a pure function of its task (:func:`run_fit_task`): the same rows from every
backend. Its outcome, whatever it is (an accepted gait, a rejected candidate, no candidate,
an exception), is saved as soon as it arrives in ``fits/<fit_id>/result.json`` (with
``curves.csv`` and IPOPT's ``ipopt.log``), written atomically (a temporary file renamed
over it), with a fingerprint of everything the fit depends on (the curve file's bytes, the
walker, the options, the toolkit's version). A
later run with the same fingerprint skips the fit; a fit cut off (Ctrl-C, a crash, a killed
machine) left no ``result.json`` and runs again, as does one whose inputs changed. The table
is always assembled from those files, so a resumed run and an uninterrupted one write the
same table.

Each subject on their own body (``CohortOptions.body = "own"`` and body data in the
study): the walker is scaled to the subject once per subject
(:func:`pdw_casadi.studies.scaling.stable_subject_walker`: de Leva 1996 by continuation
from the uniformly scaled reference, then the nearest stable gait), saved in
``bodies/<subject_id>.json`` (resumable the same way), and that subject's fits start from
its stable gait.

Table columns (one row per fit; units in the names; :data:`ID_COLUMNS` first):
``status`` "accepted" (stable, rho <= max_radius, valid, re-simulated), "rejected" (a
gait was found but not accepted; ``reason`` says why) or "failed" (no gait; ``reason``);
R^2 per curve (``r2_knee``, ``r2_hip``, ``r2_thigh``; a per-side fit also per leg,
``r2_knee_left``..., and the plain names are the mean of its two legs); compliance
(``k_knee_N_m_per_rad``...; per side ``k_knee_left_N_m_per_rad``...); ``slope_rad``; the
gait's timing (``step_time_s``, ``step_length_m``, ``speed_m_s``, ``stance_pct``,
``double_support_pct``); ``spectral_radius`` (per step; a stride's per-step equivalent, the
square root of ``stride_spectral_radius``); solver ``iterations`` (all solves) and
``solver_status`` (IPOPT's status of the solve the row's gait came from);
``certified`` (False: the solve stopped short of convergence and the gait is its best
feasible iterate, checked the same way);
``wall_time_s`` and ``cpu_time_s`` (the fit's own, in its worker: on shared cores the
CPU time is what the fit cost, the wall time what it waited).
"""

from __future__ import annotations

import contextlib
import dataclasses
import glob
import hashlib
import json
import math
import os
import re
import signal
import tempfile
import threading
import time
import tomllib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from pdw_casadi._version import __version__
from pdw_casadi.engine.errors import GaitDataError, ProblemError, UsageError
from pdw_casadi.engine.jsonio import jsonable
from pdw_casadi.engine.parallel import map_tasks
from pdw_casadi.fit import FitOptions, check_targets, fit_gait
from pdw_casadi.fit.options import PER_LEG_FIELDS
from pdw_casadi.fit.stride_fit import check_stride_targets
from pdw_casadi.gait.stride import stride_map
from pdw_casadi.gait.timing import fixed_point_timing
from pdw_casadi.model.faces import walker_faces
from pdw_casadi.model.gait_data import SIDES, GaitCurves, SideCurves, is_per_side, load_gait_file
from pdw_casadi.model.problem import (
    DEFAULT_PROBLEM,
    Problem,
    load_problem,
    problem_from_dict,
    problem_toml,
)
from pdw_casadi.model.units import COMPLIANCE_PREFIXES
from pdw_casadi.studies.scaling import (
    BODY_MAX_RADIUS,
    check_scalable,
    stable_subject_walker,
)

#: kinds of fit: "symmetric" (one-step fit, one set of compliance) and "sides" (per-leg
#: fit on the stride); a study selects with "auto" (each file as its header says),
#: "symmetric" (the one-curve files) or "sides" (the per-side files)
KINDS = ("auto", "symmetric", "sides")
#: whose body: "own" (the subject's, where the study gives mass and height) or "paper"
#: (the problem's reference body for every subject)
BODIES = ("own", "paper")
#: the outcome of a fit
STATUSES = ("accepted", "rejected", "failed")
#: the identifying columns of the table, first in every row
ID_COLUMNS = ("fit_id", "subject_id", "condition", "kind", "side", "body", "mass_kg",
              "height_m", "sex", "human_speed_m_s", "gait_file")
#: columns that measure the run, not the fit: they differ between runs of the same study
RUN_COLUMNS = ("wall_time_s", "cpu_time_s")
#: the study table's columns (``file`` required; the others optional)
TABLE_COLUMNS = ("file", "subject_id", "condition", "mass_kg", "height_m", "sex",
                 "speed_m_s")
#: body data ranges of the de Leva scaling (kg, m)
MASS_RANGE_KG = (20.0, 200.0)
HEIGHT_RANGE_M = (1.2, 2.2)
SEX_CODES = {"f": "female", "female": "female", "m": "male", "male": "male"}
RESULT_FILE = "result.json"
CURVES_FILE = "curves.csv"
#: IPOPT's own log of every solve of the fit (written by the process that saves the fit: a
#: Dask worker on another machine returns the text with the record)
LOG_FILE = "ipopt.log"


@dataclass
class CohortOptions:
    """Settings of a cohort run.

    ``problem``: the walker (bundled name or TOML path); ``kind``: which fits (:data:`KINDS`);
    ``body``: whose body (:data:`BODIES`); ``fit``: the settings of every fit (a per-side
    fit also reads ``side`` and ``start``; the symmetric fits ignore them);
    ``body_max_radius``: the largest spectral radius of a subject's body gait before its
    fits (the start of a fit on a subject's own body, see
    :func:`~pdw_casadi.studies.scaling.stable_subject_walker`).
    """

    problem: str = DEFAULT_PROBLEM
    kind: str = "auto"
    body: str = "own"
    fit: FitOptions = field(default_factory=lambda: FitOptions(verbose=False))
    body_max_radius: float = BODY_MAX_RADIUS

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise UsageError(f"kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if self.body not in BODIES:
            raise UsageError(f"body must be one of {', '.join(BODIES)}, got {self.body!r}")


@dataclass(frozen=True)
class StudyEntry:
    """One curve file of the study: who (``subject_id``), in which ``condition``, which
    ``kind`` of fit ("symmetric" or "sides"), and optional body data (kg, m, "female" or
    "male") and walking speed (m/s) of the subject."""

    gait_file: str
    subject_id: str
    condition: str
    kind: str
    mass_kg: float | None = None
    height_m: float | None = None
    sex: str | None = None
    speed_m_s: float | None = None

    @property
    def has_body(self) -> bool:
        return self.mass_kg is not None and self.height_m is not None

    @property
    def fit_id(self) -> str:
        parts = [self.subject_id, self.condition, self.kind]
        return safe_name("_".join(p for p in parts if p))


def safe_name(text: str) -> str:
    """``text`` as a file name: runs of characters other than letters, digits, ``.``,
    ``-`` and ``_`` become ``-``."""
    return re.sub(r"[^A-Za-z0-9._-]+", "-", text).strip("-.") or "fit"


# -- reading a study ---------------------------------------------------------------------------
def _ids_from_name(path: Path) -> tuple[str, str]:
    """(subject id, condition) from a file name ``<subject>_<condition>[_sides].csv``."""
    stem = path.stem
    if stem.endswith("_sides"):
        stem = stem[: -len("_sides")]
    subject, _, condition = stem.partition("_")
    return subject, condition


def _curve_kind(path: Path) -> str:
    """"sides" when the file's header has per-side columns, else "symmetric"."""
    try:
        header = pd.read_csv(path, nrows=0).columns
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise GaitDataError(f"gait curve file {path}: cannot read its header: {exc}") from None
    return "sides" if is_per_side(header) else "symmetric"


def _is_study_table(path: Path) -> bool:
    try:
        header = [str(c).strip() for c in pd.read_csv(path, nrows=0).columns]
    except (OSError, ValueError, UnicodeDecodeError):
        return False
    return "file" in header


def _optional_number(value, what: str, where: str) -> float | None:
    if value is None or (isinstance(value, float) and math.isnan(value)) or \
            (isinstance(value, str) and not value.strip()):
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UsageError(f"{where}: {what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise UsageError(f"{where}: {what} must be a finite number > 0, got {value!r}")
    return v


def _sex(value, where: str) -> str | None:
    if value is None or (isinstance(value, float) and math.isnan(value)) or \
            not str(value).strip():
        return None
    sex = SEX_CODES.get(str(value).strip().lower())
    if sex is None:
        raise UsageError(f"{where}: sex must be F, M, female or male, got {value!r}")
    return sex


def check_body(entry: StudyEntry, where: str) -> None:
    """Raise :class:`UsageError` when the body data are partial or outside the table's
    adult range (de Leva 1996)."""
    if (entry.mass_kg is None) != (entry.height_m is None):
        raise UsageError(f"{where}: give both mass_kg and height_m (or neither) for "
                         f"subject {entry.subject_id}")
    if entry.has_body:
        lo, hi = MASS_RANGE_KG
        if not lo <= entry.mass_kg <= hi:
            raise UsageError(f"{where}: mass_kg {entry.mass_kg:g} of subject "
                             f"{entry.subject_id} outside {lo:g}..{hi:g} kg")
        lo, hi = HEIGHT_RANGE_M
        if not lo <= entry.height_m <= hi:
            raise UsageError(f"{where}: height_m {entry.height_m:g} of subject "
                             f"{entry.subject_id} outside {lo:g}..{hi:g} m")


def read_bodies(path: str | os.PathLike) -> dict[str, dict]:
    """A table of subjects' bodies (``subject_id``, ``mass_kg``, ``height_m``, optional
    ``sex``: F/M/female/male; e.g. ``data/anthropometry/subjects.csv``) as
    {subject_id: {mass_kg, height_m, sex}}."""
    path = Path(path)
    try:
        table = pd.read_csv(path, dtype={"subject_id": str})
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise UsageError(f"--bodies {path}: not a readable CSV table: {exc}") from None
    table.columns = [str(c).strip() for c in table.columns]
    missing = [c for c in ("subject_id", "mass_kg", "height_m") if c not in table.columns]
    if missing:
        raise UsageError(f"--bodies {path}: missing column(s) {', '.join(missing)} "
                         f"(needs subject_id, mass_kg, height_m; sex optional)")
    out = {}
    for i, r in table.iterrows():
        where = f"--bodies {path} row {i + 2}"
        sid = str(r["subject_id"]).strip()
        if sid in out:
            raise UsageError(f"{where}: subject {sid} listed twice")
        out[sid] = {"mass_kg": _optional_number(r["mass_kg"], "mass_kg", where),
                    "height_m": _optional_number(r["height_m"], "height_m", where),
                    "sex": _sex(r.get("sex"), where)}
    return out


def _table_entries(path: Path) -> list[StudyEntry]:
    """The entries of a study table (:data:`TABLE_COLUMNS`; files relative to the table)."""
    table = pd.read_csv(path, dtype=str, keep_default_na=False)
    table.columns = [str(c).strip() for c in table.columns]
    unknown = [c for c in table.columns if c not in TABLE_COLUMNS]
    if unknown:
        raise UsageError(f"study table {path}: unknown column(s) {', '.join(unknown)}; "
                         f"known: {', '.join(TABLE_COLUMNS)}")
    if table.empty:
        raise UsageError(f"study table {path}: no rows")
    entries = []
    for i, r in table.iterrows():
        where = f"study table {path} row {i + 2}"
        name = r["file"].strip()
        if not name:
            raise UsageError(f"{where}: empty file")
        f = Path(name) if Path(name).is_absolute() else path.parent / name
        if not f.is_file():
            raise UsageError(f"{where}: curve file {f} not found")
        subject, condition = _ids_from_name(f)
        sid = r.get("subject_id", "").strip() or subject
        cond = r.get("condition", "").strip() if "condition" in table.columns else condition
        entries.append(StudyEntry(
            str(f.resolve()), sid, cond, _curve_kind(f),
            _optional_number(r.get("mass_kg"), "mass_kg", where),
            _optional_number(r.get("height_m"), "height_m", where),
            _sex(r.get("sex"), where),
            _optional_number(r.get("speed_m_s"), "speed_m_s", where)))
        check_body(entries[-1], where)
    return entries


def _expand(source: str) -> list[Path]:
    """The curve files or study tables a source names: a file, a directory (its ``*.csv``)
    or a glob pattern."""
    p = Path(source)
    if p.is_dir():
        files = sorted(q for q in p.glob("*.csv") if q.is_file())
        if not files:
            raise UsageError(f"{source}: a directory without .csv files")
        return files
    if p.is_file():
        return [p]
    if glob.has_magic(source):
        files = sorted(Path(q) for q in glob.glob(source) if Path(q).is_file())
        if not files:
            raise UsageError(f"{source}: the pattern matches no file")
        return files
    raise UsageError(f"{source}: no such file, directory or pattern")


def read_study(sources: Sequence[str], kind: str = "auto",
               bodies: dict[str, dict] | None = None) -> tuple[list[StudyEntry], list[str]]:
    """The study's entries from ``sources`` (curve files, directories, glob patterns, study
    tables), those of ``kind`` (:data:`KINDS`), with body data from ``bodies``
    (:func:`read_bodies`) for subjects the study table gives none; and the files left out
    (another kind). Subject id and condition come from a study table's columns, else from
    the file name ``<subject>_<condition>[_sides].csv``. Every curve file is read and
    checked here (nothing runs on a file that does not load)."""
    if kind not in KINDS:
        raise UsageError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    if not sources:
        raise UsageError("no study: give curve files, directories, glob patterns or a "
                         "study table")
    entries: list[StudyEntry] = []
    for source in sources:
        for path in _expand(source):
            if _is_study_table(path):
                entries += _table_entries(path)
            else:
                subject, condition = _ids_from_name(path)
                entries.append(StudyEntry(str(path.resolve()), subject, condition,
                                          _curve_kind(path)))
    for e in entries:
        load_gait_file(e.gait_file)  # GaitDataError names the file and the defect
    if bodies:
        entries = [e if e.has_body or e.subject_id not in bodies else
                   dataclasses.replace(e, **{k: v for k, v in bodies[e.subject_id].items()
                                             if getattr(e, k) is None})
                   for e in entries]
        for e in entries:
            check_body(e, f"subject {e.subject_id}")
    left_out = [e.gait_file for e in entries if kind != "auto" and e.kind != kind]
    entries = [e for e in entries if kind == "auto" or e.kind == kind]
    if not entries:
        raise UsageError(f"no {kind} curve file in the study ({len(left_out)} of another "
                         f"kind: {', '.join(Path(f).name for f in left_out[:4])}"
                         f"{', ...' if len(left_out) > 4 else ''})")
    seen: dict[str, str] = {}
    for e in entries:
        if e.fit_id in seen and seen[e.fit_id] != e.gait_file:
            raise UsageError(f"two curve files make the same fit {e.fit_id}: "
                             f"{seen[e.fit_id]} and {e.gait_file}; give subject_id and "
                             f"condition in a study table")
        seen[e.fit_id] = e.gait_file
    unique = list({e.fit_id: e for e in entries}.values())  # a file named twice: one fit
    return unique, left_out


# -- the tasks -----------------------------------------------------------------------------
@dataclass(frozen=True)
class BodyTask:
    """Scale ``reference`` to one subject (see :func:`run_body_task`)."""

    subject_id: str
    mass_kg: float
    height_m: float
    sex: str
    reference: Problem
    max_radius: float

    def fingerprint(self) -> str:
        return _digest({"task": "body", "subject": self.subject_id, "mass_kg": self.mass_kg,
                        "height_m": self.height_m, "sex": self.sex,
                        "reference": self.reference.to_dict(), "max_radius": self.max_radius,
                        "version": __version__})


@dataclass(frozen=True)
class FitTask:
    """One fit: the entry, the walker it runs on (the subject's body or the reference),
    the options and the fingerprint of everything the outcome depends on."""

    entry: StudyEntry
    problem: Problem
    options: FitOptions
    body: str
    fingerprint: str


def _digest(obj) -> str:
    text = json.dumps(jsonable(obj), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _file_digest(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


#: the settings of a symmetric fit (those of :class:`~pdw_casadi.fit.FitOptions` but the
#: per-leg fit's ``side`` and ``start``)
FIT_FIELDS = tuple(f.name for f in dataclasses.fields(FitOptions)
                   if f.name not in PER_LEG_FIELDS)


def symmetric_options(opts: FitOptions) -> FitOptions:
    """The symmetric fit's part of ``opts`` (the per-leg fields at their defaults)."""
    return FitOptions(**{k: getattr(opts, k) for k in FIT_FIELDS})


def _option_values(opts: FitOptions) -> dict:
    """The options a fit's outcome depends on (not its logging)."""
    d = dataclasses.asdict(opts)
    for k in ("verbose", "log_file"):
        d.pop(k, None)
    return d


def fit_fingerprint(entry: StudyEntry, problem: Problem, opts: FitOptions, body: str) -> str:
    """What a fit's outcome depends on, hashed: the curve file's bytes, the entry, the
    walker, the options and the toolkit's version."""
    options = _option_values(opts)
    if entry.kind != "sides":  # the per-leg settings do not change a symmetric fit
        options = {k: v for k, v in options.items() if k in FIT_FIELDS}
    return _digest({"task": "fit", "entry": dataclasses.asdict(entry),
                    "file": _file_digest(entry.gait_file), "problem": problem.to_dict(),
                    "options": options, "body": body, "version": __version__})


@contextlib.contextmanager
def interrupts_noted():
    """Note a Ctrl-C (SIGINT) that arrives inside the block; yields a function that says
    whether one did. IPOPT under CasADi turns a Ctrl-C into a failed solve
    (``NonIpopt_Exception_Thrown``) instead of an exception, so without this an interrupted
    fit would come back as a complete "failed" result and a resumed run would skip it. The
    handler still calls the one it replaces (Python's raises KeyboardInterrupt). Where
    Ctrl-C is ignored (the pool's workers: the parent stops them) or off the main thread (a
    Dask worker's task) nothing is installed."""
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield lambda: False
        return
    hit: list[bool] = []

    def handler(signum, frame):
        hit.append(True)
        previous(signum, frame)

    signal.signal(signal.SIGINT, handler)
    try:
        yield lambda: bool(hit)
    finally:
        signal.signal(signal.SIGINT, previous)


def run_body_task(task: BodyTask) -> dict:
    """The subject's walker with a stable gait, as a JSON-ready record (``problem``: the
    problem as a dict, with the gait as its initial state; ``status`` "accepted" or
    "failed" with ``reason``)."""
    t0 = time.perf_counter()
    rec = {"subject_id": task.subject_id, "fingerprint": task.fingerprint(),
           "mass_kg": task.mass_kg, "height_m": task.height_m, "sex": task.sex}
    with interrupts_noted() as interrupted:
        try:
            res = stable_subject_walker(task.mass_kg, task.height_m, task.sex,
                                        task.reference, max_radius=task.max_radius)
        except Exception as exc:  # a failed body is a row with its reason, not a lost study
            res = exc
    if interrupted():  # never saved as this subject's outcome: the next run redoes it
        raise KeyboardInterrupt
    if isinstance(res, Exception):
        rec.update(status="failed", reason=_reason(res), wall_time_s=time.perf_counter() - t0)
        return rec
    rec.update(res.record())
    rec["problem"] = None if res.problem is None else problem_toml(
        res.problem, f"# the walker of subject {task.subject_id} ({task.mass_kg:g} kg, "
        f"{task.height_m:g} m, {task.sex}), written by pdw-cohort\n")
    rec["wall_time_s"] = time.perf_counter() - t0
    return rec


def _reason(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:500]


def compliance_column(name: str, side: str | None = None) -> str:
    """``k_knee`` -> ``k_knee_N_m_per_rad`` (``k_knee_left_...`` with a side)."""
    unit = next((u for p, u in COMPLIANCE_PREFIXES if name.startswith(p)), None)
    base = name if side is None else f"{name}_{side}"
    return base if unit is None else f"{base}_" + unit.replace(" ", "_").replace("/", "_per_")


def _fit_outcome(res, score) -> tuple:
    """(the fit's accepted candidate, else its best by ``score``, or None; whether it was
    accepted; the row's solver columns) of a fit result (either kind)."""
    cand, accepted = res.best, res.best is not None
    if cand is None and res.candidates:
        cand = max(res.candidates, key=score)
    # the status of the solve the row's gait came from: a later round may stop short while
    # the gait kept is an earlier round's converged answer
    last = res.solves[-1].status if res.solves else None
    status = cand.solver_status if cand is not None and cand.solver_status else last
    row: dict = {"solver_status": status,
                 "iterations": int(sum(s.iterations for s in res.solves)),
                 "solves": len(res.solves)}
    return cand, accepted, row


def _fit_rows_symmetric(problem: Problem, human: GaitCurves, opts: FitOptions):
    res = fit_gait(problem, human, opts, log=lambda m: None)
    cand, accepted, row = _fit_outcome(res, lambda c: c.mean_score(res.targets))
    if cand is None:
        row.update(status="failed", reason="; ".join(res.notes) or "every start failed")
        return row, None
    fp = cand.fixed_point
    comp, slope = problem.split_parameters(cand.parameters)
    row.update({f"r2_{t}": cand.scores.get(f"r2_{t}") for t in ("knee", "hip", "thigh")})
    row.update({compliance_column(k): v for k, v in comp.items()})
    row.update(slope_rad=slope, spectral_radius=fp.spectral_radius,
               stride_spectral_radius=fp.spectral_radius ** 2,
               stable=bool(cand.stable),
               valid=bool(cand.valid), certified=bool(cand.certified),
               resimulation_deviation=cand.resimulation_deviation,
               step_time_s=fp.step_time_s, step_length_m=fp.step_length_m,
               speed_m_s=fp.step_length_m / fp.step_time_s)
    timing = fixed_point_timing(problem, cand.state, cand.parameters)
    if timing is not None:
        row.update(stance_pct=timing.stance_pct,
                   double_support_pct=timing.double_support_total_pct)
    row.update(status="accepted" if accepted else "rejected",
               reason="" if accepted else _rejection(row, opts, fp.failure))
    return row, cand.curves


def _rejection(row: dict, opts: FitOptions, failure) -> str:
    """Why a fit's row was not accepted: its per-step radius above ``opts.max_radius``,
    invalid, or re-simulated off its NLP answer (by more than ``opts.resim_tol``)."""
    max_radius = opts.max_radius
    why = []
    if row["spectral_radius"] > max_radius or not row["stable"]:
        why.append(f"spectral radius {row['spectral_radius']:.4f} > {max_radius:g}")
    if not row["valid"]:
        why.append("invalid" + (f" ({failure})" if failure else "")
                   + (f", re-simulation deviation {row['resimulation_deviation']:.2e}"
                      if not row["resimulation_deviation"] < opts.resim_tol else ""))
    return "; ".join(why) or "not accepted"


def _fit_rows_sides(problem: Problem, sides: SideCurves, opts: FitOptions):
    res = fit_gait(problem, sides, opts, log=lambda m: None)
    cand, accepted, row = _fit_outcome(res, lambda c: c.mean_score(res.targets))
    if cand is None:
        row.update(status="failed", reason="; ".join(res.notes) or "the stride solve failed")
        return row, None
    fp, rep = cand.fixed_point, cand.report
    names = list(stride_map(problem).parameter_names)
    for t in ("knee", "hip", "thigh"):
        vals = [cand.scores[s].get(f"r2_{t}") for s in SIDES]
        for s, v in zip(SIDES, vals, strict=True):
            row[f"r2_{t}_{s}"] = v
        row[f"r2_{t}"] = float(np.mean(vals)) if None not in vals else None
    for s in SIDES:
        for k in problem.compliance_names:
            row[compliance_column(k, s)] = float(cand.parameters[names.index(f"{s}.{k}")])
    legs = rep["legs"]
    row.update(slope_rad=float(cand.parameters[names.index("slope")]),
               spectral_radius=math.sqrt(fp.spectral_radius),
               stride_spectral_radius=fp.spectral_radius,
               stable=bool(cand.stable), valid=bool(cand.valid), certified=bool(cand.certified),
               resimulation_deviation=cand.resimulation_deviation,
               step_time_s=float(np.mean([legs[s]["step_time_s"] for s in SIDES])),
               step_length_m=float(np.mean([legs[s]["step_length_m"] for s in SIDES])),
               speed_m_s=rep["speed_m_s"],
               stance_pct=float(np.mean([legs[s]["stance_pct"] for s in SIDES])),
               double_support_pct=rep["double_support_pct"],
               step_length_asymmetry_pct=rep["step_length_asymmetry_pct"],
               step_time_asymmetry_pct=rep["step_time_asymmetry_pct"])
    row.update(status="accepted" if accepted else "rejected",
               reason="" if accepted else _rejection(row, opts, fp.failure))
    curves = pd.concat([rep["curves"][s].add_suffix(f"_{s}") for s in SIDES], axis=1)
    return row, curves


def _id_row(entry: StudyEntry, body: str) -> dict:
    return {"fit_id": entry.fit_id, "subject_id": entry.subject_id,
            "condition": entry.condition, "kind": entry.kind, "side": None, "body": body,
            "mass_kg": entry.mass_kg, "height_m": entry.height_m, "sex": entry.sex,
            "human_speed_m_s": entry.speed_m_s, "gait_file": Path(entry.gait_file).name}


def run_fit_task(task: FitTask) -> dict:
    """Run one fit and return its record: ``row`` (the table row), ``curves`` (the fitted
    gait cycle, or None), ``fingerprint``. Never raises for a fit that fails: the row says
    ``failed`` and why (Ctrl-C and a killed process still stop it)."""
    t0, c0 = time.perf_counter(), time.process_time()
    e = task.entry
    row = _id_row(e, task.body)
    if e.kind == "sides":
        row["side"] = task.options.side
    with tempfile.TemporaryDirectory(prefix="pdw_cohort_") as tmp:
        log = Path(tmp) / LOG_FILE
        with interrupts_noted() as interrupted:
            fit_row, curves, error = _fit_entry(
                dataclasses.replace(task, options=dataclasses.replace(task.options,
                                                                      log_file=str(log))))
        if interrupted():  # an interrupted fit is never saved: the next run redoes it
            raise KeyboardInterrupt
        log_text = log.read_text(errors="replace") if log.is_file() else ""
    if error is not None:
        row.update(status="failed", reason=error)
    else:
        row.update(fit_row)
    row["wall_time_s"] = time.perf_counter() - t0
    row["cpu_time_s"] = time.process_time() - c0
    return {"fit_id": e.fit_id, "fingerprint": task.fingerprint, "row": jsonable(row),
            "curves": None if curves is None else jsonable(
                {c: curves[c].to_numpy() for c in curves.columns}),
            "ipopt_log": log_text}


def _fit_entry(task: FitTask):
    """(row of the fit's results, its curves, None) or (None, None, the reason it failed)."""
    e = task.entry
    try:
        human = load_gait_file(e.gait_file)
        if e.kind == "sides":
            if not isinstance(human, SideCurves):
                raise GaitDataError(f"{e.gait_file}: no per-side columns")
            fit_row, curves = _fit_rows_sides(task.problem, human, task.options)
        else:
            if isinstance(human, SideCurves):
                human = human.mean()
            fit_row, curves = _fit_rows_symmetric(task.problem, human,
                                                  symmetric_options(task.options))
    except Exception as exc:  # a failed fit is a row with its reason, not a lost study
        return None, None, _reason(exc)
    return fit_row, curves, None


# -- saving and resuming -------------------------------------------------------------------
def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that ``path`` is either the old file or the whole new
    one (a temporary file in the same directory renamed over it), never a part."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def save_fit(out: Path, record: dict) -> Path:
    """Save a fit's record: ``fits/<fit_id>/curves.csv`` (when it has curves) and
    ``ipopt.log`` (IPOPT's log of its solves, when it ran any) first, then ``result.json``
    (the mark of a complete fit)."""
    d = Path(out) / "fits" / record["fit_id"]
    d.mkdir(parents=True, exist_ok=True)
    if record.get("curves") is not None:
        write_atomic(d / CURVES_FILE, pd.DataFrame(record["curves"]).to_csv(index=False))
    if record.get("ipopt_log"):
        write_atomic(d / LOG_FILE, record["ipopt_log"])
    stored = {k: v for k, v in record.items() if k not in ("curves", "ipopt_log")}
    stored["has_curves"] = record.get("curves") is not None
    write_atomic(d / RESULT_FILE, json.dumps(stored, indent=1, allow_nan=False) + "\n")
    return d / RESULT_FILE


def load_complete(path: Path, fingerprint: str) -> dict | None:
    """The saved record at ``path`` if it is complete and of the same inputs, else None."""
    try:
        rec = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or rec.get("fingerprint") != fingerprint:
        return None
    if rec.get("has_curves") and not (Path(path).parent / CURVES_FILE).is_file():
        return None
    return rec


def body_problem(rec: dict) -> Problem:
    """The walker of a body record (its ``problem``: the problem file's TOML text)."""
    name = f"subject_{safe_name(rec['subject_id'])}"
    return problem_from_dict(tomllib.loads(rec["problem"]), name=name)


def _body_path(out: Path, subject_id: str) -> Path:
    return Path(out) / "bodies" / f"{safe_name(subject_id)}.json"


def _fit_path(out: Path, fit_id: str) -> Path:
    return Path(out) / "fits" / fit_id / RESULT_FILE


# -- the plan and the run ------------------------------------------------------------------
@dataclass
class CohortPlan:
    """What a run does: the study's entries, the reference walker, the body tasks (one per
    subject with body data, on the "own" body) and the options."""

    entries: list[StudyEntry]
    reference: Problem
    options: CohortOptions
    bodies: dict[str, BodyTask]

    @property
    def n_fits(self) -> int:
        return len(self.entries)


def check_walker(reference: Problem, entries: Sequence[StudyEntry], options: CohortOptions
                 ) -> None:
    """Raise :class:`UsageError` when the walker cannot run the study's fits."""
    if reference.asymmetric:
        raise UsageError(f"{reference.name}: a cohort starts from a walker whose legs are "
                         f"alike")
    faces = walker_faces(reference)
    if not faces.has_gait_curves:
        raise UsageError(f"{reference.name} ({reference.family}) has no knee and hip curves "
                         f"to fit")
    if not reference.compliance and not options.fit.free_slope:
        raise UsageError(f"{reference.name} ({reference.family}) has no compliance values "
                         f"to fit; fit the slope (free_slope)")
    if any(e.kind == "sides" for e in entries):
        if not reference.compliance:
            raise UsageError(f"{reference.name} has no compliance values to fit per leg")
        try:
            stride_map(reference)
        except ProblemError as exc:
            raise UsageError(f"per-side fits: {exc}") from None
    fit_opts = symmetric_options(options.fit)
    for e in entries:
        human = load_gait_file(e.gait_file)
        try:
            if isinstance(human, SideCurves) and e.kind == "sides":
                check_stride_targets(reference, human, options.fit)
            else:
                check_targets(reference, human.mean() if isinstance(human, SideCurves)
                              else human, fit_opts)
        except ValueError as exc:
            raise UsageError(f"{Path(e.gait_file).name}: {exc}") from None
    if options.body == "own" and any(e.has_body for e in entries):
        try:
            check_scalable(reference)
        except ProblemError as exc:
            raise UsageError(f"{exc}; fit on the reference body instead (body 'paper')") \
                from None


def plan_cohort(entries: Sequence[StudyEntry], options: CohortOptions | None = None,
                reference: Problem | None = None) -> CohortPlan:
    """Check the study against the walker and the options; the plan (nothing runs).
    ``reference``: the walker (default: ``options.problem`` loaded)."""
    options = options or CohortOptions()
    reference = reference if reference is not None else load_problem(options.problem)
    check_walker(reference, entries, options)
    bodies: dict[str, BodyTask] = {}
    if options.body == "own":
        for e in entries:
            if not e.has_body:
                continue
            task = BodyTask(e.subject_id, float(e.mass_kg), float(e.height_m),
                            e.sex or "female", reference, options.body_max_radius)
            old = bodies.setdefault(e.subject_id, task)
            if (old.mass_kg, old.height_m, old.sex) != (task.mass_kg, task.height_m,
                                                        task.sex):
                raise UsageError(f"subject {e.subject_id} has two bodies in the study: "
                                 f"{old.mass_kg:g} kg {old.height_m:g} m {old.sex} and "
                                 f"{task.mass_kg:g} kg {task.height_m:g} m {task.sex}")
    return CohortPlan(list(entries), reference, options, bodies)


@dataclass
class Progress:
    """What a run reports as it goes: called with (event, fit_id or subject id, record)
    for each "skip" (already complete), "done" and body ("body") outcome."""

    callback: Callable[[str, str, dict], None] | None = None

    def __call__(self, event: str, key: str, rec: dict) -> None:
        if self.callback is not None:
            self.callback(event, key, rec)


def run_bodies(plan: CohortPlan, out: Path, workers: int = 1, scheduler: str | None = None,
               progress: Progress | None = None) -> dict[str, dict]:
    """Build (or load, when complete) the walker of each subject of ``plan.bodies``; their
    records by subject id."""
    progress = progress or Progress()
    records: dict[str, dict] = {}
    todo = []
    for sid, task in plan.bodies.items():
        rec = load_complete(_body_path(out, sid), task.fingerprint())
        if rec is None:
            todo.append(task)
        else:
            records[sid] = rec
            progress("body-skip", sid, rec)
    for rec in map_tasks(run_body_task, todo, workers=workers, scheduler=scheduler,
                         ordered=False):
        if rec.get("problem"):  # the walker as a problem file (pdw-fit --problem FILE)
            write_atomic(_body_path(out, rec["subject_id"]).with_suffix(".toml"),
                         rec["problem"])
        write_atomic(_body_path(out, rec["subject_id"]),
                     json.dumps(jsonable(rec), indent=1, allow_nan=False) + "\n")
        records[rec["subject_id"]] = rec
        progress("body", rec["subject_id"], rec)
    return records


def fit_tasks(plan: CohortPlan, bodies: dict[str, dict]) -> tuple[list[FitTask], dict]:
    """The fit tasks of the plan, and the rows of fits that cannot run (their subject's
    body could not be built) by fit id."""
    tasks, blocked = [], {}
    for e in plan.entries:
        problem, body = plan.reference, "paper"
        if plan.options.body == "own" and e.has_body:
            rec = bodies.get(e.subject_id)
            body = "own"
            if rec is None or rec.get("status") != "accepted" or rec.get("problem") is None:
                reason = "no record" if rec is None else rec.get("reason", "")
                row = _id_row(e, body)
                row.update(status="failed", reason=f"the subject's body: {reason}",
                           wall_time_s=0.0)
                if e.kind == "sides":
                    row["side"] = plan.options.fit.side
                blocked[e.fit_id] = jsonable(row)
                continue
            problem = body_problem(rec)
        fp = fit_fingerprint(e, problem, plan.options.fit, body)
        tasks.append(FitTask(e, problem, plan.options.fit, body, fp))
    return tasks, blocked


def run_cohort(plan: CohortPlan, out: Path, workers: int = 1, scheduler: str | None = None,
               progress: Progress | None = None,
               fit_fn: Callable[[FitTask], dict] = run_fit_task,
               table_dir: Path | None = None) -> pd.DataFrame:
    """Run the plan into directory ``out``: the bodies, then every fit not yet complete
    there (as each ends its record is saved), then the table (:func:`cohort_table`) from
    the saved records, written as ``cohort.csv`` (and ``cohort.parquet`` with pyarrow)
    into ``table_dir`` (default ``out``; the command writes it into its staging folder,
    moved into place when the run completes, while the saved fits stay in ``out`` whatever
    happens). ``fit_fn``: the function of one :class:`FitTask` (module level, picklable;
    tests inject a fake one)."""
    out = Path(out)
    progress = progress or Progress()
    bodies = run_bodies(plan, out, workers, scheduler, progress)
    tasks, blocked = fit_tasks(plan, bodies)
    todo = []
    for t in tasks:
        rec = load_complete(_fit_path(out, t.entry.fit_id), t.fingerprint)
        if rec is None:
            todo.append(t)
        else:
            progress("skip", t.entry.fit_id, rec)
    for fit_id, row in blocked.items():
        rec = {"fit_id": fit_id, "fingerprint": "blocked", "row": row, "curves": None}
        save_fit(out, rec)
        progress("done", fit_id, rec)
    for rec in map_tasks(fit_fn, todo, workers=workers, scheduler=scheduler, ordered=False):
        save_fit(out, rec)
        progress("done", rec["fit_id"], rec)
    table = cohort_table(plan, out)
    write_table(table, Path(table_dir) if table_dir is not None else out)
    return table


def cohort_table(plan: CohortPlan, out: Path) -> pd.DataFrame:
    """The table of the plan's fits, from their saved records, in the study's order."""
    rows = []
    for e in plan.entries:
        path = _fit_path(out, e.fit_id)
        try:
            rec = json.loads(path.read_text())
        except (OSError, ValueError):
            row = _id_row(e, "own" if plan.options.body == "own" and e.has_body else
                          "paper")
            row.update(status="failed", reason="no result (the fit did not complete)")
            rows.append(row)
            continue
        rows.append(rec["row"])
    return tidy(pd.DataFrame(rows))


#: the table's columns after the ids, in order (those a study has; compliance columns next)
RESULT_ORDER = ("status", "reason", "r2_knee", "r2_hip", "r2_thigh", "r2_knee_left",
                "r2_knee_right", "r2_hip_left", "r2_hip_right", "r2_thigh_left",
                "r2_thigh_right")
TAIL_ORDER = ("slope_rad", "spectral_radius", "stride_spectral_radius", "stable", "valid",
              "certified", "resimulation_deviation", "step_time_s", "step_length_m", "speed_m_s",
              "stance_pct", "double_support_pct", "step_length_asymmetry_pct",
              "step_time_asymmetry_pct", "solver_status", "iterations", "solves",
              "wall_time_s", "cpu_time_s")


def tidy(table: pd.DataFrame) -> pd.DataFrame:
    """The table's columns in their fixed order (ids, status, R^2, compliance, the rest)."""
    table = table.copy()
    for c in (*ID_COLUMNS, "status", "reason"):
        if c not in table.columns:
            table[c] = None
    cols = list(table.columns)
    head = [c for c in (*ID_COLUMNS, *RESULT_ORDER) if c in cols]
    tail = [c for c in TAIL_ORDER if c in cols]
    middle = sorted(c for c in cols if c not in head and c not in tail)
    return table[[*head, *middle, *tail]].reset_index(drop=True)


def write_table(table: pd.DataFrame, out: Path) -> list[Path]:
    """``cohort.csv`` and, when pyarrow is installed, ``cohort.parquet``; the paths."""
    out = Path(out)
    paths = [out / "cohort.csv"]
    write_atomic(paths[0], table.to_csv(index=False))
    with contextlib.suppress(ImportError):
        # deferred: pyarrow is optional (not a dependency); without it no parquet file
        import pyarrow  # noqa: F401

        tmp = out / ".cohort.parquet.tmp"
        table.to_parquet(tmp, index=False)
        os.replace(tmp, out / "cohort.parquet")
        paths.append(out / "cohort.parquet")
    return paths


def result_columns(table: pd.DataFrame) -> list[str]:
    """The columns of the fits' results (all but :data:`RUN_COLUMNS`): what two runs of the
    same study agree on bit for bit."""
    return [c for c in table.columns if c not in RUN_COLUMNS]


def count_status(records: Iterable[dict]) -> dict[str, int]:
    counts = dict.fromkeys(STATUSES, 0)
    for rec in records:
        counts[rec["row"].get("status", "failed")] += 1
    return counts
