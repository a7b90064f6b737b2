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

Left out on purpose: wall and CPU times; anything from a fit, a cohort, a design run or a
benchmark (minutes each); numbers a page gives as history ("before ...", "measured
before ..."). The toe-foot walker's two sampled scans (about 40 s each) and the heel-radius
sweep (kept out of the default run to hold it within a minute) are marked slow:
``pytest -m slow tests/test_results_pages.py``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import math
import re
import tomllib
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

    def truth(self, name: str, what: str, ok: bool) -> None:
        """A fact the page states in words (valid, stable, a failure's name)."""
        if not ok:
            self.failures.append(f"docs/results/{name}: {what}")

    def verify(self) -> None:
        assert not self.failures, "\n".join(self.failures)


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
