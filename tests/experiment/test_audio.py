"""The subject's voice: per-trial recordings and voice onset.

Voice onset is tested by parameter recovery on synthetic recordings with a known onset (a
harmonic "vowel" in noise), the level against a direct computation, and the recorder through a
scripted microphone (the test twin of the sound card) and a real SQLite trial log.
"""

from __future__ import annotations

import asyncio
import json
import sqlite3
import sys
from pathlib import Path

import numpy as np
import pytest

from experiment.audio import ScriptedMicrophone, TrialAudio, audio_dir, open_microphone
from experiment.audio.recorder import read_audio_rows
from experiment.audio.voice import (
    MARGIN_DB,
    WINDOW_S,
    short_time_level_db,
    voice_onset_s,
)
from experiment.console import OperatorConsole
from experiment.console.launch import _open_recorder
from experiment.log import MIGRATIONS
from experiment.presentation.displays import NullDisplay
from tests.experiment.conftest import console_session

sf = pytest.importorskip("soundfile", reason="soundfile (the 'audio' extra) is not installed")


def synthetic_answer(
    onset_s: float,
    *,
    fs: int = 16000,
    duration_s: float = 2.0,
    snr_db: float = 30.0,
    f0_hz: float = 140.0,
    rng: int = 0,
) -> np.ndarray:
    """Noise (-50 dBFS) plus a harmonic vowel from ``onset_s`` (5 ms attack), 0.6 s long."""
    g = np.random.default_rng(rng)
    n = int(duration_s * fs)
    t = np.arange(n) / fs
    noise_rms = 10 ** (-50 / 20)
    x = noise_rms * g.standard_normal(n)
    voice = sum(np.sin(2 * np.pi * k * f0_hz * t + g.uniform(0, 6.3)) / k for k in range(1, 6))
    voice *= 10 ** ((snr_db - 50) / 20) / np.sqrt(np.mean(voice**2))
    env = np.clip((t - onset_s) / 0.005, 0, 1) * (t < onset_s + 0.6)
    return (x + env * voice).astype(np.float32)


@pytest.mark.parametrize("fs", [16000, 44100])
@pytest.mark.parametrize("onset", [0.31, 0.734, 1.2])
@pytest.mark.parametrize("snr_db", [20.0, 40.0])
def test_voice_onset_recovered_within_10_ms(fs, onset, snr_db) -> None:
    """Tolerance 10 ms: the window's half-width (5 ms) plus the 5 ms attack."""
    x = synthetic_answer(onset, fs=fs, snr_db=snr_db, rng=int(onset * 1000))
    got = voice_onset_s(x, fs)
    assert got is not None and abs(got - onset) <= 0.010, (got, onset)


def test_clicks_before_the_voice_are_ignored() -> None:
    fs = 16000
    x = synthetic_answer(0.9, fs=fs)
    for at in (0.2, 0.5):  # two 3 ms key taps, much louder than the voice
        i = int(at * fs)
        x[i : i + 48] += 0.5
    assert abs(voice_onset_s(x, fs) - 0.9) <= 0.010


def test_no_voice_gives_none() -> None:
    fs = 16000
    noise = synthetic_answer(5.0, fs=fs)  # onset after the end: noise only
    assert voice_onset_s(noise, fs) is None
    quiet = synthetic_answer(0.5, fs=fs, snr_db=MARGIN_DB - 8)  # below the margin
    assert voice_onset_s(quiet, fs) is None
    assert voice_onset_s(np.zeros(0, np.float32), fs) is None
    assert voice_onset_s(np.zeros(10, np.float32), fs) is None


def test_level_matches_direct_computation() -> None:
    """Reference: mean square of each window computed with a plain loop."""
    fs = 8000
    x = np.random.default_rng(1).standard_normal(4000).astype(np.float32) * 0.1 + 0.05
    times, level = short_time_level_db(x, fs)
    win = int(round(WINDOW_S * fs))
    y = x.astype(np.float64)
    y -= y.mean()
    for k in (0, 17, len(level) - 1):
        start = int(round(times[k] * fs - win / 2))
        ref = 10 * np.log10(np.mean(y[start : start + win] ** 2) + 1e-12)
        # the implementation takes differences of a running sum: 1e-9 dB covers its rounding
        assert level[k] == pytest.approx(ref, abs=1e-9)


def test_bad_samples_raise() -> None:
    with pytest.raises(ValueError, match=r"samples must be 1-D \(mono\), got shape \(2, 3\)"):
        voice_onset_s(np.zeros((2, 3), np.float32), 16000)
    with pytest.raises(TypeError, match="samples must be float in"):
        voice_onset_s(np.zeros(10, np.int16), 16000)
    with pytest.raises(ValueError, match="samplerate_hz must be a positive number"):
        voice_onset_s(np.zeros(10, np.float32), 0)


@pytest.fixture
def session(tmp_path):
    with console_session(tmp_path) as (s, clock, log):
        yield s, clock, log, tmp_path


def test_migration_adds_append_only_audio_table(session) -> None:
    _, _, log, _ = session
    assert 5 in [v for v, _, _ in MIGRATIONS] and log.schema_version() >= 5
    cols = [r[1] for r in log.execute("PRAGMA table_info(audio)")]
    assert {"path", "sha256", "voice_rt_s", "start_s", "method_json"} <= set(cols)


def test_console_records_each_answer_and_its_voice_onset(session) -> None:
    s, clock, log, tmp_path = session
    fs = 16000
    onset_in_file = [0.8, 1.3]
    mic = ScriptedMicrophone(
        [synthetic_answer(o, fs=fs, rng=i) for i, o in enumerate(onset_in_file)], fs, clock
    )
    recorder = TrialAudio(s, mic)
    app = OperatorConsole(s, NullDisplay(clock), recorder=recorder)

    async def script() -> None:
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.press("enter", "enter")  # part screen, trial 1
            clock.advance(2.5)
            await pilot.press("a", "f1")  # the operator types late: key 2.5 s after onset
            assert "Voice onset 0.80 s" in str(app.query_one("#status").render())
            await pilot.press("enter")
            clock.advance(3.0)
            await pilot.press("b", "f4")
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(script(), timeout=60))
    rows = read_audio_rows(log, s.session_id)
    assert [r["trial_index"] for r in rows] == [0, 1]
    for r, expected in zip(rows, onset_in_file, strict=True):
        # the scripted microphone starts at the stimulus onset (FakeClock), so voice_rt_s is the
        # onset inside the file; the keystroke time is kept apart as key_rt_s
        assert r["voice_rt_s"] == pytest.approx(expected, abs=0.010)
        assert r["key_rt_s"] == pytest.approx(2.5 if r["trial_index"] == 0 else 3.0)
        path = tmp_path / r["audio_path"]
        assert path.parent == audio_dir(log.path) / f"session-{s.session_id}"
        data, rate = sf.read(path, dtype="float32")
        assert rate == fs and data.shape == (2 * fs,)
        # 16-bit PCM: the same samples to 1/2**15
        k = r["trial_index"]
        ref = synthetic_answer(onset_in_file[k], fs=fs, rng=k)
        assert np.abs(data - ref).max() <= 2.0**-15
        method = json.loads(
            log.execute("SELECT method_json FROM audio WHERE trial_index = ?", (r["trial_index"],))[
                0
            ][0]
        )
        assert method["margin_db"] == MARGIN_DB and method["device"] == "scripted"
    with pytest.raises(sqlite3.DatabaseError, match="append-only"):
        with log.atomic() as con:
            con.execute("UPDATE audio SET voice_rt_s = 0")

    # the second rater replays the recorded answer (F7)
    from experiment.commands.score import pending_for_rater
    from experiment.console import ScoringApp

    played: list[Path] = []
    rater_app = ScoringApp(log, "B", pending_for_rater(log, "B"))
    rater_app.player = lambda path: played.append(Path(path)) or ""

    async def rate() -> None:
        async with rater_app.run_test(size=(100, 30)) as pilot:
            await pilot.press("f7")
            assert "playing trial-0000.flac" in str(rater_app.query_one("#status").render())
            await pilot.press("f1", "f7")
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(rate(), timeout=60))
    assert [p.name for p in played] == ["trial-0000.flac", "trial-0001.flac"]
    assert all(p.is_file() for p in played)


def test_without_a_microphone_the_session_says_so_once(session, monkeypatch) -> None:
    s, clock, log, _ = session
    monkeypatch.setitem(sys.modules, "sounddevice", None)  # import fails: extra not installed
    mic, why = open_microphone(clock)
    assert mic is None and "pip install .[audio]" in why
    recorder, note = _open_recorder(s, True, None)
    assert recorder is None and "Recording off" in note
    events = log.execute("SELECT note FROM events WHERE kind = 'audio_unavailable'")
    assert len(events) == 1 and "pip install .[audio]" in events[0][0]
    app = OperatorConsole(s, NullDisplay(clock), audio_note=note)

    async def script() -> None:
        async with app.run_test(size=(100, 30)) as pilot:
            assert "Recording off" in str(app.query_one("#status").render())
            await pilot.press("enter", "enter")
            await pilot.press("a", "f1")
            assert "Recording off" not in str(app.query_one("#status").render())
            assert app.result.recorded == [app.result.recorded[0]]
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(script(), timeout=60))
    assert log.execute("SELECT count(*) FROM audio")[0][0] == 0
    assert log.execute("SELECT count(*) FROM trials")[0][0] == 1

    from experiment.commands.score import pending_for_rater
    from experiment.console import ScoringApp

    rater_app = ScoringApp(log, "B", pending_for_rater(log, "B"))
    rater_app.player = lambda path: pytest.fail("nothing to play")

    async def rate() -> None:
        async with rater_app.run_test(size=(100, 30)) as pilot:
            await pilot.press("f7")
            assert "no recording" in str(rater_app.query_one("#status").render())
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(rate(), timeout=60))


def test_a_failing_microphone_stops_recording_not_the_session(session) -> None:
    s, clock, log, _ = session

    def broken(k: int) -> np.ndarray:
        raise OSError("input overflow; device unplugged")

    app = OperatorConsole(s, NullDisplay(clock), recorder=TrialAudio(s, ScriptedMicrophone(broken)))

    async def script() -> None:
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.press("enter", "enter", "a", "f1")
            assert app.recorder is None and app.state == "scored"
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(script(), timeout=60))
    assert log.execute("SELECT count(*) FROM trials")[0][0] == 1
    ev = log.execute("SELECT note FROM events WHERE kind = 'audio_failed'")
    assert len(ev) == 1 and "device unplugged" in ev[0][0]


def test_recorder_needs_a_log_file() -> None:
    class S:
        class log:  # noqa: N801
            path = ":memory:"

        session_id = 1

    with pytest.raises(ValueError, match="needs a trial log file"):
        TrialAudio(S(), ScriptedMicrophone([np.zeros(10, np.float32)]))
    assert audio_dir(Path("/x/study.sqlite")) == Path("/x/study_audio")
