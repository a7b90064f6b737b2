"""The console scripts (``pdw-fit`` ...): each command's main, run as a process of its own.

An interrupted process exits as soon as its ``interrupted:`` line is out: tearing down a
fit's solver and the interpreter takes seconds on a loaded machine, and a Ctrl-C or a
SIGTERM must end the process within a few (:func:`pdw_casadi.cli.contract.run`).
"""

from __future__ import annotations

import sys

from pdw_casadi.cli import COMMANDS
from pdw_casadi.engine import interrupt


def _script(command: str):
    def main() -> None:
        interrupt.EXIT_AT_ONCE[0] = True
        sys.exit(COMMANDS[command]())
    main.__name__ = command.replace("-", "_")
    main.__doc__ = f"``pdw-{command}`` as a process (see the module docstring)."
    return main


simulate = _script("simulate")
fixed_point = _script("fixed-point")
fit = _script("fit")
sweep = _script("sweep")
scale = _script("scale")
design = _script("design")
atlas = _script("atlas")
