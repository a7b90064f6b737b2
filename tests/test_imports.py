"""The package's import graph: no cycle, none hidden behind a function-level import, every
function-level import saying why it is deferred, and no module that switches the matplotlib
backend when imported."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pdw_casadi

PACKAGE = Path(pdw_casadi.__file__).resolve().parent


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(node: ast.ImportFrom, module: str, is_pkg: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".")
    if not is_pkg:
        base.pop()
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST):
    """(import node, inside a function?) for every import statement that runs."""
    stack = [(tree, False)]
    while stack:
        node, in_function = stack.pop()
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_type_checking(child):
                continue  # annotations only, never executed
            if isinstance(child, ast.Import | ast.ImportFrom):
                yield child, in_function
            fn = isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
            stack.append((child, in_function or fn))


def import_graph(root: Path) -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """Edges between the modules of the package at ``root``: (top-level, function-level).

    An edge a -> b means module a imports module b (``from .b import x`` and ``from . import
    b`` alike). The implicit import of a parent package is left out: a package's
    ``__init__`` re-exporting its submodules is not a cycle.
    """
    files = sorted(root.rglob("*.py"))
    modules = {_module_name(f, root): f for f in files}
    top: dict[str, set[str]] = {m: set() for m in modules}
    nested: dict[str, set[str]] = {m: set() for m in modules}

    def targets(node, module, is_pkg):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            base = _resolve(node, module, is_pkg)
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                     for a in node.names]
        out = set()
        for name in names:
            while name and name not in modules:  # ``import a.b.c`` imports a.b.c's module
                name = name.rpartition(".")[0]
            if name and name != module:
                out.add(name)
        return out

    for module, path in modules.items():
        is_pkg = path.name == "__init__.py"
        for node, in_function in _imports(ast.parse(path.read_text())):
            (nested if in_function else top)[module] |= targets(node, module, is_pkg)
    return top, nested


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph (as a list of nodes, first = last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def dfs(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(edges.get(u, ())):
            if state.get(v) == 1:
                return stack[stack.index(v):] + [v]
            if v not in state and (c := dfs(v)):
                return c
        stack.pop()
        state[u] = 2
        return None

    for u in sorted(edges):
        if u not in state and (c := dfs(u)):
            return c
    return None


def _both(top, nested):
    return {m: top[m] | nested[m] for m in top}


def test_no_import_cycle_at_module_level():
    top, _ = import_graph(PACKAGE)
    assert len(top) > 30 and sum(map(len, top.values())) > 50  # the graph was read
    assert find_cycle(top) is None, " -> ".join(find_cycle(top))


def test_no_function_level_import_hides_a_cycle():
    # a function-level import deferred on purpose (an optional dependency, a command's heavy
    # part) is fine, but if moving it to the top would close a cycle it only hides one
    top, nested = import_graph(PACKAGE)
    cycle = find_cycle(_both(top, nested))
    assert cycle is None, "hidden import cycle: " + " -> ".join(cycle)


def test_the_graph_check_finds_cycles_it_should(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("from .a import f\n")
    (pkg / "a.py").write_text("from .sub import b\n\ndef f():\n    return b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text(textwrap.dedent("""
        from typing import TYPE_CHECKING
        if TYPE_CHECKING:
            from ..a import f
        def g():
            from .. import a
            return a
    """))
    top, nested = import_graph(pkg)
    assert top["pkg.a"] == {"pkg.sub.b"} and nested["pkg.sub.b"] == {"pkg.a"}
    assert find_cycle(top) is None  # the TYPE_CHECKING import is not an edge
    assert find_cycle(_both(top, nested)) == ["pkg.a", "pkg.sub.b", "pkg.a"]


#: the comment that says why an import sits inside a function (docs/architecture.md)
DEFERRED = "# deferred:"


def _import_runs(body: list) -> Iterator[list]:
    """The runs of import statements one after another in a list of statements."""
    run: list = []
    for stmt in [*body, None]:
        if isinstance(stmt, ast.Import | ast.ImportFrom):
            run.append(stmt)
        elif run:
            yield run
            run = []


def _undeclared(node: ast.AST, lines: list[str], in_function: bool = False):
    """The import statements under ``node`` that run inside a function and do not say why."""
    for _, value in ast.iter_fields(node):
        if in_function and isinstance(value, list):
            for run in _import_runs(value):
                said = lines[max(run[0].lineno - 2, 0):run[-1].end_lineno]
                if not any(DEFERRED in line for line in said):
                    yield from run
        for child in value if isinstance(value, list) else [value]:
            if isinstance(child, ast.AST) and not (
                    isinstance(child, ast.If) and _is_type_checking(child)):
                yield from _undeclared(child, lines, in_function or isinstance(
                    child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda))


def undeclared_deferrals(root: Path) -> list[str]:
    """Imports inside a function (outside ``if TYPE_CHECKING:``) that do not say why: no
    ``# deferred:`` comment on their lines or on the line above (for a run of imports one
    after another, the line above the run's first), as ``module: import``."""
    bad = []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text()
        module = _module_name(path, root)
        bad += [f"{module}: {ast.unparse(n)}"
                for n in _undeclared(ast.parse(text), text.splitlines())]
    return bad


def test_every_function_level_import_says_why_it_is_deferred():
    # imports are at module level; one left in a function on purpose (an optional
    # dependency, a command's heavy part kept out of its start-up) says why
    bad = undeclared_deferrals(PACKAGE)
    assert bad == [], "\n".join(bad)


def test_the_deferral_check_finds_an_import_that_does_not_say_why(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text(textwrap.dedent("""
        import os
        from typing import TYPE_CHECKING

        if TYPE_CHECKING:
            import json


        def f():
            # deferred: optional
            import csv
            import json

            from os import path
            return csv, json, path


        def g():
            try:
                import sys  # deferred: optional
            except ImportError:
                return None
            x = 1
            import re
            return re, sys, x, os


        class C:
            def h(self):
                if TYPE_CHECKING:
                    import typing
                return lambda: __import__("os")
    """))
    assert undeclared_deferrals(pkg) == ["pkg.a: import re"]


def test_importing_every_module_leaves_the_matplotlib_backend_alone():
    # a fresh interpreter: the backend a user (or Jupyter's inline kernel) chose must survive
    # importing any module of the package; only the command-line entry points select Agg
    modules = sorted(m for m in import_graph(PACKAGE)[0] if not m.endswith(".__main__"))
    code = textwrap.dedent(f"""
        import importlib, matplotlib
        matplotlib.use("svg")
        for m in {modules!r}:
            importlib.import_module(m)
        print(matplotlib.get_backend())
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True,
                         env={k: v for k, v in os.environ.items() if k != "MPLBACKEND"})
    assert out.stdout.strip().lower() == "svg", out.stdout + out.stderr


#: the package's layers, bottom up: a module imports only its own layer and those below
LAYERS = ("engine", "model", "gait", "nlp", "fit", "studies", "report", "cli")


def layer_of(module: str) -> int | None:
    """The layer index of a module ``pdw_casadi.<layer>...`` (None: the package's face)."""
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def layer_violations(edges: dict[str, set[str]]) -> list[str]:
    """Every import that reaches a layer above the importing module's own."""
    bad = []
    for a, targets in edges.items():
        la = layer_of(a)
        for b in targets:
            lb = layer_of(b)
            if la is not None and lb is not None and lb > la:
                bad.append(f"{a} ({LAYERS[la]}) imports {b} ({LAYERS[lb]})")
    return sorted(bad)


def test_every_module_lives_in_a_layer():
    stray = [m for m in import_graph(PACKAGE)[0]
             if layer_of(m) is None and m not in ("pdw_casadi", "pdw_casadi._version")]
    assert not stray, f"modules outside the layers {LAYERS}: {stray}"


def test_every_module_imports_only_its_layer_and_the_layers_below():
    top, nested = import_graph(PACKAGE)
    assert layer_violations(_both(top, nested)) == []


def test_the_layer_check_finds_an_upward_import():
    edges = {"pdw_casadi.gait.simulate": {"pdw_casadi.model.problem", "pdw_casadi.fit.core"},
             "pdw_casadi.cli.fit": {"pdw_casadi.fit.core"}}
    assert layer_violations(edges) == [
        "pdw_casadi.gait.simulate (gait) imports pdw_casadi.fit.core (fit)"]


def private_imports(root: Path) -> list[str]:
    """Imports of a private name (``_x``) from another module of the package."""
    bad = []
    for path in sorted(root.rglob("*.py")):
        module = _module_name(path, root)
        for node, _ in _imports(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom):
                continue
            source = _resolve(node, module, path.name == "__init__.py")
            if not source.startswith(root.name):
                continue
            bad += [f"{module} imports {source}.{a.name}" for a in node.names
                    if a.name.startswith("_") and not a.name.startswith("__")]
    return bad


def test_no_module_imports_a_private_name_of_another():
    assert private_imports(PACKAGE) == []


def test_the_private_name_check_finds_one(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def _helper():\n    return 1\n")
    (pkg / "b.py").write_text("def f():\n    from .a import _helper\n    return _helper()\n")
    assert private_imports(pkg) == ["pkg.b imports pkg.a._helper"]


def test_importing_the_package_loads_no_numerics():
    # ``import pdw_casadi`` is light: casadi, IPOPT and the fit load on first use of a name
    code = ("import sys, pdw_casadi; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('casadi', 'numpy', 'pandas', 'matplotlib') or m.startswith('pdw_casadi.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "['pdw_casadi._version']", out.stdout


#: modules that solve or simulate: the report layer renders results and calls none of them
SOLVERS = ("pdw_casadi.fit.core", "pdw_casadi.fit.rounds", "pdw_casadi.fit.driver",
           "pdw_casadi.gait.simulate", "pdw_casadi.gait.fixed_point", "pdw_casadi.gait.poincare",
           "pdw_casadi.engine.compile", "pdw_casadi.nlp", "pdw_casadi.studies.fit_run")


def test_the_fit_reports_only_render():
    """The fit's report modules import no solver, simulator or compiler, at module level or
    in a function: the fit workflow (studies.fit_run) computes, the report renders its
    result (a solver imported by a report would put work back in the report layer)."""
    top, nested = import_graph(PACKAGE)
    for module in ("pdw_casadi.report.fit_report", "pdw_casadi.report.fit_stride_report"):
        reached = top.get(module, set()) | nested.get(module, set())
        bad = sorted(m for m in reached if any(m == s or m.startswith(s + ".")
                                                for s in SOLVERS))
        assert not bad, f"{module} imports {bad}"


#: the longest function a reader should have to hold in mind at once (lines of its def)
MAX_FUNCTION_LINES = 120


def test_no_function_in_the_package_is_longer_than_a_reader_holds():
    # a longer one is split into named steps (issue of the house: _assemble, Simulator.run,
    # HybridSystem.__init__, design_main and sweep_main were 141-271 lines)
    long = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{_module_name(path, PACKAGE)}.{node.name}: {n} lines")
    assert long == [], "\n".join(long)
