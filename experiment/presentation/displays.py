"""Headless display: the test twin of the moderngl presenter (house style H4).

:class:`NullDisplay` shows nothing; it timestamps each "flip" with the injected clock and keeps
what it was asked to show, so a whole session runs in CI with no screen. Like a presenter with
input on, it queues subject inputs (:meth:`NullDisplay.post_input`, :meth:`NullDisplay.poll_inputs`)
for the active-search console.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from experiment.clock import Clock, PerfCounterClock
from experiment.interfaces import FlipRecord

__all__ = ["NullDisplay"]


class NullDisplay:
    """A display that draws nothing and records flips with a clock.

    Parameters
    ----------
    clock : Clock, optional
        Source of flip times (``PerfCounterClock`` if omitted; ``FakeClock`` in tests).
    hold_s : float
        Seconds each stimulus stays "on screen" before :meth:`show_stimulus` returns (0 = none).
        Only for paced headless pilots (and the crash test's child process); tests use 0.
    sleep : callable
        How to wait ``hold_s`` (``time.sleep``; injectable).
    """

    def __init__(
        self,
        clock: Clock | None = None,
        *,
        hold_s: float = 0.0,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if hold_s < 0:
            raise ValueError(f"hold_s must be >= 0, got {hold_s!r}")
        self.clock = clock if clock is not None else PerfCounterClock()
        self.hold_s = float(hold_s)
        self._sleep = sleep
        self.shown: list[tuple[int, ...]] = []
        self.last_image: np.ndarray | None = None
        self.texts: list[str] = []
        self.closed = False
        self._inputs: list[dict] = []

    def show_stimulus(self, image: np.ndarray) -> FlipRecord:
        """Record the image's shape and return a flip stamped with the clock (seconds)."""
        a = np.asarray(image)
        if a.ndim != 2 and not (a.ndim == 3 and a.shape[2] == 3):
            raise ValueError(
                f"image must be 2-D (rows, cols) or a colour photo (rows, cols, 3), got shape "
                f"{a.shape}"
            )
        self.shown.append(a.shape)
        self.last_image = a.copy()
        onset = self.clock.now_s()
        if self.hold_s > 0:
            self._sleep(self.hold_s)
        return FlipRecord(onset_s=onset)

    def clear(self) -> FlipRecord:
        """Return a flip stamped now (its onset is the stimulus offset, seconds)."""
        return FlipRecord(onset_s=self.clock.now_s())

    def show_text(self, text: str) -> None:
        """Record the text."""
        self.texts.append(str(text))

    def close(self) -> None:
        """Mark the display closed."""
        self.closed = True

    def post_input(self, event: dict) -> None:
        """Queue a subject input (``key``, optional ``box``), stamped with the clock."""
        self._inputs.append({"t_s": self.clock.now_s(), **event})

    def poll_inputs(self) -> list[dict]:
        """Return and forget the queued inputs, oldest first."""
        out, self._inputs = self._inputs, []
        return out
