"""Interfaces between the session engine and its hardware (house style H4).

The session loop only sees these. The real implementations are the moderngl presenter
(:mod:`experiment.presentation.presenter`) and the operator console (:mod:`experiment.console`);
the test twins are a headless display and scripted or simulated responders
(:mod:`experiment.observers`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, Self, runtime_checkable

if TYPE_CHECKING:
    import numpy as np

__all__ = ["FlipRecord", "Answer", "Display", "Responder", "ClosesOnExit", "combine_flips"]


@dataclass(frozen=True)
class FlipRecord:
    """Timing of one stimulus presentation as the display saw it.

    Parameters
    ----------
    onset_s : float
        Clock time of the flip that put the stimulus on screen, seconds.
    offset_s : float or None
        Clock time of the flip that removed it, seconds (None until removed).
    frame_intervals_ms : tuple of float
        Intervals between successive flips while the stimulus was shown, milliseconds.
    dropped_frames : int
        Frames whose interval exceeded 1.5 refresh periods.
    refresh_hz : float or None
        Refresh rate measured at start, Hz (None for a display without one).
    """

    onset_s: float
    offset_s: float | None = None
    frame_intervals_ms: tuple[float, ...] = field(default_factory=tuple)
    dropped_frames: int = 0
    refresh_hz: float | None = None


def combine_flips(onset: FlipRecord, offset: FlipRecord | None) -> FlipRecord:
    """Return one trial's flip record from its onset flip and its offset flip (``clear()``).

    The onset time and the refresh rate come from the onset flip; the offset time, the frame
    intervals and the dropped frames measured while the stimulus was up come from the offset
    flip (the display reports them when the stimulus is removed).
    """
    if offset is None:
        return onset
    return FlipRecord(
        onset_s=onset.onset_s,
        offset_s=offset.onset_s,
        frame_intervals_ms=tuple(offset.frame_intervals_ms),
        dropped_frames=int(offset.dropped_frames),
        refresh_hz=onset.refresh_hz if onset.refresh_hz is not None else offset.refresh_hz,
    )


@dataclass(frozen=True)
class Answer:
    """What the subject said and how it was scored.

    Parameters
    ----------
    response : str
        The subject's words as typed by the operator ("" for a pass).
    score : {'named', 'use', 'shape', 'wrong', 'pass'}
    rater : str
        Who scored it ("operator", "A", a simulated observer's name...).
    rt_s : float or None
        Response time from stimulus onset, seconds.
    """

    response: str
    score: str
    rater: str
    rt_s: float | None = None


@runtime_checkable
class Display(Protocol):
    """The subject's screen."""

    def show_stimulus(self, image: np.ndarray) -> FlipRecord:
        """Show a stimulus (bool or float32 [0, 1], native resolution); return its onset flip."""
        ...

    def clear(self) -> FlipRecord:
        """Remove the stimulus (blank or fixation); return the flip (its onset is the offset)."""
        ...

    def show_text(self, text: str) -> None:
        """Show an instruction, pause or end screen."""
        ...

    def close(self) -> None:
        """Release the window or context."""
        ...


@runtime_checkable
class Responder(Protocol):
    """Who answers a trial: the operator console (a person) or a simulated observer."""

    def respond(self, trial: object, image: np.ndarray) -> Answer:
        """Return the answer to ``trial`` shown as ``image``.

        ``trial`` is a :class:`~experiment.trials.Trial`.
        """
        ...


class ClosesOnExit:
    """Base of a class that holds a resource.

    ``with obj:`` gives ``obj`` and calls :meth:`close` on leaving, whether or not an exception is
    raised.
    """

    def close(self) -> None:
        """Release the resource (each subclass says which)."""
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
