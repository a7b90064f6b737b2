"""The console scripts (``pdw-fit`` ...): each command's main, run as a process of its own.

An interrupted process exits as soon as its ``interrupted:`` line is out: tearing down a
fit's solver and the interpreter takes seconds on a loaded machine, and a Ctrl-C or a
SIGTERM must end the process within a few (:func:`pdw_casadi.cli.contract.run`). A
finished one skips that teardown too, after its exit handlers and output buffers
(:func:`_exit_after_work`).
"""

from __future__ import annotations

import atexit
import ctypes
import multiprocessing
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
        _exit_after_work(code)
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


def _exit_after_work(code: int) -> None:
    """End a console script's process once its work is written: the exit handlers run
    (temporary folders, log handlers), Python's and C's output buffers are flushed, and
    the interpreter's teardown is skipped (freeing every solver's and CasADi function's
    memory one object at a time: 0.3 s after a fit, docs/results/fit.md). While child
    processes of this one live (a pool's workers), the normal exit, which joins them."""
    if multiprocessing.active_children():
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):  # Python's first: they were written first
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    try:
        ctypes.CDLL(None).fflush(None)  # C stdio (IPOPT's log file, CasADi's prints)
    except (OSError, AttributeError):
        sys.exit(code)  # no C library to flush: the normal exit does it
    interrupt.exit_at_once(code)
    sys.exit(code)  # not a console script after all (exit_at_once returned)


def dispatch() -> None:
    """``python -m pdw_casadi.cli COMMAND [options]`` as a process."""
    if len(sys.argv) < 2 or sys.argv[1] not in COMMANDS:
        sys.exit(main())  # the usage error
    _script(sys.argv[1])(sys.argv[2:])
