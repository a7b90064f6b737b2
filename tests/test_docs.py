"""The documentation: the site builds strictly, every command has its page, the README stays
an entry point, and nothing in the docs points outside the repository."""

from __future__ import annotations

import html
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


#: (page of the site, figure) of every figure the docs build draws (docs/hooks.py, FIGURES)
FIGURE_PAGES = [("", "fit"), ("model", "walker"), ("results/sweeps", "slope_sweep"),
                ("results/cohort", "cohort_r2"),
                ("results/cohort", "cohort_compliance"),
                ("commands/outputs", "fit"), ("commands/outputs", "limit_cycle"),
                ("results/prosthesis", "prosthetist_study")]


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


def test_site_builds_strictly(api_site):
    """``mkdocs build --strict``: a warning (a broken link or anchor, a page missing from the
    nav, a docstring role naming nothing, a command without its page) fails the build (the
    module's one build, :func:`api_site`: it runs the bundled fit for the outputs page)."""
    site = api_site
    # the command pages hold their parsers' help, the API pages the docstrings
    fit = (site / "commands" / "fit" / "index.html").read_text(encoding="utf-8")
    assert "usage: pdw-fit" in fit and "--max-radius" in fit
    gait = (site / "api" / "gait" / "index.html").read_text(encoding="utf-8")
    assert 'id="pdw_casadi.gait.fixed_point.find_fixed_point"' in gait
    # a docstring role became a link to its object
    assert 'href="#pdw_casadi.gait.design.symmetry_conditions"' in gait
    assert not list(site.rglob("*.py")), "build helpers copied into the site"
    # nor their bytecode (docs/__pycache__, written where Python writes bytecode)
    assert not list(site.rglob("*.pyc")), "the build helpers' bytecode copied into the site"
    # the figures drawn by the build (docs/hooks.py, FIGURES): each is a PNG of the site,
    # shown on its page, and none is a stored file of docs/
    for page, name in FIGURE_PAGES:
        html = (site / page / "index.html").read_text(encoding="utf-8")
        assert f'src="../../figures/{name}.png"' in html or \
            f'src="../figures/{name}.png"' in html or \
            f'src="figures/{name}.png"' in html, (page, name)
        assert (site / "figures" / f"{name}.png").read_bytes()[:4] == b"\x89PNG", name
    assert not (DOCS / "figures").exists()


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


# -- the outputs of pdw-fit: every field of summary.json is documented ------------------------
def _function(path: Path, name: str):
    """The ``def name`` (function or method) of the module at ``path``, as an AST node."""
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    return next(n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == name)


def _dict_keys_into(fn, target: str) -> set[str]:
    """The string keys that function ``fn`` (an AST node) puts into the dict named
    ``target``: the keys of the dict literals bound to it, set on it (``target["k"] = v``)
    or merged into it (``target.update({...})``), and, recursively, those of every dict
    literal (or local name bound to one, or comprehension building one) held in them."""
    import ast

    bound: dict[str, list] = {}
    for node in ast.walk(fn):
        if isinstance(node, ast.Assign):
            for t in node.targets:
                if isinstance(t, ast.Name):
                    bound.setdefault(t.id, []).append(node.value)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) \
                and node.value is not None:
            bound.setdefault(node.target.id, []).append(node.value)
    keys: set[str] = set()
    seen: set[str] = set()

    def visit(node) -> None:
        if isinstance(node, ast.Dict):
            for k, v in zip(node.keys, node.values, strict=True):
                if isinstance(k, ast.Constant) and isinstance(k.value, str):
                    keys.add(k.value)
                visit(v)  # also a ** merge (k is None)
        elif isinstance(node, ast.Name) and node.id not in seen:
            seen.add(node.id)
            for value in bound.get(node.id, []):
                visit(value)
        elif isinstance(node, ast.IfExp):
            visit(node.body)
            visit(node.orelse)
        elif isinstance(node, ast.DictComp):
            visit(node.value)

    visit(ast.Name(id=target))
    for node in ast.walk(fn):
        if isinstance(node, ast.Assign):
            for t in node.targets:
                if isinstance(t, ast.Subscript) and isinstance(t.value, ast.Name) \
                        and t.value.id == target and isinstance(t.slice, ast.Constant):
                    keys.add(t.slice.value)
                    visit(node.value)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr == "update" and isinstance(node.func.value, ast.Name) \
                and node.func.value.id == target:
            for arg in node.args:
                visit(arg)
    return keys


def _literal_keys(fn) -> set[str]:
    """The string keys of every dict literal in function ``fn`` (an AST node)."""
    import ast

    return {k.value for n in ast.walk(fn) if isinstance(n, ast.Dict) for k in n.keys
            if isinstance(k, ast.Constant) and isinstance(k.value, str)}


def _fit_summary_fields() -> set[str]:
    """Every field name of the ``summary.json`` that ``pdw-fit`` writes (one-step and per-leg
    fits), read from the code that writes it, so that the list cannot go stale: the keys the
    two report writers put into the summary and into its nested tables, and the fields of
    the records it embeds (the IPOPT solves, the starts, the R² scores, a stride's legs,
    the gait timing, the human timing values, the units block)."""
    import ast
    import dataclasses

    from pdw_casadi.fit.result import Solve
    from pdw_casadi.gait.timing import HUMAN_NORMS, UNITS

    pkg = ROOT / "pdw_casadi"
    fields = _dict_keys_into(_function(pkg / "report" / "fit_report.py", "write_fit_report"),
                             "summary")
    fields |= _dict_keys_into(_function(pkg / "report" / "fit_stride_report.py",
                                        "write_fit_stride_report"), "summary")
    # summary.update(cand.scores) and **_scores(...): the R² names that _scores keeps
    fields |= {n.value for n in ast.walk(_function(pkg / "report" / "fit_report.py", "_scores"))
               if isinstance(n, ast.Constant) and isinstance(n.value, str)}
    fields |= {f.name for f in dataclasses.fields(Solve)}  # solver.solves[]
    fields |= _literal_keys(_function(pkg / "fit" / "result.py", "starts_frame"))  # starts[]
    # a stride's legs.<side> and stride values (its curves go to curves.csv)
    fields |= _literal_keys(_function(pkg / "gait" / "stride.py", "stride_report")) - {"curves"}
    fields |= set(UNITS) | set(HUMAN_NORMS)  # timing, timing_human.values
    fields |= _dict_keys_into(_function(pkg / "model" / "units.py", "summary"), "out")  # legs
    return fields


def test_every_field_of_a_fit_summary_is_documented():
    """The outputs page documents every field of the summary.json that pdw-fit writes
    (``accepted``, ``stability_margin``, ``comparison``, ...), each named in backticks in
    its section "What pdw-fit writes" (alone or as part of a dotted path such as
    ``solver.solves[].nlp_radius_bound``)."""
    fields = _fit_summary_fields()
    assert {"accepted", "stability_margin", "comparison", "table3", "comparison_walker",
            "nlp_radius_bound", "stride_spectral_radius", "legs"} <= fields, fields
    page = (DOCS / "commands" / "outputs.md").read_text(encoding="utf-8")
    section = page.split("\n## What pdw-fit writes\n", 1)[1].split("\n## ", 1)[0]
    named = {word for span in re.findall(r"`([^`\n]+)`", section)
             for word in re.findall(r"\w+", span)}
    missing = sorted(fields - named)
    assert not missing, f"summary.json fields not documented on commands/outputs.md: {missing}"


def test_the_outputs_page_quotes_every_file_of_a_fit():
    """Each file that pdw-fit writes has its own heading on the outputs page."""
    import ast

    fn = _function(ROOT / "pdw_casadi" / "cli" / "fit.py", "fit_main")
    names = {n.value for n in ast.walk(fn) if isinstance(n, ast.Constant)
             and isinstance(n.value, str) and re.fullmatch(r"[\w]+\.(json|csv|png|md|log)",
                                                           n.value)}
    assert {"summary.json", "table.md", "ipopt.log"} <= names
    page = (DOCS / "commands" / "outputs.md").read_text(encoding="utf-8")
    missing = [n for n in sorted(names) if f"\n### {n}\n" not in page]
    assert not missing, f"no section of commands/outputs.md for {missing}"
    for image in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", page):
        assert (DOCS / "commands" / image).is_file(), image


# -- exit codes, sources, the install page -----------------------------------------------------
def test_exit_code_tables_hold_every_code_of_the_contract():
    """The table that every command page gets (docs/hooks.py) lists the contract's exit
    codes and the signal codes (Ctrl-C 130, SIGTERM 143), as the commands index promises."""
    pytest.importorskip("mkdocs", reason="the docs extra is not installed")
    from pdw_casadi.cli import contract
    from pdw_casadi.engine import interrupt

    hooks = _load(DOCS / "hooks.py", "_docs_hooks")
    table = hooks.exit_codes()
    codes = {int(c) for c in re.findall(r"^\| (\d+) \|", table, flags=re.M)}
    expected = {contract.EXIT_OK, contract.EXIT_NO_GAIT, contract.EXIT_USAGE,
                contract.EXIT_INTERRUPTED, *interrupt.EXIT_CODES.values()}
    assert codes == expected
    assert {130, 143} <= codes
    index = (DOCS / "commands" / "index.md").read_text(encoding="utf-8")
    assert "130" in index and "143" in index


def test_every_command_page_names_its_source_file():
    """Each command page names the module of its command (``pdw_casadi/cli/fit.py``): the
    site has no repository link, so the pages point to the source themselves."""
    import inspect

    import pdw_casadi.cli as cli
    from pdw_casadi.cli import COMMANDS

    for name, main in COMMANDS.items():
        source = Path(inspect.getsourcefile(getattr(cli, main.__name__)))
        ref = source.relative_to(ROOT).as_posix()
        page = DOCS / "commands" / f"{name}.md"
        assert f"`{ref}`" in page.read_text(encoding="utf-8"), f"{page.name} lacks `{ref}`"


def test_the_install_page_matches_pyproject():
    """docs/install.md names the Python version of ``requires-python``, every extra of
    pyproject.toml with every package it adds, the compile cache and its switches; the home
    page links to it."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    text = (DOCS / "install.md").read_text(encoding="utf-8")
    version = re.search(r"\d+\.\d+", project["requires-python"]).group()
    assert f"Python {version} or later" in text
    assert project["requires-python"] in text
    base = {re.split(r"[<>=\[ ]", d)[0] for d in project["dependencies"]}
    for extra, requirements in project["optional-dependencies"].items():
        assert f"`{extra}`" in text, extra
        for req in requirements:
            name = re.split(r"[<>=\[ ]", req)[0]
            if name == project["name"]:  # another extra: named above
                continue
            if name not in base:
                assert f"`{name}" in text, f"extra {extra}: {name} not on the install page"
    for word in ("$PDW_CACHE", "~/.cache/pdw_casadi", "PDW_NO_COMPILE=1", "$CC", "gcc",
                 'pip install -e .', 'pip install -e ".[dev]"', "git clone", "venv"):
        assert word in text, word
    assert "(install.md)" in (DOCS / "index.md").read_text(encoding="utf-8")


# -- the curated API reference: the public API first, by job; every entry with its own text,
# -- every object once ---------------------------------------------------------------------
#: the most entries without text of their own that one API page may show; measured after the
#: curation (docs/griffe_roles.py, CuratedApi; show_if_no_docstring: false): 0 on every page
#: (before it: 1,075 of 2,104 entries, e.g. StabilityRow.n, o_X)
MAX_BARE_ENTRIES = 0


class _ApiEntries:
    """The mkdocstrings entries of a built page: (heading id, characters of its own text), the
    text of its ``doc-contents`` outside its members (``doc-children``, nested entries) and
    outside the class-bases line."""

    def __init__(self, html: str) -> None:
        from html.parser import HTMLParser

        entries: list[list] = []
        divs: list[list] = []  # [kind, entry] of every open div
        state = {"bases": False}

        class Parser(HTMLParser):
            def handle_starttag(self, tag, attrs):
                cls = (dict(attrs).get("class") or "").split()
                if tag == "p" and "doc-class-bases" in cls:
                    state["bases"] = True
                if tag == "div":
                    kind = next((k for k in ("doc-object", "doc-contents", "doc-children")
                                 if "doc" in cls and k in cls), "other")
                    divs.append([kind, None])
                elif re.fullmatch(r"h[1-6]", tag) and "doc-heading" in cls \
                        and dict(attrs).get("id"):
                    entry = [dict(attrs)["id"], 0]
                    entries.append(entry)
                    owner = next((d for d in reversed(divs) if d[0] == "doc-object"), None)
                    if owner is not None:
                        owner[1] = entry

            def handle_endtag(self, tag):
                if tag == "p":
                    state["bases"] = False
                if tag == "div" and divs:
                    divs.pop()

            def handle_data(self, data):
                if not data.strip() or state["bases"]:
                    return
                doc = [d for d in divs if d[0] != "other"]
                if len(doc) >= 2 and doc[-1][0] == "doc-contents" \
                        and doc[-2][0] == "doc-object" and doc[-2][1] is not None:
                    doc[-2][1][1] += len(data.strip())

        Parser(convert_charrefs=True).feed(html)
        self.entries = [(name, chars) for name, chars in entries]
        self.html = html


@pytest.fixture(scope="module")
def api_site(tmp_path_factory):
    """The site, built strictly once for this module's tests."""
    for module in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python", "material",
                   "griffe_sphinx", "yaml"):
        pytest.importorskip(module, reason="the docs extra is not installed")
    site = tmp_path_factory.mktemp("api_site") / "site"
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
         "-d", str(site)], cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    return site


def _api_pages(site: Path) -> dict[str, _ApiEntries]:
    pages = {str(p.relative_to(site)): _ApiEntries(p.read_text(encoding="utf-8"))
             for p in sorted((site / "api").rglob("index.html"))}
    assert "api/index.html" in pages and len(pages) > 1, sorted(pages)
    return pages


def test_the_api_index_leads_with_the_public_api(api_site):
    """The API reference opens on its index page, the layer pages after it under "Modules";
    the index renders the package, then every name of ``pdw_casadi.__all__`` (under the name a
    user imports, ``pdw_casadi.fit_gait``) and every ``::: path`` entry of api/index.md, each
    with text of its own, and only then its "Modules" section."""
    import yaml

    import pdw_casadi

    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))["nav"]
    api = next(item["API reference"] for item in nav
               if isinstance(item, dict) and "API reference" in item)
    assert api[0] == "api/index.md", api
    modules = [page for item in api[1]["Modules"] for page in item.values()]
    layers = _load(ROOT / "tests" / "test_imports.py", "_layers_of_test_imports").LAYERS
    assert api[1:] == [api[1]] and modules == [f"api/{layer}.md" for layer in layers], api

    page = _api_pages(api_site)["api/index.html"]
    own = dict(page.entries)
    names = [name for name in pdw_casadi.__all__ if name != "__version__"]
    assert {"load_problem", "simulate", "poincare_map", "find_fixed_point", "fit_gait",
            "FitOptions"} <= set(names), names
    missing = [n for n in names if not own.get(f"pdw_casadi.{n}")]
    assert not missing, f"the API index lacks (or has no text for) {missing}"
    index = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    paths = re.findall(r"^::: *([\w.]+) *$", index, flags=re.M)
    assert paths[0] == "pdw_casadi" and page.entries[0][0] == "pdw_casadi"
    unrendered = [p for p in paths if p not in own]
    assert not unrendered, f"entries of api/index.md not rendered: {unrendered}"
    headings = [name for name, _ in page.entries]
    assert [h for h in headings if h in paths] == paths, "the index renders its entries in order"
    last_entry = page.html.rindex('class="doc doc-heading"')
    assert page.html.index('id="modules"') > last_entry, "the modules come after the API"


def test_every_api_entry_has_its_own_text_and_appears_once(api_site):
    """No API page shows more than MAX_BARE_ENTRIES entries without text of their own; no
    heading id appears twice across the API pages; and no object is rendered twice under two
    names (a re-export at its home only, an index entry not again on its module page), except
    the package's own names: ``pdw_casadi.fit_gait`` on the index, ``fit_gait`` at home on its
    module's page (the gait page keeps ``find_fixed_point``: test_site_builds_strictly)."""
    from collections import Counter, defaultdict

    import griffe

    import pdw_casadi

    pages = _api_pages(api_site)
    bare = {page: [name for name, chars in entries.entries if not chars]
            for page, entries in pages.items()}
    over = {page: names for page, names in bare.items() if len(names) > MAX_BARE_ENTRIES}
    assert not over, f"entries without text of their own: {over}"

    ids = Counter(name for entries in pages.values() for name, _ in entries.entries)
    assert len(ids) > 500, len(ids)  # the whole package, not an empty reference
    twice = sorted(name for name, n in ids.items() if n > 1)
    assert not twice, f"rendered more than once: {twice}"

    lazy = pdw_casadi._LAZY
    collection = griffe.GriffeLoader(search_paths=[str(ROOT)]).load("pdw_casadi") \
        .modules_collection
    by_object: dict[str, list[str]] = defaultdict(list)
    unknown = []
    for name in ids:
        head, _, rest = name.removeprefix("pdw_casadi.").partition(".")
        path = f"{lazy[head]}.{head}" + (f".{rest}" if rest else "") \
            if name.startswith("pdw_casadi.") and head in lazy else name
        try:
            obj = collection[path]
            by_object[obj.final_target.path if obj.is_alias else obj.path].append(name)
        except (KeyError, griffe.AliasResolutionError):
            unknown.append(name)
    assert not unknown, f"headings naming nothing in the package: {unknown}"

    def face(name: str) -> bool:
        head = name.removeprefix("pdw_casadi.").split(".")[0]
        return name.startswith("pdw_casadi.") and head in lazy

    doubled = {home: names for home, names in by_object.items() if len(names) > 1
               and not (len(names) == 2 and sum(map(face, names)) == 1)}
    assert not doubled, f"an object rendered under two names: {doubled}"


# -- the notebooks on the site: a page per notebook with its saved outputs, linked by the tour --
def _article(html: str) -> str:
    """The content of a built page (without the nav, which links every page)."""
    return html[html.index("<article"):html.index("</article>")]


def test_every_notebook_has_a_page_with_its_saved_outputs(api_site):
    """docs/hooks.py renders each notebooks/*.ipynb as the page notebooks/NN_name/ of the site:
    its first line names the notebook and says the build does not execute it (and that it has
    no saved outputs, when so), every line of its code cells is on it, every saved image output
    is an <img> whose file is in the site; the nav's "Notebooks" and the tour link every page."""
    import html
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    assert notebooks
    home = (api_site / "index.html").read_text(encoding="utf-8")
    tour = _article((api_site / "tour" / "index.html").read_text(encoding="utf-8"))
    tour_md = (DOCS / "tour.md").read_text(encoding="utf-8")
    images_per_page = {}
    for nb in notebooks:
        cells = json.loads(nb.read_text(encoding="utf-8"))["cells"]
        outputs = [o for c in cells if c["cell_type"] == "code" for o in c.get("outputs", [])]
        images = [o for o in outputs if any(k.startswith("image/") for k in o.get("data", {}))]
        code = [c for c in cells if c["cell_type"] == "code" and "".join(c["source"]).strip()]
        page = api_site / "notebooks" / nb.stem / "index.html"
        assert page.is_file(), f"{nb.name} has no page on the site"
        article = _article(page.read_text(encoding="utf-8"))
        first = re.sub(r"<[^>]+>", "", re.search(r"<p>(.*?)</p>", article, re.S).group(1))
        assert first.startswith(f"Rendered from notebooks/{nb.name}"), first
        assert "does not execute" in first, first
        assert ("no saved outputs" in first) == (not outputs), first
        text = html.unescape(re.sub(r"<[^>]+>", "", article))
        missing = [line for c in code for line in "".join(c["source"]).splitlines()
                   if line.strip() and line not in text]
        assert not missing, f"{nb.name}: code not on its page: {missing[:3]}"
        srcs = re.findall(r'<img[^>]*\ssrc="([^"]+)"', article)
        assert len(srcs) == len(images), f"{nb.name}: {len(images)} images saved, {srcs} shown"
        for src in srcs:
            assert not src.startswith("data:") and (page.parent / src).stat().st_size > 0, src
        images_per_page[nb.name] = len(srcs)
        assert f'href="notebooks/{nb.stem}/"' in home, f"{nb.name}: not in the nav"
        assert f"(../notebooks/{nb.name})" in tour_md, f"docs/tour.md does not link {nb.name}"
        assert f'href="../notebooks/{nb.stem}/"' in tour, f"the tour does not link {nb.name}"
    assert any(images_per_page.values()), images_per_page  # notebooks with figures show them


class _PreBlocks:
    """The code blocks (``<pre>``) of an HTML page as a reader sees them: their text (tags
    dropped, entities decoded) and whether they wrap (a notebook's text output)."""

    def __init__(self, html: str):
        from html.parser import HTMLParser

        self.blocks: list[tuple[str, bool]] = []
        outer = self

        class Parser(HTMLParser):
            def __init__(self):
                super().__init__(convert_charrefs=True)
                self.depth, self.text, self.wraps, self.classes = 0, [], False, []

            def handle_starttag(self, tag, attrs):
                cls = dict(attrs).get("class") or ""
                if tag in ("div", "pre", "code", "span", "a", "button"):
                    self.classes.append(cls)
                if tag == "pre":
                    self.depth += 1
                    if self.depth == 1:
                        self.text, self.wraps = [], any(
                            "language-output" in c for c in self.classes)

            def handle_endtag(self, tag):
                if tag in ("div", "pre", "code", "span", "a", "button") and self.classes:
                    self.classes.pop()
                if tag == "pre":
                    self.depth -= 1
                    if self.depth == 0:
                        outer.blocks.append(("".join(self.text), self.wraps))

            def handle_data(self, data):
                if self.depth:
                    self.text.append(data)

        Parser().feed(html)


def test_every_code_block_of_the_site_fits_the_page(api_site):
    """A code block shows CODE_COLUMNS columns whole in a 1280 px window (docs/hooks.py);
    a longer line is cut at the block's edge (the --help blocks were cut at 75-82 of their
    100 columns). Every line of every code block of the built site (pages, notebooks,
    --help, API) fits, except a notebook's text outputs, which wrap (extra.css)."""
    hooks = _load(DOCS / "hooks.py", "_docs_hooks")
    too_wide = []
    for page in sorted(api_site.rglob("*.html")):
        for text, wraps in _PreBlocks(page.read_text(encoding="utf-8")).blocks:
            if wraps:
                continue
            too_wide += [f"{page.relative_to(api_site)}: {len(line)} columns: {line[:60]}"
                         for line in text.split("\n") if len(line) > hooks.CODE_COLUMNS]
    assert not too_wide, f"{len(too_wide)} code lines wider than the page:\n" + \
        "\n".join(too_wide[:40])


def test_every_formula_of_the_site_is_mathml_and_no_script_is_fetched(api_site):
    """The formulas are MathML in the built pages (docs/hooks.py, on_page_content): no
    arithmatex element still holds TeX, the model page's formulas are there (its power
    bound's norm, the Frobenius subscript), and no page loads a script from another host
    (the math needs no network)."""
    tex_left, remote, escaped = [], [], []
    formulas = 0
    for page in sorted(api_site.rglob("*.html")):
        text = page.read_text(encoding="utf-8")
        rel = page.relative_to(api_site)
        tex_left += [f"{rel}: {m[:60]}" for m in
                     re.findall(r'class="arithmatex">\\[(\[][^<]*', text)]
        remote += [f"{rel}: {src}" for src in
                   re.findall(r'<script[^>]+src="((?:https?:)?//[^"]+)"', text)]
        formulas += text.count("<math ")
        escaped += [f"{rel}: {m}" for m in re.findall(r"<mtext>[^<]*&amp;#x[^<]*</mtext>", text)]
    assert not tex_left, "formulas left as TeX:\n" + "\n".join(tex_left[:20])
    # latex2mathml's own entities (a space of \text{foot COM}) not escaped once more
    assert not escaped, "entities escaped twice:\n" + "\n".join(escaped[:20])
    assert not remote, "scripts from another host:\n" + "\n".join(remote[:20])
    model = (api_site / "model" / "index.html").read_text(encoding="utf-8")
    assert model.count("<math ") >= 10 and "<mi>F</mi>" in model
    assert formulas >= 100


def test_a_formula_with_an_unknown_command_fails_the_build():
    """docs/hooks.py's tex_to_mathml: a misspelt command (``\\lamda``, which latex2mathml
    would leave as text) and TeX the library rejects fail with the page's name; text with
    a "<" or a bare "&" is escaped in the MathML, the library's own entities kept."""
    from mkdocs.exceptions import PluginError

    hooks = _load(DOCS / "hooks.py", "_docs_hooks")

    def convert(tex):
        m = hooks.ARITHMATEX.search(f'<span class="arithmatex">\\({tex}\\)</span>')
        return hooks.tex_to_mathml(m, "model.md")

    assert "<math" in convert(r"\lambda x") and "<mi>&#x003BB;</mi>" in convert(r"\lambda")
    with pytest.raises(PluginError, match=r"model\.md.*\\lamda"):
        convert(r"\lamda x")
    with pytest.raises(PluginError, match=r"model\.md.*not TeX that latex2mathml reads"):
        convert("x^")  # a superscript without its argument: the library's own error
    assert "a&lt;b" in convert(r"\text{a&lt;b}")
    # its own entities (a space in text) kept, a bare "&" escaped
    assert "<mtext>a&#x000A0;&amp;&#x000A0;b</mtext>" in convert(r"\text{a &amp; b}")


def test_the_width_rule_catches_a_wide_line_and_spares_wrapped_output():
    """The parser of the test above: a 90-column code line is found; the same line in a
    notebook's wrapped output block is not held to the width."""
    wide = "x" * 90
    code = f'<div class="language-python highlight"><pre><span></span><code>{wide}\nok' \
           '</code></pre></div>'
    out = f'<div class="language-output highlight"><pre><span></span><code>{wide}' \
          '</code></pre></div>'
    blocks = _PreBlocks(f"<p>text</p>{code}<p>more</p>{out}").blocks
    assert [(len(t.split(chr(10))[0]), w) for t, w in blocks] == [(90, False), (90, True)]


# -- the outputs page's excerpts: from the fit the build runs ------------------------------
def test_a_json_excerpt_keeps_every_top_field_and_cuts_long_inner_ones():
    """docs/hooks.py's json_excerpt: every field of the top level, an inner dict of more
    than JSON_KEEP entries cut to its first two, "..." and its last, one that fits on its
    line written on it, and what it prints, the "..." lines dropped, reads back as JSON."""
    hooks = _load(DOCS / "hooks.py", "_docs_hooks")
    n = hooks.JSON_KEEP + 3
    data = {"a": 1, "long": {f"k{i}": i / 7 for i in range(n)}, "short": [1, 2],
            **{f"f{i}": i for i in range(n)}}
    text = hooks.json_excerpt(data)
    lines = text.splitlines()
    assert all(f'"f{i}": {i}' in text for i in range(n))  # the top level whole
    assert '  "short": [1, 2],' in lines  # fits on its line
    inner = [ln.strip() for ln in lines if ln.startswith("    ")]
    assert inner == [f'"k0": {0 / 7},', f'"k1": {1 / 7},', "...", f'"k{n - 1}": {(n - 1) / 7}']
    back = json.loads("\n".join(ln for ln in lines if ln.strip() != "..."))
    assert back["long"] == {"k0": 0.0, "k1": 1 / 7, f"k{n - 1}": (n - 1) / 7}
    assert back["a"] == 1 and back["short"] == [1, 2] and back[f"f{n - 1}"] == n - 1


def test_an_ipopt_excerpt_keeps_the_sizes_and_the_first_solves_ends():
    """docs/hooks.py's ipopt_excerpt: of a log of two solves, the first one's sizes, its
    iteration table's head, first two and last iterations and its end; a log without a
    solve fails the build."""
    from mkdocs.exceptions import PluginError

    hooks = _load(DOCS / "hooks.py", "_docs_hooks")
    iteration = "{:4d}  3.4450473e-01 1.86e-08 1.00e+00   0.0 0.00e+00    -  0.00e+00 " \
                "0.00e+00   0"
    solve = ["This is Ipopt version 3.14.19, running with linear solver MUMPS 5.8.2.", "",
             "Total number of variables............................:     2842",
             "iter    objective    inf_pr   inf_du lg(mu)  ||d||  lg(rg) alpha_du alpha_pr  ls",
             *(iteration.format(k) for k in range(6)), "",
             "Number of Iterations....: 5", "EXIT: Optimal Solution Found."]
    text = hooks.ipopt_excerpt("\n".join(solve + [ln.replace("5", "7") for ln in solve]))
    lines = text.splitlines()
    assert lines[0].startswith("This is Ipopt") and lines[1].endswith("2842")
    assert lines[3:7] == [iteration.format(0), iteration.format(1), "...", iteration.format(5)]
    assert lines[-2:] == ["Number of Iterations....: 5", "EXIT: Optimal Solution Found."]
    with pytest.raises(PluginError):
        hooks.ipopt_excerpt("no solve here")


def test_the_outputs_page_shows_the_builds_own_fit(api_site):
    """The outputs page's excerpts are written by the build from the bundled fit it runs
    (``<!-- output: NAME -->``, docs/hooks.py): no marker is left, and the terminal's
    headline, table.md's row of the fit and summary.json's fields agree (one run), and the
    IPOPT log's excerpt (its first solve) has the iterations of summary.json's first solve."""
    page = (api_site / "commands" / "outputs" / "index.html").read_text(encoding="utf-8")
    blocks = [html.unescape(re.sub(r"<[^>]+>", "", b))
              for b in re.findall(r"<pre[^>]*>(.*?)</pre>", page, re.S)]
    assert "&lt;!-- output:" not in page and "<!-- output:" not in page
    terminal = next(b for b in blocks if b.startswith("r2_knee = "))
    summary = next(b for b in blocks if b.lstrip().startswith('{\n  "gait_file"'))
    table = next(b for b in blocks if b.startswith("# Fit of humanlike_6link"))
    log = next(b for b in blocks if b.startswith("This is Ipopt"))
    knee, hip = (float(v) for v in re.match(r"r2_knee = (\S+)  r2_hip = (\S+)", terminal)
                 .groups())
    row = re.search(r"^\| this fit \| (\S+) \| (\S+) \|", table, re.M)
    assert (float(row.group(1)), float(row.group(2))) == (knee, hip)
    fields = dict(re.findall(r'^  "(r2_knee|r2_hip)": (\S+),$', summary, re.M))
    assert round(float(fields["r2_knee"]), 3) == knee and round(float(fields["r2_hip"]), 3) == hip
    # the log's excerpt is its first solve: summary.json's first solve
    first = int(re.search(r'"solves": \[\s*\{[^}]*?"iterations": (\d+)', summary).group(1))
    assert int(re.search(r"Number of Iterations\.+: +(\d+)", log).group(1)) == first
    total = int(re.search(r"\| IPOPT iterations \(all solves\) \| (\d+) \|", table).group(1))
    assert first <= total
    assert terminal.rstrip().endswith("wrote fit")
