"""The console scripts (``pdw-fit`` ...): each command's main, run as a process of its own.

An interrupted process exits as soon as its ``interrupted:`` line is out: tearing down a
fit's solver and the interpreter takes seconds on a loaded machine, and a Ctrl-C or a
SIGTERM must end the process within a few (:func:`pdw_casadi.cli.contract.run`).
"""

from __future__ import annotations

import sys
import time

from pdw_casadi.cli import COMMANDS, main
from pdw_casadi.engine import interrupt

#: when the console script's process began its work (s, time.perf_counter): what a verbose
#: run's last line counts its start-up and imports from
STARTED: list[float | None] = [None]


def _script(command: str):
    def main(argv=None) -> None:
        STARTED[0] = time.perf_counter()
        interrupt.EXIT_AT_ONCE[0] = True
        with interrupt.handling():  # from the start: the command's imports take seconds
            try:
                code = COMMANDS[command](argv)
            except KeyboardInterrupt as exc:  # before the command's own run() took over
                print("interrupted: nothing written", file=sys.stderr, flush=True)
                code = interrupt.EXIT_CODES.get(getattr(exc, "signum", 2), 130)
                interrupt.exit_at_once(code)
        sys.exit(code)
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
cohort = _script("cohort")
seed = _script("seed")
compare = _script("compare")


def dispatch() -> None:
    """``python -m pdw_casadi.cli COMMAND [options]`` as a process."""
    if len(sys.argv) < 2 or sys.argv[1] not in COMMANDS:
        sys.exit(main())  # the usage error
    _script(sys.argv[1])(sys.argv[2:])
