"""The operator console fits the terminal from 80x24 upward; log lines stay off it.

Textual's pilot runs the app headless at several terminal sizes; the test compares each widget's
region with the screen size and reads the rendered screen back as text.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sys
from pathlib import Path

import pytest
from textual.widgets import Footer

from experiment.console import OperatorConsole, logs_to_file, session_log_path
from experiment.presentation.displays import NullDisplay
from experiment.presentation.process import PROTOCOL_VERSION, RemoteDisplay
from tests.experiment.conftest import console_session

#: Stimulus shape (rows, cols): the paper's level 3 (164x109 is 1/3 of 492x327), the aspect of
#: every level, large enough that a careless preview would push the input line off screen.
SHAPE_PX = (109, 164)


@pytest.fixture
def session(tmp_path):
    with console_session(tmp_path, shape_px=SHAPE_PX, window_px=3) as (s, clock, _):
        yield s, clock


def _inside(region, size) -> bool:
    return (
        region.width > 0
        and region.height > 0
        and region.x >= 0
        and region.y >= 0
        and region.x + region.width <= size.width
        and region.y + region.height <= size.height
    )


def screen_text(app) -> list[str]:
    """The rendered screen, one string per terminal row."""
    return [strip.text for strip in app.screen._compositor.render_strips()]


@pytest.mark.parametrize("size", [(80, 24), (100, 30), (160, 50)])
def test_response_box_footer_and_preview_fit(session, size) -> None:
    s, clock = session
    app = OperatorConsole(s, NullDisplay(clock))
    seen: dict[str, object] = {}

    async def script() -> None:
        async with app.run_test(size=size) as pilot:
            await pilot.press("enter")  # "Main part"
            await pilot.press("enter")  # trial 1
            await pilot.pause()
            assert app.state == "trial"
            scr = app.screen.size
            assert (scr.width, scr.height) == size
            regions = {
                w: app.query_one(w).region for w in ("#trial", "#preview", "#status", "#response")
            }
            regions["footer"] = app.query_one(Footer).region
            for name, r in regions.items():
                assert _inside(r, scr), (name, r, scr)
            # the input box is 3 rows (border, text, border), the footer the last row
            assert regions["#response"].height == 3
            assert regions["footer"].y == scr.height - 1
            # nothing overlaps the input box or the footer
            for name in ("#trial", "#preview", "#status"):
                assert not regions[name].overlaps(regions["#response"]), name
                assert not regions[name].overlaps(regions["footer"]), name
            assert not regions["#response"].overlaps(regions["footer"])
            text = screen_text(app)
            footer = text[-1]
            for b in app.active_bindings.values():
                if b.binding.show:
                    assert b.binding.description in footer, (b.binding.description, footer)
            assert "the subject's words" in "\n".join(text)
            assert any(f"object {app.trial.object_name}" in line for line in text)
            seen["preview_rows"] = regions["#preview"].height
            # the note line replaces the input line and fits too
            await pilot.press("f6")
            await pilot.pause()
            note = app.query_one("#note").region
            assert _inside(note, scr) and note.height == 3
            await pilot.press("escape", "enter")

    asyncio.run(asyncio.wait_for(script(), timeout=60))
    if size == (160, 50):
        assert seen["preview_rows"] > 12  # a larger screen gets a larger preview


def test_preview_grows_with_the_terminal(session) -> None:
    s, clock = session
    widths = []

    async def one(size) -> None:
        app = OperatorConsole(s, NullDisplay(clock))
        async with app.run_test(size=size) as pilot:
            await pilot.press("enter", "enter")
            await pilot.pause()
            widths.append(app.query_one("#preview").region.width)
            await pilot.press("ctrl+q")

    for size in ((80, 24), (160, 50)):
        asyncio.run(asyncio.wait_for(one(size), timeout=60))
    assert widths[1] > widths[0]


def test_library_log_lines_go_to_the_session_log_not_the_terminal(tmp_path, capsys) -> None:
    lib = logging.getLogger("moderngl_window")
    terminal = logging.StreamHandler(sys.stderr)
    lib.addHandler(terminal)
    try:
        path = tmp_path / "study.log"
        with logs_to_file(path, prefix="session 1"):
            lib.info("Context Version:")
            logging.getLogger("experiment.presentation.presenter").warning("frame dropped")
        lib.warning("after the console")
        text = path.read_text()
        assert "session 1 moderngl_window INFO: Context Version:" in text
        assert "frame dropped" in text and "after the console" not in text
        err = capsys.readouterr().err
        assert "Context Version" not in err and "after the console" in err
        assert terminal in lib.handlers
    finally:
        lib.removeHandler(terminal)


def test_session_log_path_beside_the_trial_log(session) -> None:
    s, _ = session
    assert session_log_path(s) == Path(s.log.path).with_suffix(".log")


def test_presenter_process_stderr_goes_to_the_log_file(tmp_path, capfd) -> None:
    """A stand-in child that logs on stderr like moderngl-window, then speaks the protocol."""
    child = (
        "import sys, json\n"
        "print('moderngl_window INFO Context Version: 4.5', file=sys.stderr, flush=True)\n"
        f"print(json.dumps({{'event': 'ready', 'protocol': {PROTOCOL_VERSION}}}), flush=True)\n"
        "sys.stdin.read()\n"
    )
    log_path = tmp_path / "study.log"
    display = RemoteDisplay(
        {"unused": True},
        command=[sys.executable, "-c", child],
        stderr_path=log_path,
        start_timeout_s=30,
    )
    try:
        assert display.info["event"] == "ready"
    finally:
        display.close()
    assert "Context Version: 4.5" in log_path.read_text()
    assert "Context Version" not in capfd.readouterr().err
    json.dumps(display.info)


def test_clock_tick_while_shutting_down_is_harmless(session) -> None:
    """The clock's timer may fire once more after the panes are gone (the app shutting down):
    its tick then has nothing to update and must not end the session with an error."""
    s, clock = session
    app = OperatorConsole(s, NullDisplay(clock))

    async def script() -> None:
        async with app.run_test(size=(80, 24)) as pilot:
            await pilot.press("enter")  # "Main part"
            await pilot.pause()
            await app.query_one("#timer").remove()  # as at shutdown: the pane is gone
            app._tick()  # the timer's next tick

    asyncio.run(asyncio.wait_for(script(), timeout=60))
