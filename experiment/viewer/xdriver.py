"""An independent driver that types into an X window (the XTEST extension, through ctypes).

The viewer's tests and ``benchmarks/bench_viewer.py`` use it to press real keys in a
``confocal view`` window running in another process under Xvfb: the events go through the X
server, pyglet and moderngl-window exactly as a keyboard's do (so a test sees, for instance,
whether Esc still closes the window). It needs ``libX11`` and ``libXtst`` (Xvfb ships the
extension) and no Python package; :class:`XDriverError` says what is missing.
"""

from __future__ import annotations

import ctypes
import time

from experiment.errors import ConfocalError

__all__ = ["XDriverError", "XDriver"]


class XDriverError(ConfocalError):
    """No X display, no XTEST, or the window was not found."""


class XDriver:
    """Press keys in the X window with a given title on ``display`` (e.g. ``":99"``).

    Parameters
    ----------
    display : str
        The X display name.
    """

    def __init__(self, display: str) -> None:
        try:
            self._x = ctypes.CDLL("libX11.so.6")
            self._t = ctypes.CDLL("libXtst.so.6")
        except OSError as exc:
            raise XDriverError(f"libX11 or libXtst missing: {exc}") from None
        x = self._x
        x.XOpenDisplay.restype = ctypes.c_void_p
        x.XOpenDisplay.argtypes = [ctypes.c_char_p]
        x.XDefaultRootWindow.restype = ctypes.c_ulong
        x.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        x.XStringToKeysym.restype = ctypes.c_ulong
        x.XStringToKeysym.argtypes = [ctypes.c_char_p]
        x.XKeysymToKeycode.restype = ctypes.c_ubyte
        x.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
        x.XFlush.argtypes = [ctypes.c_void_p]
        x.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        x.XCloseDisplay.argtypes = [ctypes.c_void_p]
        x.XQueryTree.argtypes = [
            ctypes.c_void_p,
            ctypes.c_ulong,
            ctypes.POINTER(ctypes.c_ulong),
            ctypes.POINTER(ctypes.c_ulong),
            ctypes.POINTER(ctypes.POINTER(ctypes.c_ulong)),
            ctypes.POINTER(ctypes.c_uint),
        ]
        x.XFetchName.argtypes = [
            ctypes.c_void_p,
            ctypes.c_ulong,
            ctypes.POINTER(ctypes.c_char_p),
        ]
        x.XSetInputFocus.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_ulong]
        x.XFree.argtypes = [ctypes.c_void_p]
        self._t.XTestFakeKeyEvent.argtypes = [
            ctypes.c_void_p,
            ctypes.c_uint,
            ctypes.c_int,
            ctypes.c_ulong,
        ]
        self._d = x.XOpenDisplay(display.encode())
        if not self._d:
            raise XDriverError(f"cannot open X display {display!r}")

    def _windows(self, w: int):
        x = self._x
        root, parent = ctypes.c_ulong(), ctypes.c_ulong()
        children = ctypes.POINTER(ctypes.c_ulong)()
        n = ctypes.c_uint()
        if not x.XQueryTree(self._d, w, root, parent, children, n):
            return
        kids = [children[i] for i in range(n.value)]
        if children:
            x.XFree(children)
        for k in kids:
            yield k
            yield from self._windows(k)

    def find(self, title: str, *, timeout_s: float = 60.0) -> int:
        """Return the id of the first window named ``title``, waiting up to ``timeout_s``."""
        end = time.monotonic() + timeout_s
        while True:
            for w in self._windows(self._x.XDefaultRootWindow(self._d)):
                name = ctypes.c_char_p()
                if self._x.XFetchName(self._d, w, ctypes.byref(name)) and name.value:
                    found = name.value.decode(errors="replace") == title
                    self._x.XFree(name)
                    if found:
                        return int(w)
            if time.monotonic() > end:
                raise XDriverError(f"no window named {title!r} after {timeout_s:g} s")
            time.sleep(0.2)

    def focus(self, window: int) -> None:
        """Give ``window`` the keyboard focus (no window manager needed)."""
        self._x.XSetInputFocus(self._d, window, 2, 0)  # RevertToParent, CurrentTime
        self._x.XSync(self._d, 0)

    def press(self, keysym: str, *, hold_s: float = 0.02) -> None:
        """Press and release one key by its X keysym name (``Escape``, ``q``, ``Up``)."""
        sym = self._x.XStringToKeysym(keysym.encode())
        code = self._x.XKeysymToKeycode(self._d, sym) if sym else 0
        if not code:
            raise XDriverError(f"no key for keysym {keysym!r}")
        self._t.XTestFakeKeyEvent(self._d, code, 1, 0)
        self._x.XFlush(self._d)
        time.sleep(hold_s)
        self._t.XTestFakeKeyEvent(self._d, code, 0, 0)
        self._x.XFlush(self._d)

    def close(self) -> None:
        """Close the connection to the display."""
        if self._d:
            self._x.XCloseDisplay(self._d)
            self._d = None
