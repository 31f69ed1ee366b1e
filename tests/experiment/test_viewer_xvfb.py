"""``confocal view`` in a real window (moderngl-window + pyglet over GLX) under Xvfb.

The viewer runs on the synthetic three-plane scene (simulated). Input events are injected with
``--script``: a JSON-lines file whose events go, one per frame, through the same
``Viewer.handle`` method that the window's key, wheel and mouse callbacks call (real X events
would need xdotool, which CI does not have). After each event the window's framebuffer is saved
(``--shots``) and compared with the CPU pipeline's frame for the state the event log recorded;
the log's input events must equal the events sent. Skips with a reason when there is neither a
DISPLAY nor an ``Xvfb``, or no GLX window can be opened.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.gl

pytest.importorskip("moderngl_window", reason="moderngl-window not importable")

from experiment.viewer.app import Viewer  # noqa: E402
from experiment.viewer.events import ViewerEventLog  # noqa: E402
from experiment.viewer.screen import STATUS_ROWS_PX  # noqa: E402
from experiment.viewer.source import open_source  # noqa: E402
from experiment.viewer.state import ViewerState  # noqa: E402
from tests.experiment.conftest import confocal_process  # noqa: E402
from tests.experiment.test_window_xvfb import x_display  # noqa: E402, F401

SIZE = (400, 560)  # rows, cols: small so that llvmpipe draws quickly

EVENTS = [
    {"kind": "key", "payload": {"key": "page_down"}},  # next detected plane
    {"kind": "drag", "payload": {"box": [20, 15, 90, 70]}},  # zoom box
    {"kind": "key", "payload": {"key": "i"}},  # implant switch
    {"kind": "key", "payload": {"key": "escape"}},  # un-zoom
    {"kind": "key", "payload": {"key": "o"}},  # obstacle mode (range: here to nearest)
    {"kind": "wheel", "payload": {"dy": -10}},  # obstacle range: far edge farther
]


@pytest.fixture(scope="module")
def lf_path(tmp_path_factory):
    """The simulated three-plane scene as a small camera array (160x120 views, .npz)."""
    path = tmp_path_factory.mktemp("lf") / "scene.npz"
    r = confocal_process(
        "lightfield", "synth", "--kind", "camera", "--size", "160x120", "--out", path, timeout=120
    )
    assert r.returncode == 0, r.stderr
    return path


def test_viewer_window_events_screenshots_and_log(x_display, lf_path, tmp_path) -> None:  # noqa: F811
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    script = tmp_path / "events.jsonl"
    script.write_text("".join(json.dumps(e) + "\n" for e in EVENTS))
    shots, log_path = tmp_path / "shots", tmp_path / "events.sqlite"
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            "view",
            str(lf_path),
            "--implant",
            "argus2",
            "--implant",
            "brainport",
            "--script",
            str(script),
            "--shots",
            str(shots),
            "--log",
            str(log_path),
            "--seconds",
            "0",
            "--size",
            f"{SIZE[1]}x{SIZE[0]}",
            "--planes",
            "60",
            "--compute",
            "gpu",  # the shaders in a real window (auto picks numpy on llvmpipe: tested offscreen)
        ],
        env={**os.environ, "DISPLAY": x_display},
        capture_output=True,
        text=True,
        timeout=300,
    )
    if r.returncode != 0 and "cannot open a window" in r.stderr:
        pytest.skip(f"no GLX window under {x_display}: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    log = ViewerEventLog(log_path)
    logged = log.events()
    inputs = [e for e in logged if e.kind in ("key", "wheel", "drag", "click")]
    assert [{"kind": e.kind, "payload": e.payload} for e in inputs] == EVENTS
    # each input event is followed by the state it led to
    states = [logged[logged.index(e) + 1] for e in inputs]
    assert all(s.kind == "state" for s in states)
    st = [ViewerState.from_dict(s.payload) for s in states]
    assert st[0].plane == 1 and st[1].zoom == (20, 15, 90, 70)
    assert (st[2].implant, st[3].zoom) == ("brainport", None)
    assert st[4].mode == "obstacle" and st[5].obstacle_px[1] < st[4].obstacle_px[1]
    assert [e.kind for e in logged][:1] == ["open"] and logged[-1].kind == "close"

    from PIL import Image

    ref = Viewer(
        open_source(lf_path), ["argus2", "brainport"], screen_shape_px=SIZE, ctx=None, n_planes=60
    )
    try:
        for k, s in enumerate(st):
            ref.state = s
            want = ref.render()[: SIZE[0] - STATUS_ROWS_PX]
            got = np.asarray(Image.open(shots / f"shot_{k:03d}.png").convert("RGB"))
            got = got[: SIZE[0] - STATUS_ROWS_PX]
            diff = np.abs(got.astype(int) - want.astype(int))
            assert diff.max() <= 1, f"shot {k}: {int((diff > 1).sum())} pixels differ by > 1"
    finally:
        ref.close()


def _states(log_path) -> list[ViewerState]:
    """The states logged so far (none while the viewer is still creating its log's table)."""
    import sqlite3

    con = sqlite3.connect(f"file:{log_path}?mode=ro", uri=True)
    try:
        rows = con.execute(
            "SELECT payload_json FROM viewer_events WHERE kind = 'state' ORDER BY event_id"
        ).fetchall()
    except sqlite3.OperationalError as exc:
        if "no such table" not in str(exc):
            raise
        return []
    finally:
        con.close()
    return [ViewerState.from_dict(json.loads(r[0])) for r in rows]


def _wait(pred, what: str, timeout_s: float = 30.0):
    import time

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        got = pred()
        if got:
            return got
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def test_real_keys_esc_unzooms_and_never_closes_the_window(x_display, lf_path, tmp_path) -> None:  # noqa: F811
    """Keys typed through the X server: Esc un-zooms and the window stays; q then y quits."""
    from experiment.viewer.xdriver import XDriver, XDriverError

    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    try:
        drv = XDriver(x_display)
    except XDriverError as exc:
        pytest.skip(str(exc))
    log_path = tmp_path / "events.sqlite"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "view", str(lf_path), "--implant", "argus2",
         "--zoom", "20,15,90,70", "--log", str(log_path), "--size", "560x400", "--planes", "30"],
        env={**os.environ, "DISPLAY": x_display},
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        try:
            win = drv.find("confocal view", timeout_s=90)
        except XDriverError:
            proc.kill()
            err = proc.communicate()[1]
            if "cannot open a window" in err:
                pytest.skip(f"no GLX window under {x_display}: {err.strip()}")
            raise AssertionError(err) from None
        # the viewer logs its initial state, then the one the options set (zoomed)
        last_zoom = [(20, 15, 90, 70)]
        _wait(lambda: log_path.exists() and [s.zoom for s in _states(log_path)][-1:] == last_zoom,
              "the state --zoom sets")  # fmt: skip
        drv.focus(win)
        drv.press("Escape")
        _wait(lambda: _states(log_path)[-1].zoom is None, "Esc to un-zoom")
        drv.press("h")
        _wait(lambda: _states(log_path)[-1].help, "h to show the key help")
        import time

        time.sleep(0.5)
        assert proc.poll() is None, "the window closed after Esc"
        drv.press("q")  # logging: asks first
        time.sleep(1.0)
        assert proc.poll() is None, "q closed a logging session without asking"
        drv.press("y")
        assert proc.wait(timeout=30) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        drv.close()
    log = ViewerEventLog(log_path)
    kinds = [e.kind for e in log.events()]
    assert "quit" in kinds and kinds[-1] == "close"
    assert log.events(kind="quit")[0].payload == {"confirmed": True}
    keys = [e.payload["key"] for e in log.events(kind="key")]
    assert keys == ["escape", "h"]
