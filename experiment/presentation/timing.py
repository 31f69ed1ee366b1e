"""Frame timing of the subject's screen: dropped frames and the refresh self-test.

Every flip is followed by ``glFinish`` and a time stamp from the injected clock (H17), as
PsychoPy does. In a window with vsync, flips are locked to the refresh;
:meth:`~experiment.presentation.presenter.Presenter.pump` redraws and flips once per refresh
while a stimulus is up, so the offset record carries every frame interval and the number of
dropped frames (:func:`count_dropped`: intervals over 1.5 refresh periods). The refresh rate is
measured at start (:meth:`~experiment.presentation.presenter.Presenter.measure_refresh`, with
:func:`refresh_stats`) and a failed timing self-test (:func:`check_timing`) refuses to start
unless skipped (H12). Offscreen (EGL) there is no refresh: flips are ``glFinish`` only and
``refresh_hz`` is None.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from experiment.presentation.errors import PresenterError

__all__ = [
    "DROPPED_FRAME_FACTOR",
    "TimingCheckFailed",
    "StimulusTiming",
    "count_dropped",
    "refresh_stats",
    "check_timing",
]

#: A frame interval above this many refresh periods counts as a dropped frame (PsychoPy's rule).
DROPPED_FRAME_FACTOR: float = 1.5

#: Fastest refresh a vsync-locked screen is believed to have, Hz; ours: faster flips mean that
#: vsync is off.
MAX_VSYNC_HZ: float = 300.0
#: Largest share of intervals that may be irregular (off the median by over
#: :data:`IRREGULAR_TOLERANCE`); ours.
MAX_IRREGULAR_FRACTION: float = 0.1
#: How far (fraction of the median) an interval may be off the median and still count as regular;
#: ours.
IRREGULAR_TOLERANCE: float = 0.2


class TimingCheckFailed(PresenterError):
    """The frame-timing self-test failed (no vsync or irregular flips); see skip_timing_check."""


@dataclass
class StimulusTiming:
    """Flip times of the stimulus now on screen, s (clock time), and its frame intervals, ms."""

    onset_s: float
    last_flip_s: float
    intervals_ms: list[float] = field(default_factory=list)


def count_dropped(intervals_ms: Any, refresh_hz: float | None) -> int:
    """Return how many frame intervals exceed 1.5 refresh periods (0 without a refresh)."""
    if not refresh_hz:
        return 0
    limit = DROPPED_FRAME_FACTOR * 1e3 / refresh_hz
    return int(sum(1 for d in intervals_ms if d > limit))


def refresh_stats(flip_times_s: Any) -> tuple[float, float]:
    """Return ``(refresh_hz, irregular)`` of consecutive flip times, s.

    ``refresh_hz`` is one over the median interval (inf when it is 0); ``irregular`` is the
    fraction (0-1) of intervals off the median by more than :data:`IRREGULAR_TOLERANCE`.
    """
    intervals = np.diff(flip_times_s)
    median = float(np.median(intervals))
    hz = 1.0 / median if median > 0 else float("inf")
    irregular = float(np.mean(np.abs(intervals - median) > IRREGULAR_TOLERANCE * median))
    return hz, irregular


def check_timing(refresh_hz: float, irregular: float) -> None:
    """Raise :class:`TimingCheckFailed` when flips are not vsync-locked or are irregular.

    Parameters
    ----------
    refresh_hz : float
        Measured refresh rate, Hz (from :func:`refresh_stats`).
    irregular : float
        Fraction of irregular intervals, 0-1.
    """
    if refresh_hz > MAX_VSYNC_HZ or irregular > MAX_IRREGULAR_FRACTION:
        raise TimingCheckFailed(
            f"frame-timing self-test failed: {refresh_hz:.1f} Hz measured, "
            f"{100 * irregular:.0f}% of intervals irregular (is vsync on?); pass "
            "--skip-timing-check to run anyway (the choice is logged)"
        )
