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


def test_window_shows_stimulus_and_closes_cleanly(x_display, tmp_path) -> None:
    """The window's framebuffer holds exactly the expected frame; closing exits with status 0."""
    env = {**os.environ, "DISPLAY": x_display}
    try:
        display = RemoteDisplay(GEOMETRY, mode="window", skip_timing_check=True, env=env)
    except PresenterDied as exc:
        pytest.skip(f"no GLX window under {x_display}: {exc}")
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
