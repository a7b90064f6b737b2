"""The workflows of ``pdw-design`` and ``pdw-sweep`` (studies.design_run, studies.sweep_run)
and their reports (report.design_report, report.sweep_report): the command parses, checks,
calls one workflow and writes through the report; the workflow computes; the report only
renders."""

from __future__ import annotations

import ast
import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from test_imports import PACKAGE, SOLVERS, import_graph

from pdw_casadi.engine.errors import NoGait, ProblemError
from pdw_casadi.model.problem import load_problem
from pdw_casadi.report.design_report import (
    design_gait_lines,
    design_headline,
    write_designed_walker,
)
from pdw_casadi.studies import sweep_run
from pdw_casadi.studies.design_run import (
    DesignRequest,
    check_compliance_keys,
    check_mass_distribution,
    run_design,
)
from pdw_casadi.studies.prosthesis import (
    DesignSolve,
    ProsthesisResult,
    atlas_problem,
    prosthetic_problem,
)
from pdw_casadi.studies.sweep_run import SweepRequest, check_sweep, run_sweep

DEG = math.pi / 180
#: the modules of the two commands, their workflows and their reports
MODULES = ("cli.design", "cli.sweep", "studies.design_run", "studies.sweep_run",
           "report.design_report", "report.sweep_report")


def test_no_function_of_the_commands_workflows_and_reports_is_over_120_lines():
    long = []
    for name in MODULES:
        path = PACKAGE.joinpath(*name.split(".")).with_suffix(".py")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > 120:
                    long.append(f"{name}.{node.name}: {lines} lines")
    assert long == []


def test_the_commands_import_only_workflows_reports_and_model_loading():
    top, nested = import_graph(PACKAGE)
    for command in ("pdw_casadi.cli.design", "pdw_casadi.cli.sweep"):
        reached = top[command] | nested[command]
        bad = sorted(m for m in reached if m.split(".")[1] not in ("cli", "studies", "report")
                     and m != "pdw_casadi.model.problem")
        assert not bad, f"{command} imports {bad}"


def test_the_design_and_sweep_reports_only_render():
    top, nested = import_graph(PACKAGE)
    workflows = ("pdw_casadi.studies.design_run", "pdw_casadi.studies.sweep_run",
                 "pdw_casadi.studies.prosthesis", "pdw_casadi.gait.sweep")
    for module in ("pdw_casadi.report.design_report", "pdw_casadi.report.sweep_report"):
        reached = top[module] | nested[module]
        bad = sorted(m for m in reached if m in workflows or any(
            m == s or m.startswith(s + ".") for s in SOLVERS))
        assert not bad, f"{module} imports {bad}"


# -- the design --------------------------------------------------------------------------------
def _stand_in(calls: list, report: bool = True):
    """A design function that returns a made-up design at once (the solve is not under test
    here): the walker 20 % lighter, a stride report (or none), two NLP solves."""
    def design(problem, **kw):
        calls.append(kw)
        rep = {"legs": {"left": {"step_length_m": 0.5, "step_time_s": 0.6, "stance_pct": 61.0},
                        "right": {"step_length_m": 0.51, "step_time_s": 0.61,
                                  "stance_pct": 60.0}},
               "step_length_asymmetry_pct": 1e-3, "step_time_asymmetry_pct": 2e-3,
               "double_support_pct": 11.0} if report else None
        solves = [DesignSolve(0.1, "Solve_Succeeded", 12, 1.5, 0.7, 0.6, 0.01, 0.02, True,
                              [], True),
                  DesignSolve(0.2, "Maximum_Iterations_Exceeded", 100, 9.0, 0.8, 0.7, 0.02,
                              0.03, True, [], True, fallback_iteration=87)]
        return ProsthesisResult(prosthetic_problem(problem, 0.2),
                                SimpleNamespace(spectral_radius=0.64, valid=True), rep,
                                {"k_ankle": 1.23456}, [(0.0, None, None), (0.2, None, None)],
                                True, 1.0, solves, {}, {})
    return design


def test_run_design_calls_the_method_asked_and_the_report_renders_it(tmp_path):
    start = atlas_problem()
    nlp_calls, cont_calls = [], []
    request = DesignRequest(lighter=0.2, free=("k_ankle", "k_knee"))
    run = run_design(start, request, nlp=_stand_in(nlp_calls),
                     continuation=_stand_in(cont_calls))
    assert cont_calls == [] and nlp_calls[0]["free"] == ("k_ankle", "k_knee")
    assert nlp_calls[0]["options"] is request.options and nlp_calls[0]["lighter"] == 0.2
    assert run.has_gait and run.stable and run.wall_time_s >= 0
    assert run.lighter_reached == pytest.approx(0.2)
    head = design_headline(run, "atlas entry x")
    assert head[0] == "start: atlas entry x; target: right shank+foot 20 % lighter; method nlp"
    assert head[1].startswith("reached 20.00 % lighter in 2 NLP solves: right shank+foot "
                              "20.00 % lighter")
    lines = design_gait_lines(run)
    assert lines[0] == "step length L/R 0.50000 / 0.51000 m (asymmetry 1.00e-03 %)"
    assert "prosthetic-leg compliance: k_ankle = 1.2346" in lines
    assert lines[-1].startswith("wall time ")
    # a solve that stopped short says which iterate it answered with; a success does not
    solve_lines = [ln for ln in lines if ln.startswith("  NLP ")]
    assert "best feasible" not in solve_lines[0]
    assert "(100 iter, 9.0 s; its best feasible iterate, iteration 87)" in solve_lines[1]
    path = write_designed_walker(run, tmp_path / "d.toml")
    assert path.read_text().startswith("# written by pdw-design\n")
    assert load_problem(path).asymmetric  # the lighter leg is in the file

    cont = run_design(start, DesignRequest(method="continuation", hold_first_phase=False),
                      nlp=_stand_in(nlp_calls), continuation=_stand_in(cont_calls))
    assert cont_calls == [{"lighter": 0.3, "hold_first_phase": False}]
    assert design_headline(cont, "here")[1].startswith("reached lambda = 0.2000 (2 points)")
    none = run_design(start, DesignRequest(), nlp=_stand_in([], report=False))
    assert not none.has_gait
    with pytest.raises(ProblemError, match="unknown design method"):
        run_design(start, DesignRequest(method="guess"))


def test_design_rules_name_what_the_walker_has():
    start = atlas_problem()
    check_compliance_keys(start, ("k_ankle",))
    check_compliance_keys(start, (), required=False)
    with pytest.raises(ProblemError, match="^no key given; the humanlike_6link walker's"):
        check_compliance_keys(start, ())
    with pytest.raises(ProblemError, match="^kneee; the humanlike_6link walker's compliance"):
        check_compliance_keys(start, ("k_knee", "kneee"), required=False)
    check_mass_distribution(("l_fc", "J_f"))
    with pytest.raises(ProblemError, match="^foo not among l_sc, J_s, l_fc, J_f$"):
        check_mass_distribution(("foo",))


# -- the sweep ---------------------------------------------------------------------------------
def test_run_sweep_hands_every_row_over_as_it_is_found_and_the_report_renders_it(tmp_path):
    from pdw_casadi.report.sweep_report import (
        SweepRows,
        sweep_lines,
        sweep_units,
        write_sweep_report,
    )

    problem = load_problem("compass_gait")
    request = SweepRequest("slope", 3 * DEG, 6 * DEG, num=4)
    units = sweep_units(problem)
    rows = SweepRows(tmp_path / "rows.csv", units)
    covered = []
    run = run_sweep(problem, request, on_row=rows.append, progress=covered.append)
    table = run.result.table
    assert rows.count == len(table) and sum(covered) == 4
    np.testing.assert_allclose(run.result.grid, request.grid)
    written = pd.read_csv(rows.path)
    assert len(written) == len(table) and "slope_rad" in written.columns
    events, figure = write_sweep_report(run, tmp_path, units)
    assert events.name == "events.json" and figure.stat().st_size > 0
    lines = sweep_lines(run)
    assert lines[0].startswith(f"{len(table)} points (")


def test_check_sweep_and_a_start_without_a_gait():
    problem = load_problem("compass_gait")
    check_sweep(problem, "slope", [("--from 0.05", 0.05), ("--to 0.06", 0.06)])
    with pytest.raises(ProblemError, match="no parameter 'nope'"):
        check_sweep(problem, "nope", [])
    with pytest.raises(ProblemError, match="^--to 0.9: slope = 0.9 rad must be below"):
        check_sweep(problem, "slope", [("--to 0.9", 0.9)])
    lost = problem.with_state({"q_st": 1.2, "dq_st": 5.0})
    with pytest.raises(NoGait, match="no valid fixed point at the start"):
        run_sweep(lost, SweepRequest("slope", 0.05, 0.06, num=3))


def test_refit_sweeps_with_the_fit_as_corrector(monkeypatch):
    from pdw_casadi.fit import RefitCorrector

    seen = {}

    def sweep(problem, values, **kw):
        seen.update(kw)
        return "result"

    monkeypatch.setattr(sweep_run, "sweep", sweep)
    problem = load_problem("humanlike_6link")
    curves = object()
    run = run_sweep(problem, SweepRequest("slope", 0.14, 0.15, num=3, gait="female_fast.csv",
                                          refit=True), curves)
    assert run.result == "result" and isinstance(seen["corrector"], RefitCorrector)
    assert seen["corrector"].human is curves and seen["gait"] == "female_fast.csv"
    run_sweep(problem, SweepRequest("slope", 0.14, 0.15, num=3))
    assert seen["corrector"] is None
