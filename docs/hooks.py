"""MkDocs hooks of the documentation site: the command pages are generated from the parsers.

A line ``<!-- cli: pdw-fit -->`` in a page becomes that command's ``--help`` (run through
the command's own argparse parser, so the page cannot drift from the code) followed by the
exit codes of the contract (:mod:`pdw_casadi.cli.contract`). Every command of
:data:`pdw_casadi.cli.COMMANDS` must have its page ``commands/<name>.md`` holding its
marker, or the build fails.

The notebooks are pages too: each ``notebooks/NN_name.ipynb`` becomes the page
``notebooks/NN_name.md``, generated at build time with the outputs saved in the notebook (the
build never runs a notebook, and nothing is written into the repository), listed in the nav's
section "Notebooks"; a link to a notebook file in a page becomes a link to its page.

The outputs page's excerpts are written at build time too: a line ``<!-- output: NAME -->``
becomes an excerpt of that output of the same bundled fit (``terminal``, ``summary.json``,
``table.md``, ``curves.csv``, ``ipopt.log``; :func:`output_excerpt`), so that what the page
shows is what the current code writes.

Formulas are typeset at build time: ``pymdownx.arithmatex`` (generic mode) wraps each
``$...$`` and ``$$...$$`` of a page in an element of class ``arithmatex``, and
:func:`on_page_content` replaces its TeX by MathML (``latex2mathml``), which browsers draw
natively: the site needs no script and no network to show its math.

Figures are drawn at build time by the current code, never stored: a line
``<!-- figure: walker -->`` in a page becomes that figure (a PNG of the site,
``figures/<name>.png``, drawn by the function of :data:`FIGURES` from the bundled problems
and the data of the repository, or written by a command run at build time: ``fit.png``
and ``limit_cycle.png`` of the bundled file's fit) with its caption; a name without a
function fails the build.
"""

from __future__ import annotations

import atexit
import base64
import contextlib
import html
import io
import json
import os
import posixpath
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

MARKER = re.compile(r"^<!-- cli: (pdw-[a-z-]+) -->$", re.MULTILINE)
#: the widest code line a page shows whole: a code block holds 82 columns in a 1280 px
#: window with both sidebars (measured with scripts/make_screenshots.py), the copy button covers
#: the first line's last two (tests/test_docs.py holds every code block of the site to it)
CODE_COLUMNS = 80
#: the language of a notebook's text outputs: wrapped at the page's width (extra.css), not
#: cut, since a program's output lines are as long as they are
OUTPUT_LANG = "output"


def command_help(command: str) -> str:
    """The ``--help`` text of console script ``command`` (e.g. ``pdw-fit``), wrapped at
    :data:`CODE_COLUMNS`."""
    from pdw_casadi.cli import COMMANDS

    name = command.removeprefix("pdw-")
    if name not in COMMANDS:
        raise PluginError(f"docs: no command {command!r} (commands: {sorted(COMMANDS)})")
    buf = io.StringIO()
    old = os.environ.get("COLUMNS")
    # argparse wraps at COLUMNS - 2; its usage line breaks at words, not inside them
    os.environ["COLUMNS"] = str(CODE_COLUMNS + 2)
    try:
        with contextlib.redirect_stdout(buf):
            try:
                COMMANDS[name](["--help"])
            except SystemExit as exc:
                if exc.code not in (0, None):
                    raise PluginError(f"docs: {command} --help exited {exc.code}") from None
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    return buf.getvalue().rstrip()


def exit_codes() -> str:
    """The contract's exit codes as a Markdown table: those of
    :mod:`pdw_casadi.cli.contract` and the signal codes of :mod:`pdw_casadi.engine.interrupt`
    (Ctrl-C 130, SIGTERM 143)."""
    import signal

    from pdw_casadi.cli import contract
    from pdw_casadi.engine import interrupt

    rows = [
        (contract.EXIT_OK, "done (a walker that falls is a result: `failure` in the summary)"),
        (contract.EXIT_NO_GAIT, "ran, but no gait: one line `no gait: <reason>` (or "
                                "`error: could not write FILE: ...`, a failed write; or "
                                "`error: internal error ...`, a bug)"),
        (contract.EXIT_USAGE, "bad input: one line `error: ...`, nothing written or deleted"),
        (interrupt.EXIT_CODES[signal.SIGINT], "interrupted by Ctrl-C (SIGINT): one line "
                                              "`interrupted: ...` naming what is on disk"),
        (interrupt.EXIT_CODES[signal.SIGTERM], "terminated by SIGTERM (e.g. `kill PID`): the "
                                               "same as Ctrl-C"),
    ]
    lines = ["| exit code | meaning |", "|---|---|"]
    lines += [f"| {code} | {text} |" for code, text in rows]
    return "\n".join(lines)


def render(command: str) -> str:
    return (f"### `{command} --help`\n\n```text\n{command_help(command)}\n```\n\n"
            f"### Exit codes\n\n{exit_codes()}\n")


# -- figures: drawn by the current code when the site is built (never a stored image) --------
FIGURE = re.compile(r"^<!-- figure: ([a-z0-9_-]+) -->$", re.MULTILINE)
FIGURES_DIR = "figures"  # their folder on the site


def figure_walker(root: Path):
    """The 6-link walker of ``problems/humanlike_6link.toml`` at its section state, labelled
    (:func:`pdw_casadi.report.plots.plot_walker`)."""
    from pdw_casadi.model.problem import load_problem
    from pdw_casadi.model.system import hybrid_system
    from pdw_casadi.report.plots import plot_walker

    problem = load_problem(root / "problems" / "humanlike_6link.toml")
    return plot_walker(hybrid_system(problem), problem.state_vector(),
                       problem.parameter_vector(),
                       title=f"{problem.name} at its section state (the paper's Table 2: "
                             "just after foot strike)")


#: the stored output of the sweep of docs/results/sweeps.md (pdw-sweep's sweep.csv and
#: events.json; tests/test_results_pages.py re-runs the sweep and compares)
SLOPE_SWEEP = ("docs", "results", "slope_sweep")


def figure_slope_sweep(root: Path):
    """The bifurcation diagram of the paper's gait over the slope from the stored output of
    ``pdw-sweep`` (``docs/results/slope_sweep/``), drawn by the plotting code of its
    ``sweep.png`` (:func:`pdw_casadi.report.plots.plot_sweep`)."""
    import pandas as pd

    from pdw_casadi.gait.bifurcation import BranchEvent
    from pdw_casadi.report.plots import plot_sweep

    folder = root.joinpath(*SLOPE_SWEEP)
    summary = json.loads((folder / "events.json").read_text(encoding="utf-8"))
    events = [BranchEvent(kind=e["kind"], parameter=e["parameter"], value=e["value"],
                          bracket=tuple(e["bracket"]), reason=e["reason"])
              for e in summary["events"]]
    # the written table names its columns with their units (slope_rad); the plot takes the
    # sweep's own table, whose parameter column is the parameter's name
    table = pd.read_csv(folder / "sweep.csv").rename(columns={"slope_rad": "slope"})
    return plot_sweep(table, events, "slope",
                      title="humanlike_6link: sweep over the slope (rad)")


def _cohort_table(root: Path):
    import pandas as pd

    return pd.read_csv(root / "docs" / "results" / "cohort.csv")


def figure_cohort_r2(root: Path):
    """R^2 per subject of the cohorts of ``docs/results/cohort.csv`` (the plotting code of
    ``pdw-cohort``'s ``r2_by_subject.png``)."""
    from pdw_casadi.report.cohort import plot_r2_by_subject

    return plot_r2_by_subject(_cohort_table(root))


def figure_cohort_compliance(root: Path):
    """The fitted compliance against body mass of the cohorts of ``docs/results/cohort.csv``
    (the plotting code of ``pdw-cohort``'s ``compliance.png``)."""
    from pdw_casadi.report.cohort import plot_compliance

    return plot_compliance(_cohort_table(root))


#: the stored table of the prosthetist's study of docs/results/prosthesis.md
#: (scripts/make_prosthetist_study.py's study.csv; tests/test_results_pages.py holds the page's
#: table to it)
PROSTHETIST_STUDY = ("docs", "results", "prosthetist", "study.csv")


def figure_prosthetist_study(root: Path):
    """The prosthetist's study from its stored table (the plotting code of
    ``scripts/make_prosthetist_study.py``'s ``study.png``)."""
    import pandas as pd

    from pdw_casadi.report.prosthetist import plot_prosthetist_study

    return plot_prosthetist_study(pd.read_csv(root.joinpath(*PROSTHETIST_STUDY)),
                                  title="humanlike_6link fitted to WBDS09's left side, "
                                        "its right shank and foot made lighter")


#: the bundled file's fit, run once per build (:func:`bundled_fit`)
_FIT_RUN: dict[Path, Path] = {}
#: the longest the bundled fit may take in a build (s): 30 s from an empty compile cache on
#: two shared cores, so ten times that is a hang, not a slow machine
FIT_TIMEOUT_S = 300
#: the file of the bundled fit's folder that keeps the command's stdout
TERMINAL = "terminal.txt"


def bundled_fit(root: Path) -> Path:
    """The output folder of ``pdw-fit --gait female_fast.csv`` run now by the current code
    (a new process, as a user runs it: about 10 s with a warm compile cache, 30 s from an
    empty one); once per build, in a temporary folder removed when the build ends."""
    if root not in _FIT_RUN:
        out = Path(tempfile.mkdtemp(prefix="pdw-docs-fit-"))
        atexit.register(shutil.rmtree, out, True)
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            [str(root), *filter(None, [os.environ.get("PYTHONPATH")])])}
        try:
            done = subprocess.run([sys.executable, "-m", "pdw_casadi.cli", "fit", "--gait",
                                   "female_fast.csv", "--out", str(out), "--quiet"],
                                  cwd=root, env=env, capture_output=True, text=True,
                                  timeout=FIT_TIMEOUT_S)
        except subprocess.TimeoutExpired as exc:
            raise PluginError(f"docs: the bundled fit took more than {FIT_TIMEOUT_S} s") \
                from exc
        if done.returncode != 0:
            raise PluginError(f"docs: the bundled fit failed ({done.returncode}): "
                              f"{done.stderr.strip()[-2000:]}")
        # its terminal output, for the outputs page; the folder named as a user's default
        (out / TERMINAL).write_text(done.stdout.replace(str(out), "fit"))
        _FIT_RUN[root] = out
    return _FIT_RUN[root]


# -- the outputs page's excerpts: from the bundled fit the build runs ------------------------
#: a line ``<!-- output: NAME -->`` of a page becomes an excerpt of that output of the build's
#: bundled fit (:func:`bundled_fit`): the terminal's stdout or one of the files it wrote
OUTPUT = re.compile(r"^<!-- output: ([a-z.]+) -->$", re.MULTILINE)
#: the longest dict or list printed whole in a JSON excerpt; longer ones keep their first
#: two entries and the last, with "..." between
JSON_KEEP = 12


def json_excerpt(value, indent: int = 0, width: int = CODE_COLUMNS, key: str | None = None
                 ) -> str:
    """``value`` as JSON the way a reader skims it: a dict or list that fits on the rest
    of its line on one line, else one entry per line, indented by 2; below the top level,
    more than :data:`JSON_KEEP` entries cut to the first two, "..." and the last."""
    pad = " " * indent
    head = pad if key is None else f"{pad}{json.dumps(key)}: "
    flat = json.dumps(value)
    if not isinstance(value, dict | list) or len(head) + len(flat) <= width:
        return head + flat
    if isinstance(value, dict):
        entries = [json_excerpt(v, indent + 2, width, k) for k, v in value.items()]
        opening, closing = "{", "}"
    else:
        entries = [json_excerpt(v, indent + 2, width) for v in value]
        opening, closing = "[", "]"
    if len(entries) > JSON_KEEP and indent > 0:  # the top level whole: every field
        # "..." stands for entries left out: no comma of its own
        body = ",\n".join(entries[:2]) + ",\n" + " " * (indent + 2) + "...\n" + entries[-1]
    else:
        body = ",\n".join(entries)
    return f"{head}{opening}\n{body}\n{pad}{closing}"


#: the lines of IPOPT's log an excerpt keeps: the sizes, the iteration table's head, its
#: first two and last iterations, and the final measures
IPOPT_KEEP = re.compile(r"^(This is Ipopt|Number of nonzeros|Total number of variables|"
                        r"Total number of (in)?equality constraints|iter +objective|"
                        r"Number of Iterations|Total seconds in IPOPT|EXIT:)")
IPOPT_ITERATION = re.compile(r"^ *\d+r? +[-+0-9.e]+ ")


def ipopt_excerpt(log: str) -> str:
    """The first solve of an IPOPT log (print level 5), cut to what a reader needs."""
    if "This is Ipopt" not in log:
        raise PluginError("docs: the bundled fit's ipopt.log holds no IPOPT solve")
    lines = ("This is Ipopt" + log.split("This is Ipopt")[1]).splitlines()
    iterations = [ln for ln in lines if IPOPT_ITERATION.match(ln)]
    keep, shown = [], set()
    for ln in lines:
        if IPOPT_KEEP.match(ln) and ln not in shown:
            keep.append(ln)
            shown.add(ln)
            if ln.startswith("iter"):
                keep += iterations[:2] + (["..."] if len(iterations) > 3 else [])
                keep += iterations[2:][-1:]
    return "\n".join(keep)


def output_excerpt(name: str, root: Path) -> str:
    """The fenced excerpt of output ``name`` of the build's bundled fit (see :data:`OUTPUT`)."""
    folder = bundled_fit(root)
    if name == "terminal":
        return f"```{OUTPUT_LANG}\n{(folder / TERMINAL).read_text().strip()}\n```"
    path = folder / name
    if not path.is_file():
        raise PluginError(f"docs: <!-- output: {name} -->: the bundled fit wrote no {name}")
    text = path.read_text(encoding="utf-8")
    if name == "summary.json":
        data = json.loads(text)
        gait = Path(data["gait_file"])
        if not gait.is_relative_to(root):
            raise PluginError(f"docs: the bundled fit read {gait}, outside the repository")
        data["gait_file"] = ".../" + gait.relative_to(root).as_posix()
        text = json_excerpt(data)
    elif name == "curves.csv":
        rows = text.strip().splitlines()
        text = "\n".join([*rows[:3], "...", rows[-1]])
    elif name == "ipopt.log":
        return f"```text\n{ipopt_excerpt(text)}\n```"
    return f"```{OUTPUT_LANG}\n{text.strip()}\n```"


def figure_fit(root: Path) -> bytes:
    """``fit.png`` of the bundled file's fit (:func:`bundled_fit`), as the command wrote it."""
    return (bundled_fit(root) / "fit.png").read_bytes()


def figure_limit_cycle(root: Path) -> bytes:
    """``limit_cycle.png`` of the bundled file's fit (:func:`bundled_fit`)."""
    return (bundled_fit(root) / "limit_cycle.png").read_bytes()


#: name -> (function of the repository root returning a Figure or a PNG's bytes, caption)
FIGURES = {
    "fit": (figure_fit,
            "fit.png of `pdw-fit --gait female_fast.csv`, run by the docs build with the "
            "current code."),
    "limit_cycle": (figure_limit_cycle,
                    "limit_cycle.png of the same run."),
    "walker": (figure_walker,
               "The paper's 6-link walker at the section state of "
               "`problems/humanlike_6link.toml`, drawn by the docs build with "
               "`pdw_casadi.report.plots.plot_walker`."),
    "slope_sweep": (figure_slope_sweep,
                    "The branch of the paper's gait over the slope: step length, speed and "
                    "spectral radius; stable and valid solid, otherwise dashed; BND the "
                    "gait-pattern boundary, NS the Neimark–Sacker point, LP the fold. Drawn "
                    "by the docs build with `pdw-sweep`'s plotting code from its stored output "
                    "`docs/results/slope_sweep/` (the sweep takes about 10 s warm and "
                    "compiles the walker's functions first on a fresh machine, so the build "
                    "does not run it; `tests/test_results_pages.py` re-runs it and "
                    "compares)."),
    "cohort_r2": (figure_cohort_r2,
                  "R² per subject of the three cohorts below (symmetric fits on the paper's "
                  "body and on their own, per-side fits on their own; a per-side fit's knee "
                  "and hip R² the mean of its legs), drawn by the docs build from "
                  "`docs/results/cohort.csv` with `pdw-cohort`'s plotting code "
                  "(`r2_by_subject.png`)."),
    "prosthetist_study": (figure_prosthetist_study,
                          "The prosthetist's study: (a) the designed compliance of each leg "
                          "relative to the fitted sound leg's, (b) each leg's knee and hip "
                          "R² against the sound side's curves and the spectral radius per "
                          "step, over the prosthetic leg's mass reduction. Drawn by the docs "
                          "build from the stored table `docs/results/prosthetist/study.csv` "
                          "(the study runs for minutes, so the build "
                          "does not run it)."),
    "cohort_compliance": (figure_cohort_compliance,
                          "The fitted k_knee and k_ankle against body mass: the symmetric fits "
                          "on the subjects' own bodies (the paper-body rows have no body mass, "
                          "and the page does not list the per-side compliance), drawn by the "
                          "docs build from `docs/results/cohort.csv` with `pdw-cohort`'s "
                          "plotting code (`compliance.png`)."),
}


def figure_png(name: str, root: Path) -> bytes:
    """The PNG of figure ``name`` of :data:`FIGURES`, drawn now."""
    if name not in FIGURES:
        raise PluginError(f"docs: no figure {name!r} (figures: {sorted(FIGURES)})")
    try:
        fig = FIGURES[name][0](root)
    except PluginError:
        raise
    except Exception as exc:  # the build names the figure whose code failed
        raise PluginError(f"docs: figure {name!r} failed: {type(exc).__name__}: {exc}") \
            from exc
    if isinstance(fig, bytes):  # a command's own PNG
        return fig
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def figure_markdown(name: str, page_uri_: str) -> str:
    """The image of figure ``name`` with its caption, linked relative to the page."""
    src = posixpath.relpath(f"{FIGURES_DIR}/{name}.png", posixpath.dirname(page_uri_))
    caption = FIGURES[name][1]
    return f"![{caption}]({src})\n\n*{caption}*"


def on_files(files, config):
    from pdw_casadi.cli import COMMANDS

    wanted = sorted({name for f in files if f.src_uri.endswith(".md") and f.abs_src_path
                     for name in FIGURE.findall(f.content_string)})
    for name in wanted:
        uri = f"{FIGURES_DIR}/{name}.png"
        if files.get_file_from_path(uri) is not None:
            raise PluginError(f"docs: {uri} is drawn by the build, but the docs hold a file {uri}")
        files.append(File.generated(config, uri, content=figure_png(name, _root(config))))

    pages = {f.src_uri: f for f in files if f.src_uri.endswith(".md")}
    for name in COMMANDS:
        page = f"commands/{name}.md"
        if page not in pages:
            raise PluginError(f"docs: command pdw-{name} has no page {page}")
        text = pages[page].content_string
        if f"<!-- cli: pdw-{name} -->" not in text:
            raise PluginError(f"docs: {page} lacks the marker <!-- cli: pdw-{name} -->")
    for notebook in notebook_paths(config):
        markdown, images = render_notebook(notebook, config)
        for uri, content in [(page_uri(notebook), markdown), *images.items()]:
            if files.get_file_from_path(uri) is not None:
                raise PluginError(f"docs: {uri} is generated from {NOTEBOOKS}/{notebook.name}, "
                                  f"but the docs hold a file {uri}")
            files.append(File.generated(config, uri, content=content))
    return files


#: a formula as pymdownx.arithmatex (generic mode) writes it: inline \( \) in a span,
#: display \[ \] in a div (its TeX HTML-escaped)
ARITHMATEX = re.compile(r'<(span|div) class="arithmatex">\\([(\[])(.*?)\\[)\]]</\1>', re.S)


#: a TeX command latex2mathml did not know: it leaves it as the text of an element
UNKNOWN_COMMAND = re.compile(r">(\\[A-Za-z]+)<")
#: text that latex2mathml writes into an element unescaped (``\text{a<b}``)
MATHML_TEXT = re.compile(r"(<mtext[^>]*>)(.*?)(</mtext>)", re.S)


def _escape_text(text: str) -> str:
    """``text`` of an element as markup: ``<``, ``>`` and a bare ``&`` escaped, the
    entities latex2mathml writes itself (a space as ``&#x000A0;``) kept."""
    text = re.sub(r"&(?!#?\w+;)", "&amp;", text)
    return text.replace("<", "&lt;").replace(">", "&gt;")


def tex_to_mathml(match: re.Match, where: str = "") -> str:
    """One arithmatex element with its TeX replaced by MathML (inline or display); a
    formula latex2mathml rejects, or one with a command it does not know (left as text),
    fails the build, naming the page ``where`` and the formula."""
    from latex2mathml.converter import convert

    tag, opening, tex = match.groups()
    source = html.unescape(tex).strip()
    try:
        mathml = convert(source, display="block" if opening == "[" else "inline")
    except Exception as exc:  # the library's own errors: name the page and the formula
        raise PluginError(f"docs: {where}: the formula {source!r} is not TeX that "
                          f"latex2mathml reads ({type(exc).__name__}: {exc})") from exc
    unknown = UNKNOWN_COMMAND.search(mathml)
    if unknown:
        raise PluginError(f"docs: {where}: the formula {source!r} has a command latex2mathml "
                          f"does not know: {unknown.group(1)}")
    mathml = MATHML_TEXT.sub(lambda m: m.group(1) + _escape_text(m.group(2)) + m.group(3),
                             mathml)
    return f'<{tag} class="arithmatex">{mathml}</{tag}>'


def on_page_content(html_text, page, config, files):
    """Every formula of the page as MathML (the module docstring)."""
    return ARITHMATEX.sub(lambda m: tex_to_mathml(m, page.file.src_uri), html_text)


def on_page_markdown(markdown, page, config, files):
    if page.file.abs_src_path:  # a page of docs/: its links to notebook files go to their pages
        markdown = notebook_links(markdown, page.file, config)
    markdown = FIGURE.sub(lambda m: figure_markdown(m.group(1), page.file.src_uri), markdown)
    markdown = OUTPUT.sub(lambda m: output_excerpt(m.group(1), _root(config)), markdown)
    return MARKER.sub(lambda m: render(m.group(1)), markdown)


# -- the notebooks: each notebooks/NN_name.ipynb is a page, rendered with its saved outputs ----
# A notebook's page: its markdown cells as Markdown, its code cells as ``python`` blocks, each
# followed by its saved outputs (streams and plain text as text blocks, images as files of the
# site next to the page, HTML and Markdown as they are).
NOTEBOOKS = "notebooks"  # the folder of the repository, and that of its pages on the site
NAV_SECTION = "Notebooks"
#: the output representations shown, richest first; images are written as files
IMAGE_TYPES = {"image/png": "png", "image/jpeg": "jpg", "image/gif": "gif",
               "image/svg+xml": "svg"}
OUTPUT_ORDER = (*IMAGE_TYPES, "text/markdown", "text/html", "text/plain")
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
MD_LINK = re.compile(r"(!?)\[([^\]\n]*)\]\(([^)\s]+)\)")
HEADING = re.compile(r"^# +(.+)$", re.MULTILINE)


def _root(config) -> Path:
    return Path(config.config_file_path).resolve().parent


def notebook_paths(config) -> list[Path]:
    """The notebooks of the repository, ``notebooks/*.ipynb``, in name order."""
    return sorted((_root(config) / NOTEBOOKS).glob("*.ipynb"))


def page_uri(notebook: Path) -> str:
    """The page of a notebook in the docs: ``notebooks/01_reproduce_paper.md``."""
    return f"{NOTEBOOKS}/{notebook.stem}.md"


def read_notebook(path: Path) -> dict:
    """The notebook at ``path`` (nbformat 4, read as JSON: the docs extra needs no nbformat),
    every ``source`` and text output joined into one string."""
    try:
        nb = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise PluginError(f"docs: cannot read notebook {path.name}: {exc}") from None
    if nb.get("nbformat") != 4:
        raise PluginError(f"docs: {path.name} is nbformat {nb.get('nbformat')}, not 4")

    def text(value) -> str:
        return "".join(value) if isinstance(value, list) else (value or "")

    for cell in nb.get("cells", []):
        cell["source"] = text(cell.get("source"))
        for out in cell.get("outputs", []):
            if "text" in out:
                out["text"] = text(out["text"])
            out["data"] = {k: text(v) if isinstance(v, (list, str)) else v
                           for k, v in out.get("data", {}).items()}
    return nb


def nav_title(path: Path, nb: dict) -> str:
    """``01 Reproducing the paper``: the number of the file name and the notebook's first
    heading up to its colon (without a number or dash of its own)."""
    number = path.stem.split("_", 1)[0]
    heading = next((m.group(1) for cell in nb.get("cells", []) if cell["cell_type"] == "markdown"
                    for m in [HEADING.search(cell["source"])] if m), None)
    if heading is None:
        return path.stem.replace("_", " ")
    heading = re.sub(r"^\d+\s*[—–-]?\s*", "", heading.split(":", 1)[0]).strip()
    return f"{number} {heading}" if number.isdigit() else heading


def _fence(text: str, lang: str) -> str:
    """``text`` in a fenced block longer than any run of backticks it holds."""
    longest = max((len(m) for m in re.findall(r"`+", text)), default=0)
    fence = "`" * max(3, longest + 1)
    return f"{fence}{lang}\n{text.rstrip()}\n{fence}"


def _plain(text: str) -> str:
    """Terminal text as a page shows it: no colour codes, a carriage return overwriting."""
    text = ANSI.sub("", text)
    return "\n".join(line.rsplit("\r", 1)[-1] for line in text.split("\n"))


def _link(target: str, notebook: Path, config) -> str | None:
    """A link of a notebook's markdown, made relative to its page: a page of the docs (the
    notebook says ``../docs/model.md``), another notebook's page, or None (a file of the
    repository that is not on the site)."""
    if re.match(r"[a-zA-Z][\w+.-]*:", target) or target.startswith(("#", "/")):
        return target
    path, hash_, anchor = target.partition("#")
    local = (notebook.parent / path).resolve()
    docs = Path(config.docs_dir).resolve()
    here = posixpath.dirname(page_uri(notebook))
    if local.suffix == ".ipynb" and local.parent == notebook.parent and local.is_file():
        uri = page_uri(local)
    elif docs in local.parents and local.exists():
        uri = local.relative_to(docs).as_posix()
    else:
        return None
    return posixpath.relpath(uri, here) + hash_ + anchor


def render_notebook(path: Path, config) -> tuple[str, dict[str, bytes]]:
    """The Markdown page of the notebook at ``path`` and its images (site path -> bytes)."""
    nb = read_notebook(path)
    stem, rel = path.stem, f"{NOTEBOOKS}/{path.name}"
    images: dict[str, bytes] = {}
    blocks: list[str] = []

    def image(name: str, mime: str, data) -> str:
        raw = data.encode() if mime == "image/svg+xml" else base64.b64decode(data)
        images[f"{NOTEBOOKS}/{stem}/{name}.{IMAGE_TYPES[mime]}"] = raw
        return f"{stem}/{name}.{IMAGE_TYPES[mime]}"

    def markdown_cell(n: int, cell: dict) -> str:
        attachments = cell.get("attachments") or {}

        def sub(m: re.Match) -> str:
            bang, label, target = m.groups()
            if target.startswith("attachment:"):
                name = target.removeprefix("attachment:")
                mime = next((t for t in IMAGE_TYPES if t in attachments.get(name, {})), None)
                if mime is None:
                    raise PluginError(f"docs: {rel} cell {n}: no image attachment {name!r}")
                stemmed = re.sub(r"[^\w-]", "_", Path(name).stem)
                src = image(f"cell{n:02d}-{stemmed}", mime, attachments[name][mime])
                return f"{bang}[{label}]({src})"
            new = _link(target, path, config)
            if new is None:  # a file of the repository, not on the site: named, not linked
                local = (path.parent / target.split("#")[0]).resolve()
                try:
                    shown = local.relative_to(_root(config)).as_posix()
                except ValueError:
                    shown = target
                return f"{label} (`{shown}`)"
            return f"{bang}[{label}]({new})"

        return MD_LINK.sub(sub, cell["source"])

    def output(n: int, k: int, out: dict) -> str | None:
        kind = out.get("output_type")
        if kind == "error":
            trace = out.get("traceback") or [f"{out.get('ename')}: {out.get('evalue')}"]
            return _fence(_plain("\n".join(trace)), OUTPUT_LANG)
        data = out.get("data", {})
        mime = next((t for t in OUTPUT_ORDER if t in data), None)
        if mime is None:
            return None if not data else f"*(output of type {', '.join(sorted(data))} not shown)*"
        if mime in IMAGE_TYPES:
            return f"![output of cell {n}]({image(f'cell{n:02d}-{k}', mime, data[mime])})"
        if mime == "text/markdown":
            return data[mime].strip()
        if mime == "text/html":
            return f'<div class="notebook-output">\n{data[mime].strip()}\n</div>'
        return _fence(_plain(data[mime]), OUTPUT_LANG)

    saved = 0
    for n, cell in enumerate(nb.get("cells", []), 1):
        if cell["cell_type"] == "markdown":
            blocks.append(markdown_cell(n, cell))
            continue
        if cell["cell_type"] != "code":  # a raw cell
            if cell["source"].strip():
                blocks.append(_fence(cell["source"], "text"))
            continue
        if cell["source"].strip():
            blocks.append(_fence(cell["source"], "python"))
        stream, name = [], None
        for k, out in enumerate(cell.get("outputs", []), 1):
            saved += 1
            if out.get("output_type") == "stream":
                if stream and out.get("name") != name:
                    blocks.append(_fence(_plain("".join(stream)), OUTPUT_LANG))
                    stream = []
                stream.append(out.get("text", ""))
                name = out.get("name")
                continue
            if stream:
                blocks.append(_fence(_plain("".join(stream)), OUTPUT_LANG))
                stream = []
            shown = output(n, k, out)
            if shown:
                blocks.append(shown)
        if stream:
            blocks.append(_fence(_plain("".join(stream)), OUTPUT_LANG))
    if saved:
        first = (f"*Rendered from `{rel}` with its saved outputs, as they were when the "
                 "notebook was last run: the site build does not execute it.*")
    else:
        first = (f"*Rendered from `{rel}`, which has no saved outputs: this page shows its "
                 "text and code only (the site build does not execute it; run the notebook "
                 "to see its results).*")
    return "\n\n".join([first, *blocks]) + "\n", images


def notebook_links(markdown: str, file, config) -> str:
    """``markdown`` of the docs page ``file`` with its links to a notebook of the repository
    (``../notebooks/01_reproduce_paper.ipynb#x``) turned into links to the notebook's page."""
    notebooks = (_root(config) / NOTEBOOKS).resolve()

    def sub(m: re.Match) -> str:
        bang, label, target = m.groups()
        path, hash_, anchor = target.partition("#")
        if bang or not path.endswith(".ipynb") or re.match(r"[a-zA-Z][\w+.-]*:", path):
            return m.group(0)
        local = (Path(file.abs_src_path).parent / path).resolve()
        if local.parent != notebooks or not local.is_file():
            return m.group(0)  # MkDocs reports it
        uri = posixpath.relpath(page_uri(local), posixpath.dirname(file.src_uri))
        return f"[{label}]({uri}{hash_}{anchor})"

    return MD_LINK.sub(sub, markdown)


def on_config(config):
    """The nav's "Notebooks" section: one entry per notebook, in name order. A new build
    (``mkdocs serve`` rebuilds in one process) runs the bundled fit again."""
    _FIT_RUN.clear()
    section = next((item for item in config.nav or [] if isinstance(item, dict)
                    and NAV_SECTION in item), None)
    if section is None:
        raise PluginError(f"docs: the nav of mkdocs.yml lacks the section {NAV_SECTION!r} "
                          "(its pages are generated from notebooks/*.ipynb)")
    paths = notebook_paths(config)
    if not paths:
        raise PluginError("docs: no notebooks/*.ipynb for the nav section 'Notebooks'")
    section[NAV_SECTION] = [{nav_title(p, read_notebook(p)): page_uri(p)} for p in paths]
    return config


def on_serve(server, config, builder):
    server.watch(str(_root(config) / NOTEBOOKS))
    return server
