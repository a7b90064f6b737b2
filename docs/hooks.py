"""MkDocs hooks of the documentation site: the command pages are generated from the parsers.

A line ``<!-- cli: pdw-fit -->`` in a page becomes that command's ``--help`` (run through
the command's own argparse parser, so the page cannot drift from the code) followed by the
exit codes of the contract (:mod:`pdw_casadi.cli.contract`). Every command of
:data:`pdw_casadi.cli.COMMANDS` must have its page ``commands/<name>.md`` holding its
marker, or the build fails.
"""

from __future__ import annotations

import contextlib
import io
import os
import re

from mkdocs.exceptions import PluginError

MARKER = re.compile(r"^<!-- cli: (pdw-[a-z-]+) -->$", re.MULTILINE)


def command_help(command: str) -> str:
    """The ``--help`` text of console script ``command`` (e.g. ``pdw-fit``), 100 columns."""
    from pdw_casadi.cli import COMMANDS

    name = command.removeprefix("pdw-")
    if name not in COMMANDS:
        raise PluginError(f"docs: no command {command!r} (commands: {sorted(COMMANDS)})")
    buf = io.StringIO()
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"
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


def on_files(files, config):
    from pdw_casadi.cli import COMMANDS

    pages = {f.src_uri: f for f in files if f.src_uri.endswith(".md")}
    for name in COMMANDS:
        page = f"commands/{name}.md"
        if page not in pages:
            raise PluginError(f"docs: command pdw-{name} has no page {page}")
        text = pages[page].content_string
        if f"<!-- cli: pdw-{name} -->" not in text:
            raise PluginError(f"docs: {page} lacks the marker <!-- cli: pdw-{name} -->")
    return files


def on_page_markdown(markdown, page, config, files):
    return MARKER.sub(lambda m: render(m.group(1)), markdown)
