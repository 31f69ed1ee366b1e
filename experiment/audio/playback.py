"""Replay a trial's recording for the second rater."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

from experiment.audio.devices import AUDIO_EXTRA_HINT

__all__ = ["recording_for", "play"]


def recording_for(log: Any, session_id: int, trial_index: int) -> Path | None:
    """Return the audio file of a trial's spoken answer, or None (none recorded, old log)."""
    try:
        rows = log.execute(
            "SELECT path FROM audio WHERE session_id = ? AND trial_index = ?",
            (session_id, trial_index),
        )
    except (sqlite3.Error, ValueError, RuntimeError):  # e.g. a log from before migration 5
        return None
    if not rows:
        return None
    return Path(str(log.path)).parent / rows[0][0]


def play(path: str | Path) -> str:
    """Start playing an audio file on the default output (returns at once); return "" or why not."""
    try:
        import sounddevice as sd
        import soundfile as sf
    except ImportError:
        return f"cannot play audio: {AUDIO_EXTRA_HINT}"
    except OSError as exc:
        return f"cannot play audio: {' '.join(str(exc).split())}"
    try:
        data, rate = sf.read(str(path), dtype="float32")
        sd.play(data, rate)
    except Exception as exc:  # missing file, no output device
        return f"cannot play {Path(path).name}: {' '.join(str(exc).split())}"
    return ""
