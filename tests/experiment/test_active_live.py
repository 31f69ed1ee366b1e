"""A person searching: the subject's inputs drive the active-search session,
the operator scores in the console; every input and displayed state is logged.

The subject's screen here is the headless twin (``NullDisplay`` with input); the presenter
process's side of the input path (real pyglet key and mouse events in a window) is tested in
``test_window_xvfb.py``.
"""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from experiment.active.live import INPUT_ACTIONS, LiveSearch, zoom_box_px
from experiment.active.session import ActiveSession
from experiment.clock import FakeClock
from experiment.log import TrialLog
from experiment.presentation.displays import NullDisplay
from stimuli import jung2015
from stimuli.compress import compress
from stimuli.declutter import auto_threshold, declutter
from stimuli.refocus import refocus
from tests.experiment.test_active import small_protocol


def reference_grid(lf, depth_px, zoom, grid_px, centre=None):
    """The implant's view computed directly with the stimuli pipeline (refocus, crop, Sobel
    with Otsu, compression at the paper's edge ratio)."""
    img = centre if centre is not None else refocus(lf, float(depth_px), workers=1)
    if zoom is not None:
        x, y, w, h = zoom
        img = img[y : y + h, x : x + w]
    edges = declutter(img, threshold=auto_threshold(img))
    return compress(edges, tuple(grid_px), edge_ratio=jung2015.EDGE_RATIO)


def unpack(hexbits: str, grid_px) -> np.ndarray:
    n = grid_px[0] * grid_px[1]
    bits = np.unpackbits(np.frombuffer(bytes.fromhex(hexbits), np.uint8))[:n]
    return bits.reshape(grid_px).astype(bool)


def listed_protocol(**fields):
    """The small active-search protocol, de-cluttered only, its trials in the listed order."""
    return small_protocol(conditions=["decluttered"], trial_order="listed", **fields)


def person_search(log, spec, clock, **open_options) -> tuple[ActiveSession, LiveSearch]:
    """Open S01's session with a person searching on the headless twin: (session, search)."""
    session = ActiveSession.open(log, spec, "S01", clock=clock, responder="person", **open_options)
    return session, LiveSearch(session, NullDisplay(clock))


@pytest.fixture()
def live():
    clock = FakeClock(100.0)
    log = TrialLog(":memory:")
    spec = listed_protocol(time_limit_s=30.0)
    session = ActiveSession.open(log, spec, "S01", seed=3, clock=clock, responder="person")
    display = NullDisplay(clock)
    yield LiveSearch(session, display, rater="op1"), clock, display
    session.close()
    log.close()


def test_zoom_box_maps_drags_on_the_shown_view_to_view_pixels() -> None:
    assert zoom_box_px([0.25, 0.5, 0.75, 1.0], (100, 200), None) == (50, 50, 100, 50)
    # a drag made backwards is the same box
    assert zoom_box_px([0.75, 1.0, 0.25, 0.5], (100, 200), None) == (50, 50, 100, 50)
    # inside a zoom the drag is relative to the zoomed region
    assert zoom_box_px([0.0, 0.0, 0.5, 0.5], (100, 200), (50, 50, 100, 50)) == (50, 50, 50, 25)
    # a click (no extent) and junk are not zoom boxes
    assert zoom_box_px([0.5, 0.5, 0.5, 0.5], (100, 200), None) is None
    assert zoom_box_px("junk", (100, 200), None) is None
    # fractions beyond the image are clipped to it
    assert zoom_box_px([-1, -1, 2, 2], (100, 200), None) == (0, 0, 200, 100)


def test_subject_inputs_are_logged_with_their_times_and_drive_the_view(live) -> None:
    search, clock, display = live
    session = search.session
    assert search.cue().target == "pedestrian"
    assert "Find the pedestrian" in display.texts[-1]
    display.post_input({"key": "PageDown"})  # pressed during the cue: not part of the trial
    search.begin()
    onset = clock.now_s()
    assert search.pump() == []  # the cue's key was dropped at onset
    sent = [
        ({"key": "PageDown"}, "plane_next"),
        ({"key": "Down"}, "depth_far"),
        ({"key": "WheelUp"}, "depth_near"),
        ({"key": "PageDown"}, "plane_next"),
        ({"key": "drag", "box": [0.25, 0.25, 0.75, 0.75]}, "zoom"),
        ({"key": "F12"}, None),  # not a search key: ignored, not logged
        ({"key": "Escape"}, "unzoom"),
        ({"key": "drag", "box": [0.1, 0.2, 0.6, 0.9]}, "zoom"),
    ]
    times = []
    for ev, _ in sent:
        clock.advance(0.7)
        times.append(clock.now_s())
        display.post_input(ev)
    clock.advance(0.05)  # the console polls a little after the keys
    rows = search.pump()
    keys = [r for r in rows if r["kind"] == "key"]
    expected = [(ev, a, t) for (ev, a), t in zip(sent, times, strict=True) if a is not None]
    assert [k["payload"]["action"] for k in keys] == [a for _, a, _ in expected]
    assert [k["payload"]["key"] for k in keys] == [ev["key"] for ev, _, _ in expected]
    # each key row carries the time the subject pressed it, not when it was applied
    assert [k["t_s"] for k in keys] == pytest.approx([t for _, _, t in expected])
    assert search.ignored_inputs == 1
    # the zoom boxes are the drags mapped to view pixels (the second inside no zoom)
    rows_px, cols_px = session.scene.shape_px
    boxes = [k["payload"]["box"] for k in keys if k["payload"]["action"] == "zoom"]
    assert boxes[0] == list(zoom_box_px([0.25, 0.25, 0.75, 0.75], (rows_px, cols_px), None))
    assert boxes[1] == list(zoom_box_px([0.1, 0.2, 0.6, 0.9], (rows_px, cols_px), None))
    # every displayed state equals the stimuli pipeline's image for that depth and zoom, and
    # the last one is what the subject's screen shows
    states = [r["payload"] for r in rows if r["kind"] == "state"]
    assert len(states) >= 5
    grid_px = session.task.grid_px
    for st in states:
        ref = reference_grid(session.scene.lightfield, st["depth_px"], st["zoom"], grid_px)
        np.testing.assert_array_equal(unpack(st["implant"], grid_px), ref)
    np.testing.assert_array_equal(display.last_image, unpack(states[-1]["implant"], grid_px))
    assert states[-1]["zoom"] == boxes[1]
    # Enter: the subject knows; later keys are not applied until the operator scores
    clock.advance(1.0)
    t_enter = clock.now_s()
    display.post_input({"key": "Enter"})
    display.post_input({"key": "Up"})
    clock.advance(0.1)
    assert search.pump() == [] and search.answered
    clock.advance(4.0)  # the operator types
    assert search.suggest("a man walking") == "named"
    out = search.score("a man walking", "named")
    by = {r["kind"]: r for r in out}
    assert by["key"]["payload"] == {"key": "Enter", "action": "answer"}
    assert by["answer"]["t_s"] == pytest.approx(t_enter)
    assert by["answer"]["payload"]["rt_s"] == pytest.approx(t_enter - onset)
    assert by["answer"]["payload"]["response"] == "a man walking"
    assert by["score"]["payload"]["rater"] == "op1" and by["score"]["payload"]["recognized"]
    assert by["score"]["t_s"] == pytest.approx(clock.now_s())
    assert not search.running and search.ignored_inputs == 2
    # the log holds exactly what was returned (nothing else was written for this trial)
    logged = [r for r in session.events.rows() if r["trial"] == 0]
    returned = [r for r in rows if r["trial"] == 0] + out
    assert [(r["seq"], r["kind"]) for r in logged][-len(returned) :] == [
        (r["seq"], r["kind"]) for r in returned
    ]


def test_operator_scores_without_an_answer_key_and_time_limit_passes(live) -> None:
    search, clock, display = live
    search.cue()
    search.begin()
    clock.advance(2.5)
    out = search.score("tree", "wrong")  # the subject spoke without pressing Enter
    by = {r["kind"]: r for r in out}
    assert by["key"]["payload"]["key"] == "operator"
    assert by["answer"]["payload"]["rt_s"] == pytest.approx(2.5)
    assert by["score"]["payload"]["score"] == "wrong"
    # the next trial runs out of time: a pass, rt at the limit exactly
    search.cue()
    search.begin()
    clock.advance(29.0)
    assert search.tick() == []
    clock.advance(1.5)
    out = search.tick()
    by = {r["kind"]: r for r in out}
    assert by["key"]["payload"] == {"key": "timeout", "action": "pass"}
    assert by["answer"]["payload"]["rt_s"] == pytest.approx(30.0)
    assert by["score"]["payload"] == {
        "score": "pass",
        "recognized": False,
        "rater": "auto",
        "primary": True,
    }
    assert search.cue() is None and "finished" in display.texts[-1]
    assert search.session.log.unfinished_session("S01") is None  # the session is complete


def test_input_names_are_the_viewer_keymap_plus_the_wheel() -> None:
    from experiment.presentation.presenter import INPUT_KEYS
    from experiment.viewer.state import ACTIONS, KEYMAP

    assert set(INPUT_ACTIONS.values()) <= set(ACTIONS)
    # every key the presenter reports maps to an action, and every mapped key can be reported
    assert set(INPUT_KEYS.values()) == set(KEYMAP)
    assert INPUT_ACTIONS["WheelUp"] == KEYMAP["Up"] and INPUT_ACTIONS["WheelDown"] == KEYMAP["Down"]


def test_console_runs_a_trial_from_operator_keys(live) -> None:
    """The Textual console: Enter starts, subject keys are applied by its poll, F1 scores."""
    from experiment.console.active import ActiveConsole

    search, clock, display = live

    async def drive() -> None:
        app = ActiveConsole(search)
        async with app.run_test(size=(100, 30)) as pilot:
            assert "Find the pedestrian" in display.texts[-1]
            await pilot.press("enter")
            assert search.running
            clock.advance(1.0)
            display.post_input({"key": "PageDown"})
            display.post_input({"key": "drag", "box": [0.2, 0.2, 0.8, 0.8]})
            clock.advance(1.0)
            display.post_input({"key": "Enter"})
            await pilot.pause(0.2)
            assert search.answered
            panel = str(app.query_one("#trial").render())
            assert "pedestrian" in panel and "pressed Enter" in panel
            for ch in "a person":
                await pilot.press("space" if ch == " " else ch)
            await pilot.press("f1")
            assert not search.running
            assert "Find the tree" in display.texts[-1]
            await pilot.press("ctrl+q")

    asyncio.run(drive())
    rows = search.session.events.rows()
    keys = [r["payload"]["action"] for r in rows if r["kind"] == "key"]
    assert keys == ["plane_next", "zoom", "answer"]
    ans = next(r for r in rows if r["kind"] == "answer")
    assert ans["payload"]["response"] == "a person"
    assert ans["payload"]["rt_s"] == pytest.approx(2.0)
    score = next(r for r in rows if r["kind"] == "score")
    assert score["payload"]["score"] == "named" and score["payload"]["rater"] == "op1"
    assert search.session.progress() == (1, 2)


def test_analysis_reports_a_person_as_not_simulated(tmp_path) -> None:
    from analysis.active import active_trials, read_active_events, summarize_active

    path = tmp_path / "person.sqlite"
    clock = FakeClock(0.0)
    with TrialLog(path) as log:
        s, search = person_search(log, listed_protocol(), clock, seed=1)
        for words in ("a pedestrian", "a tree"):
            search.cue()
            search.begin()
            clock.advance(0.5)
            s_disp = search.display
            s_disp.post_input({"key": "PageDown"})
            clock.advance(3.0)
            s_disp.post_input({"key": "Enter"})
            search.pump()
            search.score(words, "named")
        s.close()
    trials = active_trials(read_active_events([path]))
    assert list(trials["searcher"]) == ["person", "person"]
    assert list(trials["rt_s"]) == pytest.approx([3.5, 3.5])
    result = summarize_active(trials)
    assert not result.simulated


def test_quitting_mid_search_restarts_that_trial_on_resume(tmp_path) -> None:
    path = tmp_path / "resume.sqlite"
    clock = FakeClock(0.0)
    spec = listed_protocol()
    with TrialLog(path) as log:
        s, live = person_search(log, spec, clock, seed=4)
        live.cue()
        live.begin()
        clock.advance(1.0)
        live.display.post_input({"key": "PageDown"})
        assert len(live.pump()) == 2
        s.close()  # Ctrl+Q with the search on screen, unscored
    with TrialLog(path) as log:
        s, live = person_search(log, spec, clock)
        assert live.cue().index == 0  # the same trial again
        live.begin()
        clock.advance(2.0)
        out = live.score("a person", "named")
        assert {r["attempt"] for r in out} == {1}
        kinds = [r["kind"] for r in s.events.rows() if r["trial"] == 0]
        assert kinds.count("attempt_abandoned") == 1 and kinds.count("answer") == 1
        assert s.progress() == (1, 2)
        s.close()


# -- active search through an implant's layout ----------------------------------------------------


def _implant_protocol(tmp_path, grid_line: str = ""):
    from experiment.protocol import load_protocol

    text = open(load_protocol("active_search").source_path, encoding="utf-8").read()
    text = text.replace("grid_px = [28, 35]          # Jung 2015 Fig. 13: 980 cells\n", grid_line)
    text = text.replace("n_planes = 200", "n_planes = 60\nscene_shape_px = [154, 192]")
    text += '\n[display]\nimplant = "argus2"\n'
    path = tmp_path / "argus_search.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_display_implant_sets_the_search_grid_and_refuses_a_conflict(tmp_path) -> None:
    from experiment.protocol import ProtocolError, ProtocolSpec, load_protocol

    spec = load_protocol(_implant_protocol(tmp_path))
    assert spec.task.grid_px == (6, 10)  # Argus II: 6 x 10 electrodes
    again = ProtocolSpec.from_dict(spec.to_dict())
    assert again.task.grid_px == (6, 10) and again.content_sha256() == spec.content_sha256()
    assert load_protocol(_implant_protocol(tmp_path, "grid_px = [6, 10]\n")).task.grid_px == (6, 10)
    with pytest.raises(
        ProtocolError, match=r"task.grid_px \[28, 35\] differs from display.implant"
    ):
        load_protocol(_implant_protocol(tmp_path, "grid_px = [28, 35]\n"))


def test_a_search_through_argus_ii_logs_its_grid_and_draws_its_phosphenes(tmp_path) -> None:
    """States carry the 6x10 grid the stimuli pipeline gives; the subject's screen draws it as
    Argus II's phosphenes across its 19.97 deg field of view."""
    from experiment.commands.active import subject_phosphenes
    from experiment.presentation.presenter import PhospheneSpec, ScreenGeometry, stimulus_rect_px
    from experiment.presentation.process import PresenterDied, RemoteDisplay
    from experiment.protocol import load_protocol

    spec = load_protocol(_implant_protocol(tmp_path))
    clock = FakeClock(0.0)
    with TrialLog(":memory:") as log:
        s, live = person_search(log, spec, clock, seed=1)
        live.cue()
        live.begin()
        live.display.post_input({"key": "PageDown"})
        states = [r["payload"] for r in live.pump() if r["kind"] == "state"]
        st = states[-1]
        assert st["grid_px"] == [6, 10]
        centre = s.scene.centre_view() if live.trial.condition == "cluttered" else None
        ref = reference_grid(s.scene.lightfield, st["depth_px"], None, (6, 10), centre=centre)
        np.testing.assert_array_equal(unpack(st["implant"], (6, 10)), ref)
        cells = live.display.last_image
        s.close()
    assert cells.shape == (6, 10) and cells.any()
    phos = subject_phosphenes(spec)
    assert phos["spacing_deg"] == pytest.approx(19.97 / 10)
    geometry = ScreenGeometry.from_display_spec(spec.display)
    try:
        display = RemoteDisplay(geometry, mode="offscreen", inputs=True, phosphenes=phos)
    except PresenterDied as exc:
        pytest.skip(f"no headless OpenGL for the presenter: {exc}")
    try:
        display.show_stimulus(cells)
        display.screenshot(str(tmp_path / "argus.png"))
    finally:
        display.close()
    from PIL import Image

    frame = np.asarray(Image.open(tmp_path / "argus.png").convert("L"), dtype=float) / 255
    top, left, rows, cols = stimulus_rect_px(geometry, (6, 10), phosphenes=PhospheneSpec(**phos))
    # the grid spans the implant's field of view (closed form: degrees x px per degree)
    assert cols == pytest.approx(19.97 * geometry.px_per_deg, abs=10)
    cy = top + (np.arange(6) + 0.5) * rows / 6
    cx = left + (np.arange(10) + 0.5) * cols / 10
    centres = frame[np.ix_(cy.astype(int), cx.astype(int))]
    assert (centres[cells] > 0.9).all() and (centres[~cells] < 0.05).all()
