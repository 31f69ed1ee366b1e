"""Time: one monotonic clock, passed in (house style H17)."""

from __future__ import annotations

import time
from typing import Protocol, runtime_checkable

__all__ = ["Clock", "PerfCounterClock", "FakeClock"]


@runtime_checkable
class Clock(Protocol):
    """A monotonic clock."""

    def now_s(self) -> float:
        """Return the current time in seconds (monotonic, arbitrary origin)."""
        ...


class PerfCounterClock:
    """The real clock: ``time.perf_counter()``."""

    def now_s(self) -> float:
        """Return ``time.perf_counter()`` in seconds."""
        return time.perf_counter()


class FakeClock:
    """A clock for tests: time only moves when :meth:`advance` is called (no sleeping)."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._t = float(start_s)

    def now_s(self) -> float:
        """Return the fake current time in seconds."""
        return self._t

    def advance(self, dt_s: float) -> None:
        """Move the fake time forward by ``dt_s`` seconds."""
        if dt_s < 0:
            raise ValueError(f"dt_s must be >= 0, got {dt_s!r}")
        self._t += float(dt_s)
