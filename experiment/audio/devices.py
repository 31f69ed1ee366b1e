"""Microphones behind a small interface (house style H4): sounddevice, and a scripted twin.

``sounddevice`` (PortAudio) and ``soundfile`` (libsndfile) are the optional extra ``audio``
(``pip install .[audio]``). Without them, or without an input device, :func:`open_microphone`
returns ``None`` and the reason, and the session runs without recording.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np

from experiment.clock import Clock, PerfCounterClock

__all__ = [
    "Microphone",
    "SoundDeviceMicrophone",
    "ScriptedMicrophone",
    "open_microphone",
    "AUDIO_EXTRA_HINT",
]

logger = logging.getLogger(__name__)

#: How to get the optional audio libraries.
AUDIO_EXTRA_HINT = "install the 'audio' extra: pip install .[audio]"


@runtime_checkable
class Microphone(Protocol):
    """A mono input that records between ``start`` and ``stop``."""

    samplerate_hz: int

    def start(self) -> float:
        """Start recording; return the clock time of the first sample, seconds."""
        ...

    def stop(self) -> np.ndarray:
        """Stop; return the samples since ``start``: float32, shape (n,), in [-1, 1]."""
        ...

    def close(self) -> None:
        """Release the device."""
        ...


class SoundDeviceMicrophone:
    """The default (or a named) input device through ``sounddevice``; one stream per session.

    The stream runs for the whole session; ``start`` and ``stop`` only open and close the
    window of samples kept, so a trial's recording begins without the device's start-up delay.
    The time of the first kept sample comes from PortAudio's capture time stamp of its block
    (``inputBufferAdcTime``), mapped to ``clock`` at that moment.

    Parameters
    ----------
    clock : Clock
        The session's clock (same time base as the stimulus flips).
    device : int or str or None
        PortAudio input device; default: the system's default input.
    samplerate_hz : int or None
        Default: the device's default rate.
    """

    def __init__(
        self, clock: Clock, *, device: int | str | None = None, samplerate_hz: int | None = None
    ) -> None:
        import sounddevice as sd

        self.clock = clock
        info = sd.query_devices(device, "input")
        self.samplerate_hz = int(samplerate_hz or info["default_samplerate"])
        self.device_name = str(info.get("name", device))
        self._lock = threading.Lock()
        self._blocks: list[np.ndarray] = []
        self._recording = False
        self._first_s: float | None = None
        self._stream = sd.InputStream(
            device=device,
            channels=1,
            samplerate=self.samplerate_hz,
            dtype="float32",
            callback=self._callback,
        )
        self._stream.start()
        self.latency_s = float(self._stream.latency)

    def _callback(self, data: np.ndarray, frames: int, time: Any, status: Any) -> None:
        if status:
            logger.warning("microphone: %s", status)
        with self._lock:
            if not self._recording:
                return
            if self._first_s is None:
                lag = float(self._stream.time) - float(time.inputBufferAdcTime)
                self._first_s = self.clock.now_s() - lag
            self._blocks.append(data[:, 0].copy())

    def start(self) -> float:
        """Start keeping samples; return the clock time of the first, seconds (see class doc)."""
        with self._lock:
            self._blocks = []
            self._first_s = None
            self._recording = True
            t0 = self.clock.now_s()
        return t0

    def stop(self) -> np.ndarray:
        """Stop keeping samples; return them (float32 mono)."""
        with self._lock:
            self._recording = False
            blocks, self._blocks = self._blocks, []
        return np.concatenate(blocks) if blocks else np.zeros(0, np.float32)

    @property
    def first_sample_s(self) -> float | None:
        """Clock time of the first kept sample from PortAudio's time stamps (None before one)."""
        return self._first_s

    def close(self) -> None:
        """Stop and close the stream."""
        self._stream.stop()
        self._stream.close()


class ScriptedMicrophone:
    """Test twin: returns scripted recordings, one per ``start``/``stop``.

    Parameters
    ----------
    recordings : callable (k) -> ndarray, or list of ndarray
        The ``k``-th recording (float32 mono in [-1, 1]).
    samplerate_hz : int
    clock : Clock or None
        ``start`` returns ``clock.now_s()``.
    """

    def __init__(
        self,
        recordings: Callable[[int], np.ndarray] | list[np.ndarray],
        samplerate_hz: int = 16000,
        clock: Clock | None = None,
    ) -> None:
        self.recordings = recordings
        self.samplerate_hz = int(samplerate_hz)
        self.clock = clock or PerfCounterClock()
        self.count = 0
        self.closed = False
        self.device_name = "scripted"
        self.latency_s = 0.0

    def start(self) -> float:
        """Return the clock time (the first sample's)."""
        return self.clock.now_s()

    def stop(self) -> np.ndarray:
        """Return the next scripted recording."""
        r = self.recordings
        x = r(self.count) if callable(r) else r[self.count % len(r)]
        self.count += 1
        return np.asarray(x, np.float32)

    def close(self) -> None:
        """Mark closed."""
        self.closed = True


def open_microphone(
    clock: Clock, *, device: int | str | None = None
) -> tuple[Microphone | None, str]:
    """Open the input device; return ``(microphone, "")`` or ``(None, why)`` (one line).

    Never raises for a missing library or device: the session runs without recording.
    """
    try:
        import sounddevice  # noqa: F401
        import soundfile  # noqa: F401  (needed to write the recordings)
    except ImportError as exc:
        return None, f"audio libraries not installed ({exc.name}); {AUDIO_EXTRA_HINT}"
    except OSError as exc:  # sounddevice without the PortAudio library
        return None, f"no audio system: {' '.join(str(exc).split())}"
    try:
        return SoundDeviceMicrophone(clock, device=device), ""
    except Exception as exc:  # PortAudioError, ValueError (no such device), ...
        return None, f"no microphone: {' '.join(str(exc).split())}"
