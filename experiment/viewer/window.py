"""The viewer's window: moderngl-window callbacks turned into :meth:`Viewer.handle` calls.

Esc un-zooms and never closes the window; ``q`` quits (asking for ``y`` while a session logs).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from experiment.errors import ConfocalError

__all__ = ["run_window"]


_NAMED_KEYS = {
    "UP": "up",
    "DOWN": "down",
    "LEFT": "left",
    "RIGHT": "right",
    "PAGE_UP": "page_up",
    "PAGE_DOWN": "page_down",
    "ESCAPE": "escape",
}


def run_window(
    viewer_factory: Any,
    *,
    size_px: tuple[int, int] = (720, 1080),
    seconds: float | None = None,
    script: list[dict] | None = None,
    shots_dir: Path | None = None,
    video_fps: float = 0.0,
    confirm_quit: bool = False,
) -> int:
    """Open a moderngl-window (pyglet) window and run the viewer until closed; return frames.

    A frame is drawn when the state changes (input, script, video); otherwise the loop only
    dispatches window events.

    Parameters
    ----------
    viewer_factory : callable(ctx) -> Viewer
    size_px : (rows, cols)
        Window size.
    seconds : float, optional
        Close after this long.
    script : list of events, optional
        Injected one per frame through :meth:`Viewer.handle` (the same path as real input);
        with ``shots_dir``, the window's framebuffer is saved after each as ``shot_NNN.png``.
    video_fps : float
        Advance video frames at this rate (0: only the n/p keys do).
    confirm_quit : bool
        ``q`` asks first (``y`` quits, any other key stays): a session is being logged.

    Notes
    -----
    Esc never closes the window (moderngl-window's exit key is switched off, as the
    presenter does): it un-zooms. Only ``q`` quits.
    """
    try:
        import moderngl_window
    except Exception as exc:  # noqa: BLE001 - pyglet raises on import without a display
        raise ConfocalError(f"cannot open a window (no display?): {exc}") from exc
    try:
        window_cls = moderngl_window.get_local_window_cls("pyglet")
        rows, cols = size_px
        window = window_cls(
            title="confocal view",
            size=(cols, rows),
            resizable=False,
            vsync=False,
            gl_version=(3, 3),
        )
    except Exception as exc:  # noqa: BLE001
        raise ConfocalError(f"cannot open a window (no display?): {exc}") from exc
    window.exit_key = None  # Esc un-zooms; quitting is the q key's job
    moderngl_window.activate_context(window=window)
    try:
        viewer = viewer_factory(window.ctx)
    except BaseException:
        window.close()
        raise
    viewer.screen_shape_px = (window.buffer_height, window.buffer_width)
    keys = window.keys
    named = {getattr(keys, k): v for k, v in _NAMED_KEYS.items()}
    drag: dict[str, Any] = {}

    asking: dict[str, bool] = {"quit": False}

    def on_key(key, action, modifiers):
        if action != keys.ACTION_PRESS or key not in named:
            return
        if asking["quit"]:
            asking["quit"] = False
            viewer.say("quit cancelled")
            return
        viewer.handle("key", {"key": named[key]})

    def on_char(char):
        if asking["quit"]:
            asking["quit"] = False
            if char in "yY":
                viewer.log.append(viewer.clock(), "quit", {"confirmed": True})
                window.is_closing = True
            else:
                viewer.say("quit cancelled")
            return
        if char == "q":
            if confirm_quit:
                asking["quit"] = True
                viewer.say("quit? y: quit (the log is saved), any other key: stay")
            else:
                viewer.log.append(viewer.clock(), "quit", {"confirmed": False})
                window.is_closing = True
        elif char in "igaoevnpmh?[]-=123456789":
            viewer.handle("key", {"key": char})

    def on_scroll(dx, dy):
        if dy:
            viewer.handle("wheel", {"dy": 1 if dy > 0 else -1})

    def on_press(x, y, button):
        drag["start"] = viewer.view_pixel(x, y)

    def on_release(x, y, button):
        start, end = drag.pop("start", None), viewer.view_pixel(x, y)
        if start is None or end is None:
            return
        if abs(end[0] - start[0]) < 3 and abs(end[1] - start[1]) < 3:
            viewer.handle("click", {"x": end[0], "y": end[1]})
        else:
            box = [start[0], start[1], end[0] - start[0], end[1] - start[1]]
            viewer.handle("drag", {"box": box})

    window.key_event_func = on_key
    window.unicode_char_entered_func = on_char
    window.mouse_scroll_event_func = on_scroll
    window.mouse_press_event_func = on_press
    window.mouse_release_event_func = on_release
    pending = list(script or [])
    t0 = time.perf_counter()
    last_video = t0
    n = shot = 0
    drawn = shown = None
    try:
        while not window.is_closing:
            now = time.perf_counter()
            if video_fps > 0 and viewer.source.n_frames > 1 and now - last_video >= 1 / video_fps:
                nxt = (viewer.state.frame + 1) % viewer.source.n_frames
                viewer.handle("frame", {"frame": nxt})
                last_video = now
            injected = False
            if pending:
                ev = pending.pop(0)
                viewer.handle(ev["kind"], ev["payload"])
                injected = True
            if viewer.state == drawn and viewer.message == shown and not injected:
                # nothing changed: no redraw; refocus the depths the user may go to next
                # (one per loop, so input stays responsive), then idle
                if not viewer.prefetch():
                    time.sleep(0.005)
                window._window.dispatch_events()
            else:
                drawn, shown = viewer.state, viewer.message
                viewer.render(window.fbo)
                if injected and shots_dir is not None:
                    shots_dir.mkdir(parents=True, exist_ok=True)
                    _window_shot(window, shots_dir / f"shot_{shot:03d}.png")
                    shot += 1
                window.swap_buffers()
                n += 1
            if seconds is not None and time.perf_counter() - t0 >= seconds and not pending:
                break
    finally:
        viewer.close()
        window.close()
    return n


def _window_shot(window: Any, path: Path) -> None:
    # the back buffer just drawn, read before the swap (its contents are undefined after)
    from PIL import Image

    rows, cols = window.buffer_height, window.buffer_width
    raw = window.fbo.read(components=3)
    from stimuli.io import atomic_path  # a link at the path is refused; no partial file

    with atomic_path(path) as tmp:
        Image.fromarray(np.frombuffer(raw, np.uint8).reshape(rows, cols, 3)[::-1]).save(
            tmp, format="PNG"
        )
