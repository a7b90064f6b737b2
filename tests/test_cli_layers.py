"""The commands are thin (issue 46): a module of ``pdw_casadi.cli`` parses, checks its
arguments through the layer that owns each rule, calls one workflow of ``studies`` and
writes through ``report``. It imports from the package only ``cli``, ``studies``,
``report``, ``model`` (loading a problem and its data) and ``engine`` (errors, JSON output,
the process pool), never the gait, NLP or fit layers; and the reports the commands write
through import no solver."""

from __future__ import annotations

from test_imports import PACKAGE, SOLVERS, import_graph

#: the layers a command module may import from
CLI_MAY_IMPORT = ("cli", "studies", "report", "model", "engine")
#: modules of cli allowed another import, with the reason (none today)
EXCEPTIONS: dict[str, str] = {}
#: modules outside the layers a command may import, with the reason
OUTSIDE_LAYERS = {"pdw_casadi._version": "the package's version string (the contract's "
                                         "--version), no layer's code"}
#: the reports written by the thin commands
REPORTS = ("simulate_report", "fixed_point_report", "scale_report", "atlas_report",
           "design_report", "sweep_report", "seed_report", "compare_report",
           "conditioning_report", "sweep_timing_report")


def cli_layer_violations(root=PACKAGE) -> list[str]:
    """Every import (module level or in a function) of a ``cli`` module that reaches a
    layer outside :data:`CLI_MAY_IMPORT`."""
    top, nested = import_graph(root)
    bad = []
    for module in sorted(top):
        if module.split(".")[1:2] != ["cli"] or module in EXCEPTIONS:
            continue
        for target in sorted(top[module] | nested[module]):
            parts = target.split(".")
            if target in OUTSIDE_LAYERS:
                continue
            if len(parts) > 1 and parts[1] not in CLI_MAY_IMPORT:
                bad.append(f"{module} imports {target}")
    return bad


def test_every_command_imports_only_workflows_reports_model_and_engine():
    assert cli_layer_violations() == []


def test_every_exception_says_why():
    assert all(reason.strip() for reason in [*EXCEPTIONS.values(),
                                             *OUTSIDE_LAYERS.values()])


def test_the_cli_check_finds_a_gait_import(tmp_path):
    pkg = tmp_path / "pkg"
    for sub in ("cli", "gait", "studies"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "gait" / "stride.py").write_text("X = 1\n")
    (pkg / "studies" / "run.py").write_text("from pkg.gait.stride import X\n")
    (pkg / "cli" / "ok.py").write_text("from pkg.studies.run import X\n")
    (pkg / "cli" / "bad.py").write_text(
        "def main():\n    # deferred: test\n    from pkg.gait.stride import X\n    return X\n")
    assert cli_layer_violations(pkg) == ["pkg.cli.bad imports pkg.gait.stride"]


def test_the_commands_reports_only_render():
    top, nested = import_graph(PACKAGE)
    for name in REPORTS:
        module = f"pdw_casadi.report.{name}"
        reached = top[module] | nested[module]
        # no workflow either (its result types under TYPE_CHECKING only): a workflow module
        # would bring the solvers in with it
        bad = sorted(m for m in reached if m.split(".")[1] in ("gait", "nlp", "fit", "studies")
                     or any(m == s or m.startswith(s + ".") for s in SOLVERS))
        assert not bad, f"{module} imports {bad}"
