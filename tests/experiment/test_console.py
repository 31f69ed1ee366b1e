"""Operator console driven by Textual's pilot: a scripted operator runs a short session end to end.

The log must hold exactly what was typed and scored, including undo (an appended re-score),
pause/resume and notes; timing data is present for every trial. The presenter-process tests
(restart after a crash) need a headless GL context and are marked ``gl``.
"""

from __future__ import annotations

import asyncio
import json

import numpy as np
import pytest

from experiment.clock import PerfCounterClock
from experiment.console import OperatorConsole, preview_text
from experiment.interfaces import FlipRecord, combine_flips
from experiment.presentation.displays import NullDisplay
from experiment.session.engine import Session
from tests.experiment.conftest import console_session


@pytest.fixture
def mini(tmp_path):
    with console_session(tmp_path) as (session, clock, log):
        yield session, clock, log, tmp_path


async def type_text(pilot, text: str) -> None:
    await pilot.press(*("space" if ch == " " else ch for ch in text))


async def score_first_trial(pilot, words: str, score_key: str) -> None:
    """Start the main part, type WORDS for trial 1, score them with SCORE_KEY, show trial 2."""
    await pilot.press("enter", "enter")
    await type_text(pilot, words)
    await pilot.press(score_key)
    await pilot.press("enter")


def run(coro):
    """Run the coroutine with a 60 s limit; return its value."""
    return asyncio.run(asyncio.wait_for(coro, timeout=60))


def test_scripted_operator_session_logs_every_word_and_score(mini) -> None:
    """Typed words, scores, undo, pause and a note all land in the log exactly."""
    session, clock, log, _ = mini
    display = NullDisplay(clock)
    app = OperatorConsole(session, display)
    typed: dict[int, str] = {}

    async def script() -> None:
        async with app.run_test() as pilot:
            await pilot.press("enter")  # "Main part" screen
            assert display.texts[-1] == "Main part"
            await pilot.press("enter")  # trial 1 on screen
            assert app.state == "trial" and len(display.shown) == 1
            first = app.trial
            clock.advance(2.0)
            await type_text(pilot, "a stapler")
            clock.advance(1.5)
            await pilot.press("f1")
            assert app.state == "scored"
            typed[first.index] = "a stapler"
            # Undo: re-open scoring, change the words and score "shape".
            await pilot.press("ctrl+z")
            assert app.state == "rescoring"
            assert app.query_one("#response").value == "a stapler"
            await pilot.press(*["backspace"] * 9)
            await type_text(pilot, "something to clip")
            await pilot.press("f3")
            assert app.state == "scored"
            # Pause and resume between trials.
            await pilot.press("f8")
            assert app.state == "paused" and display.texts[-1] == "Pause"
            await pilot.press("f8")
            assert app.state == "scored"
            # Trial 2: Enter takes the suggested score.
            await pilot.press("enter")
            second = app.trial
            clock.advance(4.0)
            await type_text(pilot, "a mug")
            suggested = session.suggest_score(second, "a mug")
            await pilot.press("enter")
            typed[second.index] = "a mug"
            # Trial 3: a pass before 60 s is refused; after 60 s it is taken.
            await pilot.press("enter")
            third = app.trial
            clock.advance(10.0)
            await pilot.press("f5")
            assert app.state == "trial"  # refused
            clock.advance(55.0)
            await pilot.press("f5")
            typed[third.index] = ""
            # Trial 4: a note, then "use"; a pause asked for during the trial waits for the score.
            await pilot.press("enter")
            fourth = app.trial
            await pilot.press("f8")
            assert app.state == "trial"
            await pilot.press("f6")
            await type_text(pilot, "subject tired")
            await pilot.press("enter")
            await type_text(pilot, "you drink from it")
            clock.advance(3.0)
            await pilot.press("f2")
            typed[fourth.index] = "you drink from it"
            assert app.state == "paused"
            await pilot.press("f8")
            await pilot.press("enter")
            assert app.state == "finished"
            assert display.texts[-1].startswith("The session is complete")
            await pilot.press("ctrl+q")
        return suggested

    suggested = run(script())

    rows = {r["trial_index"]: dict(r) for r in log.execute("SELECT * FROM trials")}
    assert {i: r["response"] for i, r in rows.items()} == typed
    scores = [
        (r["trial_index"], r["score"], r["rater"], r["note"])
        for r in log.execute("SELECT * FROM scores ORDER BY score_id")
    ]
    idx = sorted(typed, key=lambda i: i)
    assert [s for s in scores if s[0] == idx[0]] == [
        (idx[0], "named", "operator", ""),
        (idx[0], "shape", "operator", "undo by operator; corrected response: 'something to clip'"),
    ]
    assert [s[1] for s in scores if s[0] == idx[1]] == [suggested]
    assert [s[1] for s in scores if s[0] == idx[2]] == ["pass"]
    assert [s[1] for s in scores if s[0] == idx[3]] == ["use"]
    tidy = {r["trial_index"]: r["score"] for r in log.tidy_trials()}
    assert tidy == {idx[0]: "shape", idx[1]: suggested, idx[2]: "pass", idx[3]: "use"}
    # Response times from the first keystroke (FakeClock), timing present for every trial.
    assert rows[idx[0]]["rt_s"] == pytest.approx(2.0)
    assert rows[idx[2]]["rt_s"] == pytest.approx(65.0)  # a pass: time of the score key
    for r in rows.values():
        assert r["onset_s"] is not None and r["offset_s"] is not None
        assert r["offset_s"] >= r["onset_s"]
        assert json.loads(r["frame_intervals_ms"]) == []  # NullDisplay has no frames
    assert rows[idx[2]]["offset_s"] - rows[idx[2]]["onset_s"] == pytest.approx(65.0)
    kinds = [e["kind"] for e in log.events(session.session_id)]
    assert kinds.count("pause") == 2 and kinds.count("resume") == 2
    notes = [e["note"] for e in log.events(session.session_id) if e["kind"] == "note"]
    assert notes == ["subject tired"]
    corrected = [e for e in log.events(session.session_id) if e["kind"] == "response_corrected"]
    assert json.loads(corrected[0]["note"]) == {
        "trial_index": idx[0],
        "was": "a stapler",
        "now": "something to clip",
    }
    assert "complete" in kinds
    assert app.return_value.answered == 4 and app.return_value.finished


def test_quit_mid_trial_then_resume_shows_it_again(mini) -> None:
    """Quitting with a stimulus up records nothing for it; the resumed session starts there."""
    session, clock, log, tmp_path = mini
    display = NullDisplay(clock)
    app = OperatorConsole(session, display)

    async def script() -> None:
        async with app.run_test() as pilot:
            await score_first_trial(pilot, "cup", "f1")
            pending = app.trial.index
            await type_text(pilot, "half typed")
            await pilot.press("ctrl+q")
            return pending

    pending = run(script())
    session.close()
    assert log.answered_count(session.session_id) == 1
    kinds = [e["kind"] for e in log.events(session.session_id)]
    assert "abort" in kinds
    resumed = Session.open(log, session.protocol, session.stimset, "S01", clock=clock)
    assert resumed.next_trial().index == pending
    assert resumed.progress() == (1, 4)
    resumed.close()


def test_undo_only_until_next_trial(mini) -> None:
    """After the next trial starts, Ctrl+Z changes nothing."""
    session, clock, log, _ = mini
    app = OperatorConsole(session, NullDisplay(clock))

    async def script() -> None:
        async with app.run_test() as pilot:
            await score_first_trial(pilot, "cup", "f4")
            await pilot.press("ctrl+z")
            assert app.state == "trial"
            await pilot.press("ctrl+q")

    run(script())
    assert [r["score"] for r in log.execute("SELECT score FROM scores")] == ["wrong"]


def test_combine_flips_and_preview() -> None:
    on = FlipRecord(onset_s=1.0, refresh_hz=60.0)
    off = FlipRecord(onset_s=1.5, frame_intervals_ms=(16.7, 33.4), dropped_frames=1)
    f = combine_flips(on, off)
    assert (f.onset_s, f.offset_s, f.frame_intervals_ms, f.dropped_frames, f.refresh_hz) == (
        1.0,
        1.5,
        (16.7, 33.4),
        1,
        60.0,
    )
    assert combine_flips(on, None) is on
    img = np.zeros((8, 12), bool)
    img[:4, :6] = True
    text = preview_text(img, cols=12)
    lines = text.splitlines()
    # 8 image rows -> 4 text lines of two rows each; the lit quarter is the top-left 2 x 6 cells.
    assert len(lines) == 4 and all(len(line) == 12 for line in lines)
    assert lines[0] == lines[1] == "\u2588" * 6 + " " * 6 and lines[2] == lines[3] == " " * 12


@pytest.mark.gl
def test_presenter_process_dies_and_restarts(mini) -> None:
    """The console says when the presenter dies, and the session continues after F9."""
    presenter_proc = pytest.importorskip("experiment.presentation.process")
    from experiment.presentation.presenter import ScreenGeometry

    session, clock, log, _ = mini
    geometry = ScreenGeometry.from_display_spec(session.protocol.display)
    try:
        display = presenter_proc.RemoteDisplay(geometry, mode="offscreen", start_timeout_s=60)
    except presenter_proc.PresenterDied as exc:
        pytest.skip(f"no headless OpenGL context for the presenter process: {exc}")
    app = OperatorConsole(session, display, clock=PerfCounterClock())

    async def script() -> None:
        async with app.run_test() as pilot:
            await pilot.press("enter", "enter")
            assert app.state == "trial"
            shown = app.trial.index
            display.kill()
            await type_text(pilot, "cup")
            await pilot.pause(0.5)  # the 0.25 s liveness check runs
            assert app.state == "down"
            assert "PRESENTER STOPPED" in str(app.query_one("#status").render())
            await pilot.press("f9")
            assert display.alive and app.state == "trial" and app.trial.index == shown
            await type_text(pilot, "cup")
            await pilot.press("f1")
            assert app.state == "scored"
            await pilot.press("ctrl+q")

    try:
        run(script())
    finally:
        display.close()
    kinds = [e["kind"] for e in log.events(session.session_id)]
    assert {"presenter_died", "presenter_restart", "trial_reshown"} <= set(kinds)
    (row,) = log.execute("SELECT * FROM trials")
    assert row["response"] == "cup" and row["offset_s"] > row["onset_s"]
    assert len(json.loads(row["frame_intervals_ms"])) == 1  # offscreen: onset -> offset only


def _answer_all(session, clock, responses: list[str]) -> None:
    from experiment.interfaces import Answer

    for text in responses:
        trial = session.next_trial()
        clock.advance(1.0)
        session.record(
            trial,
            Answer(text, "named", "operator", rt_s=0.5),
            FlipRecord(onset_s=0.0, offset_s=1.0),
        )


def test_second_rater_scores_blind(mini) -> None:
    """``confocal score``'s app shows object and words, never the first rater's scores."""
    from experiment.commands.score import pending_for_rater
    from experiment.console import ScoringApp

    session, clock, log, _ = mini
    _answer_all(session, clock, ["a cup", "clip thing", "no idea"])
    pending = pending_for_rater(log, "B")
    assert [p["response"] for p in pending] == ["a cup", "clip thing", "no idea"]
    assert all("score" not in p for p in pending)
    app = ScoringApp(log, "B", pending)
    seen = []

    async def script() -> None:
        async with app.run_test() as pilot:
            seen.append(str(app.query_one("#item").render()))
            await pilot.press("f1")
            seen.append(str(app.query_one("#item").render()))
            await pilot.press("f3")
            await pilot.press("ctrl+q")

    run(script())
    assert app.return_value == 2
    assert "a cup" in seen[0] and "clip thing" in seen[1]
    assert not any("named" in s for s in seen)  # the operator's score is not shown
    rows = log.execute("SELECT trial_index, score, rater, is_primary FROM scores WHERE rater='B'")
    assert [(r["score"], r["is_primary"]) for r in rows] == [("named", 0), ("shape", 0)]
    assert [p["response"] for p in pending_for_rater(log, "B")] == ["no idea"]
    # The operator's (primary) scores are unchanged in tidy_trials.
    assert {r["score"] for r in log.tidy_trials()} == {"named"}


def test_score_command_missing_log_exit_2(tmp_path) -> None:
    import subprocess
    import sys

    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    r = subprocess.run(
        [sys.executable, "-c", code, "score", str(tmp_path / "none.sqlite"), "--rater", "B"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2
    assert r.stderr.strip() == f"confocal: error: {tmp_path / 'none.sqlite'}: trial log not found"


def test_run_console_refuses_when_presenter_cannot_start(mini, monkeypatch) -> None:
    """No screen for the subject's window: one clear error, the failure logged, nothing shown."""
    from experiment.console import run_console
    from experiment.errors import ConfocalError

    session, _, log, _ = mini
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(ConfocalError, match="the presenter could not start"):
        run_console(session, presenter="process", fullscreen=False)
    kinds = [e["kind"] for e in log.events(session.session_id)]
    assert "presenter_failed" in kinds and kinds[-1] == "close"
    assert log.answered_count(session.session_id) == 0
