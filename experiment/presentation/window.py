"""The subject's window: opening it on a chosen screen, and the subject's keys, wheel and drags.

moderngl-window (pyglet back end) opens the window; both are imported when a window is opened,
never on import (pyglet raises on import without a display).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from experiment.presentation.errors import PresenterError
from experiment.presentation.geometry import ScreenGeometry

__all__ = ["INPUT_KEYS", "open_window", "bind_subject_input"]

#: Keys of the subject's window reported as input when input is on
#: (:meth:`~experiment.presentation.presenter.Presenter.enable_input`): moderngl-window key name
#: -> the name sent to the console (the names of :data:`experiment.viewer.state.KEYMAP`). The
#: wheel is reported as ``WheelUp``/``WheelDown`` and a mouse drag as ``drag`` with its box.
INPUT_KEYS: dict[str, str] = {
    "UP": "Up",
    "DOWN": "Down",
    "PAGE_UP": "PageUp",
    "PAGE_DOWN": "PageDown",
    "ESCAPE": "Escape",
    "ENTER": "Enter",
}


def open_window(
    geometry: ScreenGeometry,
    *,
    screen: int | None,
    fullscreen: bool,
    vsync: bool,
    title: str,
) -> Any:
    """Open a moderngl-window (pyglet) window at the geometry's resolution on ``screen``.

    ``screen`` is an index into pyglet's screen list (0 = first, None = the first); full screen
    uses that screen's current mode. The window's GL context is made current; the caller closes
    the window.

    Raises
    ------
    PresenterError
        No display, or ``screen`` out of range.
    """
    try:
        import moderngl_window
        import pyglet
    except Exception as exc:  # noqa: BLE001 - pyglet raises on import without a display
        raise PresenterError(f"cannot open a window (no display?): {exc}") from exc
    rows, cols = geometry.screen_shape_px
    screens = pyglet.display.get_display().get_screens()
    if screen is not None and not 0 <= screen < len(screens):
        raise PresenterError(f"screen must be in 0..{len(screens) - 1}, got {screen}")
    target = screens[screen if screen is not None else 0]
    window_cls = moderngl_window.get_local_window_cls("pyglet")
    window = window_cls(
        title=title,
        size=(cols, rows),
        fullscreen=False,
        resizable=False,
        vsync=vsync,
        gl_version=(3, 3),
        cursor=not fullscreen,
    )
    window._window.set_location(target.x, target.y)
    if fullscreen:
        window._window.set_fullscreen(True, screen=target)
        window._buffer_width, window._buffer_height = window._window.get_framebuffer_size()
    moderngl_window.activate_context(window=window)
    return window


def bind_subject_input(
    window: Any,
    post: Callable[[dict[str, Any]], None],
    to_fraction: Callable[[float, float], tuple[float, float]],
) -> None:
    """Send the window's :data:`INPUT_KEYS`, wheel and mouse drags to ``post``, one dict each.

    A key or wheel step posts ``{"key": name}``; a drag posts ``{"key": "drag", "box": [x0, y0,
    x1, y1]}`` with corners from ``to_fraction`` (window point -> fractions of the stimulus).
    Escape no longer closes the window (moderngl-window's default): it is the un-zoom key.
    """
    keys = window.keys
    named = {getattr(keys, k): v for k, v in INPUT_KEYS.items() if hasattr(keys, k)}
    window.exit_key = None
    start: dict[str, tuple[float, float]] = {}

    def on_key(key: Any, action: Any, modifiers: Any) -> None:
        if action == keys.ACTION_PRESS and key in named:
            post({"key": named[key]})

    def on_scroll(dx: float, dy: float) -> None:
        if dy:
            post({"key": "WheelUp" if dy > 0 else "WheelDown"})

    def on_press(x: float, y: float, button: Any) -> None:
        start["xy"] = to_fraction(x, y)

    def on_release(x: float, y: float, button: Any) -> None:
        a = start.pop("xy", None)
        if a is None:
            return
        b = to_fraction(x, y)
        box = [min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1])]
        post({"key": "drag", "box": box})

    window.key_event_func = on_key
    window.mouse_scroll_event_func = on_scroll
    window.mouse_press_event_func = on_press
    window.mouse_release_event_func = on_release
