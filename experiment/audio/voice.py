"""Voice onset in a recording of a spoken answer: an energy threshold (a software voice key).

Method (ours, not the paper's: Jung et al. 2015 had the operator write the answers down)
----------------------------------------------------------------------------------------
1. The recording (mono, float in [-1, 1]) loses its mean (DC offset).
2. Short-time level: the mean square in a window of :data:`WINDOW_S` centred on each time step
   of :data:`HOP_S`, in dB re full scale, ``10 log10(mean square)``.
3. Noise floor: the :data:`FLOOR_PERCENTILE` th percentile of those levels. In a naming trial
   the subject is silent for most of the recording (before the answer, between words, while
   the operator types), so a low percentile is the room's noise, measured in every recording
   anew rather than fixed in advance.
4. Threshold: floor + :data:`MARGIN_DB`. A recording whose loudest level does not reach it holds
   no voice (``None``).
5. Onset: the centre of the first window above the threshold that begins a run of at least
   :data:`MIN_VOICED_S` above it, so that a click, a cough-length knock on the table or a
   keyboard tap shorter than that is not taken for speech.

This is the classic "voice key" (a level crossing with a hold time) done offline on the whole
recording, where the noise floor can be measured first. Voice keys trigger late on soft onsets
(fricatives such as /f/, /s/) by tens of ms (Kessler, Treiman & Mullennix 2002); the
recordings are kept so that onsets can be checked by ear or with other methods.

References
----------
Kessler, B., Treiman, R., & Mullennix, J. (2002). Phonetic biases in voice key response time
measurements. Journal of Memory and Language 47, 145-171.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "WINDOW_S",
    "HOP_S",
    "FLOOR_PERCENTILE",
    "MARGIN_DB",
    "MIN_VOICED_S",
    "short_time_level_db",
    "voice_onset_s",
    "method_dict",
]

#: Level window, s (ours: 10 ms spans one to two glottal periods of adult speech, 100-200 Hz).
WINDOW_S = 0.010
#: Time step of the level, s (ours: 1 ms, finer than the window's own smear of +-5 ms).
HOP_S = 0.001
#: Percentile of the levels taken as the noise floor (ours; see the module docstring).
FLOOR_PERCENTILE = 10.0
#: Threshold above the noise floor, dB (ours: conversational speech at 1 m is 20-40 dB above a
#: quiet room; 15 dB leaves room for soft voices and is far above the noise's own +-3 dB
#: fluctuation in 10 ms windows).
MARGIN_DB = 15.0
#: Shortest run above the threshold taken as voice, s (ours: a syllable's vowel lasts 50 ms or
#: more; clicks and taps last a few ms).
MIN_VOICED_S = 0.040

_TINY = 1e-12


def _check(samples: np.ndarray, samplerate_hz: float) -> np.ndarray:
    x = np.asarray(samples)
    if x.ndim != 1:
        raise ValueError(f"samples must be 1-D (mono), got shape {x.shape}")
    if not np.issubdtype(x.dtype, np.floating):
        raise TypeError(f"samples must be float in [-1, 1], got dtype {x.dtype}")
    if not (np.isfinite(samplerate_hz) and samplerate_hz > 0):
        raise ValueError(f"samplerate_hz must be a positive number, got {samplerate_hz!r}")
    return x.astype(np.float64)


def short_time_level_db(samples: np.ndarray, samplerate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(times_s, level_db)``: the mean-square level in windows centred on each hop.

    Parameters
    ----------
    samples : ndarray of shape (n,), float in [-1, 1]
        Mono recording.
    samplerate_hz : float > 0

    Returns
    -------
    times_s : ndarray of shape (m,)
        Window centres, seconds from the first sample.
    level_db : ndarray of shape (m,)
        ``10 log10(mean square)`` of the DC-free signal in each window, dB re full scale.
    """
    x = _check(samples, samplerate_hz)
    x = x - x.mean() if x.size else x
    win = max(1, int(round(WINDOW_S * samplerate_hz)))
    hop = max(1, int(round(HOP_S * samplerate_hz)))
    if x.size < win:
        return np.zeros(0), np.zeros(0)
    c = np.concatenate([[0.0], np.cumsum(x * x)])
    starts = np.arange(0, x.size - win + 1, hop)
    ms = (c[starts + win] - c[starts]) / win
    return (starts + win / 2) / samplerate_hz, 10 * np.log10(ms + _TINY)


def voice_onset_s(samples: np.ndarray, samplerate_hz: float) -> float | None:
    """Return the voice onset in a recording, seconds from its first sample, or ``None``.

    See the module docstring for the method.

    Parameters
    ----------
    samples, samplerate_hz
        As in :func:`short_time_level_db`: a mono float recording in [-1, 1], its rate > 0.

    Returns
    -------
    float or None
        ``None`` when no run of :data:`MIN_VOICED_S` rises :data:`MARGIN_DB` above the floor.

    Raises
    ------
    ValueError, TypeError
        Samples not 1-D float, or a bad sample rate.

    Examples
    --------
    >>> fs = 16000
    >>> rng = np.random.default_rng(0)
    >>> x = 0.001 * rng.standard_normal(fs)
    >>> t = np.arange(fs) / fs
    >>> x[8000:12000] += 0.2 * np.sin(2 * np.pi * 150 * t[8000:12000])
    >>> round(voice_onset_s(x, fs), 2)
    0.5
    """
    times, level = short_time_level_db(samples, samplerate_hz)
    if level.size == 0:
        return None
    floor = float(np.percentile(level, FLOOR_PERCENTILE))
    above = level > floor + MARGIN_DB
    if not above.any():
        return None
    need = max(1, int(round(MIN_VOICED_S / HOP_S)))
    # length of the run of True starting at each index
    run = np.zeros(above.size + 1, int)
    for i in range(above.size - 1, -1, -1):
        run[i] = run[i + 1] + 1 if above[i] else 0
    hits = np.flatnonzero(run[:-1] >= need)
    if hits.size == 0:
        return None
    return float(times[hits[0]])


def method_dict() -> dict[str, float | str]:
    """Return the method and its constants, for the log's ``method_json`` (provenance)."""
    return {
        "method": "energy threshold above the recording's noise floor (voice key)",
        "window_s": WINDOW_S,
        "hop_s": HOP_S,
        "floor_percentile": FLOOR_PERCENTILE,
        "margin_db": MARGIN_DB,
        "min_voiced_s": MIN_VOICED_S,
    }
