"""Record each trial's spoken answer beside the trial log and find its voice onset.

Files: ``<log stem>_audio/session-<id>/trial-<index>.flac`` (mono, 16-bit, FLAC: lossless and
about half the size of WAV; a 10 s answer at 44.1 kHz is about 0.5 MB) next to the SQLite trial
log, written to a temporary name and renamed. Each file gets a row in the log's
``audio`` table (migration 5): its path relative to the log's folder, sha256, sample rate,
duration, the clock time of its first sample (``start_s``), and ``voice_rt_s``, the voice onset
after the stimulus onset (:func:`experiment.audio.voice.voice_onset_s`). The operator's first
keystroke stays in ``trials.rt_s``; the view ``voice_trials`` shows both as ``key_rt_s`` and
``voice_rt_s``.

The trial is committed first (its answer is never at risk), then the recording; a crash
between the two leaves a file without a row, never a row without a file.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from experiment.audio.devices import AUDIO_EXTRA_HINT, Microphone
from experiment.audio.voice import method_dict, voice_onset_s

__all__ = ["TrialAudio", "AudioResult", "audio_dir", "read_audio_rows"]

logger = logging.getLogger(__name__)


def audio_dir(log_path: str | os.PathLike) -> Path:
    """Return the folder of a trial log's recordings (``study.sqlite`` -> ``study_audio/``)."""
    p = Path(log_path)
    return p.with_name(f"{p.stem}_audio")


@dataclass(frozen=True)
class AudioResult:
    """One trial's recording as logged.

    Parameters
    ----------
    path : Path
        The recording (FLAC).
    duration_s : float
    voice_rt_s : float or None
        Voice onset after the stimulus onset, s; None when no voice was found.
    """

    path: Path
    duration_s: float
    voice_rt_s: float | None


class TrialAudio:
    """Per-trial recording for a session: ``start`` at stimulus onset, ``finish`` at scoring.

    Parameters
    ----------
    session : experiment.session.engine.Session
        An open session on a file trial log.
    microphone : Microphone
    """

    def __init__(self, session: Any, microphone: Microphone) -> None:
        try:
            import soundfile  # noqa: F401
        except ImportError as exc:
            raise ImportError(f"recording needs soundfile; {AUDIO_EXTRA_HINT}") from exc
        db = str(session.log.path)
        if db == ":memory:":
            raise ValueError("audio recording needs a trial log file, not ':memory:'")
        self.session = session
        self.microphone = microphone
        self.root = Path(db).parent
        self.folder = audio_dir(db) / f"session-{session.session_id}"
        self._trial: Any = None
        self._onset_s: float | None = None
        self._start_s: float | None = None

    def start(self, trial: Any, onset_s: float) -> None:
        """Start recording ``trial``, whose stimulus appeared at ``onset_s`` (clock s)."""
        self._trial, self._onset_s = trial, float(onset_s)
        self._start_s = float(self.microphone.start())

    def discard(self) -> None:
        """Stop and drop the current recording (trial not answered: quit, presenter crash)."""
        if self._trial is not None:
            self.microphone.stop()
        self._trial = None

    def finish(self, trial: Any) -> AudioResult | None:
        """Stop, write the file, find the voice onset and log it; return what was logged."""
        if self._trial is None or trial.index != self._trial.index:
            return None
        samples = np.clip(np.asarray(self.microphone.stop(), np.float32), -1.0, 1.0)
        self._trial = None
        fs = int(self.microphone.samplerate_hz)
        first = getattr(self.microphone, "first_sample_s", None)
        start_s = float(first) if first is not None else float(self._start_s)
        onset_in_file = voice_onset_s(samples, fs) if samples.size else None
        voice_rt = None if onset_in_file is None else start_s + onset_in_file - self._onset_s
        path = self._write(trial.index, samples, fs)
        method = {
            **method_dict(),
            "device": getattr(self.microphone, "device_name", "?"),
            "input_latency_s": getattr(self.microphone, "latency_s", None),
            "stimulus_onset_s": self._onset_s,
            "onset_in_recording_s": onset_in_file,
        }
        log = self.session.log
        with log.atomic() as con:
            con.execute(
                "INSERT INTO audio (session_id, trial_index, path, sha256, samplerate_hz, "
                "duration_s, start_s, voice_rt_s, method_json, recorded_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, datetime('now'))",
                (
                    self.session.session_id,
                    trial.index,
                    path.relative_to(self.root).as_posix(),
                    hashlib.sha256(path.read_bytes()).hexdigest(),
                    fs,
                    samples.size / fs,
                    start_s,
                    voice_rt,
                    json.dumps(method, sort_keys=True),
                ),
            )
        return AudioResult(path=path, duration_s=samples.size / fs, voice_rt_s=voice_rt)

    def _write(self, index: int, samples: np.ndarray, fs: int) -> Path:
        import soundfile as sf

        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / f"trial-{index:04d}.flac"
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".flac", dir=self.folder)
        os.close(fd)
        try:
            sf.write(tmp, samples, fs, subtype="PCM_16", format="FLAC")
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        return path

    def close(self) -> None:
        """Drop any recording in progress and release the microphone."""
        self.discard()
        self.microphone.close()


def read_audio_rows(log: Any, session_id: int) -> list[dict[str, Any]]:
    """Return the session's ``voice_trials`` rows: trial_index, key_rt_s, voice_rt_s, paths."""
    rows = log.execute(
        "SELECT * FROM voice_trials WHERE session = ? ORDER BY trial_index", (session_id,)
    )
    return [dict(r) for r in rows]
