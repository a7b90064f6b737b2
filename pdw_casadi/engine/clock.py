"""Where a run's wall time goes: named parts, summed, for the last line of a verbose run."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager


class Stopwatch:
    """Wall time (s) per named part of a run, in the order the parts were first timed."""

    def __init__(self) -> None:
        self.parts: dict[str, float] = {}

    @contextmanager
    def part(self, name: str) -> Iterator[None]:
        """Time the block as part ``name`` (added to its earlier time, if any)."""
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0)

    def add(self, name: str, seconds: float) -> None:
        """Add ``seconds`` (s) to part ``name``."""
        self.parts[name] = self.parts.get(name, 0.0) + seconds

    def total(self) -> float:
        """The sum of the parts (s)."""
        return sum(self.parts.values())

    def line(self) -> str:
        """``where the time went: a 1.2 s, b 0.3 s; total 1.5 s``."""
        body = ", ".join(f"{k} {v:.1f} s" for k, v in self.parts.items())
        return f"where the time went: {body}; total {self.total():.1f} s"
