"""The walker comparison of ``pdw-compare``: one gait fitted by several walkers, one table.

The question it was built for (the ankle-extension study, ``docs/results/timing.md``):
which passive ankle element gives the 6-link walker humanlike double support, judged by
the fit. :func:`run_compare` fits the curve file of a :class:`CompareRequest` with every
walker it names (with and/or without the timing target), each fit by a runner the caller
gives (``pdw-compare`` runs ``pdw-fit`` as a process of its own per fit, into
``OUT/<walker>[_timing]``); a fit already on disk is read, not run again (unless
``rerun``). :func:`compare_rows` reads the fits' ``summary.json`` into one row each
(:func:`compare_row`): double support of each period, stance, heel off and toe off (% of
the gait cycle; heel off is 50 % where the stance heel lifts at the other heel's strike,
earlier only with a forefoot rocker), cadence (steps/min), speed (m/s), knee/hip/thigh
R^2, the spectral radius, whether the gait is stable and valid, the phase durations (ms),
the tightest validity margins (what binds: margin minus its required minimum, in the
margin's unit) and the compliance. The table is rendered by
:mod:`pdw_casadi.report.compare_report`.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pdw_casadi.engine.errors import ProblemError
from pdw_casadi.gait.fixed_point import validity_slacks
from pdw_casadi.model.problem import load_problem

#: the ankle-extension study's walkers: the paper's walker, each passive ankle element on
#: its own, all three, the forefoot rocker and the rolling feet (docs/results/timing.md)
ANKLE_STUDY = ("humanlike_6link", "humanlike_6link_ankle_load",
               "humanlike_6link_ankle_quasistiff", "humanlike_6link_ankle_clutch",
               "humanlike_6link_ankle", "humanlike_6link_heeloff", "humanlike_6link_arc")
#: the folder suffix of a fit with the timing target
TIMING_SUFFIX = "_timing"


def walker_label(problem: str) -> str:
    """The folder name of a walker's fits: a bundled problem's name, or a problem file's
    stem (``problems/x.toml`` -> ``x``)."""
    path = Path(problem)
    return path.stem if path.suffix.lower() == ".toml" or len(path.parts) > 1 else problem


@dataclass(frozen=True)
class CompareFit:
    """One fit of a comparison: its folder name ``label``, its ``problem`` (name or path,
    as given) and whether it has the timing target (``timing``)."""

    label: str
    problem: str
    timing: bool


@dataclass(frozen=True)
class CompareRequest:
    """What :func:`run_compare` compares: the curve file ``gait`` fitted by every walker
    of ``problems`` (names or problem files) without the timing target, with it too
    (``timing``) or with it only (``only_timing``), each fit with ``rounds`` NLP rounds of
    at most ``max_iter`` IPOPT iterations; ``rerun``: fit again where a fit is on disk;
    ``table_only``: fit nothing, tabulate the fits on disk."""

    gait: str = "female_fast.csv"
    problems: tuple[str, ...] = field(default=ANKLE_STUDY)
    timing: bool = False
    only_timing: bool = False
    rerun: bool = False
    table_only: bool = False
    rounds: int = 2
    max_iter: int = 300

    def fits(self) -> list[CompareFit]:
        """The fits in order: per walker without, then with the timing target."""
        kinds = (True,) if self.only_timing else (False, True) if self.timing else (False,)
        return [CompareFit(walker_label(p) + (TIMING_SUFFIX if t else ""), p, t)
                for p in self.problems for t in kinds]


def check_compare(request: CompareRequest) -> None:
    """Raise :class:`~pdw_casadi.engine.errors.ProblemError` unless every walker of
    ``request`` loads and no two fits share a folder."""
    seen: dict[str, str] = {}
    for fit in request.fits():
        load_problem(fit.problem)
        if fit.label in seen and seen[fit.label] != fit.problem:
            raise ProblemError(f"{seen[fit.label]} and {fit.problem} would share the folder "
                               f"{fit.label}: give one of them another file name")
        if fit.label in seen:
            raise ProblemError(f"{fit.problem} is named twice")
        seen[fit.label] = fit.problem


def binding_margins(summary: dict, problem: str, n: int = 2) -> str:
    """The ``n`` smallest validity slacks of a fit (margin minus its required minimum, in
    the margin's unit: N, m or N s), as ``"name value; ..."`` ('-' without margins)."""
    margins = summary.get("margins") or {}
    if not margins:
        return "-"
    slacks = validity_slacks(margins, load_problem(problem))
    return "; ".join(f"{k} {v:.3g}" for k, v in sorted(slacks.items(), key=lambda kv: kv[1])[:n])


def compare_row(fit: CompareFit, summary: dict) -> dict:
    """One row of the table from a fit's ``summary.json`` (the module docstring; column
    names carry their units: ``_pct`` % of the gait cycle, ``_steps_min``, ``_m_s``,
    ``phases_ms`` phase durations in ms)."""
    s = summary
    t = s.get("timing") or {}
    ds = t.get("double_support_pct") or [float("nan")] * 2
    return {"fit": fit.label, "double_support_pct": ds[0], "double_support_2_pct": ds[-1],
            "stance_pct": t.get("stance_pct"), "heel_off_pct": t.get("heel_off_pct"),
            "toe_off_pct": t.get("toe_off_pct"),
            "cadence_steps_min": t.get("cadence_steps_min"), "speed_m_s": t.get("speed_m_s"),
            "r2_knee": s.get("r2_knee"), "r2_hip": s.get("r2_hip"),
            "r2_thigh": s.get("r2_thigh"), "spectral_radius": s.get("spectral_radius"),
            "stable": s.get("stable"), "valid": s.get("valid"),
            "phases_ms": " ".join(f"{k} {1000 * v:.1f}" for k, v in
                                  (t.get("phase_durations_s") or {}).items()),
            "tightest margins": binding_margins(s, fit.problem),
            "compliance": json.dumps({k: round(v, 4) for k, v in
                                      (s.get("compliance") or {}).items()})}


def summary_path(out: Path, fit: CompareFit) -> Path:
    """Where a fit of the comparison in ``out`` keeps its summary."""
    return Path(out) / fit.label / "summary.json"


def compare_rows(request: CompareRequest, out: Path) -> list[dict]:
    """The rows of the fits of ``request`` found in ``out`` (:func:`compare_row`), in the
    request's order; a fit without a summary is left out. Raises
    :class:`~pdw_casadi.engine.errors.ProblemError` for a summary that is not JSON."""
    rows = []
    for fit in request.fits():
        path = summary_path(out, fit)
        if not path.is_file():
            continue
        try:
            summary = json.loads(path.read_text())
        except (ValueError, UnicodeDecodeError) as exc:
            raise ProblemError(f"{path}: not a fit summary: {exc}") from None
        rows.append(compare_row(fit, summary))
    return rows


@dataclass
class CompareRun:
    """A comparison: the ``rows`` of its table (:func:`compare_row`) and the fits run by
    this call (``ran``; the others were read from disk)."""

    request: CompareRequest
    rows: list[dict]
    ran: list[CompareFit]


def run_compare(request: CompareRequest, out: Path,
                fit: Callable[[CompareFit, Path], None]) -> CompareRun:
    """Fit as ``request`` asks into ``out`` and tabulate: ``fit(one, folder)`` fits
    ``one`` into ``folder`` (``out/<label>``; it writes ``summary.json`` there), called
    for every fit without a summary on disk (every fit with ``request.rerun``; none with
    ``request.table_only``)."""
    ran = []
    for one in request.fits():
        if request.table_only:
            break
        if request.rerun or not summary_path(out, one).exists():
            fit(one, Path(out) / one.label)
            ran.append(one)
    return CompareRun(request, compare_rows(request, out), ran)
