"""The toolkit's exception types, in one module that imports nothing of the package.

Every other module raises and catches these from here, so a walker module can raise
:class:`ProblemError` without importing :mod:`pdw_casadi.model.problem` (which imports the walker
registry) and no import cycle needs hiding.
"""

from __future__ import annotations


class ProblemError(ValueError):
    """A problem file or override is invalid (message names the file and key)."""


class GaitDataError(ValueError):
    """A gait-curve file is missing, unreadable or does not hold valid gait curves."""


class CurveError(ValueError):
    """The curves cannot be fitted: the walker or the curve file lacks a target."""


class TimingError(ValueError):
    """The phases cannot be timed (unknown phase, a leg that never touches the ground)."""


class UsageError(ProblemError):
    """Bad command-line input (exit code 2, one ``error:`` line)."""


class NoGait(Exception):  # noqa: N818 (a result, not a bug: "the command found no gait")
    """The command ran but found no gait; the message is the reason (exit code 1)."""


class NoStartGait(ProblemError):
    """The sweep's start (the problem's own parameters and initial state) has no valid
    fixed point: nothing to follow."""


class PoincareError(RuntimeError):
    """The step from this state does not complete (the gait fails); ``failure`` says why."""

    def __init__(self, failure):
        super().__init__(f"step failed: {failure.reason} in phase {failure.phase} at "
                         f"t = {failure.time:.4f} s")
        self.failure = failure


def one_line(message: object) -> str:
    """``message`` as a single line (whitespace runs collapsed): the form of every error a
    command prints (an exception's text, e.g. a JSON parser's, may span lines)."""
    return " ".join(str(message).split()) or "unknown error"


__all__ = ["CurveError", "GaitDataError", "NoGait", "NoStartGait", "PoincareError",
           "ProblemError", "UsageError", "one_line"]
