"""Timing a driver's stages with one context manager."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager


class Clock:
    """Seconds per named stage: ``with clock.stage("exact"): ...``; ``seconds`` maps
    each stage (in the order first run) to its time, summed over repeats."""

    def __init__(self) -> None:
        self.seconds: dict = {}
        self.started = time.perf_counter()

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - t0

    def total(self) -> float:
        """Seconds since the clock was made."""
        return time.perf_counter() - self.started
