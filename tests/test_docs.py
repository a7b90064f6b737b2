"""The documentation: the site builds strictly, every command has its page, the README stays
an entry point, and nothing in the docs points outside the repository."""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
LINK = re.compile(r"\]\(([^)\s]+)\)")
#: a filesystem path from the root (not a web address, not ~/.cache): the docs carry what
#: they cite, so they name files relative to the repository only
ABSOLUTE_PATH = re.compile(r"(?<![\w~.:/-])(/(?:[A-Za-z_][\w.-]*/)+)")
#: a relative path that climbs directories, e.g. ../../x
UP_PATH = re.compile(r"(?<![\w.])((?:\.\./)+[\w.-]+)")


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _doc_texts():
    """(path, text) of every Markdown page, the site config, the README and data/README.md."""
    paths = [*sorted(DOCS.rglob("*.md")), ROOT / "mkdocs.yml", ROOT / "README.md",
             ROOT / "data" / "README.md"]
    return [(p, p.read_text(encoding="utf-8")) for p in paths]


def test_site_builds_strictly(tmp_path):
    """``mkdocs build --strict``: a warning (a broken link or anchor, a page missing from the
    nav, a docstring role naming nothing, a command without its page) fails the build."""
    for module in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python", "material",
                   "griffe_sphinx"):
        pytest.importorskip(module, reason="the docs extra is not installed")
    site = tmp_path / "site"
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
         "-d", str(site)], cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    # the command pages hold their parsers' help, the API pages the docstrings
    fit = (site / "commands" / "fit" / "index.html").read_text(encoding="utf-8")
    assert "usage: pdw-fit" in fit and "--max-radius" in fit
    gait = (site / "api" / "gait" / "index.html").read_text(encoding="utf-8")
    assert 'id="pdw_casadi.gait.fixed_point.find_fixed_point"' in gait
    # a docstring role became a link to its object
    assert 'href="#pdw_casadi.gait.design.symmetry_conditions"' in gait
    assert not list(site.rglob("*.py")), "build helpers copied into the site"


def test_every_command_has_a_page_in_the_nav():
    from pdw_casadi.cli import COMMANDS

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert sorted(scripts) == sorted(f"pdw-{name}" for name in COMMANDS)
    config = (ROOT / "mkdocs.yml").read_text()
    for name in COMMANDS:
        page = DOCS / "commands" / f"{name}.md"
        assert page.is_file(), f"pdw-{name} has no page {page.relative_to(ROOT)}"
        assert f"<!-- cli: pdw-{name} -->" in page.read_text(), page
        assert f"commands/{name}.md" in config, f"{page.name} is not in the nav of mkdocs.yml"


def test_every_page_is_in_the_nav():
    config = (ROOT / "mkdocs.yml").read_text()
    missing = [str(p.relative_to(DOCS)) for p in sorted(DOCS.rglob("*.md"))
               if str(p.relative_to(DOCS)) not in config]
    assert not missing, f"pages missing from the nav of mkdocs.yml: {missing}"


def test_architecture_page_names_the_layers_in_order():
    layers = _load(ROOT / "tests" / "test_imports.py", "_layers_of_test_imports").LAYERS
    text = (DOCS / "architecture.md").read_text()
    line = next(l for l in text.splitlines() if l.startswith("Layers, bottom up:"))
    assert re.findall(r"`(\w+)`", line) == list(layers)
    assert "tests/test_imports.py" in text
    for layer in layers:
        assert (DOCS / "api" / f"{layer}.md").read_text().count(f"::: pdw_casadi.{layer}") == 1


def test_readme_is_an_entry_point():
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 200
    assert 'pip install -e ".[dev]" && pdw-fit --gait female_fast.csv' in text
    assert 'pip install -e ".[dev]" && pytest' in text
    for command in ("pdw-simulate", "pdw-fixed-point", "pdw-fit", "pdw-sweep", "pdw-scale",
                    "pdw-design", "pdw-atlas"):
        assert f"`{command}`" in text, command
    assert "CC BY 4.0" in text and "10.7717/peerj.4640" in text


def test_nothing_points_outside_the_repository():
    bad = []
    for path, text in _doc_texts():
        for absolute in ABSOLUTE_PATH.findall(text):
            bad.append(f"{path.relative_to(ROOT)}: absolute path {absolute}")
        for up in set(UP_PATH.findall(text)):
            if ROOT not in (path.parent / up).resolve().parents:
                bad.append(f"{path.relative_to(ROOT)}: {up} leaves the repository")
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue  # a web address or an anchor on the same page
            local = (path.parent / target.split("#")[0]).resolve()
            if ROOT not in local.parents and local != ROOT:
                bad.append(f"{path.relative_to(ROOT)}: {target} leaves the repository")
            elif not local.exists():
                bad.append(f"{path.relative_to(ROOT)}: {target} does not exist")
    assert not bad, bad


def test_notebook_links_resolve():
    bad = []
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        for cell in json.loads(nb.read_text())["cells"]:
            if cell["cell_type"] != "markdown":
                continue
            for target in LINK.findall("".join(cell["source"])):
                if re.match(r"[a-z]+:", target) or target.startswith("#"):
                    continue
                local = (nb.parent / target.split("#")[0]).resolve()
                if ROOT not in local.parents or not local.exists():
                    bad.append(f"{nb.name}: {target}")
    assert not bad, bad


def test_a_docstring_role_naming_nothing_is_an_error(tmp_path):
    """The extension that turns reST roles into links warns (a strict build fails) on a role
    naming nothing in the package, and links the ones that resolve."""
    griffe = pytest.importorskip("griffe", reason="the docs extra is not installed")
    roles = _load(DOCS / "griffe_roles.py", "_griffe_roles")
    pkg = tmp_path / "docs_fixture_pkg"
    (pkg / "gait").mkdir(parents=True)
    (pkg / "__init__.py").write_text('"""Top."""\n')
    (pkg / "gait" / "__init__.py").write_text('"""Gaits: :mod:`.design`."""\n')
    (pkg / "gait" / "design.py").write_text(
        '"""Designs: :func:`solve_design`, :func:`symmetric_design`, :class:`numpy.ndarray`,\n'
        ':func:`~docs_fixture_pkg.gait.design.solve_design`, :func:`_private`."""\n\n\n'
        'def solve_design():\n    """Solve."""\n')
    package = griffe.GriffeLoader(search_paths=[str(tmp_path)]).load("docs_fixture_pkg")
    assert Path(package.filepath).parent == pkg
    records: list[logging.LogRecord] = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append
    roles.LOG.addHandler(handler)  # the mkdocs loggers need not propagate to the root
    try:
        roles.RolesToLinks(package="docs_fixture_pkg").on_package(pkg=package)
    finally:
        roles.LOG.removeHandler(handler)
    assert [r.getMessage() for r in records] == [
        "docs_fixture_pkg.gait.design: docstring names 'symmetric_design', which is not in "
        "docs_fixture_pkg"]
    text = package["gait.design"].docstring.value
    assert "[`solve_design`][docs_fixture_pkg.gait.design.solve_design]" in text
    assert text.count("][docs_fixture_pkg.gait.design.solve_design]") == 2
    assert "`symmetric_design`" in text and "`numpy.ndarray`" in text and "`_private`" in text
    assert ":func:" not in text and ":class:" not in text
    assert "[`design`][docs_fixture_pkg.gait.design]" in package["gait"].docstring.value


#: (corpus file names carry + and - : data/corpus/WBDS18_hip+.csv)
PATH_REF = re.compile(r"(?<![\w./+-])((?:pdw_casadi|scripts|tests|data|problems|notebooks|docs)"
                      r"/[\w./+-]*[\w/])(?![\w{<*+])")
#: paths that a source citation names in another repository (data/README.md)
CITED_ELSEWHERE = {"data/h2a_comfspeed_43subs.csv"}
NAME_REF = re.compile(r"(?<![\w./])(pdw_casadi(?:\.\w+)+)")


def test_paths_and_names_in_the_docs_exist():
    """Every repository path (``pdw_casadi/gait/stride.py``, ``scripts/bench_fit.py``,
    ``data/designs/...``) and every dotted name (``pdw_casadi.gait.sweep.sweep``) the
    documentation mentions exists: a reorganisation cannot leave the docs behind."""
    import importlib

    bad = []
    for path, text in _doc_texts():
        for ref in sorted(set(PATH_REF.findall(text))):
            if "xx" in ref or ref in CITED_ELSEWHERE:
                continue  # a pattern (WBDSxx), or a file of another repository
            if not (ROOT / ref).exists():
                bad.append(f"{path.relative_to(ROOT)}: {ref}")
        for ref in sorted(set(NAME_REF.findall(text))):
            parts = ref.split(".")
            for i in range(len(parts), 0, -1):  # the longest importable module
                try:
                    obj = importlib.import_module(".".join(parts[:i]))
                except ImportError:
                    continue
                try:
                    for attr in parts[i:]:
                        obj = getattr(obj, attr)
                except AttributeError:
                    bad.append(f"{path.relative_to(ROOT)}: {ref}")
                break
    assert not bad, bad


def test_docs_pages_named_in_the_code_exist():
    """The docstrings and comments point to results pages (``docs/results/prosthesis.md``):
    those pages exist."""
    bad = []
    for path in sorted([*(ROOT / "pdw_casadi").rglob("*.py"), *(ROOT / "problems").glob("*"),
                        *(ROOT / "tests").glob("*.py"), *(ROOT / "scripts").glob("*.py")]):
        for ref in set(re.findall(r"(?<![\w./-])(docs/[\w./-]*\.md)", path.read_text())):
            if not (ROOT / ref).is_file():
                bad.append(f"{path.relative_to(ROOT)}: {ref}")
    assert not bad, bad


def test_the_architecture_page_lists_every_module_and_command():
    """docs/architecture.md's table names exactly the modules (and sub-packages) of each
    layer, and the page names every console script of pyproject.toml."""
    import re
    import tomllib

    root = Path(__file__).resolve().parents[1]
    page = (root / "docs" / "architecture.md").read_text()
    package = root / "pdw_casadi"
    rows = re.findall(r"^\| \[(\w+)\]\(api/\w+\.md\) \| ([^|]+) \|", page, flags=re.M)
    assert {layer for layer, _ in rows} == {p.name for p in package.iterdir()
                                           if (p / "__init__.py").is_file()}
    for layer, cell in rows:
        listed = {name.rstrip("/") for name in re.findall(r"`([\w/]+)`", cell)}
        actual = {p.stem for p in (package / layer).iterdir()
                  if (p.suffix == ".py" and not p.stem.startswith("__"))
                  or (p.is_dir() and (p / "__init__.py").is_file())}
        assert listed == actual, f"{layer}: page {sorted(listed - actual)}, package " \
                                 f"{sorted(actual - listed)}"
    scripts = tomllib.loads((root / "pyproject.toml").read_text())["project"]["scripts"]
    missing = [s for s in scripts if s not in page]
    assert not missing, f"the architecture page does not name {missing}"


def test_every_list_on_the_site_starts_after_a_blank_line():
    """Python-Markdown renders a list that directly follows a paragraph line as run-on text
    with literal "- " (commands/sweep.md and the conventions of commands/outputs.md did):
    every list item that follows text has a blank line before its list."""
    bad = []
    for page in sorted((ROOT / "docs").rglob("*.md")):
        fence = False
        prev = ""
        for n, line in enumerate(page.read_text().split("\n"), 1):
            if line.startswith("```"):
                fence = not fence
            if not fence and line.startswith("- ") and prev.strip() and not (
                    prev.startswith(("- ", "  ", "|", "#", "<!--"))):
                bad.append(f"{page.relative_to(ROOT)}:{n}")
            prev = line
    assert not bad, f"a list right after a paragraph line: {bad}"
