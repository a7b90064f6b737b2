"""The results pages' numbers that cheap commands reproduce, re-run and compared (issue 47).

Every measured figure on ``docs/results/*.md`` is printed with the command that reproduces
it. Most of those commands are long (fits of the corpus, benchmarks) or print wall times,
which no test can compare; the ones here are deterministic and take seconds: fixed points
and simulations of bundled problems, ``pdw-scale`` bodies, sweeps and seeds of the
rolling-foot and toe-foot walkers, and numbers computed from the bundled data files (the
corpus's spread, the R^2 of the problem file's own compliance, the shipped designs, the
atlas, the subjects' anthropometry) and the options' defaults the pages quote.

**The expected numbers are read from the pages themselves**: each check names a page and a
passage of it (a regular expression on the page's text with its whitespace collapsed, so
re-wrapping a paragraph does not matter; ``NUM`` stands for a printed number), runs the
command into a temporary directory (in this process, through the console script's
``COMMANDS`` entry) and asserts each number to the precision the page prints it with: a
number printed as 0.8709 must equal the value rounded to four decimals, one printed as
5.9e-12 the value to two significant digits. So the test fails when the page and the code
disagree, in either direction, and when a passage it names is reworded (then the case here
is updated with the page).

A page's prose that restates its own tables (the medians, totals, counts and ranges under
a corpus run's table, a study's changes in %) is checked against those tables, or against
the stored tables they print (``cohort.csv``, ``prosthetist/study.csv``), at the printed
digits; where a table's rounding leaves a figure open (a median half way between two rounded
times, a time printed 10.0 against "above 10 s") either side passes (``Checks.figure``,
``Checks.tally``).

Left out on purpose: wall and CPU times (but as a table restates them); anything from a
fit, a cohort, a design run or a benchmark (minutes each); numbers a page gives as history
("before ...", "measured before ..."). The toe-foot walker's two sampled scans (about 40
s each) and the heel-radius sweep (kept out of the default run to hold it within a minute)
are marked slow:
``pytest -m slow tests/test_results_pages.py``.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import io
import json
import math
import re
import statistics
import sys
import tomllib
from decimal import ROUND_HALF_DOWN, ROUND_HALF_EVEN, ROUND_HALF_UP, Decimal
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "docs" / "results"
DATA = ROOT / "data"
#: a number as the pages print it: 0.8709, -16.3, +23, 5.9e-12, 30
NUM = r"(?<![\w.])([-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?)"


# -- the pages ---------------------------------------------------------------------------------
@functools.cache
def page(name: str) -> str:
    """``docs/results/<name>``'s text, whitespace collapsed, the typographic minus as ``-``."""
    text = (RESULTS / name).read_text(encoding="utf-8").replace("\u2212", "-")
    return " ".join(text.split())


def find(name: str, pattern: str) -> re.Match:
    """The first match of ``pattern`` (``NUM``: a printed number) in page ``name``; fails
    when the page no longer has that passage."""
    m = re.search(pattern.replace("NUM", NUM), page(name))
    assert m, (f"docs/results/{name} no longer has the passage {pattern!r}: the page was "
               f"reworded; update this check with it")
    return m


def passage(name: str, pattern: str) -> tuple[str, ...]:
    """The groups of ``pattern``'s first match in page ``name`` (:func:`find`)."""
    return find(name, pattern).groups()


def table(name: str, header_has: str, nth: int = 0) -> list[dict[str, str]]:
    """The ``nth`` Markdown table of page ``name`` whose header row contains ``header_has``:
    one dict per row, keyed by the header's cells (cells stripped, ``−`` as ``-``)."""
    lines = (RESULTS / name).read_text(encoding="utf-8").replace("\u2212", "-").splitlines()
    found = []
    for i, line in enumerate(lines):
        if line.startswith("|") and header_has in line and i + 1 < len(lines) \
                and lines[i + 1].startswith("|---"):
            head = _cells(line)
            rows = []
            for row in lines[i + 2:]:
                if not row.startswith("|"):
                    break
                rows.append(dict(zip(head, _cells(row), strict=True)))
            found.append(rows)
    assert len(found) > nth, f"docs/results/{name} has no table with {header_has!r}"
    return found[nth]


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]


def as_printed(value: float, text: str) -> str:
    """``value`` written with the precision of the printed number ``text``: as many decimals,
    or as many significant digits when ``text`` is in e-notation."""
    m = re.fullmatch(r"[-+]?\d+(?:\.(\d+))?(?:e([-+]?\d+))?", text)
    assert m, f"not a number as the pages print them: {text!r}"
    decimals = len(m.group(1) or "")
    if m.group(2) is not None:
        mantissa, exponent = f"{value:.{decimals}e}".split("e")
        out = f"{mantissa}e{int(exponent)}"
    else:
        out = f"{value:.{decimals}f}"
    return out.lstrip("-") if float(out) == 0 else out


def canonical(text: str) -> str:
    """A printed number without its ``+`` sign and its exponent's leading zeros."""
    text = text.lstrip("+")
    if "e" in text:
        mantissa, exponent = text.split("e")
        return f"{mantissa}e{int(exponent)}"
    return text


class Checks:
    """Numbers of the pages against values, collected: every mismatch is reported at once."""

    #: (page, printed) of every number compared in this session (the coverage count)
    compared: list[tuple[str, str]] = []

    def __init__(self):
        self.failures: list[str] = []

    def number(self, name: str, printed: str, *values: float, what: str = "") -> None:
        """Each of ``values`` (one or more: e.g. both legs' asymmetry against one printed
        "both -0.90 %") must give ``printed`` at its printed precision."""
        self.compared.append((name, printed))
        for value in values:
            got = as_printed(float(value), canonical(printed))
            if got != canonical(printed):
                self.failures.append(f"docs/results/{name}: {what or 'a number'} printed "
                                     f"{printed}, the command gives {value!r} ({got})")

    def passage(self, name: str, pattern: str, *values) -> None:
        """The numbers of ``pattern``'s groups in page ``name`` against ``values`` (one per
        group; a tuple for several values that must all give that group's number)."""
        m = find(name, pattern)
        groups = m.groups()
        assert len(groups) == len(values), f"{pattern!r}: {len(groups)} groups, " \
                                           f"{len(values)} values"
        for k, (printed, value) in enumerate(zip(groups, values, strict=True)):
            vals = value if isinstance(value, tuple) else (value,)
            before = m.string[max(m.start(), m.start(k + 1) - 60):m.start(k + 1)]
            self.number(name, printed, *vals, what=f"number {k + 1} of \"...{before}\"")

    def figure(self, name: str, printed: str, value: Decimal, column: int | None = None,
               what: str = "") -> None:
        """A figure the page computes from its own table's printed numbers (a median, a
        maximum, a sum), ``value``, exact from those numbers, against ``printed``: at the
        printed decimals, an exact half rounded to even (a median of counts: 32.5 is printed
        32). ``column``: the decimals of the table's figures when they are rounded
        measurements (seconds, R²); then the comparison is at the coarser of the two
        precisions, and a value exactly half way (a median of two rounded times, 14.05)
        admits both neighbours, which only the unrounded run decides."""
        self.compared.append((name, printed))
        p = Decimal(canonical(printed))
        places = -p.as_tuple().exponent
        if column is not None:
            places = min(places, column)
        q = Decimal(1).scaleb(-places)
        modes = (ROUND_HALF_EVEN,) if column is None else (ROUND_HALF_UP, ROUND_HALF_DOWN)
        want = {value.quantize(q, m) for m in modes}
        got = {p.quantize(q, m) for m in (ROUND_HALF_UP, ROUND_HALF_DOWN)}
        if not want & got:
            self.failures.append(f"docs/results/{name}: {what or 'a figure'} printed {printed}, "
                                 f"its table gives {value}")

    def tally(self, name: str, printed: str, outcomes: list, what: str = "") -> None:
        """A count the page prints against one outcome per table row: True, False, or None
        when the row's printed digits do not decide it (a time printed 10.0 against "above
        10 s", a knee R² printed equal to Table 3's against "above"). ``printed`` must lie
        between the rows certainly counted and those possibly counted; exact when every row
        is decided."""
        self.compared.append((name, printed))
        sure = sum(o is True for o in outcomes)
        possible = sure + sum(o is None for o in outcomes)
        if not sure <= int(printed) <= possible:
            span = f"{sure}" if sure == possible else f"{sure} to {possible}"
            self.failures.append(f"docs/results/{name}: {what or 'a count'} printed {printed}, "
                                 f"its table gives {span}")

    def bound(self, name: str, printed: str, cells: list[str], what: str = "") -> None:
        """A bound the page states of a table column ("re-simulation < 5e-7"): no printed
        cell is certainly above it."""
        self.compared.append((name, printed))
        top = Decimal(canonical(printed))
        over = [c for c in cells if exceeds(span(c), (top, top)) is True]
        if over:
            self.failures.append(f"docs/results/{name}: {what or 'a bound'} printed {printed}, "
                                 f"its table has {over}")

    def truth(self, name: str, what: str, ok: bool) -> None:
        """A fact the page states in words (valid, stable, a failure's name)."""
        if not ok:
            self.failures.append(f"docs/results/{name}: {what}")

    def verify(self) -> None:
        assert not self.failures, "\n".join(self.failures)


def span(text: str) -> tuple[Decimal, Decimal]:
    """The values a printed number stands for: half a unit of its last digit either side."""
    v = Decimal(canonical(text))
    h = Decimal(1).scaleb(v.as_tuple().exponent) / 2
    return v - h, v + h


def plus(*spans: tuple[Decimal, Decimal]) -> tuple[Decimal, Decimal]:
    return sum(s[0] for s in spans), sum(s[1] for s in spans)


def exceeds(a: tuple[Decimal, Decimal], b: tuple[Decimal, Decimal]) -> bool | None:
    """Whether a value in span ``a`` is above one in span ``b`` (at or above: the same, but
    for a tie of measure zero); None when the spans overlap, the printed digits undecided."""
    if a[0] >= b[1]:
        return True
    if a[1] <= b[0]:
        return False
    return None


def within(cell: str, limit: float) -> bool | None:
    """A printed time at most ``limit`` (None: its digits do not decide)."""
    over = exceeds(span(cell), (Decimal(str(limit)),) * 2)
    return None if over is None else not over


def decimals(cells: list[str]) -> int:
    """The decimals the table prints a column's figures with."""
    places = {-Decimal(c).as_tuple().exponent for c in cells}
    assert len(places) == 1, f"a column printed with {places} decimals"
    return places.pop()


@pytest.fixture
def checks():
    """A :class:`Checks`; the test ends with ``checks.verify()``."""
    return Checks()


# -- the commands ------------------------------------------------------------------------------
def cli(command: str, *args) -> str:
    """``pdw-<command> args`` in this process (the console script's main, as the CLI tests
    run it); its stdout and stderr. Fails unless it exits 0."""
    from pdw_casadi.cli import COMMANDS

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = COMMANDS[command]([str(a) for a in args])
    text = out.getvalue() + err.getvalue()
    assert code == 0, f"pdw-{command} {' '.join(map(str, args))} exited {code}:\n{text[-3000:]}"
    return text


def read_json(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("results_pages")


@pytest.fixture(scope="module")
def fixed_point(workdir):
    """``pdw-fixed-point --problem P --out DIR``'s summary.json, once per problem."""
    done: dict[str, dict] = {}

    def run(problem: str | Path) -> dict:
        key = str(problem)
        if key not in done:
            out = workdir / f"fp_{len(done)}"
            cli("fixed-point", "--problem", problem, "--out", out)
            done[key] = read_json(out / "summary.json")
        return done[key]
    return run


@pytest.fixture(scope="module")
def female_fast_r2():
    """R^2 of a problem file's own gait on ``female_fast.csv`` (the fit's reference row:
    ``pdw_casadi.fit.result.reference_gait``), once per problem."""
    from pdw_casadi.fit.result import reference_gait
    from pdw_casadi.model.gait_data import load_gait_curves
    from pdw_casadi.model.problem import load_problem

    human = load_gait_curves(DATA / "female_fast.csv")
    done: dict[str, dict] = {}

    def scores(problem: str) -> dict:
        if problem not in done:
            done[problem] = reference_gait(load_problem(problem), human)
        return done[problem]
    return scores


def timing_of(summary: dict) -> dict:
    """Double support per period and stance (% of the cycle), phase durations (ms)."""
    t = summary["timing"]
    return {"double_support": t["double_support_pct"][0], "stance": t["stance_pct"],
            "heel_off": t["heel_off_pct"], "toe_off": t["toe_off_pct"],
            **{k: 1e3 * v for k, v in t["phase_durations_s"].items()}}


def numbers(cell: str) -> list[str]:
    """The printed numbers of a table cell, in order."""
    return re.findall(NUM, cell.replace("−", "-"))


# -- scaling.md, cohort.md: the subjects' bodies -----------------------------------------------
@pytest.fixture(scope="module")
def scaled_body(workdir, fixed_point):
    """``pdw-scale --mass 62.45 --height 1.695 --out w.toml``, then ``pdw-fixed-point
    --problem w.toml --out fp`` (scaling.md, cohort.md): (the written TOML, its fixed point,
    pdw-scale's output)."""
    out = workdir / "w.toml"
    text = cli("scale", "--mass", "62.45", "--height", "1.695", "--out", out)
    return tomllib.loads(out.read_text(encoding="utf-8")), fixed_point(out), text


def test_scaling_page_the_body_pdw_scale_writes(scaled_body, checks):
    """scaling.md and cohort.md: ``pdw-scale --mass 62.45 --height 1.695`` writes a stable,
    valid gait of spectral radius 0.8709 (pdw-fixed-point on the written file: 0 Newton
    iterations), on the de Leva body of that subject."""
    from pdw_casadi.studies.scaling import subject_anthropometry

    body, fp, text = scaled_body
    rho = fp["spectral_radius"]
    checks.passage("scaling.md", r"`pdw-scale --mass 62\.45 --height 1\.695 --out w\.toml` "
                   r"[\d.]+ s, spectral radius NUM, stable, valid", rho)
    checks.truth("scaling.md", "the scaled body's gait is stable and valid",
                 fp["stable"] and fp["valid"])
    checks.passage("cohort.md", r"`pdw-scale --mass 62\.45 --height 1\.695 --out w\.toml` "
                   r"takes the same route \([\d.]+ s; spectral radius NUM\) and "
                   r"`pdw-fixed-point --problem w\.toml --out fp` confirms it \(NUM Newton "
                   r"iterations, residual [\d.e-]+, stable, valid\)", rho, fp["iterations"])
    checks.truth("cohort.md", "pdw-fixed-point on w.toml: stable, valid",
                 fp["stable"] and fp["valid"])
    # what pdw-scale prints is the same figure
    printed = re.search(r"spectral radius ([\d.]+)", text).group(1)
    checks.number("scaling.md", printed, rho, what="pdw-scale's own line")
    # the written body: de Leva's for 62.45 kg, 1.695 m (female)
    mass, height = map(float, passage("scaling.md", r"`pdw-scale --mass NUM --height NUM "
                                      r"--out w\.toml` [\d.]+ s, spectral radius"))
    deleva = subject_anthropometry(mass, height, "female")
    anth = body["anthropometry"]
    checks.truth("scaling.md", f"w.toml's body is de Leva's for {mass} kg, {height} m",
                 all(math.isclose(anth[k], v, rel_tol=1e-12) for k, v in deleva.items()))
    checks.truth("scaling.md", "w.toml's body weighs the subject's mass",
                 math.isclose(anth["m_h"] + 2 * (anth["m_t"] + anth["m_s"] + anth["m_f"]),
                              mass, rel_tol=1e-12))
    checks.verify()


def test_cohort_page_every_female_body_is_one_scaled_walker(scaled_body, checks):
    """cohort.md: WBDS20's de Leva body is WBDS09's scaled by s = 1.695/1.691 in length and
    m = 62.45/61.25 in mass, to a relative difference of 7e-16 in every segment value: the
    body ``pdw-scale --mass 62.45 --height 1.695`` writes (WBDS20's; the shipped body,
    ``data/bodies/deleva_female.toml``, is WBDS09's, carried by the scaling law) against de
    Leva's table for WBDS20; the heights and masses are the subjects' of
    ``data/anthropometry/subjects.csv``."""
    from pdw_casadi.studies.scaling import (
        reference_height,
        reference_mass,
        shipped_body,
        subject_anthropometry,
    )

    subjects = pd.read_csv(DATA / "anthropometry" / "subjects.csv").set_index("subject_id")
    s20, s09 = subjects.loc["WBDS20"], subjects.loc["WBDS09"]
    written = scaled_body[0]["anthropometry"]
    target = subject_anthropometry(s20.mass_kg, s20.height_m, "female")
    rel = max(abs(written[k] - v) / abs(v) for k, v in target.items())
    checks.passage("cohort.md", r"WBDS20's body is WBDS09's scaled by s = NUM/NUM, m = NUM/NUM "
                   r"to a relative difference of NUM in every segment value", s20.height_m,
                   s09.height_m, s20.mass_kg, s09.mass_kg, rel)
    body = shipped_body("female")
    checks.truth("cohort.md", "the shipped female body is WBDS09's (61.25 kg, 1.691 m)",
                 math.isclose(reference_mass(body), s09.mass_kg, rel_tol=1e-12)
                 and math.isclose(reference_height(body, "female"), s09.height_m,
                                  rel_tol=1e-12))
    checks.verify()


def test_cohort_page_each_subjects_own_body(workdir, checks):
    """cohort.md, "Each subject on their own body": the body's spectral radius of every
    subject (``pdw-scale --subject ID``, the route the cohort's ``--bodies`` takes)."""
    rows = table("cohort.md", "body: spectral radius")
    assert len(rows) == 4
    for row in rows:
        subject = row["subject"]
        text = cli("scale", "--subject", subject, "--out", workdir / f"{subject}.toml")
        rho = float(re.search(r"spectral radius ([\d.]+)", text).group(1))
        checks.number("cohort.md", row["body: spectral radius"], rho,
                      what=f"{subject}'s body: spectral radius")
    checks.verify()


def test_cohort_page_the_tables_are_the_stored_cohort_table(checks):
    """cohort.md: ``docs/results/cohort.csv``, from which the site build draws the page's
    figures (docs/hooks.py), holds exactly the fits of its three tables (on the paper's
    body, per side, on their own body), number for number, in the columns ``pdw-cohort``
    writes: a per-side fit's ``r2_knee`` and ``r2_hip`` the mean of its legs, the bodies'
    mass and height those of ``data/anthropometry/subjects.csv``."""
    stored = pd.read_csv(RESULTS / "cohort.csv", dtype=str, keep_default_na=False)
    bodies = pd.read_csv(DATA / "anthropometry" / "subjects.csv").set_index("subject_id")
    tables = {("symmetric", "paper"): table("cohort.md", "| rho | status |"),
              ("sides", "own"): table("cohort.md", "stride rho"),
              ("symmetric", "own"): table("cohort.md", "body: spectral radius")}
    assert len(stored) == sum(len(rows) for rows in tables.values())
    for (kind, body), rows in tables.items():
        mine = stored[(stored["kind"] == kind) & (stored["body"] == body)]
        assert list(mine["subject_id"]) == [r["subject"] for r in rows], (kind, body)
        for (_, got), row in zip(mine.iterrows(), rows, strict=True):
            sid = row["subject"]

            def same(column, printed, got=got, sid=sid, kind=kind, body=body):
                checks.truth("cohort.md", f"cohort.csv {sid} {kind} {body}: {column} "
                             f"{got[column]!r}, the table prints {printed!r}",
                             got[column] == printed)

            if body == "own":
                checks.truth("cohort.md", f"cohort.csv {sid}: the body of subjects.csv",
                             float(got["mass_kg"]) == bodies.loc[sid, "mass_kg"]
                             and float(got["height_m"]) == bodies.loc[sid, "height_m"])
            else:
                same("mass_kg", "")
            if kind == "sides":
                for curve in ("knee", "hip"):
                    left, right = row[f"{curve} R² left / right"].split(" / ")
                    same(f"r2_{curve}_left", left)
                    same(f"r2_{curve}_right", right)
                    checks.number("cohort.md", got[f"r2_{curve}"],
                                  (float(left) + float(right)) / 2,
                                  what=f"{sid}'s per-side mean {curve} R²")
                same("r2_thigh", row["thigh R²"])
                same("stride_spectral_radius", row["stride rho"])
                same("iterations", row["iterations (solves)"].split()[0])
                same("status", "accepted")  # "All four accepted" under the table
                continue
            r2 = (("knee $R^2$", "hip $R^2$", "thigh $R^2$") if body == "paper"
                  else ("knee", "hip", "thigh"))
            for curve, header in zip(("knee", "hip", "thigh"), r2, strict=True):
                same(f"r2_{curve}", row[header])
            same("k_knee_N_m_per_rad", row["k_knee (N m/rad)"])
            same("k_ankle_N_m_per_rad", row["k_ankle (N m/rad)"])
            same("spectral_radius", row["rho"])
            same("iterations", row["iterations"])
            same("status", row.get("status", "accepted"))
    checks.verify()


def test_cohort_page_the_eight_step_bound_at_the_kneed_walkers_start(checks):
    """cohort.md: the kneed walker's start (its problem file's own gait; it has no atlas)
    has an eight-step bound ||J^8||_F^(1/8) of 1.088, above the fit's 0.9."""
    from pdw_casadi.fit import FitOptions
    from pdw_casadi.gait.fixed_point import own_fixed_point
    from pdw_casadi.model.problem import load_problem
    from pdw_casadi.nlp.stability import power_bound

    opts = FitOptions()
    fp = own_fixed_point(load_problem("kneed_walker"))
    bound, _ = power_bound(fp.jacobian, opts.stability_power)
    checks.passage("cohort.md", r"The eight-step stability bound \(the fit's default, "
                   r"\[fit results\]\(fit\.md#the-eight-step-bound-the-default\)\) is NUM at "
                   r"this walker's start, above its NUM", bound, opts.radius_bound(1))
    checks.truth("cohort.md", "the eight-step bound is the fit's default",
                 opts.stability_bound == "power" and opts.stability_power == 8)
    checks.verify()


# -- prosthesis.md: the shipped designs --------------------------------------------------------
#: the 28.9 % design is the page's evidence of a design invalid under the guard rule (kept
#: beside the page, not shipped with the data)
DESIGNS = {29: RESULTS / "designs" / "humanlike_6link_prosthesis29.toml",
           30: DATA / "designs" / "humanlike_6link_prosthesis30.toml"}
KEYS = ("k_ankle", "c_ankle", "k_knee", "c_knee_flex", "c_knee_ext", "c_knee_stance",
        "theta_eq", "theta_dis")


def _legs(summary: dict, leg: str) -> list[float]:
    return [summary["parameters"][f"{leg}.{k}"] for k in KEYS]


def _compliance_pattern(head: str) -> str:
    """``head k_ankle NUM, c_ankle NUM, ... theta_dis NUM`` (the pages' order of KEYS)."""
    return head + " " + ", ".join(f"{k} NUM" for k in KEYS)


def test_prosthesis_page_the_30_percent_design(fixed_point, checks):
    """prosthesis.md: ``pdw-fixed-point --problem
    data/designs/humanlike_6link_prosthesis30.toml --out fp30``: stride radius 0.8000 (per
    step 0.894), valid, residual 5.9e-12, the toe forces after each foot strike, the steps
    (-0.90 % asymmetries), stance, double support, slope and both legs' compliance."""
    fp = fixed_point(DESIGNS[30])
    stride, legs = fp["stride"], fp["stride"]["legs"]
    m = fp["margins"]
    checks.passage("prosthesis.md", r"data/designs/humanlike_6link_prosthesis30\.toml --out "
                   r"fp30`: stride radius NUM, valid, residual NUM; the trailing toe pushes "
                   r"with NUM N after the left foot's strike and NUM N after the right's",
                   fp["spectral_radius"], fp["residual"], m["left.foot_strike:toe_off_ahead"],
                   m["right.foot_strike:toe_off_ahead"])
    checks.passage(
        "prosthesis.md",
        r"data/designs/humanlike_6link_prosthesis30\.toml --out fp30` gives residual NUM, "
        r"stride radius NUM \(per step NUM\), valid, step length NUM / NUM m and step time "
        r"NUM / NUM s \(left / right; both asymmetries NUM %, the NLP's tolerance bound\), "
        r"stance NUM / NUM %, double support NUM %, slope NUM rad\. "
        + _compliance_pattern("Prosthetic leg:") + "; " + _compliance_pattern("sound leg:"),
        fp["residual"], fp["spectral_radius"], stride["step_spectral_radius_equivalent"],
        legs["left"]["step_length_m"], legs["right"]["step_length_m"],
        legs["left"]["step_time_s"], legs["right"]["step_time_s"],
        (stride["step_length_asymmetry_pct"], stride["step_time_asymmetry_pct"]),
        legs["left"]["stance_pct"], legs["right"]["stance_pct"], stride["double_support_pct"],
        fp["parameters"]["slope"], *_legs(fp, "right"), *_legs(fp, "left"))
    checks.truth("prosthesis.md", "the 30 % design is valid and stable",
                 fp["valid"] and fp["stable"])
    checks.verify()


def test_prosthesis_page_the_28_9_percent_design(fixed_point, checks):
    """prosthesis.md: ``pdw-fixed-point --problem
    docs/results/designs/humanlike_6link_prosthesis29.toml``: residual 3e-11, stride radius 0.7829
    (per step 0.885), equal steps (0.6140 m, 0.6536 s), the failed guard
    ``left.foot_strike:toe_off_ahead`` = -0.0335 N, invalid under today's guard rule as the
    page says, both legs' compliance."""
    fp = fixed_point(DESIGNS[29])
    stride, legs = fp["stride"], fp["stride"]["legs"]
    checks.passage("prosthesis.md", r"docs/results/designs/humanlike_6link_prosthesis29\.toml "
                   r"--out "
                   r"fp29`: stride radius NUM, `left\.foot_strike:toe_off_ahead` = NUM N",
                   fp["spectral_radius"], fp["margins"]["left.foot_strike:toe_off_ahead"])
    checks.truth("prosthesis.md", "the 28.9 % design is not valid, at the left foot strike's "
                 "toe-off guard", not fp["valid"] and
                 fp["failure"].startswith("left.foot_strike:toe_off_ahead"))
    checks.passage(
        "prosthesis.md",
        r"docs/results/designs/humanlike_6link_prosthesis29\.toml` gives residual NUM, stride "
        r"radius NUM \(per step NUM\), invalid, step length NUM / NUM m and step time NUM / "
        r"NUM s "
        r"\(both asymmetries below NUM %\), slope NUM rad unchanged\. "
        + _compliance_pattern("Prosthetic leg:") + "; " + _compliance_pattern("sound leg:"),
        fp["residual"], fp["spectral_radius"], stride["step_spectral_radius_equivalent"],
        legs["left"]["step_length_m"], legs["right"]["step_length_m"],
        legs["left"]["step_time_s"], legs["right"]["step_time_s"], 0.001,
        fp["parameters"]["slope"], *_legs(fp, "right"), *_legs(fp, "left"))
    bound = float(passage("prosthesis.md", r"\(both asymmetries below NUM %\), slope")[0])
    checks.truth("prosthesis.md", f"the 28.9 % design's asymmetries are below {bound} %",
                 abs(stride["step_length_asymmetry_pct"]) < bound
                 and abs(stride["step_time_asymmetry_pct"]) < bound)
    checks.verify()


def test_prosthesis_page_the_shipped_designs_table(fixed_point, checks):
    """prosthesis.md, the shipped designs' table: how much lighter (the right shank's and
    foot's mass in the file), the stride radius and its per-step equivalent, and the
    asymmetries, re-solved from each file."""
    for row in table("prosthesis.md", "stride radius (per step)"):
        path = ROOT / row["file"].strip("`")
        design = tomllib.loads(path.read_text(encoding="utf-8"))["anthropometry"]
        lighter = [100 * (1 - design["right"][k] / design[k]) for k in ("m_s", "m_f")]
        checks.number("prosthesis.md", numbers(row["lighter"])[0], *lighter,
                      what=f"{path.name}: lighter")
        fp = fixed_point(path)
        rho, per_step = numbers(row["stride radius (per step)"])
        checks.number("prosthesis.md", rho, fp["spectral_radius"], what=f"{path.name}: rho")
        checks.number("prosthesis.md", per_step, fp["stride"]["step_spectral_radius_equivalent"],
                      what=f"{path.name}: per step")
        asym = [fp["stride"]["step_length_asymmetry_pct"],
                fp["stride"]["step_time_asymmetry_pct"]]
        cell = row["asymmetries (length / time)"]
        if cell.startswith("below"):
            checks.truth("prosthesis.md", f"{path.name}: asymmetries {cell}",
                         max(map(abs, asym)) < float(numbers(cell)[0]))
        else:
            for printed, value in zip(numbers(cell), asym, strict=True):
                checks.number("prosthesis.md", printed, value, what=f"{path.name}: asymmetry")
    checks.verify()


def test_prosthesis_page_changes_against_the_atlas_start(checks):
    """prosthesis.md: the designs' compliance against the atlas start gait's
    (``humanlike_6link-own-rho0.86`` of ``data/atlas/humanlike_6link.json``), in %, and that
    gait's stride radius (its per-step radius squared: 0.69)."""
    atlas = read_json(DATA / "atlas" / "humanlike_6link.json")
    entry = next(e for e in atlas["entries"] if e["label"] == "humanlike_6link-own-rho0.86")
    start = dict(zip(atlas["parameter_names"], entry["parameters"], strict=True))
    design = {n: tomllib.loads(p.read_text(encoding="utf-8"))["compliance"]
              for n, p in DESIGNS.items()}

    def change(n, leg, key):
        value = design[n]["right"][key] if leg == "right" else design[n][key]
        return 100 * (value / start[key] - 1)

    checks.passage(
        "prosthesis.md",
        r"Against the atlas start gait's compliance the sound leg changes by NUM % "
        r"\(c_knee_stance\), NUM % \(theta_eq and theta_dis\) and about 3 % or less in the "
        r"rest; the prosthetic leg by NUM % \(c_knee_ext\), NUM % \(c_knee_flex\), NUM % "
        r"\(c_ankle\), NUM % \(k_ankle, NUM % theta_dis and c_knee_stance\)",
        change(30, "left", "c_knee_stance"),
        (change(30, "left", "theta_eq"), change(30, "left", "theta_dis")),
        change(30, "right", "c_knee_ext"), change(30, "right", "c_knee_flex"),
        change(30, "right", "c_ankle"), change(30, "right", "k_ankle"),
        (change(30, "right", "theta_dis"), change(30, "right", "c_knee_stance")))
    checks.passage(
        "prosthesis.md",
        r"whose sound leg moves by NUM % \(c_knee_stance\), NUM % \(theta_eq\), NUM % "
        r"\(k_ankle\), and its prosthetic c_knee_flex by NUM %",
        change(29, "left", "c_knee_stance"), change(29, "left", "theta_eq"),
        change(29, "left", "k_ankle"), change(29, "right", "c_knee_flex"))
    checks.passage(
        "prosthesis.md", r"knee spring engaging and releasing earlier \(theta_eq NUM -> NUM, "
        r"theta_dis NUM -> NUM\)", start["theta_eq"], design[29]["theta_eq"],
        start["theta_dis"], design[29]["theta_dis"])
    checks.passage("prosthesis.md", r"a 0\.1 % lighter leg raises the stride radius from NUM",
                   entry["spectral_radius"] ** 2)
    checks.verify()


def test_prosthesis_page_the_long_double_support_start(fixed_point, checks):
    """prosthesis.md: the ankle walker's long-double-support gait
    (``problems/humanlike_6link_ankle_ds.toml``) has stride radius 0.776 (its step map's
    radius squared: a symmetric gait)."""
    fp = fixed_point("humanlike_6link_ankle_ds")
    checks.passage("prosthesis.md", r"`--start problems/humanlike_6link_ankle_ds\.toml`, "
                   r"stride radius NUM\)", fp["spectral_radius"] ** 2)
    checks.verify()


# -- toes.md: the toe-foot walker --------------------------------------------------------------
def test_toes_page_the_shipped_gait(fixed_point, female_fast_r2, checks):
    """toes.md, "The shipped gait": ``pdw-fixed-point --problem humanlike_toes --out fp``:
    its phases, heel off, toe off, stance, double support, rho, the failed margin, the
    eigenvalues, and its curves' R^2 on ``female_fast.csv``."""
    fp = fixed_point("humanlike_toes")
    t = timing_of(fp)
    row, = table("toes.md", "heel off")
    checks.truth("toes.md", f"phases {row['phases']}",
                 list(fp["timing"]["phase_durations_s"]) == row["phases"].split(", "))
    for column, value in (("heel off", t["heel_off"]), ("toe off", t["toe_off"]),
                          ("stance", t["stance"]),
                          ("double support per period", t["double_support"]),
                          ("rho", fp["spectral_radius"])):
        checks.number("toes.md", numbers(row[column])[0], value, what=column)
    margin, = numbers(row["valid"])
    checks.number("toes.md", margin, 1e3 * fp["margins"]["I:min_copmargin_foot1"],
                  what="phase I copmargin_foot1 (mm)")
    checks.truth("toes.md", "the shipped toe gait is not valid, in phase I's copmargin",
                 not fp["valid"] and fp["failure"].startswith("I:min_copmargin_foot1"))
    eig = sorted((complex(*e) for e in fp["eigenvalues"]), key=lambda z: (-abs(z), -z.imag))
    checks.passage("toes.md", r"Eigenvalues: NUM, NUM ± NUMi, NUM, NUM ± NUMi, NUM\.",
                   eig[0].real, eig[1].real, abs(eig[1].imag), eig[3].real, eig[4].real,
                   abs(eig[4].imag), abs(eig[6]))
    r2 = female_fast_r2("humanlike_toes")
    checks.passage("toes.md", r"Knee / hip / thigh R² of its curves on `female_fast\.csv`: "
                   r"NUM / NUM / NUM", r2["r2_knee"], r2["r2_hip"], r2["r2_thigh"])
    checks.verify()


def test_toes_page_the_continuations(workdir, checks):
    """toes.md: ``pdw-seed toes --out c --continue KEY TO NUM`` for each row of the
    continuation table: the key's shipped and last converged values, rho and the smallest
    heel load along the way, and where Newton fails."""
    rows = table("toes.md", "smallest heel load")
    assert len(rows) == 3
    for i, row in enumerate(rows):
        key = re.match(r"`(\w+)`", row["KEY (from the shipped value)"]).group(1)
        first, last, to, num = numbers(row["KEY (from the shipped value)"])
        out = workdir / f"continue_{i}"
        cli("seed", "toes", "--out", out, "--continue", key, to, num)
        points = read_json(out / "continuation.json")["continuation"]
        ok = [p for p in points if p["converged"]]
        failed = next(p for p in points if not p["converged"])
        checks.number("toes.md", first, ok[0][key], what=f"{key}: shipped value")
        checks.number("toes.md", last, ok[-1][key], what=f"{key}: last converged value")
        rhos, loads = numbers(row["rho along the way"]), numbers(row["smallest heel load (N m)"])
        assert len(rhos) == len(loads) == len(ok), f"{key}: {len(ok)} points converged"
        for printed, p in zip(rhos, ok, strict=True):
            checks.number("toes.md", printed, p["rho"], what=f"{key}: rho")
        for printed, p in zip(loads, ok, strict=True):
            checks.number("toes.md", printed, p["min_heel_load_Nm"], what=f"{key}: heel load")
        checks.number("toes.md", numbers(row["where it stops"])[0], failed[key],
                      what=f"{key}: where Newton fails")
    checks.verify()


def test_toes_page_the_energy_balance_and_the_toes(workdir, checks):
    """toes.md, "Numerics of the toes": the shipped gait closes a step's energy balance to
    4e-7 J (``pdw-simulate --problem humanlike_toes``), the toes' inertia about the MTP joint
    (5e-5 kg m^2: J_toe + m_toe l_toec^2 of the problem file) and the fit bounds of k_mtp
    and c_mtp (its compliance_bounds)."""
    out = workdir / "sim_toes"
    cli("simulate", "--problem", "humanlike_toes", "--out", out)
    summary = read_json(out / "summary.json")
    checks.passage("toes.md", r"the shipped gait has no such phase and closes its balance to "
                   r"NUM J", summary["energy_balance_max_abs_J"])
    problem = tomllib.loads((ROOT / "problems" / "humanlike_toes.toml").read_text("utf-8"))
    a = problem["anthropometry"]
    checks.passage("toes.md", r"The toes' inertia about the MTP joint is NUM kg m²",
                   a["J_toe"] + a["m_toe"] * a["l_toec"] ** 2)
    b = problem["compliance_bounds"]
    checks.passage("toes.md", r"k_mtp ≤ NUM N m/rad, c_mtp ≤ NUM N m s/rad",
                   b["k_mtp"][1], b["c_mtp"][1])
    checks.verify()


def _scan(workdir, name, args):
    out = workdir / name
    cli("seed", "toes", "--out", out, *args)
    return read_json(out / "scan.json")


@pytest.mark.slow
def test_toes_page_the_first_scan(workdir, checks):
    """toes.md: ``pdw-seed toes --out scan --samples 2000 --seed 0`` (about 40 s): how the
    2000 steps ended, and how the heel-off ones did."""
    cmd = passage("toes.md", r"`pdw-seed toes --out scan --samples (\d+) --seed (\d+)`")
    samples, seed = cmd
    scan = _scan(workdir, "scan", ["--samples", samples, "--seed", seed])
    ends = dict(scan["step_ends"])
    whole = ends.pop("whole step", 0)
    rows = table("toes.md", "how the step ended")
    listed = 0
    for row in rows:
        what, printed = row["how the step ended"], row["samples"]
        key = re.match(r"`([^`]+)`", what)
        if key:
            value = ends.get(key.group(1), 0)
            listed += value
        elif what == "a whole step":
            value = whole
        else:
            n_other, = numbers(what)  # "others (11 reasons)"
            others = {k: v for k, v in ends.items()
                      if k not in {re.match(r"`([^`]+)`", r["how the step ended"]).group(1)
                                   for r in rows if r["how the step ended"].startswith("`")}}
            checks.number("toes.md", n_other, len(others), what="other reasons")
            value = sum(others.values())
        checks.number("toes.md", printed, value, what=f"steps ending at {what}")
    heel_off = scan["heel_off_step_ends"]
    checks.passage("toes.md", r"NUM of the NUM lifted the stance heel in single support",
                   sum(heel_off.values()), int(samples))
    for row in table("toes.md", "how a heel-off step ended"):
        keys = re.findall(r"`([^`]+)`", row["how a heel-off step ended"])
        printed, = numbers(row["samples"].replace("1 each", "1"))
        for key in keys:
            checks.number("toes.md", printed, heel_off.get(key, 0), what=f"heel off: {key}")
    checks.verify()


@pytest.mark.slow
def test_toes_page_the_second_scan(workdir, checks):
    """toes.md: the second scan, ``pdw-seed toes --out scan3 --samples 1500 --seed 2 --range
    ...`` (about 35 s): heel-off steps and how they ended, how all steps ended."""
    args = passage("toes.md", r"`pdw-seed toes --out scan3 ([^`]+)`")[0].split()
    scan = _scan(workdir, "scan3", args)
    heel_off, ends = scan["heel_off_step_ends"], scan["step_ends"]
    n = int(args[args.index("--samples") + 1])
    checks.passage(
        "toes.md", r"NUM of NUM lifted the heel in single support, none completed the step: "
        r"`toes1_cop_at_tip_in_II_mtp` NUM, `heel_strike_mtp: impulse_toes1` NUM, `toe_scuff` "
        r"NUM, `heel1_down` NUM, `heel_strike_behind` NUM\. Of all NUM steps NUM ended at "
        r"`heel_strike:impulse_toes1`.*?, NUM at `toe_scuff`, NUM at `cop1_at_heel`",
        sum(heel_off.values()), n, heel_off.get("toes1_cop_at_tip_in_II_mtp", 0),
        heel_off.get("heel_strike_mtp:impulse_toes1", 0), heel_off.get("toe_scuff", 0),
        heel_off.get("heel1_down", 0), heel_off.get("heel_strike_behind", 0), n,
        ends.get("heel_strike:impulse_toes1", 0), ends.get("toe_scuff", 0),
        ends.get("cop1_at_heel", 0))
    checks.truth("toes.md", "no heel-off step of the second scan completed",
                 not any(k.startswith("whole step") for k in heel_off))
    checks.verify()


# -- timing.md: the ankle, forefoot-rocker and rolling-foot walkers -----------------------------
#: the rows of timing.md's tables that are a shipped problem file's own gait (the page says
#: which file ships which row)
SHIPPED_ROWS = [
    ("fit", "all three, `--timing`", "humanlike_6link_ankle"),
    ("fit", "forefoot rocker: its heel-off start, not fitted", "humanlike_6link_heeloff"),
    ("fit", "rolling feet: its shipped 5 cm toe-arc gait (fitted with r_toe ≥ 0.05 m)",
     "humanlike_6link_arc"),
    ("r_toe / r_heel (m)", "from the 5 cm toe seed (`--state seed/seed.json --compliance "
     "seed/seed.json`)", "humanlike_6link_ankle_ds"),
    ("r_toe / r_heel (m)", "from the seed, r_toe bounds [0.05, 0.3]", "humanlike_6link_arc"),
]


@pytest.mark.parametrize("header, label, problem", SHIPPED_ROWS,
                         ids=[p + ":" + lab[:24] for _, lab, p in SHIPPED_ROWS])
def test_timing_page_rows_of_the_shipped_gaits(header, label, problem, fixed_point,
                                               female_fast_r2, checks):
    """timing.md: a table row that is a shipped problem's own gait
    (``pdw-fixed-point --problem P``): double support per period, stance, the phases' ms,
    knee / hip / thigh R^2 on ``female_fast.csv`` (the fit's reference row), rho, and the
    radii where the row gives them."""
    rows = [r for r in table("timing.md", header) if r["fit"] == label]
    assert len(rows) == 1, f"timing.md has no row {label!r}"
    row = rows[0]
    fp = fixed_point(problem)
    t = timing_of(fp)
    checks.number("timing.md", row["double support"], t["double_support"], what=label)
    checks.number("timing.md", row["stance"], t["stance"], what=label)
    phases = [p for p in fp["timing"]["phase_durations_s"]]
    printed = numbers(row["phases I / II / III (ms)"])
    names = ["I", "II", "III"] if len(printed) == 3 else ["I", "II", "II_toe", "III"]
    assert phases == names, f"{problem}: phases {phases}"
    for p, name in zip(printed, names, strict=True):
        checks.number("timing.md", p, t[name], what=f"{label}: phase {name}")
    r2 = female_fast_r2(problem)
    for column, key in (("knee R²", "r2_knee"), ("hip R²", "r2_hip"), ("thigh R²", "r2_thigh")):
        checks.number("timing.md", row[column], r2[key], what=f"{label}: {column}")
    checks.number("timing.md", row["rho"], fp["spectral_radius"], what=f"{label}: rho")
    accepted = row["accepted"]
    checks.truth("timing.md", f"{label}: {accepted}",
                 fp["valid"] == (accepted == "yes") and fp["stable"] == (accepted == "yes"))
    if "r_toe / r_heel (m)" in row and problem == "humanlike_6link_arc":
        toe, heel = numbers(row["r_toe / r_heel (m)"])
        checks.number("timing.md", toe, fp["parameters"]["r_toe"], what="r_toe")
        checks.number("timing.md", heel, fp["parameters"]["r_heel"], what="r_heel")
    checks.verify()


def test_timing_page_the_shipped_problems_in_prose(fixed_point, female_fast_r2, checks):
    """timing.md: what the page says of the shipped problem files in its prose: the
    long-double-support ankle gait (``pdw-fixed-point --problem humanlike_6link_ankle_ds``),
    the heel-off gait, the 5 cm toe-arc gait, the ankle walker's stance-force bound and its
    clutch."""
    ds = fixed_point("humanlike_6link_ankle_ds")
    checks.passage("timing.md", r"`pdw-fixed-point --problem humanlike_6link_ankle_ds`: "
                   r"residual NUM, rho NUM, valid, NUM % per period, stance NUM %",
                   ds["residual"], ds["spectral_radius"], timing_of(ds)["double_support"],
                   timing_of(ds)["stance"])
    checks.truth("timing.md", "humanlike_6link_ankle_ds is valid", ds["valid"])
    checks.passage("timing.md", r"c_ankle on its NUM bound, gives the same fixed point, rho "
                   r"NUM, valid, NUM % per period", ds["parameters"]["c_ankle"],
                   ds["spectral_radius"], timing_of(ds)["double_support"])
    heel = fixed_point("humanlike_6link_heeloff")
    t, r2 = timing_of(heel), female_fast_r2("humanlike_6link_heeloff")
    checks.passage(
        "timing.md", r"`problems/humanlike_6link_heeloff\.toml`: heel off at NUM % of the "
        r"cycle, II_toe NUM ms, NUM % double support per period and stance NUM %, but it is "
        r"far from stable \(rho NUM\), invalid \(the newly flat foot's centre of pressure NUM "
        r"mm beyond its heel margin in phase I, `I:min_copmargin_foot1`\) and its curves are "
        r"poor \(knee / hip / thigh R² NUM / NUM / NUM\)",
        t["heel_off"], t["II_toe"], t["double_support"], t["stance"],
        heel["spectral_radius"], -1e3 * heel["margins"]["I:min_copmargin_foot1"],
        r2["r2_knee"], r2["r2_hip"], r2["r2_thigh"])
    checks.truth("timing.md", "the heel-off gait is invalid in phase I's copmargin",
                 not heel["valid"] and heel["failure"].startswith("I:min_copmargin_foot1"))
    arc = fixed_point("humanlike_6link_arc")
    checks.passage("timing.md", r"`problems/humanlike_6link_arc\.toml` ships that 5 cm gait "
                   r"\(r_toe = NUM, r_heel = NUM mm; stable, valid\)",
                   arc["parameters"]["r_toe"], 1e3 * arc["parameters"]["r_heel"])
    checks.truth("timing.md", "the 5 cm toe-arc gait is stable and valid",
                 arc["stable"] and arc["valid"])
    ankle = fixed_point("humanlike_6link_ankle")
    checks.passage("timing.md", r"The ankle walker's shipped gait sits on its phase-I "
                   r"stance-force bound \(NUM N\)", ankle["margins"]["I:min_N_foot1"])
    checks.passage("timing.md", r"the fit stiffens the clutch spring \(k_clutch [\d.]+ → NUM "
                   r"N m/rad\)", ankle["parameters"]["k_clutch"])
    checks.verify()


def test_timing_page_the_rolling_foot_seed(workdir, checks):
    """timing.md: ``pdw-seed arc --r-toe 0.05 --r-heel 0 --n-min 20 --out seed`` carries the
    ankle walker's gait to a 5 cm toe arc: valid, rho 1.43, double support 6.23 %."""
    out = workdir / "seed_arc"
    cli("seed", "arc", "--r-toe", "0.05", "--r-heel", "0", "--n-min", "20", "--out", out)
    seed = read_json(out / "seed.json")
    checks.passage("timing.md", r"`pdw-seed arc --r-toe 0\.05 --r-heel 0 --n-min 20 --out "
                   r"seed` carries it to a 5 cm toe arc by the design continuation \(all other "
                   r"compliance free; valid, rho NUM, double support NUM %",
                   seed["spectral_radius"], seed["double_support_pct"][0])
    checks.truth("timing.md", "the 5 cm seed is reached and valid",
                 seed["reached"] and seed["valid"])
    checks.verify()


def test_timing_page_any_radius_breaks_the_ankle_gait(workdir, checks):
    """timing.md: from the ankle walker's gait at radii 0 (``pdw-seed arc --r-toe 0 --r-heel
    0 --out start``), ``pdw-sweep ... --param r_toe --from 0 --to 0.1 --num 11 --mode grid``
    is valid below 1.2 µm only and has no fixed point from 1 cm on."""
    start = workdir / "start"
    cli("seed", "arc", "--r-toe", "0", "--r-heel", "0", "--out", start)
    seed = start / "seed.json"
    out = workdir / "sweep_arc_grid"
    cli("sweep", "--problem", "humanlike_6link_arc", "--state", seed, "--compliance", seed,
        "--param", "r_toe", "--from", "0", "--to", "0.1", "--num", "11", "--mode", "grid",
        "--out", out)
    events = read_json(out / "events.json")["events"]
    rows = pd.read_csv(out / "sweep.csv")
    boundary, = [e for e in events if e["kind"] == "boundary"]
    first_failed = rows[~rows["converged"].astype(bool)]["r_toe_m"].min()
    checks.passage("timing.md", r"valid below NUM µm only, no fixed point from NUM cm on",
                   1e6 * boundary["value"], 100 * first_failed)
    converged = rows[rows["converged"].astype(bool)]
    checks.truth("timing.md", "only r_toe = 0 of the grid converges, valid",
                 list(converged["r_toe_m"]) == [0.0] and bool(converged["valid"].iloc[0]))
    checks.verify()


def _timing_lines(text: str, parameter: str) -> dict[float, dict]:
    """``pdw-sweep --timing``'s per-point lines: parameter value -> double support, stance."""
    out = {}
    for m in re.finditer(rf"{parameter} = ([\d.e-]+): valid (\w+), stable (\w+), rho ([\d.]+), "
                         r"double support ([\d.]+), [\d.]+ %, stance ([\d.]+) %", text):
        out[float(m.group(1))] = {"valid": m.group(2) == "True", "stable": m.group(3) == "True",
                                  "double_support": float(m.group(5)), "stance": m.group(6)}
    return out


def test_timing_page_the_toe_radius_sweep(workdir, checks):
    """timing.md: ``pdw-sweep --problem humanlike_6link_arc --param r_toe --from 0 --to 0.15
    --num 16 --timing``: double support at 35 mm, the period doubling (stable from there),
    the validity boundary (the trailing toe's force in III) and the branch's end."""
    out = workdir / "sweep_arc_toe"
    text = cli("sweep", "--problem", "humanlike_6link_arc", "--param", "r_toe", "--from", "0",
               "--to", "0.15", "--num", "16", "--timing", "--out", out)
    events = {e["kind"]: e for e in read_json(out / "events.json")["events"]}
    points = _timing_lines(text, "r_toe_m")
    at = float(passage("timing.md", r"shortens double support \(NUM % at NUM mm")[1])
    near = [v for r, v in points.items() if round(1e3 * r, 6) == at]
    assert near, f"pdw-sweep --timing printed no point at {at} mm: {sorted(points)}"
    checks.passage(
        "timing.md", r"shortens double support \(NUM % at [\d.]+ mm, stable from NUM mm, where "
        r"a period doubling sets in; invalid below NUM mm, trailing-toe force in III\) and the "
        r"branch ends at NUM cm",
        near[0]["double_support"], 1e3 * events["period_doubling"]["value"],
        1e3 * events["boundary"]["value"], 1e2 * events["branch_end"]["value"])
    checks.truth("timing.md", "the validity boundary is the trailing toe's force in III",
                 "III:min_N_toe1" in events["boundary"]["reason"])
    checks.verify()


@pytest.mark.slow
def test_timing_page_the_heel_radius_fold(workdir, checks):
    """timing.md: in r_heel the 5 cm toe-arc gait sits next to a fold at 3.93 mm
    (``pdw-sweep --problem humanlike_6link_arc --param r_heel --from 0 --to 0.01 --num 11``;
    the page gives no grid: the fold is refined to 1e-7 m whatever the grid). Slow only to
    keep the default part of this file within a minute (about 7 s)."""
    out = workdir / "sweep_arc_heel"
    cli("sweep", "--problem", "humanlike_6link_arc", "--param", "r_heel", "--from", "0",
        "--to", "0.01", "--num", "11", "--out", out)
    folds = [e for e in read_json(out / "events.json")["events"] if e["kind"] == "fold"]
    assert len(folds) == 1
    checks.passage("timing.md", r"in r_heel the gait sits next to a fold at NUM mm",
                   1e3 * folds[0]["value"])
    checks.verify()


# -- sweeps.md: the paper's gait over the slope ------------------------------------------------
def test_sweeps_page_the_slope_branch(workdir, checks):
    """sweeps.md: ``pdw-sweep --problem humanlike_6link --param slope --from 0.147 --to 0.1486
    --num 17 --out sw``: the gait-pattern boundary (centre of pressure at the toe in phase
    I), the fold, and the Neimark-Sacker point where the stable, valid range begins."""
    cmd, = passage("sweeps.md", r"```bash (pdw-sweep [^`]+) ```")
    # a shell line continuation (" \\" at a line end) is not an argument
    args = [a for a in cmd.split() if a != "\\"][1:]
    out = workdir / "sw"
    cli("sweep", *args[:args.index("--out")], "--out", out)
    result = read_json(out / "events.json")
    events = {e["kind"]: e for e in result["events"]}
    checks.passage("sweeps.md", r"it ends at a gait-pattern boundary near NUM rad",
                   events["boundary"]["value"])
    checks.truth("sweeps.md", "the boundary is the centre of pressure at the toe in phase I",
                 "cop1_at_toe" in events["boundary"]["reason"])
    checks.passage("sweeps.md", r"it ends at a fold near NUM rad", events["fold"]["value"])
    checks.passage("sweeps.md", r"between a Neimark–Sacker point at NUM rad and the fold",
                   events["neimark_sacker"]["value"])
    ranges = result["stable_valid_ranges"]
    checks.truth("sweeps.md", "stable and valid only between the Neimark-Sacker point and the "
                 "fold", [(r["from_event"], r["to_event"]) for r in ranges]
                 == [("neimark_sacker", "fold")])
    # the stored output the site build draws the page's figure from (docs/hooks.py) is this
    # sweep's: the same points and events
    stored = RESULTS / "slope_sweep"
    rows, again = pd.read_csv(stored / "sweep.csv"), pd.read_csv(out / "sweep.csv")
    plotted = ["slope_rad", "branch", "converged", "stable", "valid", "step_length_m",
               "speed_m_s", "spectral_radius"]
    checks.truth("sweeps.md", f"the stored sweep.csv has the rows of the sweep ({len(rows)} "
                 f"against {len(again)})", len(rows) == len(again))
    if len(rows) == len(again):
        for col in plotted:
            same = np.allclose(rows[col].astype(float), again[col].astype(float),
                               rtol=1e-7, atol=1e-9)
            checks.truth("sweeps.md", f"the stored sweep.csv's {col} is the sweep's", same)
    kept = [(e["kind"], e["value"]) for e in read_json(stored / "events.json")["events"]]
    found = [(e["kind"], e["value"]) for e in result["events"]]
    checks.truth("sweeps.md", f"the stored events.json's events {kept} are the sweep's {found}",
                 [k for k, _ in kept] == [k for k, _ in found]
                 and np.allclose([v for _, v in kept], [v for _, v in found], rtol=1e-7))
    checks.verify()


# -- fit.md, per-leg-fit.md, performance.md: the corpus and the problem file's own gait ---------
@pytest.fixture(scope="module")
def table3():
    """R^2 of the paper's gait (Table 3 compliance: ``problems/humanlike_6link.toml``'s own
    fixed point) on every curve file of the corpus and the bundled file, by file stem."""
    from pdw_casadi.fit.result import reference_gait
    from pdw_casadi.gait.curves import fit_scores
    from pdw_casadi.model.gait_data import load_gait_curves
    from pdw_casadi.model.problem import load_problem

    problem = load_problem("humanlike_6link")
    ref = reference_gait(problem, load_gait_curves(DATA / "female_fast.csv"))
    out = {"female_fast": ref}
    for path in sorted((DATA / "corpus").glob("*.csv")):
        if not path.stem.endswith("_sides"):
            out[path.stem] = fit_scores(ref["curves"], load_gait_curves(path))
    return out


def test_fit_page_table_3_of_every_corpus_file(table3, checks):
    """fit.md: the "Table 3 knee / hip" column of every table, each row's file against the
    R^2 of the problem file's own gait on it (the fit's knee floor and its reference)."""
    text = (RESULTS / "fit.md").read_text(encoding="utf-8")
    n_tables = sum(1 for line in text.splitlines()
                   if line.startswith("|") and "Table 3 knee / hip" in line)
    assert n_tables >= 5
    rows = 0
    for k in range(n_tables):
        for row in table("fit.md", "Table 3 knee / hip", k):
            column = next(c for c in row if c.startswith("Table 3 knee / hip"))
            stem = re.sub(r" \(.*\)$", "", next(iter(row.values())))
            stem = stem.split(",")[0].strip()
            if stem not in table3:
                continue
            knee, hip = numbers(row[column])
            checks.number("fit.md", knee, table3[stem]["r2_knee"], what=f"{stem}: Table 3 knee")
            checks.number("fit.md", hip, table3[stem]["r2_hip"], what=f"{stem}: Table 3 hip")
            rows += 1
    assert rows >= 200, f"only {rows} rows with a Table 3 column were compared"
    checks.verify()


def test_fit_page_table_3_in_prose(table3, fixed_point, checks):
    """fit.md: the Table 3 figures its prose quotes (the own gait's R^2 on single files, to 3
    to 5 decimals), and the paper's gait's spectral radius (1.007: unstable)."""
    t3 = table3
    checks.passage("fit.md", r"\(iterates capped at rho_32 0\.91.*?knee 0\.753 / hip 0\.729 "
                   r"\(Table 3 NUM / NUM\)", t3["WBDS09_late"]["r2_knee"],
                   t3["WBDS09_late"]["r2_hip"])
    checks.passage("fit.md", r"\| same, WBDS10_late \| .*?knee 0\.779 / hip 0\.679 \(Table 3 "
                   r"NUM / NUM\)", t3["WBDS10_late"]["r2_knee"], t3["WBDS10_late"]["r2_hip"])
    checks.passage("fit.md", r"knee / hip 0\.8675 / 0\.9377 \(Table 3: NUM / NUM\)",
                   t3["WBDS20_mean"]["r2_knee"], t3["WBDS20_mean"]["r2_hip"])
    checks.passage("fit.md", r"above Table 3 \(knee / hip 0\.660 / 0\.647 against NUM / NUM\)",
                   t3["WBDS18_late"]["r2_knee"], t3["WBDS18_late"]["r2_hip"])
    checks.passage("fit.md", r"WBDS09_hip\+ 0\.805 → 0\.814 \(Table 3 NUM\), WBDS18_early "
                   r"0\.821 → 0\.827 \(NUM\), WBDS18_hip\+ 0\.746 → 0\.758 \(NUM,",
                   t3["WBDS09_hip+"]["r2_knee"], t3["WBDS18_early"]["r2_knee"],
                   t3["WBDS18_hip+"]["r2_knee"])
    checks.passage("fit.md", r"\(both above Table 3's NUM\)", t3["WBDS18_hip+"]["r2_hip"])
    checks.passage("fit.md", r"\(the bundled file: knee 0\.863 against NUM\)",
                   t3["female_fast"]["r2_knee"])
    checks.passage("fit.md", r"WBDS18_early 0\.82663 against NUM, on its knee floor",
                   t3["WBDS18_early"]["r2_knee"])
    checks.passage("fit.md", r"\(0\.82663 against NUM\)", t3["WBDS18_early"]["r2_knee"])
    checks.passage("fit.md", r"WBDS18_early 0\.8269 against NUM,", t3["WBDS18_early"]["r2_knee"])
    fp = fixed_point("humanlike_6link")
    checks.passage("fit.md", r"Table 3's own gait is unstable \(rho NUM\)", fp["spectral_radius"])
    checks.truth("fit.md", "Table 3's own gait is unstable", not fp["stable"])
    checks.verify()


def test_fit_page_the_corpus_spread(checks):
    """fit.md (and data/corpus/README.md): the corpus's one-SD deformations, knee range
    ±4.01°, hip offset ±3.49°, timing ±1.74 % of the cycle: as ``spread.json`` records
    them, as the sample SDs of its per-subject values, and as the corpus files deform each
    subject's mean curves."""
    spread = read_json(DATA / "corpus" / "spread.json")
    knee_sd = np.std(spread["knee_range_deg"], ddof=1)
    hip_sd = np.std(spread["hip_mean_deg"], ddof=1)
    times = np.asarray(spread["landmark_times_pct"], float)
    timing_sd = math.sqrt(np.mean(np.std(times, axis=0, ddof=1) ** 2))
    knee, hip = [], []
    for s in spread["subjects"]:
        mean = pd.read_csv(DATA / "corpus" / f"{s}_mean.csv")
        for sign in (1, -1):
            mark = "+" if sign > 0 else "-"
            k = pd.read_csv(DATA / "corpus" / f"{s}_knee{mark}.csv")
            h = pd.read_csv(DATA / "corpus" / f"{s}_hip{mark}.csv")
            knee.append(sign * (np.ptp(k.knee_mean_deg) - np.ptp(mean.knee_mean_deg)))
            hip.append(sign * (h.hip_mean_deg.mean() - mean.hip_mean_deg.mean()))
    checks.passage("fit.md", r"six one-SD deformations \(knee range ±NUM°, hip offset ±NUM°, "
                   r"timing ±NUM % of the cycle\)",
                   (spread["knee_range_sd_deg"], knee_sd, *knee),
                   (spread["hip_offset_sd_deg"], hip_sd, *hip),
                   (spread["timing_sd_pct"], timing_sd))
    checks.passage("fit.md", r"the `late` deformation \(every curve NUM % of the cycle later\)",
                   spread["timing_sd_pct"])
    checks.verify()


def test_per_leg_fit_page_the_sides_and_the_stride_bound(checks):
    """per-leg-fit.md: WBDS09's sides differ by 1.7° RMS in the knee and 1.6° in the hip
    (``data/subjects/WBDS09_fast_sides.csv``); the stride radius is held to 0.8281 (the
    fit's accepted radius over two steps, 0.91^2)."""
    from pdw_casadi.fit import FitOptions

    sides = pd.read_csv(DATA / "subjects" / "WBDS09_fast_sides.csv")

    def rms(name):
        d = sides[f"{name}_left_mean_deg"] - sides[f"{name}_right_mean_deg"]
        return float(np.sqrt(np.mean(d ** 2)))
    checks.passage("per-leg-fit.md", r"WBDS09's sides differ by NUM° RMS in the knee, NUM° in "
                   r"the hip", rms("knee"), rms("hip"))
    bound = FitOptions().accepted_radius(2)
    checks.passage("per-leg-fit.md", r"stride radius against its NUM bound", bound)
    checks.passage("per-leg-fit.md", r"stride radius 0\.56 against the bound NUM", bound)
    checks.verify()


# -- the options the pages quote ---------------------------------------------------------------
def test_the_defaults_the_pages_quote(checks):
    """fit-settings.md, fit.md, prosthesis.md: the defaults of ``FitOptions`` and
    ``DesignNLPOptions`` the pages name as the current ones."""
    from pdw_casadi.fit import FitOptions
    from pdw_casadi.studies.prosthesis import DesignNLPOptions

    o, d = FitOptions(), DesignNLPOptions()
    checks.passage("fit-settings.md", r"`start_r2_tolerance` = NUM", o.start_r2_tolerance)
    checks.passage("fit-settings.md", r"`segment_headroom_s` = NUM", o.segment_headroom_s)
    checks.passage("fit.md", r"The rule that stays: `FitOptions\.mu_max = NUM`", o.mu_max)
    checks.passage("fit.md", r"`FitOptions\.stall_window` \(NUM\), `stall_rtol` \(NUM\), "
                   r"`stall_infeasibility` \(NUM\)", o.stall_window, o.stall_rtol,
                   o.stall_infeasibility)
    checks.passage("fit.md", r"\(the `polish_keep` = NUM lowest-objective ones within "
                   r"`polish_infeasibility` = NUM\)", o.polish_keep, o.polish_infeasibility)
    checks.passage("fit.md", r"\(`nlp\.driver\.Stall\.zigzag`; "
                   r"`FitOptions\.stall_plateau_infeasibility` NUM, `stall_wander` NUM\)",
                   o.stall_plateau_infeasibility, o.stall_wander)
    checks.passage("fit.md", r"the default slack is now NUM \(`FitOptions\.iterate_radius_slack`",
                   o.iterate_radius_slack)
    checks.passage("fit.md", r"The NLP now holds knee R² NUM above the floor "
                   r"\(`FitOptions\.knee_floor_margin`\)", o.knee_floor_margin)
    checks.passage("fit.md", r"`stability_power=NUM` \(now the default\) bounds "
                   r"\$\\lVert J\^8 \\rVert_F\^\{1/8\}\$ by NUM", o.stability_power,
                   o.radius_bound(1))
    checks.passage("fit.md", r"\(`FitOptions\.rounds`, default NUM\)", o.rounds)
    checks.passage("fit.md", r"\*\*`FitOptions\.sample_stride` 2 to NUM\*\*", o.sample_stride)
    checks.passage("fit.md", r"IPOPT's `tol` \(NUM, in the rows' own units", o.tol)
    checks.passage("fit.md", r"re-simulated to 2\.0e-5 \(the bound is NUM\)", o.resim_tol)
    checks.passage("prosthesis.md", r"\*\*First step\*\* \(`--first-step`, default NUM\)",
                   d.first_step)
    checks.passage("prosthesis.md", r"\(`--max-iter`, default NUM\)", d.max_iter)
    checks.passage("prosthesis.md", r"\*\*Symmetry tolerance\*\* \(`--symmetry-tol`, default "
                   r"NUM\)", d.symmetry_tol_pct)
    checks.passage("prosthesis.md", r"\*\*Shortest segment\*\* \(`DesignNLPOptions\.t_min_s`, "
                   r"NUM s\)", d.t_min_s)
    checks.verify()


def test_prosthesis_page_the_study_tables_are_the_stored_study(checks):
    """prosthesis.md, "A prosthetist's study": ``docs/results/prosthetist/study.csv`` (the
    table ``scripts/make_prosthetist_study.py`` writes, from which the site build draws the
    page's figure) holds the page's two tables number for number: per level the per-step
    radius, validity, asymmetries and both legs' R², and both legs' compliance."""
    stored = pd.read_csv(RESULTS / "prosthetist" / "study.csv")
    gait = table("prosthesis.md", "knee R² sound / prosthetic")
    comp = table("prosthesis.md", "| lighter (%) | leg |")
    reached = stored[stored["converged"].astype(bool)]
    assert [r["lighter (%)"] for r in gait] == [f"{v:g}" for v in stored["lighter_pct"]]
    assert len(comp) == 2 * len(reached)
    for (_, got), row in zip(stored.iterrows(), gait, strict=True):
        if not got["converged"]:
            checks.truth("prosthesis.md", f"{row['lighter (%)']} %: not reached",
                         row["spectral radius per step"] == "not reached")
            continue
        checks.number("prosthesis.md", row["spectral radius per step"], got["step_radius"])
        checks.truth("prosthesis.md", f"{row['lighter (%)']} %: valid",
                     row["valid"] == ("yes" if got["valid"] else "no"))
        pairs = [("step length / time asymmetry (%)", "step_length_asymmetry_pct",
                  "step_time_asymmetry_pct"),
                 ("knee R² sound / prosthetic", "r2_knee_left", "r2_knee_right"),
                 ("hip R² sound / prosthetic", "r2_hip_left", "r2_hip_right")]
        for head, a, b in pairs:
            first, second = (v.strip() for v in row[head].split("/"))
            checks.number("prosthesis.md", first, got[a], what=f"{row['lighter (%)']} % {a}")
            checks.number("prosthesis.md", second, got[b], what=f"{row['lighter (%)']} % {b}")
    legs = {"sound": "left", "prosthetic": "right"}
    rows = [(got, leg) for _, got in reached.iterrows() for leg in ("sound", "prosthetic")]
    for (got, leg), row in zip(rows, comp, strict=True):
        checks.truth("prosthesis.md", f"compliance row {row['lighter (%)']} {row['leg']}",
                     row["lighter (%)"] == f"{got['lighter_pct']:g}" and row["leg"] == leg)
        for key in [k for k in row if k not in ("lighter (%)", "leg")]:
            checks.number("prosthesis.md", row[key], got[f"{legs[leg]}.{key}"],
                          what=f"{row['lighter (%)']} % {leg} {key}")
    checks.verify()


def test_prosthesis_page_the_study_in_prose(checks):
    """prosthesis.md, "A prosthetist's study": the prose's figures from
    ``docs/results/prosthetist/study.csv`` (left = sound, right = prosthetic): the fitted
    walker's R² and radius, the levels, the radii and asymmetries that run out, the legs'
    R² ranges (the prosthetic leg's over the lighter levels: at 0 % it is the sound leg),
    the changes up to 20 % and the gait at 30 %. The changes (%) are relative to the fitted
    walker, the 0 % row, which is both legs' (the page's figures come out of that base and
    not of the previous level: prosthetic c_knee_flex at 20 % is +38 % of the 0 % row,
    +25 % of the 10 % row)."""
    from pdw_casadi.studies.prosthetist import StudyOptions, study_design_options

    study = pd.read_csv(RESULTS / "prosthetist" / "study.csv").set_index("lighter_pct")
    at = study.loc
    name = "prosthesis.md"
    design = study_design_options()
    levels = [100 * v for v in StudyOptions().levels]
    checks.truth(name, "the study's levels are the stored table's",
                 list(study.index) == [0.0, *levels])
    checks.truth(name, "every level reached, stable and valid",
                 bool(study["converged"].all() and study["valid"].all()
                      and (study["stride_radius"] < 1).all()))
    checks.truth(name, "the fitted walker is symmetric: both legs the sound leg",
                 all(at[0, f"left.{k}"] == at[0, f"right.{k}"] for k in KEYS))
    checks.passage(name, r"\(the one-step fit: \d+ iterations, knee / hip R² NUM / NUM, "
                   r"spectral radius NUM\)", at[0, "r2_knee_left"], at[0, "r2_hip_left"],
                   at[0, "step_radius"])
    checks.passage(name, r"asymmetries up to NUM %\) whose mass homotopy stops at NUM and NUM "
                   r"% on its way to NUM %", design.symmetry_tol_pct, *levels)
    tol = design.symmetry_tol_pct
    checks.passage(
        name, r"The spectral radius per step climbs from NUM to NUM at NUM % and reaches the "
        r"design's bound \(stride radius NUM, NUM per step\) at NUM % \(NUM at NUM %\); the "
        r"step-time asymmetry uses NUM of its NUM % tolerance at NUM %",
        at[0, "step_radius"], at[10, "step_radius"], 10,
        (design.max_stride_radius - design.radius_margin, at[20, "stride_radius"]),
        at[20, "step_radius"], 20, at[30, "step_radius"], 30,
        abs(at[10, "step_time_asymmetry_pct"]), tol, 10)
    checks.truth(name, "the step-time asymmetry uses all of its tolerance from 20 % on",
                 all(round(abs(at[p, "step_time_asymmetry_pct"]), 3) == tol for p in (20, 30)))
    lighter = study[study.index > 0]
    checks.passage(
        name, r"The sound leg's knee R² stays at NUM-NUM while its hip R² falls from NUM to "
        r"NUM at NUM %; .*? \(knee NUM-NUM, hip NUM-NUM\)",
        study["r2_knee_left"].min(), study["r2_knee_left"].max(), at[0, "r2_hip_left"],
        at[30, "r2_hip_left"], 30, lighter["r2_knee_right"].min(),
        lighter["r2_knee_right"].max(), lighter["r2_hip_right"].min(),
        lighter["r2_hip_right"].max())
    r2 = study.filter(like="r2_").round(3)  # as the page's table prints them
    checks.truth(name, "the prosthetic leg fits the sound side as well as or better than the "
                 "sound leg at every level",
                 bool((r2["r2_knee_right"] >= r2["r2_knee_left"]).all()
                      and (r2["r2_hip_right"] >= r2["r2_hip_left"]).all()))

    def change(level, leg, key):
        return 100 * (at[level, f"{leg}.{key}"] / at[0, f"{leg}.{key}"] - 1)

    bound, = passage(name, r"k_ankle, c_ankle and k_knee of both legs within NUM % of the "
                     r"fitted values")
    moved = max(abs(change(p, leg, k)) for p in (10, 20) for leg in ("left", "right")
                for k in ("k_ankle", "c_ankle", "k_knee"))
    checks.truth(name, f"up to 20 % k_ankle, c_ankle, k_knee move {moved:.2f} %, within "
                 f"{bound} %", moved <= float(bound))
    checks.passage(
        name, r"\(prosthetic `c_knee_flex` NUM %, `c_knee_ext` NUM %, `c_knee_stance` NUM %; "
        r"sound `c_knee_flex` NUM %, `c_knee_stance` NUM %\) and the knee springs' release "
        r"angles \(sound theta_eq NUM % and theta_dis NUM %, prosthetic theta_dis NUM %\)",
        change(20, "right", "c_knee_flex"), change(20, "right", "c_knee_ext"),
        change(20, "right", "c_knee_stance"), change(20, "left", "c_knee_flex"),
        change(20, "left", "c_knee_stance"), change(20, "left", "theta_eq"),
        change(20, "left", "theta_dis"), change(20, "right", "theta_dis"))
    flex = [at[30, f"{leg}.c_knee_flex"] / at[0, f"{leg}.c_knee_flex"]
            for leg in ("left", "right")]
    checks.passage(
        name, r"\(k_ankle NUM and NUM against NUM N m/rad\), the knees' flexion damping "
        r"NUM-NUM times the fitted one .*? \(theta_eq NUM, theta_dis NUM rad, its lower bound\)",
        at[30, "left.k_ankle"], at[30, "right.k_ankle"],
        (at[0, "left.k_ankle"], at[0, "right.k_ankle"]), min(flex), max(flex),
        at[30, "left.theta_eq"], at[30, "left.theta_dis"])
    problem = tomllib.loads((ROOT / "problems" / "humanlike_6link.toml").read_text("utf-8"))
    lower = problem["compliance_bounds"]["theta_dis"][0]
    checks.truth(name, "the sound knee's theta_dis at 30 % is on its lower bound",
                 round(at[30, "left.theta_dis"] - lower, 4) == 0)
    checks.verify()


def test_prosthesis_page_the_design_speed_tables(checks):
    """prosthesis.md, "Checks at every fifth sample": each row's per-step iterations and
    IPOPT seconds in the prose sum to its "iterations" and, divided, to its "IPOPT s per
    iteration"; the time ratio is the two "whole design" cells'. "Tried and not kept: each
    step started near the last answer": the step table's IPOPT seconds are within the whole
    run's, and the warm run's counts (five steps' iterations and the large steps') add up to
    its solves and, but for the steps printed without a count (each at most ``--max-iter``),
    its iterations."""
    name = "prosthesis.md"
    rows = {r["every"]: r for r in table(name, "IPOPT s per iteration")}
    prose = {"5th sample": r"The steps at every fifth sample \([^)]*\): (.*?); IPOPT ([\d., "
                           r"and]+?) s\.",
             "2nd sample": r"At every second sample: (.*?); IPOPT ([\d., and]+?) s\."}
    for every, pattern in prose.items():
        steps, seconds = passage(name, pattern)
        # the parentheses hold the answer's iteration index, not a count: left out
        counts = [int(v) for v in numbers(re.sub(r"\([^)]*\)", "", steps))]
        times = [Decimal(v) for v in numbers(seconds)]
        row = rows[every]
        checks.truth(name, f"{every}: one count and one time per solve",
                     len(counts) == len(times) == int(row["solves"]))
        checks.figure(name, row["iterations"], Decimal(sum(counts)), what=f"{every}: iterations")
        checks.figure(name, row["IPOPT s per iteration"], sum(times) / int(row["iterations"]),
                      what=f"{every}: IPOPT s per iteration")
    whole = {e: Decimal(numbers(r["whole design"])[0]) for e, r in rows.items()}
    ratio, = passage(name, r"\*\*NUM of the time\*\*")
    checks.figure(name, ratio, whole["5th sample"] / whole["2nd sample"], what="time ratio")

    # the step table (steps as columns) under "did not carry it": the page's third with it
    step = {r["step (% lighter)"]: r for r in table(name, "| step (% lighter) | 0.3 |", 2)}
    secs = [Decimal(v) for k, v in step["IPOPT s"].items() if k != "step (% lighter)"]
    total, = passage(name, r"did not carry it: \*\*NUM s\*\* against")
    checks.truth(name, f"the step table's IPOPT {sum(secs)} s is part of the whole {total} s",
                 len(secs) == 8 and sum(secs) < Decimal(total))
    # the warm run: the five small steps, then the large ones up to "**919 s** in 13 solves"
    *_, small, large, _, solves, iters = passage(
        name, r"\*\*five steps to NUM % in NUM s\*\* \(([\d, and]+) iterations, .*?but the "
        r"large ones do not: (.*?): \*\*NUM s\*\* in NUM solves and NUM iterations")
    five = [int(v) for v in numbers(small)]
    levels = re.findall(NUM + r" %", large)  # "9.3 -> 18.9 %": the step's target only
    counted = [int(v) for v in re.findall(r"(?:at |its |\()(\d+)\b", large)]
    max_iter, = passage(name, r"\(`--max-iter`, default NUM\)")
    checks.truth(name, f"the warm run: {len(five)} + {len(levels)} steps, {solves} solves",
                 len(five) == 5 and len(five) + len(levels) == int(solves))
    checks.truth(name, f"the warm run: {iters} iterations, the steps' own "
                 f"{sum(five)} + {sum(counted)} (each at most {max_iter})",
                 len(counted) == len(levels) and int(iters) == sum(five) + sum(counted)
                 and max(five + counted) <= int(max_iter))
    checks.verify()


# -- fit.md, performance.md: the corpus runs' totals restate their tables ----------------------
class Run:
    """A corpus run's table on fit.md (one row per file), its columns as the page prints
    them: the wall times, the iterations (a restart's ``39+27``: their sum), the statuses,
    the answers' rho, re-simulation and R² (the rows with an answer)."""

    def __init__(self, rows: list[dict[str, str]], wall: str = "whole command s"):
        self.rows = rows
        self.by = {r["file"].split(" ")[0]: r for r in rows}
        self.wall = [r[wall] for r in rows]
        self.wall_places = decimals(self.wall)
        self.iterations = [sum(map(int, r["iterations"].split("+"))) for r in rows]
        self.status = [r["status"] for r in rows]
        self.done = [r for r in rows if r["knee"] not in ("-", "nan")]
        self.rho = [r["rho"] for r in self.done]
        self.resim = [r["re-sim"] for r in self.done]

    def median_wall(self) -> Decimal:
        return statistics.median(Decimal(w) for w in self.wall)

    def median_iterations(self) -> Decimal:
        return statistics.median(Decimal(n) for n in self.iterations)

    def total_wall(self) -> Decimal:
        return sum(Decimal(w) for w in self.wall)

    def within(self, limit: float) -> list[bool | None]:
        return [within(w, limit) for w in self.wall]

    def above_table_3(self, mean: bool = False) -> list[bool | None]:
        """Per answer: its knee R² (``mean``: the mean of knee and hip) above Table 3's."""
        out = []
        for r in self.done:
            knee, hip = numbers(r["Table 3 knee / hip"])
            if mean:
                out.append(exceeds(plus(span(r["knee"]), span(r["hip"])),
                                   plus(span(knee), span(hip))))
            else:
                out.append(exceeds(span(r["knee"]), span(knee)))
        return out


def _runs() -> dict[str, Run]:
    """fit.md's corpus tables by the run they are of."""
    return {"before": Run(table("fit.md", "missed (besides time)", 0), "wall s"),
            "floor": Run(table("fit.md", "missed (besides time)", 2), "wall s"),
            "cap": Run(table("fit.md", "| wall s | fit s |"), "wall s"),
            "power": Run(table("fit.md", "e0f3ace (schur)"), "wall s"),
            "process": Run(table("fit.md", "whole command s | status | iterations |", 0)),
            "rows": Run(table("fit.md", "whole command s | status | iterations |", 1)),
            "zigzag": Run(table("fit.md", "whole command s | status | iterations |", 2))}


def _run_figures(checks: Checks, name: str, run: Run, printed: dict[str, str]) -> None:
    """The figures of ``run`` that a sentence prints, by kind: ``median`` / ``max`` /
    ``min`` / ``total`` wall time, ``iterations`` median, ``most`` / ``fewest`` iterations,
    ``rho_min`` / ``rho_max``, ``within_<s>`` counts, ``resim`` bound."""
    w = run.wall_places
    walls = [Decimal(x) for x in run.wall]
    rho = [Decimal(x) for x in run.rho]
    for kind, text in printed.items():
        what = f"{kind} of the table"
        if kind == "median":
            checks.figure(name, text, run.median_wall(), w, what)
        elif kind == "max":
            checks.figure(name, text, max(walls), w, what)
        elif kind == "min":
            checks.figure(name, text, min(walls), w, what)
        elif kind == "total":
            checks.figure(name, text, run.total_wall(), w, what)
        elif kind == "iterations":
            checks.figure(name, text, run.median_iterations(), what=what)
        elif kind == "most":
            checks.figure(name, text, Decimal(max(run.iterations)), what=what)
        elif kind == "fewest":
            checks.figure(name, text, Decimal(min(run.iterations)), what=what)
        elif kind == "rho_min":
            checks.figure(name, text, min(rho), decimals(run.rho), what)
        elif kind == "rho_max":
            checks.figure(name, text, max(rho), decimals(run.rho), what)
        elif kind.startswith("within_"):
            checks.tally(name, text, run.within(float(kind[7:])), what)
        elif kind == "resim":
            checks.bound(name, text, run.resim, what)
        else:
            raise AssertionError(kind)


def _sentence(checks: Checks, name: str, run: Run, pattern: str, *kinds: str) -> tuple:
    """The numbers of ``pattern``'s groups against ``run``'s figures of ``kinds`` (one per
    group; "" skips a group); the groups."""
    groups = passage(name, pattern)
    assert len(groups) == len(kinds), pattern
    _run_figures(checks, name, run, {k: g for k, g in zip(kinds, groups, strict=True) if k})
    return groups


def test_fit_page_the_loaded_corpus_runs_totals(checks):
    """fit.md: the totals under the corpus tables of the loaded machine (before, with the
    knee floor, the cap, the eight-step bound): counts of statuses, stable and valid
    answers, knee and mean R² above Table 3, the wall times' median, maximum and total, the
    iterations' median, the radii, from the table above each (a restart's iterations
    summed; a count the printed digits leave open, such as a knee printed equal to Table
    3's against "above", may go either way)."""
    runs = _runs()
    name = "fit.md"
    run = runs["before"]
    n, ok, good, resim, knee, mean, med, top = passage(
        name, r"Totals \(NUM files\): NUM Solve_Succeeded, NUM stable and valid "
        r"\(re-simulation < NUM\), knee \$R\^2\$ above Table 3 on NUM, mean\(knee, hip\) above "
        r"Table 3 on NUM; no file within 15 s \(median NUM s, max NUM s, on the loaded")
    missed = [r["missed (besides time)"] for r in run.done]
    checks.number(name, n, len(run.rows), what="files")
    checks.number(name, ok, run.status.count("Solve_Succeeded"), what="Solve_Succeeded")
    checks.number(name, good, sum("stable" not in m and "valid" not in m for m in missed),
                  what="stable and valid")
    checks.tally(name, knee, run.above_table_3(), what="knee above Table 3")
    checks.tally(name, mean, run.above_table_3(mean=True), what="mean above Table 3")
    _run_figures(checks, name, run, {"resim": resim, "median": med, "max": top})
    checks.truth(name, "no file within 15 s", not any(run.within(15)))
    checks.truth(name, "both failures are the late deformation",
                 [r["file"] for r in run.rows if r["knee"] == "-"]
                 == ["WBDS09_late", "WBDS10_late"])

    run = runs["floor"]
    n, ok, acceptable = passage(name, r"Totals \(NUM files\): NUM Solve_Succeeded and one "
                                r"Solved_To_Acceptable_Level \((\w+-?),")
    checks.number(name, n, len(run.rows), what="files")
    checks.number(name, ok, run.status.count("Solve_Succeeded"), what="Solve_Succeeded")
    checks.truth(name, f"{acceptable} the one Solved_To_Acceptable_Level",
                 [r["file"] for r in run.rows if r["status"] == "Solved_To_Acceptable_Level"]
                 == [acceptable])
    stable, rho, valid, first, second = passage(
        name, r"all NUM stable \(rho <= NUM\); NUM valid \((\S+) and (\S+) miss a "
        r"centre-of-pressure margin")
    checks.number(name, stable, sum(Decimal(r) < 1 for r in run.rho), what="stable")
    _run_figures(checks, name, run, {"rho_max": rho})
    invalid = [r["file"] for r in run.done if "valid" in r["missed (besides time)"]]
    checks.number(name, valid, len(run.done) - len(invalid), what="valid")
    checks.truth(name, f"{first} and {second} invalid", invalid == [first, second])
    resim, knee, mean = passage(name, r"re-simulation < NUM on all; knee R² at or above Table "
                                r"3's on all NUM .*?; mean\(knee, hip\) above Table 3's on all "
                                r"NUM\. WBDS10_late")
    _run_figures(checks, name, run, {"resim": resim})
    checks.tally(name, knee, run.above_table_3(), what="knee at or above Table 3")
    checks.tally(name, mean, run.above_table_3(mean=True), what="mean above Table 3")
    checks.passage(name, r"WBDS10_late, at the iteration limit before the two stability rules, "
                   r"converges in NUM iterations", run.iterations[
                       [r["file"] for r in run.rows].index("WBDS10_late")])
    _sentence(checks, name, run, r"No file within 15 s \(median NUM s on the loaded", "median")
    checks.truth(name, "no file within 15 s (the knee floor)", not any(run.within(15)))
    before = runs["before"]
    checks.passage(name, r"WBDS09_hip\+ NUM → NUM \(Table 3 [\d.]+\), WBDS18_early NUM → NUM "
                   r"\([\d.]+\), WBDS18_hip\+ NUM → NUM \(",
                   *(float(r.by[f]["knee"]) for f in ("WBDS09_hip+", "WBDS18_early",
                                                      "WBDS18_hip+") for r in (before, run)))

    run = runs["cap"]
    groups = passage(
        name, r"Totals \(NUM files\): NUM Solve_Succeeded, all NUM stable \(rho <= NUM\), "
        r"valid, re-simulation < NUM; knee R² above Table 3's on NUM \((\S+) ends on its knee "
        r"floor, equal to Table 3's NUM\), mean\(knee, hip\) above Table 3's on all NUM; two "
        r"files at the iteration limit \((\S+), (\S+)\); no file within 15 s \(median NUM s, "
        r"total NUM s on the loaded machine; iterations median NUM\)")
    n, ok, stable, rho, resim, knee, floor, t3, mean, lim1, lim2, med, total, its = groups
    checks.number(name, n, len(run.rows), what="files")
    checks.number(name, ok, run.status.count("Solve_Succeeded"), what="Solve_Succeeded")
    checks.number(name, stable, sum(Decimal(r) < 1 for r in run.rho), what="stable")
    checks.tally(name, knee, run.above_table_3(), what="knee above Table 3")
    checks.number(name, t3, float(numbers(run.by[floor]["Table 3 knee / hip"])[0]))
    checks.truth(name, f"{floor}'s knee equals Table 3's",
                 run.by[floor]["knee"] == numbers(run.by[floor]["Table 3 knee / hip"])[0])
    checks.tally(name, mean, run.above_table_3(mean=True), what="mean above Table 3")
    checks.truth(name, f"{lim1}, {lim2} at the iteration limit",
                 [r["file"] for r in run.rows if r["status"] == "Maximum_Iterations_Exceeded"]
                 == [lim1, lim2])
    _run_figures(checks, name, run, {"rho_max": rho, "resim": resim, "median": med,
                                     "total": total, "iterations": its})
    checks.truth(name, "no file within 15 s (the cap)", not any(run.within(15)))

    run, cap = runs["power"], runs["cap"]
    groups = passage(
        name, r"Totals \(NUM files\): \*\*NUM Solve_Succeeded\*\* \(e0f3ace: NUM, two at the "
        r"iteration limit\), all stable \(rho NUM-NUM: .*?\), valid, re-simulation < NUM "
        r"\(e0f3ace: up to NUM\); knee R² above Table 3's on NUM \(WBDS18_early .*?\), "
        r"mean\(knee, hip\) above on all NUM; iterations median NUM, at most NUM \((\S+)\); "
        r"whole command median \*\*NUM s\*\*, at most NUM s, NUM of NUM within 15 s, total NUM "
        r"s \(e0f3ace: median NUM s loaded, total NUM s\)\. The price is knee R²: NUM-NUM "
        r"lower than the schur row's where both converged \(WBDS20_knee- NUM against NUM, "
        r"WBDS20_early NUM against NUM\)")
    (n, ok, ok_cap, lo, hi, resim, resim_cap, knee, mean, its, most, most_file, med, top,
     fast, n2, total, med_cap, total_cap, d_lo, d_hi, k1, s1, k2, s2) = groups
    checks.number(name, n, len(run.rows), what="files")
    checks.number(name, n2, len(run.rows), what="files")
    checks.number(name, ok, run.status.count("Solve_Succeeded"), what="Solve_Succeeded")
    checks.number(name, ok_cap, cap.status.count("Solve_Succeeded"), what="e0f3ace's")
    checks.truth(name, "all stable", all(Decimal(r) < 1 for r in run.rho))
    checks.number(name, resim_cap, max(float(x) for x in cap.resim), what="e0f3ace re-sim")
    checks.tally(name, knee, run.above_table_3(), what="knee above Table 3")
    checks.tally(name, mean, run.above_table_3(mean=True), what="mean above Table 3")
    checks.truth(name, f"the most iterations are {most_file}'s",
                 run.by[most_file]["iterations"] == most)
    _run_figures(checks, name, run, {"rho_min": lo, "rho_max": hi, "resim": resim,
                                     "iterations": its, "most": most, "median": med,
                                     "max": top, "within_15": fast, "total": total})
    _run_figures(checks, name, cap, {"median": med_cap, "total": total_cap})
    schur = "e0f3ace (schur): wall s, iterations, knee, rho"
    checks.truth(name, "the last column is the cap run's", all(
        r[schur] == ", ".join(c[k] for k in ("wall s", "iterations", "knee", "rho"))
        for r, c in zip(run.rows, cap.rows, strict=True)))
    lower = [Decimal(cap.by[f]["knee"]) - Decimal(r["knee"]) for f, r in run.by.items()
             if cap.by[f]["knee"] != "nan"]
    checks.figure(name, d_lo, min(lower), 3, "the least knee R² lost")
    checks.figure(name, d_hi, max(lower), 3, "the most knee R² lost")
    for printed, r in ((k1, run.by["WBDS20_knee-"]), (s1, cap.by["WBDS20_knee-"]),
                       (k2, run.by["WBDS20_early"]), (s2, cap.by["WBDS20_early"])):
        checks.number(name, printed, float(r["knee"]), what="a knee R² of the tables")
    checks.verify()


def test_fit_page_the_process_corpus_runs_totals(checks):
    """fit.md and performance.md: the totals under the corpus tables of ``bench_fit.py
    --corpus --process`` (the first one, with the new rows, with the zig-zag stall, and
    this session's three runs, whose per-file table is the last run's): radii, statuses,
    the wall times' median, maximum, total and counts within a limit, the iterations'
    median, each against the table above it and the "before" figures against the table of
    the run before. A count of files "above 10 s" leaves open the files printed 10.0."""
    runs = _runs()
    name = "fit.md"
    run, power = runs["process"], runs["power"]
    groups = passage(
        name, r"Totals: \*\*NUM of NUM stable\*\* \(rho NUM-NUM\), \*\*valid\*\*, re-simulated "
        r"to < NUM; every final solve Solve_Succeeded; knee R² and mean\(knee, hip\) at or "
        r"above the problem file's on \*\*all NUM\*\* \(before the floor margin: NUM\)\. "
        r"Iterations median \*\*NUM\*\* \(the previous corpus run: NUM\)\. Whole command: "
        r"median \*\*NUM s\*\*, at most NUM s \((\S+), NUM iterations\), NUM of NUM within 20 "
        r"s, total NUM s\. One file stalled: (\S+) stopped at NUM iterations and its warm "
        r"restart converged in NUM \(NUM in all;")
    (stable, n, lo, hi, resim, every, before, its, its_power, med, top, slow, slow_its,
     within_20, n2, total, stalled, first, restart, both) = groups
    for printed in (n, n2, every):
        checks.number(name, printed, len(run.rows), what="files")
    checks.number(name, stable, sum(Decimal(r) < 1 for r in run.rho), what="stable")
    checks.truth(name, "every final solve Solve_Succeeded",
                 all(s.endswith("Solve_Succeeded") for s in run.status))
    for what, outcomes in (("knee", run.above_table_3()),
                           ("mean", run.above_table_3(mean=True))):
        checks.truth(name, f"{what} R² at or above Table 3's on all",
                     not any(o is False for o in outcomes))
    checks.tally(name, before, power.above_table_3(), what="knee above Table 3 (before)")
    _run_figures(checks, name, run, {"rho_min": lo, "rho_max": hi, "resim": resim,
                                     "iterations": its, "median": med, "max": top,
                                     "within_20": within_20, "total": total})
    _run_figures(checks, name, power, {"iterations": its_power})
    checks.truth(name, f"the slowest file is {slow}, {slow_its} iterations",
                 run.by[slow]["whole command s"] == top
                 and run.by[slow]["iterations"] == slow_its)
    checks.truth(name, f"{stalled} stalled: {first}+{restart} = {both} iterations",
                 run.by[stalled]["iterations"] == f"{first}+{restart}"
                 and int(first) + int(restart) == int(both)
                 and "User_Requested_Stop" in run.by[stalled]["status"])

    run, before = runs["rows"], runs["process"]
    groups = passage(
        name, r"Totals: \*\*NUM of NUM stable\*\* \(rho NUM-NUM\), \*\*valid\*\*, re-simulated "
        r"to < NUM; every solve Solve_Succeeded, none stalled \((\S+) converged in NUM "
        r"iterations, before it stalled at NUM and restarted\); knee R² and mean\(knee, hip\) "
        r"at or above the problem file's on all NUM, every R² the same as in the previous "
        r"corpus run to the printed digits but (\S+)'s \(knee / thigh NUM / NUM against NUM / "
        r"NUM\)\. Whole command: median \*\*NUM s\*\* \(before NUM s\), at most \*\*NUM s\*\* "
        r"\((\S+), NUM iterations; before NUM s\), \*\*NUM of NUM within 20 s\*\* \(before "
        r"NUM\), total NUM s \(before NUM s\)\. Iterations median NUM \(before NUM\)")
    (stable, n, lo, hi, resim, again, again_its, stalled_at, every, changed, k, t, k0, t0,
     med, med0, top, slow, slow_its, top0, within_20, n2, within_0, total, total0, its,
     its0) = groups
    for printed in (n, n2, every):
        checks.number(name, printed, len(run.rows), what="files")
    checks.number(name, stable, sum(Decimal(r) < 1 for r in run.rho), what="stable")
    checks.truth(name, "every solve Solve_Succeeded",
                 set(run.status) == {"Solve_Succeeded"})
    checks.truth(name, f"{again}: {again_its} iterations, before stalled at {stalled_at}",
                 run.by[again]["iterations"] == again_its
                 and before.by[again]["iterations"].split("+")[0] == stalled_at)
    for outcomes in (run.above_table_3(), run.above_table_3(mean=True)):
        checks.truth(name, "R² at or above Table 3's on all",
                     not any(o is False for o in outcomes))
    differ = [f for f, r in run.by.items()
              if any(r[c] != before.by[f][c] for c in ("knee", "hip", "thigh"))]
    checks.truth(name, f"only {changed}'s R² changed (the table: {differ})", differ == [changed])
    for printed, value in ((k, run.by[changed]["knee"]), (t, run.by[changed]["thigh"]),
                           (k0, before.by[changed]["knee"]),
                           (t0, before.by[changed]["thigh"])):
        checks.number(name, printed, float(value), what=f"{changed}'s R²")
    checks.truth(name, f"the slowest file is {slow}, {slow_its} iterations",
                 run.by[slow]["whole command s"] == top
                 and run.by[slow]["iterations"] == slow_its)
    _run_figures(checks, name, run, {"rho_min": lo, "rho_max": hi, "resim": resim,
                                     "median": med, "max": top, "within_20": within_20,
                                     "total": total, "iterations": its})
    _run_figures(checks, name, before, {"median": med0, "max": top0, "within_20": within_0,
                                        "total": total0, "iterations": its0})

    run, before = runs["zigzag"], runs["rows"]
    groups = passage(
        name, r"Totals: \*\*NUM of NUM stable\*\* \(rho NUM-NUM\), \*\*valid\*\*, re-simulated "
        r"to < NUM; NUM solves Solve_Succeeded, one stopped as a zig-zag \((\S+), NUM "
        r"iterations, its best feasible iterate: knee / hip NUM / NUM against NUM / NUM when "
        r"IPOPT ran on to NUM\); knee R² and mean\(knee, hip\) at or above the problem file's "
        r"on all NUM\. Whole command: median \*\*NUM s\*\* \(before NUM s\), at most \*\*NUM "
        r"s\*\* \((\S+); before NUM s\), \*\*NUM of NUM within 20 s\*\*, NUM within 10 s, total "
        r"NUM s \(before NUM s\); iterations median NUM\. .*? The median file needs NUM "
        r"iterations")
    (stable, n, lo, hi, resim, ok, zig, zig_its, k, h, k0, h0, its0_zig, every, med, med0,
     top, slow, top0, within_20, n2, within_10, total, total0, its, its_again) = groups
    for printed in (n, n2, every):
        checks.number(name, printed, len(run.rows), what="files")
    checks.number(name, stable, sum(Decimal(r) < 1 for r in run.rho), what="stable")
    checks.number(name, ok, run.status.count("Solve_Succeeded"), what="Solve_Succeeded")
    checks.truth(name, f"{zig} stopped as a zig-zag, {zig_its} iterations",
                 run.by[zig]["status"].startswith("stalled (zig-zag)")
                 and run.by[zig]["iterations"] == zig_its)
    for printed, value in ((k, run.by[zig]["knee"]), (h, run.by[zig]["hip"]),
                           (k0, before.by[zig]["knee"]), (h0, before.by[zig]["hip"]),
                           (its0_zig, before.by[zig]["iterations"])):
        checks.number(name, printed, float(value), what=f"{zig} in the two runs")
    for outcomes in (run.above_table_3(), run.above_table_3(mean=True)):
        checks.truth(name, "R² at or above Table 3's on all (zig-zag run)",
                     not any(o is False for o in outcomes))
    checks.truth(name, f"the slowest file is {slow}", run.by[slow]["whole command s"] == top)
    _run_figures(checks, name, run, {"rho_min": lo, "rho_max": hi, "resim": resim,
                                     "median": med, "max": top, "within_20": within_20,
                                     "within_10": within_10, "total": total,
                                     "iterations": its})
    _run_figures(checks, name, run, {"iterations": its_again})
    _run_figures(checks, name, before, {"median": med0, "max": top0, "total": total0})

    # the session's three runs: their table of totals against the last run's per-file table
    last = table("fit.md", "knee / hip R² | spectral radius")
    per_file = Run([{**r, "status": "", "knee": "-"} for r in last])
    summary = table("fit.md", "| run | whole command: median, max, total |")
    now = next(r for r in summary if "**now**" in r["run"])
    med, top, total = numbers(now["whole command: median, max, total"])
    _run_figures(checks, name, per_file, {"median": med, "max": top, "total": total})
    checks.tally(name, now["files above 10 s"],
                 [None if o is None else not o for o in per_file.within(10)],
                 what="files above 10 s")
    for row in summary[:3]:  # the iterations are the same in all three runs of the session
        its, its_total = numbers(row["iterations: median, total"])
        _run_figures(checks, name, per_file, {"iterations": its})
        checks.figure(name, its_total, Decimal(sum(per_file.iterations)),
                      what="iterations in all")
    earlier = next(r for r in summary if "89adf82" in r["run"])
    med, top = numbers(earlier["whole command: median, max, total"])
    _run_figures(checks, name, runs["zigzag"], {"median": med, "max": top})

    # performance.md quotes the zig-zag run
    n, lo, hi, med, fewest, most = passage(
        "performance.md", r"the NUM corpus files take NUM to NUM s each for the whole "
        r"command, median NUM s, NUM to NUM IPOPT iterations at about 0\.25 s each \(measured "
        r"at commit 89adf82")
    checks.number("performance.md", n, len(run.rows), what="files")
    _run_figures(checks, "performance.md", run, {"min": lo, "max": hi, "median": med,
                                                 "fewest": fewest, "most": most})
    checks.verify()


# -- per-leg-fit.md: sums and ratios of its tables ---------------------------------------------
def _iterations_and_wall(cell: str) -> tuple[int, Decimal]:
    """A cell "123 + 54 (stalled, restart), 157.9 s" (bold or not): the iterations summed
    and the wall time."""
    m = re.fullmatch(r"\**([\d +]+?)(?: \([^)]*\))?, ([\d.]+) s\**", cell)
    assert m, f"not iterations and a wall time: {cell!r}"
    return sum(map(int, m.group(1).split("+"))), Decimal(m.group(2))


def test_per_leg_fit_page_sums_of_its_tables(checks):
    """per-leg-fit.md: the sum of 1 - R² of the start and of the fit (the table's four R²;
    the fit's 0.849 is its objective 0.8493, which the table's rounded R² give to within
    their rounding, 4 x 0.0005), the warm start's totals over the four subjects (iterations
    and whole commands per start), the counts the prose quotes from that table, a stride
    iteration's cost from the next table, its "before" column (the first table's warm
    starts) and how far WBDS18's and WBDS20's answers moved (the largest R² difference)."""
    name = "per-leg-fit.md"
    first = table(name, "stride radius | IPOPT iterations")

    def loss(row):
        r2 = [Decimal(v) for side in ("left", "right") for v in numbers(row[side])]
        assert len(r2) == 4
        return 4 - sum(r2)
    start, fit = first[0], first[1]
    assert fit["command"] == "`pdw-fit --gait data/subjects/WBDS09_fast_sides.csv`"
    objective, = passage(name, r"the stride NLP ends Solve_Succeeded in \d+ iterations at "
                         r"objective NUM")
    s0, s1 = passage(name, r"the sum of 1 - R² falls from NUM \(the symmetric fit repeated\) "
                     r"to NUM")
    checks.figure(name, s0, loss(start), 3, "the start's sum of 1 - R²")
    checks.number(name, s1, float(objective), what="the fit's sum of 1 - R²: its objective")
    checks.truth(name, f"the table's R² give the objective {objective} within their rounding",
                 abs(loss(fit) - Decimal(objective)) <= 4 * Decimal("0.0005"))

    warm = {r["subject"]: r for r in table(name, "warm, equal blocks only")}
    columns = ("warm, all rows", "warm, equal blocks only", "cold start (before)")
    cells = {c: [_iterations_and_wall(r[c]) for r in warm.values()] for c in columns}
    groups = passage(name, r"In all: NUM stride iterations with all rows mapped, NUM with "
                     r"equal blocks only, NUM cold; whole commands NUM s, NUM s, NUM s\.")
    for printed, c in zip(groups[:3], columns, strict=True):
        checks.figure(name, printed, Decimal(sum(i for i, _ in cells[c])), what=f"{c}: its")
    for printed, c in zip(groups[3:], columns, strict=True):
        checks.figure(name, printed, sum(w for _, w in cells[c]), 1, f"{c}: wall")
    checks.passage(name, r"\(WBDS20: NUM and NUM\)",
                   _iterations_and_wall(warm["WBDS20"]["warm, equal blocks only"])[0],
                   _iterations_and_wall(warm["WBDS20"]["warm, all rows"])[0])
    checks.passage(name, r"WBDS10, which converges, is slower warm \(NUM against NUM\)",
                   _iterations_and_wall(warm["WBDS10"]["warm, all rows"])[0],
                   _iterations_and_wall(warm["WBDS10"]["cold start (before)"])[0])

    later = {r["subject"]: r for r in table(name, "| symmetric start | stride NLP |")}
    cost = {s: [Decimal(v) for v in numbers(later[s]["stride NLP"])] for s in ("WBDS09",
                                                                             "WBDS10")}
    per = [wall / n for n, wall in cost.values()]
    checks.passage(name, r"a stride iteration costs NUM-NUM s \(NUM s / NUM, NUM s / NUM\)",
                   min(per), max(per), cost["WBDS09"][1], cost["WBDS09"][0],
                   cost["WBDS10"][1], cost["WBDS10"][0])
    head = "whole command (before: the table above, all rows)"
    for s, row in later.items():
        _, before = numbers(row[head])
        checks.number(name, before, float(_iterations_and_wall(warm[s]["warm, all rows"])[1]),
                      what=f"{s}: the whole command before")
    moved = max(abs(Decimal(a) - Decimal(b)) for s in ("WBDS18", "WBDS20")
                for a, b in zip(numbers(later[s]["left knee / hip"])
                                + numbers(later[s]["right knee / hip"]),
                                numbers(warm[s]["answer, all rows: left knee / hip, right "
                                             "knee / hip"]), strict=True))
    checks.passage(name, r"their answers are within NUM in R² of the table above", moved)
    checks.verify()


def test_per_leg_fit_page_the_strides_row_and_memory(checks):
    """per-leg-fit.md, the stride's eight-step row and its L-BFGS memory: the totals and
    counts the prose draws from their tables (whole commands summed, certified answers
    counted, each table against the one before it)."""
    name = "per-leg-fit.md"

    def cells(cell: str) -> tuple[bool, Decimal]:
        """A cell "24 + 79, certified, 80.9 s": certified or not, and the wall time."""
        m = re.fullmatch(r"[\d +]+, ([\w ,-]+?), \**([\d.]+) s\**", cell)
        assert m, f"not solves, an outcome and a wall time: {cell!r}"
        return m.group(1) == "certified", Decimal(m.group(2))

    row = table(name, "whole command (sixteen-step row)")
    now = [Decimal(numbers(r["whole command (sixteen-step row)"])[0]) for r in row]
    before = [Decimal(numbers(r["whole command (sixteen-step row)"])[1]) for r in row]
    total, total_before = passage(name, r"Total NUM s against NUM s; the same two files "
                                  r"certified")
    checks.figure(name, total, sum(now), 1, "the eight-step row's total")
    checks.figure(name, total_before, sum(before), 1, "the sixteen-step row's total")
    checks.tally(name, "2", [r["certified"] == "yes" for r in row], "certified files")

    mem = table(name, "50 on the stride only: solves, whole command")
    six = [cells(r["history 6: solves, whole command"]) for r in mem]
    fifty = [cells(r["50 on the stride only: solves, whole command"]) for r in mem]
    got = passage(name, r"Certified NUM of NUM against NUM of NUM, NUM s against NUM s in all")
    checks.tally(name, got[0], [c for c, _ in fifty], "certified with 50")
    checks.tally(name, got[2], [c for c, _ in six], "certified with 6")
    checks.truth(name, "eight files in the memory table", got[1] == got[3] == str(len(mem)))
    checks.figure(name, got[4], sum(w for _, w in fifty), 1, "the total with 50")
    checks.figure(name, got[5], sum(w for _, w in six), 1, "the total with 6")
    # its history-6 paper-body rows are the eight-step row's table
    for r, (_, w), t in zip(mem[:4], six[:4], now, strict=True):
        checks.truth(name, f"{r['per-side file']}: the same run in both tables", w == t)
    checks.verify()


# -- cohort.md: figures of the stored cohort table ---------------------------------------------
def test_cohort_page_figures_of_the_stored_cohort(checks):
    """cohort.md: figures the prose draws from ``docs/results/cohort.csv``: the per-side
    fits' largest stride radius and its per-step square root, the paper-body fits' R²
    against the earlier radius-bounded ones the page quotes, the own-body table's "paper
    body" column, the own bodies' knee R² lost and hip R² moved against the paper body, their
    compliance ranges, the eight-step bound's cost in knee R², and the CPU range of the
    paper-body table."""
    name = "cohort.md"
    stored = pd.read_csv(RESULTS / "cohort.csv", dtype=str, keep_default_na=False)

    def fits(kind, body):
        rows = stored[(stored["kind"] == kind) & (stored["body"] == body)]
        return rows.set_index("subject_id")
    paper, own, sides = fits("symmetric", "paper"), fits("symmetric", "own"), fits("sides",
                                                                                "own")
    top = max(float(v) for v in sides["stride_spectral_radius"])
    checks.passage(name, r"stable \(stride rho at most NUM, per step its square root, at most "
                   r"NUM\)", top, math.sqrt(top))
    # the paper body against the earlier radius-bounded fit
    m = find(name, r"knee / hip (NUM / NUM, NUM / NUM, NUM / NUM, NUM / NUM)\): the same "
             r"\$R\^2\$ to within NUM except WBDS20's knee \(NUM against NUM\) and hip \(NUM "
             r"against NUM\)")
    earlier = numbers(m.group(1))
    pairs = dict(zip(paper.index, zip(earlier[::2], earlier[1::2], strict=True), strict=True))
    moved = max(abs(Decimal(paper.loc[s, f"r2_{c}"]) - Decimal(pairs[s][i]))
                for s in paper.index if s != "WBDS20" for i, c in enumerate(("knee", "hip")))
    checks.passage(name, r"the same \$R\^2\$ to within NUM except WBDS20's knee \(NUM against "
                   r"NUM\) and hip \(NUM against NUM\)", moved,
                   float(paper.loc["WBDS20", "r2_knee"]), float(pairs["WBDS20"][0]),
                   float(paper.loc["WBDS20", "r2_hip"]), float(pairs["WBDS20"][1]))
    cpu = [Decimal(r["CPU (s)"]) for r in table(name, "| rho | status |")]
    lo, hi = passage(name, r"on the paper's body below cost NUM to NUM CPU seconds")
    checks.figure(name, lo, min(cpu), 1, "the least CPU")
    checks.figure(name, hi, max(cpu), 1, "the most CPU")
    # the own bodies
    for row in table(name, "body: spectral radius"):
        knee, hip = numbers(row["paper body: knee / hip"])
        s = row["subject"]
        checks.number(name, knee, float(paper.loc[s, "r2_knee"]), what=f"{s}: paper knee")
        checks.number(name, hip, float(paper.loc[s, "r2_hip"]), what=f"{s}: paper hip")
    lost = [float(paper.loc[s, "r2_knee"]) - float(own.loc[s, "r2_knee"]) for s in own.index]
    hip = max(abs(float(own.loc[s, "r2_hip"]) - float(paper.loc[s, "r2_hip"]))
              for s in own.index)
    checks.passage(name, r"On their own bodies knee R² is NUM to NUM \*\*lower\*\* than on the "
                   r"paper's body for the same curves and hip R² about the same \(within ±NUM\)",
                   min(lost), max(lost), hip)
    k_knee = [float(v) for v in own["k_knee_N_m_per_rad"]]
    k_ankle = [float(v) for v in own["k_ankle_N_m_per_rad"]]
    checks.passage(name, r"Compliance on the own bodies: k_knee NUM-NUM N m/rad, k_ankle "
                   r"NUM-NUM N m/rad", min(k_knee), max(k_knee), min(k_ankle), max(k_ankle))
    m = find(name, r"gave knee (NUM / NUM / NUM / NUM): the eight-step bound costs WBDS18 NUM "
             r"and WBDS20 NUM of knee R² on these bodies, and WBDS20 takes NUM iterations")
    before = dict(zip(own.index, map(float, numbers(m.group(1))), strict=True))
    checks.passage(name, r"the eight-step bound costs WBDS18 NUM and WBDS20 NUM of knee R² on "
                   r"these bodies, and WBDS20 takes NUM iterations",
                   before["WBDS18"] - float(own.loc["WBDS18", "r2_knee"]),
                   before["WBDS20"] - float(own.loc["WBDS20", "r2_knee"]),
                   int(own.loc["WBDS20", "iterations"]))
    checks.truth(name, "the eight-step bound costs WBDS09 and WBDS10 nothing", all(
        as_printed(before[s], "0.000") == own.loc[s, "r2_knee"] for s in ("WBDS09", "WBDS10")))
    checks.verify()


# -- faults.md, toes.md: the corpora the scripts build -----------------------------------------
def _script(name: str):
    """``scripts/<name>.py`` as a module."""
    path = ROOT / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"_pages_{name}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_faults_page_the_cases_by_kind(tmp_path, checks):
    """faults.md: the cases of ``scripts/faults.py`` (its ``make_cases``, without running
    them) by kind, in all, the ones the page's ``-k`` re-runs select, and the file-size
    limits' range."""
    faults = _script("faults")
    cases = faults.make_cases(faults.make_files(tmp_path))
    kinds = [c.kind for c in cases]
    name = "faults.md"
    rows = table(name, "| kind | cases |")
    checks.truth(name, "the table names every kind once",
                 sorted(r["kind"] for r in rows) == sorted(set(kinds)))
    for row in rows:
        checks.number(name, row["cases"], kinds.count(row["kind"]), what=f"{row['kind']} cases")
    checks.passage(name, r"\(`python scripts/faults\.py`, [\d-]+, idle 2 cores\): \d+ of NUM",
                   len(cases))
    checks.passage(name, r"An earlier run the same day: NUM cases", len(cases))

    def selected(k):
        return sum(k in c.id for c in cases)
    checks.passage(name, r"\(`-k signal-fixed-point-solving`: \d+ of NUM, `-k "
                   r"signal-design-imports`: \d+ of NUM\)", selected("signal-fixed-point-solving"),
                   selected("signal-design-imports"))
    checks.passage(name, r"`python scripts/faults\.py -k concurrent` gives \d+ of NUM",
                   selected("concurrent"))
    limits = [c.fsize for c in cases if c.kind == "fsize"]
    checks.passage(name, r"`RLIMIT_FSIZE` of NUM B to NUM MB", min(limits), max(limits) / 1e6)
    checks.verify()


def test_toes_page_the_sampled_ranges(checks):
    """toes.md: the compliance ranges ``pdw-seed toes`` samples by default
    (``pdw_casadi.studies.seed_run.TOES_RANGES``), each key in the page's order."""
    from pdw_casadi.studies.seed_run import TOES_RANGES

    drawn = find("toes.md", r"--samples 2000 --seed 0` \([\d.]+ s\) draws (.*?) and simulates "
                 r"one step").group(1)
    listed = re.findall(rf"(\w+) {NUM}-{NUM}", drawn)
    checks.truth("toes.md", f"the page's keys {[k for k, _, _ in listed]} are TOES_RANGES'",
                 [k for k, _, _ in listed] == list(TOES_RANGES))
    for key, lo, hi in listed:
        if key in TOES_RANGES:
            checks.number("toes.md", lo, TOES_RANGES[key][0], what=f"{key}: from")
            checks.number("toes.md", hi, TOES_RANGES[key][1], what=f"{key}: to")
    checks.verify()


# -- fit.md: the data files it counts ----------------------------------------------------------
def test_fit_page_the_corpus_and_atlas_files(checks):
    """fit.md: ``data/corpus``'s one-curve and per-side files, the gait file's samples
    (``data/female_fast.csv``, and every corpus file as many), and the atlas's entries
    (``data/atlas/humanlike_6link.json``: the walker's own curves, the cohort mean and its
    six deformations at one radius, two entries at another)."""
    name = "fit.md"
    files = sorted((DATA / "corpus").glob("*.csv"))
    sides = [p for p in files if p.stem.endswith("_sides")]
    one = [p for p in files if p not in sides]
    checks.passage(name, r"and the per-side file: NUM one-curve files and NUM per-side files",
                   len(one), len(sides))
    subjects = read_json(DATA / "corpus" / "spread.json")["subjects"]
    checks.truth(name, "one per-side file per subject of the corpus",
                 [p.stem.removesuffix("_sides") for p in sides] == sorted(subjects))
    samples = len(pd.read_csv(DATA / "female_fast.csv"))
    checks.passage(name, r"the rows held the gait file's NUM knee and hip angles", samples)
    checks.truth(name, f"every corpus file has {samples} samples",
                 all(len(pd.read_csv(p)) == samples for p in files))
    entries = read_json(DATA / "atlas" / "humanlike_6link.json")["entries"]
    checks.passage(name, r"the corpus's files start from the NUM atlas entries", len(entries))
    radius = [float(e["label"].rsplit("-rho", 1)[1]) for e in entries]
    new, kept = sorted(set(radius), reverse=True)
    targets = sorted(p.stem for p in (DATA / "atlas" / "targets").glob("*.csv"))
    checks.truth(name, "at the first radius: the own curves, female_fast and its six "
                 "deformations", sorted(e["label"] for e, r in zip(entries, radius, strict=True)
                                        if r == new)
                 == sorted(f"humanlike_6link-{c}-rho{new:g}"
                           for c in ("own", "female_fast", *targets))
                 and len(targets) == 6 and radius.count(kept) == 2)
    checks.passage(name, r"deformations \(knee range, hip offset and timing .*?\), each at "
                   r"radius NUM; the two NUM entries", new, kept)
    checks.verify()
