"""A real window (moderngl-window + pyglet over GLX) under an X server: Xvfb when DISPLAY is unset.

A stimulus is shown in the subject's window by the presenter process, read back from the window's
framebuffer and compared pixel for pixel with the numpy reference; then the window closes cleanly
(the process exits 0). Skips with a reason when there is neither a DISPLAY nor an ``Xvfb``.
"""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.gl

pytest.importorskip("experiment.presentation.presenter", reason="moderngl not importable")

from experiment.presentation.presenter import ScreenGeometry, expected_frame  # noqa: E402
from experiment.presentation.process import PresenterDied, RemoteDisplay  # noqa: E402

#: A small subject screen so that llvmpipe draws quickly: 320x256 px, 32 px/cm, 16 px cells.
GEOMETRY = ScreenGeometry(
    screen_shape_px=(256, 320),
    screen_width_cm=10.0,
    viewing_distance_cm=57.0,
    image_size_cm=(4.0, 6.0),
    border_width_px=4,
)


@pytest.fixture(scope="module")
def x_display():
    """The DISPLAY to use: ours if set, else a private Xvfb (closed after the module)."""
    if os.environ.get("DISPLAY"):
        yield os.environ["DISPLAY"]
        return
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        pytest.skip("no DISPLAY and no Xvfb (install xvfb, as .ci/run does)")
    r, w = os.pipe()
    proc = subprocess.Popen(
        [xvfb, "-displayfd", str(w), "-screen", "0", "640x480x24", "-nolisten", "tcp"],
        pass_fds=(w,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(w)
    try:
        ready, _, _ = select.select([r], [], [], 20)
        number = os.read(r, 64).decode().strip() if ready else ""
        if not number:
            pytest.skip("Xvfb did not start within 20 s")
        yield f":{number}"
    finally:
        os.close(r)
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


def open_window(x_display: str, **kwargs) -> RemoteDisplay:
    """Start the presenter process with a window on ``x_display`` (skip if GLX cannot)."""
    env = {**os.environ, "DISPLAY": x_display}
    try:
        return RemoteDisplay(GEOMETRY, mode="window", skip_timing_check=True, env=env, **kwargs)
    except PresenterDied as exc:
        pytest.skip(f"no GLX window under {x_display}: {exc}")


def test_window_shows_stimulus_and_closes_cleanly(x_display, tmp_path) -> None:
    """The window's framebuffer holds exactly the expected frame; closing exits with status 0."""
    display = open_window(x_display)
    try:
        assert display.info["timing_check"] == "skipped"
        img = np.random.default_rng(3).random((8, 12)) < 0.5
        onset = display.show_stimulus(img)
        shot = tmp_path / "window.png"
        display.screenshot(str(shot))
        offset = display.clear()
        from PIL import Image

        frame = np.asarray(Image.open(shot).convert("RGB"))
        np.testing.assert_array_equal(frame, expected_frame(GEOMETRY, img))
        # The window loop flipped at least once between the requests; offset follows onset.
        assert offset.onset_s > onset.onset_s
        assert len(offset.frame_intervals_ms) >= 1
        assert sum(offset.frame_intervals_ms) == pytest.approx(
            (offset.onset_s - onset.onset_s) * 1e3, rel=1e-6
        )
        display.show_text("The end")
    finally:
        display.close()
    assert not display.alive and display.returncode == 0


def test_present_command_opens_window(x_display, tmp_path) -> None:
    """``confocal present --window --seconds`` shows a stimulus in a window and exits 0."""
    from PIL import Image

    stim = tmp_path / "stim.png"
    Image.fromarray(((np.indices((8, 12)).sum(0) % 2) * 255).astype(np.uint8)).save(stim)
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            "present",
            "--stimulus",
            str(stim),
            "--window",
            "--seconds",
            "0.3",
            "--skip-timing-check",
            "--screen-px",
            "320x256",
            "--screen-width-cm",
            "10",
            "--image-cm",
            "6x4",
        ],
        env={**os.environ, "DISPLAY": x_display},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert "drawn at 192x128 px" in r.stdout
    assert "frames" in r.stderr and "dropped" in r.stderr


class key:  # noqa: N801 - pyglet.window.key's values (X keysyms); importing pyglet.window here
    # would open a display in the test process
    PAGEDOWN, ESCAPE, A, ENTER = 0xFF56, 0xFF1B, 0x61, 0xFF0D


class mouse:  # noqa: N801 - pyglet.window.mouse.LEFT
    LEFT = 1


def _wait_inputs(display, n: int, timeout_s: float = 10.0) -> list[dict]:
    import time

    got: list[dict] = []
    end = time.monotonic() + timeout_s
    while len(got) < n and time.monotonic() < end:
        got += display.poll_inputs()
        time.sleep(0.02)
    return got


def test_subject_keys_and_drags_reach_the_console(x_display) -> None:
    """Active search: real pyglet key, wheel and mouse events in the subject's window come back
    as ``input`` events, named as the task's key map and with the drag as stimulus fractions;
    Escape (un-zoom) no longer closes the window."""
    import time

    from experiment.presentation.presenter import stimulus_rect_px

    display = open_window(x_display, inputs=True)
    try:
        img = np.zeros((28, 35), bool)
        display.show_stimulus(img)
        top, left, rows, cols = stimulus_rect_px(GEOMETRY, img.shape)
        height = GEOMETRY.screen_shape_px[0]

        def at(fx: float, fy: float) -> list[float]:  # pyglet's origin is bottom-left
            return [left + fx * cols, height - (top + fy * rows)]

        t0 = time.perf_counter()
        display.inject(
            [
                {"pyglet": "on_key_press", "args": [key.PAGEDOWN, 0]},
                {"pyglet": "on_key_press", "args": [key.ESCAPE, 0]},
                {"pyglet": "on_key_press", "args": [key.A, 0]},  # not a search key
                {"pyglet": "on_mouse_scroll", "args": [10, 10, 0, 1]},
                {"pyglet": "on_mouse_press", "args": [*at(0.75, 0.8), mouse.LEFT, 0]},
                {"pyglet": "on_mouse_release", "args": [*at(0.25, 0.2), mouse.LEFT, 0]},
                {"pyglet": "on_key_press", "args": [key.ENTER, 0]},
            ]
        )
        got = _wait_inputs(display, 5)
        assert [g["key"] for g in got] == ["PageDown", "Escape", "WheelUp", "drag", "Enter"]
        assert got[3]["box"] == pytest.approx([0.25, 0.2, 0.75, 0.8], abs=1.5 / min(rows, cols))
        # stamped by the child's perf_counter, the console's clock too
        assert all(t0 <= g["t_s"] <= time.perf_counter() for g in got)
        assert display.alive  # Escape did not close the subject's window
        display.inject([{"key": "Up"}])  # a queued input, as scripts send
        assert [g["key"] for g in _wait_inputs(display, 1)] == ["Up"]
    finally:
        display.close()
    assert display.returncode == 0


def test_a_static_study_window_reports_no_input(x_display) -> None:
    """Without ``inputs`` (the static study) the subject's keys are not sent to the console."""
    import time

    display = open_window(x_display)
    try:
        display.inject([{"pyglet": "on_key_press", "args": [key.PAGEDOWN, 0]}])
        time.sleep(0.3)
        display.show_blank()
        assert display.poll_inputs() == []
    finally:
        display.close()


def test_a_person_searches_in_the_window_and_the_operator_scores(x_display, tmp_path) -> None:
    """The whole person path with a real subject window: pyglet key and mouse events in the
    window drive the session through the operator console; the log holds each input with the
    window's time stamp and each state, and the window shows the logged implant view."""
    import asyncio
    import time

    from PIL import Image

    from experiment.active.live import LiveSearch
    from experiment.active.session import ActiveSession
    from experiment.console.active import ActiveConsole
    from experiment.log import TrialLog
    from experiment.presentation.presenter import stimulus_rect_px
    from tests.experiment.test_active import small_protocol

    spec = small_protocol(conditions=["decluttered"], trial_order="listed")
    log = TrialLog(tmp_path / "person.sqlite")
    session = ActiveSession.open(log, spec, "S01", seed=2, responder="person")
    try:
        display = open_window(x_display, inputs=True)
    except BaseException:  # pytest.skip included
        session.close()
        log.close()
        raise
    live = LiveSearch(session, display, rater="op")
    grid = spec.task.grid_px
    top, left, rows, cols = stimulus_rect_px(GEOMETRY, grid)
    height = GEOMETRY.screen_shape_px[0]

    def at(fx: float, fy: float) -> list[float]:
        return [left + fx * cols, height - (top + fy * rows)]

    async def drive() -> None:
        app = ActiveConsole(live)
        async with app.run_test(size=(100, 30)) as pilot:
            await pilot.press("enter")
            display.inject(
                [
                    {"pyglet": "on_key_press", "args": [key.PAGEDOWN, 0]},
                    {"pyglet": "on_mouse_press", "args": [*at(0.2, 0.2), mouse.LEFT, 0]},
                    {"pyglet": "on_mouse_release", "args": [*at(0.7, 0.9), mouse.LEFT, 0]},
                ]
            )
            for _ in range(100):
                await pilot.pause(0.05)
                if sum(r["kind"] == "state" for r in session.events.rows()) >= 3:
                    break
            display.screenshot(str(tmp_path / "subject.png"))
            display.inject([{"pyglet": "on_key_press", "args": [key.ENTER, 0]}])
            for _ in range(100):
                await pilot.pause(0.05)
                if live.answered:
                    break
            for ch in "tree":
                await pilot.press(ch)
            await pilot.press("f4")
            await pilot.press("ctrl+q")

    t0 = time.perf_counter()
    try:
        asyncio.run(drive())
    finally:
        display.close()
        session.close()
    rows_ = session.events.rows()
    log.close()
    keys = [r for r in rows_ if r["kind"] == "key"]
    assert [k["payload"]["action"] for k in keys] == ["plane_next", "zoom", "answer"]
    assert [k["payload"]["key"] for k in keys] == ["PageDown", "drag", "Enter"]
    assert all(t0 < k["t_s"] < time.perf_counter() for k in keys)
    states = [r["payload"] for r in rows_ if r["kind"] == "state"]
    r_px, c_px = session.scene.shape_px
    x0, y0 = round(0.2 * c_px), round(0.2 * r_px)
    assert states[-1]["zoom"] == pytest.approx(
        [x0, y0, round(0.7 * c_px) - x0, round(0.9 * r_px) - y0], abs=2
    )
    # the subject's window showed the last logged state's implant view, cell for cell
    bits = np.unpackbits(np.frombuffer(bytes.fromhex(states[-1]["implant"]), np.uint8))
    cells = bits[: grid[0] * grid[1]].reshape(grid).astype(bool)
    frame = np.asarray(Image.open(tmp_path / "subject.png").convert("RGB"))
    np.testing.assert_array_equal(frame, expected_frame(GEOMETRY, cells))
    ans = next(r for r in rows_ if r["kind"] == "answer")
    assert ans["payload"]["response"] == "tree" and ans["t_s"] == keys[-1]["t_s"]
    assert next(r for r in rows_ if r["kind"] == "score")["payload"]["score"] == "wrong"


def test_active_run_person_opens_window_and_console(x_display, tmp_path) -> None:
    """``confocal active run --searcher person`` in a terminal: the subject's window opens with
    input, the console comes up, Ctrl+Q saves and quits with exit 0; the log names the display."""
    import fcntl
    import pty
    import sqlite3
    import struct
    import termios
    import time

    from tests.ptyread import read_pty

    text = open(
        os.path.join(os.path.dirname(__file__), "..", "..", "protocols", "active_search.toml"),
        encoding="utf-8",
    ).read()
    text = text.replace("n_planes = 200", "n_planes = 60\nscene_shape_px = [154, 192]")
    text += (
        "\n[display]\nscreen_width_px = 320\nscreen_height_px = 256\nscreen_width_cm = 10.0\n"
        "image_width_cm = 6.0\nimage_height_cm = 4.0\n"
    )
    proto = tmp_path / "person.toml"
    proto.write_text(text, encoding="utf-8")
    data = tmp_path / "study.sqlite"
    exe = os.path.join(os.path.dirname(sys.executable), "confocal")
    args = [exe, "active", "run", str(proto), "--data", str(data), "--subject", "S01"]
    args += ["--searcher", "person", "--window", "--skip-timing-check", "--seed", "1"]
    env = {**os.environ, "DISPLAY": x_display, "TERM": "xterm-256color"}
    pid, fd = pty.fork()
    if pid == 0:  # the child: the command in a terminal 100x30
        os.execve(exe, args, env)
    fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    out = bytearray()
    end = time.monotonic() + 120
    status = None
    sent = False
    while time.monotonic() < end:
        if not read_pty(fd, out, time.monotonic() + 0.2):
            break
        if not sent and b"Enter starts" in out:
            os.write(fd, b"\x11")  # Ctrl+Q
            sent = True
        done, st = os.waitpid(pid, os.WNOHANG)
        if done:
            status = st
            break
    if status is None:  # hung: kill it (the assertions below then say why)
        os.kill(pid, 9)
        _, status = os.waitpid(pid, 0)
    os.close(fd)
    plain = out.decode("utf-8", "replace")
    if "could not start" in plain:
        pytest.skip("no GLX window for the presenter under this X server")
    assert sent, plain[-2000:]
    assert os.waitstatus_to_exitcode(status) == 0, plain[-2000:]
    assert "session of S01: 0 of 12 trials answered" in plain  # 2 scenes x 3 x 2
    con = sqlite3.connect(data)
    kinds = [k for (k,) in con.execute("SELECT kind FROM events ORDER BY rowid")]
    responder = con.execute("SELECT responder FROM sessions").fetchone()[0]
    con.close()
    assert responder == "person"
    assert "display" in kinds and "timing_check" in kinds and kinds[-1] == "close"
