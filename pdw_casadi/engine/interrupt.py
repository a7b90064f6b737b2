"""Ctrl-C and SIGTERM that no solver can swallow.

Python raises ``KeyboardInterrupt`` where the signal lands. Inside IPOPT that is one of
our CasADi callbacks: CasADi catches the exception, IPOPT ends with
``NonIpopt_Exception_Thrown`` and the caller would carry on as after a failed solve. So the
handlers installed by :func:`handling` also *record* the signal: the IPOPT iteration
callback asks IPOPT to stop while one is pending, :func:`check` re-raises it after a solve,
and a command that returns while one is pending is still an interrupted run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from collections.abc import Iterator

#: the exit code of a run ended by each signal (128 + the signal's number, as shells do)
EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}

#: set by the console scripts: an interrupted run ends its process right after its last line
EXIT_AT_ONCE = [False]

_pending: list[int] = []
_deferred = [False]
_depth = [0]


class Interrupted(KeyboardInterrupt):
    """A SIGINT or SIGTERM arrived; ``signum`` says which."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def requested() -> int | None:
    """The signal received while :func:`handling` was active (None when none was)."""
    return _pending[0] if _pending else None


def active() -> bool:
    """Whether the calling code runs inside a :func:`handling` block (a command)."""
    return _depth[0] > 0


def check() -> None:
    """Raise :class:`Interrupted` when a signal is pending (call after a solve)."""
    if _pending:
        raise Interrupted(_pending[0])


def _handler(signum, frame) -> None:
    if not _pending:
        _pending.append(signum)
    if not _deferred[0]:
        raise Interrupted(signum)


@contextlib.contextmanager
def handling() -> Iterator[None]:
    """SIGINT and SIGTERM recorded and raised as :class:`Interrupted` inside the block (main
    thread only; elsewhere the block runs with the handlers it has)."""
    if not _depth[0]:  # a nested block keeps a signal that came before it
        _pending.clear()
    try:
        old = {s: signal.signal(s, _handler) for s in EXIT_CODES}
    except ValueError:  # not the main thread
        yield
        return
    _depth[0] += 1
    try:
        check()  # one that arrived before (and was swallowed on the way)
        yield
    finally:
        _depth[0] -= 1
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Signals inside the block are recorded but not raised (moving finished files into
    place must not stop half way); :func:`requested` tells afterwards."""
    _deferred[0] = True
    try:
        yield
    finally:
        _deferred[0] = False


def exit_at_once(code: int) -> None:
    """End the process with ``code`` now when it is a console script (no teardown of the
    solvers and the interpreter: seconds on a loaded machine); return otherwise."""
    if EXIT_AT_ONCE[0]:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)
