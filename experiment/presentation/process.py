"""The presenter as a separate process, and the message protocol between it and the console.

The operator console (:mod:`experiment.console`) and the subject's screen run in two processes so
that each can sit on its own screen and a crash or a closed window on one side does not take the
other down. The console starts the presenter with :class:`RemoteDisplay`, which implements
:class:`experiment.interfaces.Display` by sending messages; the child runs :func:`serve`.

Transport
---------
JSON lines over the child's stdin (requests) and stdout (replies and events), UTF-8, one object
per line. The child's stderr is its log. Nothing else is written to stdout. Times are
``time.perf_counter()`` seconds of the child; on Linux, macOS and Windows that is a system-wide
monotonic clock, so they compare directly with the console's
:class:`~experiment.clock.PerfCounterClock`.

Messages (protocol version 1)
-----------------------------
The child first sends one event, then answers each request in order with the same ``id``:

==================  ==========================================================================
child -> console    ``{"event": "ready", "protocol": 1, "pid": int, "screen_shape_px": [rows,
                    cols], "refresh_hz": float|null, "measured_refresh_hz":
                    float|null, "renderer": str, "timing_check": "passed" |
                    "skipped" | "none"}``; or ``{"event": "error", "error": str}`` and exit 2.
console -> child    ``{"id": int, "cmd": "stimulus", "shape": [rows, cols], "dtype": "bool" |
                    "float32", "data": base64 of the C-order bytes}`` -> reply with ``"flip"``
                    (the onset :class:`~experiment.interfaces.FlipRecord` as a dict)
console -> child    ``{"id": int, "cmd": "clear"}`` -> ``"flip"``: the offset flip, with the
                    frame intervals and dropped frames since the onset
console -> child    ``{"id": int, "cmd": "text", "text": str}`` (instructions, pause, end)
console -> child    ``{"id": int, "cmd": "blank"}`` (fixation screen, no record)
console -> child    ``{"id": int, "cmd": "screenshot", "path": str}`` (PNG of the current frame)
console -> child    ``{"id": int, "cmd": "ping"}``
console -> child    ``{"id": int, "cmd": "close"}`` -> reply, then the child exits 0
child -> console    replies: ``{"id": int, "ok": true, ...}`` or ``{"id": int, "ok": false,
                    "error": str}``
child -> console    ``{"event": "closed", "reason": str}`` when the subject's window is closed
child -> console    ``{"event": "input", "t_s": float, "key": str, "box": [x0, y0, x1, y1]}``
                    (only with ``--inputs``, the active-search task): a key, wheel step or mouse
                    drag of the subject (``Presenter.enable_input``; ``box`` for a drag
                    only, fractions of the stimulus rectangle)
console -> child    ``{"id": int, "cmd": "inject", "events": [...]}`` (tests, scripted runs):
                    each event is either ``{"pyglet": name, "args": [...]}``, dispatched to the
                    window as that pyglet event (the path a real key takes), or an input dict
                    as above, queued as if typed
==================  ==========================================================================

In a window the child redraws and flips once per refresh between requests (vsync-locked), which
is how the frame intervals of a stimulus are measured. Offscreen it draws only on request.
"""

from __future__ import annotations

import argparse
import base64
import json
import logging
import os
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import asdict
from typing import IO, Any

import numpy as np

from experiment.errors import ConfocalError
from experiment.interfaces import FlipRecord

__all__ = [
    "PROTOCOL_VERSION",
    "PresenterDied",
    "RemoteDisplay",
    "encode_image",
    "decode_image",
    "flip_from_dict",
    "serve",
    "main",
]

logger = logging.getLogger(__name__)

#: Version of the message protocol described in the module docstring.
PROTOCOL_VERSION = 1
#: How long the console waits for the child to open its screen, s (ours: window + timing test).
START_TIMEOUT_S = 60.0
#: How long the console waits for a reply, s (ours: a flip takes ms; generous for llvmpipe).
REPLY_TIMEOUT_S = 20.0
#: Frame cap when flips do not block (no vsync, timing check skipped), Hz; ours, to spare the CPU.
NO_VSYNC_CAP_HZ = 60.0


class PresenterDied(ConfocalError):
    """The presenter process exited, closed its window or stopped answering."""


def encode_image(image: np.ndarray) -> dict[str, Any]:
    """Return the message fields (shape, dtype, data) of an image.

    The image is bool or float32 (rows, cols), or a float32 colour photo (rows, cols, 3).
    """
    image = np.asarray(image)
    colour = image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.float32
    if image.ndim != 2 and not colour:
        raise ValueError(
            f"image must be 2-D (rows, cols) or a float32 colour photo (rows, cols, 3), "
            f"got shape {image.shape}"
        )
    if image.dtype not in (np.bool_, np.float32):
        raise TypeError(f"image must be bool or float32, got dtype {image.dtype}")
    return {
        "shape": list(image.shape),
        "dtype": "bool" if image.dtype == np.bool_ else "float32",
        "data": base64.b64encode(np.ascontiguousarray(image).tobytes()).decode("ascii"),
    }


def decode_image(msg: dict[str, Any]) -> np.ndarray:
    """Inverse of :func:`encode_image`."""
    dtype = {"bool": np.bool_, "float32": np.float32}[msg["dtype"]]
    data = base64.b64decode(msg["data"])
    return np.frombuffer(data, dtype=dtype).reshape(tuple(msg["shape"])).copy()


def flip_from_dict(d: dict[str, Any]) -> FlipRecord:
    """Build a :class:`FlipRecord` from its message form."""
    return FlipRecord(
        onset_s=float(d["onset_s"]),
        offset_s=None if d.get("offset_s") is None else float(d["offset_s"]),
        frame_intervals_ms=tuple(float(v) for v in d.get("frame_intervals_ms", ())),
        dropped_frames=int(d.get("dropped_frames", 0)),
        refresh_hz=None if d.get("refresh_hz") is None else float(d["refresh_hz"]),
    )


def _flip_dict(flip: FlipRecord) -> dict[str, Any]:
    d = asdict(flip)
    d["frame_intervals_ms"] = list(flip.frame_intervals_ms)
    return d


# -- the child ------------------------------------------------------------------------------------


def _handle(presenter: Any, msg: dict[str, Any]) -> dict[str, Any]:
    cmd = msg.get("cmd")
    if cmd == "stimulus":
        return {"flip": _flip_dict(presenter.show_stimulus(decode_image(msg)))}
    if cmd == "clear":
        return {"flip": _flip_dict(presenter.clear())}
    if cmd == "text":
        presenter.show_text(str(msg["text"]))
        return {}
    if cmd == "blank":
        presenter.show_blank()
        return {}
    if cmd == "screenshot":
        return {"path": str(presenter.screenshot(msg["path"]))}
    if cmd == "ping":
        return {}
    if cmd == "inject":
        for ev in msg.get("events", []):
            if "pyglet" in ev:
                if presenter.window is None:
                    raise ValueError("pyglet events need a window (--mode window)")
                presenter.window._window.dispatch_event(ev["pyglet"], *ev.get("args", []))
            else:
                presenter.post_input({k: v for k, v in ev.items() if k != "t_s"})
        return {}
    raise ValueError(f"unknown cmd {cmd!r}")


def serve(
    presenter: Any, inp: IO[str], out: IO[str], *, continuous: bool, cap_hz: float | None = None
) -> int:
    """Answer requests from ``inp`` on ``out`` until ``close`` or end of input; return exit status.

    Parameters
    ----------
    presenter : experiment.presentation.presenter.Presenter
    inp, out : text streams
        JSON lines in and out (see the module docstring).
    continuous : bool
        Flip once per refresh between requests (a window); False draws only on request.
    cap_hz : float or None
        Sleep to at most this frame rate when flips do not block (no vsync).
    """
    requests: queue.Queue[str | None] = queue.Queue()

    def read() -> None:
        for line in inp:
            requests.put(line)
        requests.put(None)

    threading.Thread(target=read, daemon=True, name="presenter-stdin").start()

    def send(obj: dict[str, Any]) -> None:
        out.write(json.dumps(obj) + "\n")
        out.flush()

    send(
        {
            "event": "ready",
            "protocol": PROTOCOL_VERSION,
            "pid": os.getpid(),
            "screen_shape_px": list(presenter.geometry.screen_shape_px),
            "refresh_hz": presenter.refresh_hz,
            "measured_refresh_hz": getattr(presenter, "measured_refresh_hz", presenter.refresh_hz),
            "renderer": presenter.ctx.info.get("GL_RENDERER", "?"),
            "timing_check": getattr(presenter, "timing_check", "none"),
        }
    )
    last = time.perf_counter()
    while True:
        try:
            line = requests.get_nowait() if continuous else requests.get()
        except queue.Empty:
            line = ""
        if line is None:
            return 0
        if line.strip():
            try:
                msg = json.loads(line)
            except json.JSONDecodeError as exc:
                send({"id": None, "ok": False, "error": f"bad JSON: {exc}"})
                continue
            if msg.get("cmd") == "close":
                send({"id": msg.get("id"), "ok": True})
                return 0
            try:
                reply = {"id": msg.get("id"), "ok": True, **_handle(presenter, msg)}
            except Exception as exc:  # noqa: BLE001 - every failure goes back as one line
                reply = {"id": msg.get("id"), "ok": False, "error": " ".join(str(exc).split())}
            send(reply)
            for ev in presenter.poll_inputs():
                send({"event": "input", **ev})
            continue
        if continuous:
            if presenter.window is not None and presenter.window.is_closing:
                send({"event": "closed", "reason": "the subject's window was closed"})
                return 1
            presenter.pump()
            for ev in presenter.poll_inputs():
                send({"event": "input", **ev})
            if cap_hz:
                now = time.perf_counter()
                wait = 1.0 / cap_hz - (now - last)
                if wait > 0:
                    time.sleep(wait)
                last = time.perf_counter()


def main(argv: list[str] | None = None) -> int:
    """Run the presenter process (``python -m experiment.presentation.process --geometry ...``)."""
    ap = argparse.ArgumentParser(prog="python -m experiment.presentation.process")
    ap.add_argument("--geometry", required=True, help="ScreenGeometry.to_dict() as JSON")
    ap.add_argument("--mode", choices=("window", "offscreen"), default="window")
    ap.add_argument("--screen", type=int, default=None)
    ap.add_argument("--fullscreen", action="store_true")
    ap.add_argument("--skip-timing-check", action="store_true")
    ap.add_argument("--integer-scale", action="store_true")
    ap.add_argument("--phosphenes", default=None, help="PhospheneSpec fields as JSON")
    ap.add_argument("--inputs", action="store_true", help="report the subject's keys and drags")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="presenter: %(levelname)s: %(message)s")
    out = sys.stdout
    sys.stdout = sys.stderr  # nothing but protocol lines may reach the console's pipe

    def fail(text: str) -> int:
        out.write(json.dumps({"event": "error", "error": " ".join(text.split())}) + "\n")
        out.flush()
        return 2

    try:
        from experiment.presentation.presenter import PhospheneSpec, Presenter, ScreenGeometry

        geometry = ScreenGeometry.from_dict(json.loads(args.geometry))
        phos = PhospheneSpec(**json.loads(args.phosphenes)) if args.phosphenes else None
        kw = dict(integer_scale=args.integer_scale, phosphenes=phos)
        if args.mode == "offscreen":
            presenter = Presenter.offscreen(geometry, **kw)
            presenter.timing_check = "none"
        else:
            presenter = Presenter.windowed(
                geometry, screen=args.screen, fullscreen=args.fullscreen, **kw
            )
            try:
                presenter.measure_refresh(check=not args.skip_timing_check)
            except Exception:
                presenter.close()
                raise
            presenter.timing_check = "skipped" if args.skip_timing_check else "passed"
            presenter.show_blank()
    except Exception as exc:  # noqa: BLE001 - reported to the console as one line
        return fail(str(exc))
    if args.inputs:
        presenter.enable_input()
    cap = NO_VSYNC_CAP_HZ if args.skip_timing_check else None
    presenter.measured_refresh_hz = presenter.refresh_hz
    if cap is not None and presenter.refresh_hz is not None and presenter.refresh_hz > cap:
        # No vsync: frames are paced by the cap, so that is the rate dropped frames refer to.
        logger.warning(
            "flips do not wait for vsync (%.0f Hz); capped at %g Hz", presenter.refresh_hz, cap
        )
        presenter.refresh_hz = cap
    try:
        return serve(presenter, sys.stdin, out, continuous=args.mode == "window", cap_hz=cap)
    finally:
        presenter.close()


# -- the console's side -----------------------------------------------------------------------


def _child_setup(parent_pid: int) -> Callable[[], None]:
    """Return the presenter's ``preexec_fn``: die with this process; leave Ctrl-C to it.

    A SIGKILLed session runs no ``finally``, so only the kernel can close the subject's window
    (``PR_SET_PDEATHSIG``). SIGINT is ignored in the child (the setting survives ``exec``, and
    Python then installs no ``KeyboardInterrupt`` handler): a terminal's Ctrl-C reaches the
    whole process group, and the session stops the presenter itself after logging the stop.
    The imports happen here, in the parent: importing between ``fork`` and ``exec`` can hang.
    """
    import signal

    from experiment.signals import _prctl, die_with_parent

    _prctl()  # load libc's prctl now: no dlopen between fork and exec

    def setup() -> None:
        die_with_parent(parent_pid)
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    return setup


class RemoteDisplay:
    """A :class:`~experiment.interfaces.Display` that drives a presenter process.

    Parameters
    ----------
    geometry : experiment.presentation.presenter.ScreenGeometry or dict
        The subject's screen (``to_dict()`` form is sent to the child).
    mode : {'window', 'offscreen'}
    screen : int or None
        Screen index for the window.
    fullscreen : bool
    skip_timing_check : bool
        Start even if the frame-timing self-test fails (H12; the console logs the choice).
    integer_scale : bool
    phosphenes : dict or None
        :class:`~experiment.presentation.presenter.PhospheneSpec` fields.
    inputs : bool
        Report the subject's keys, wheel and drags (:meth:`poll_inputs`; active search).
    on_event : callable or None
        Called with unsolicited events (``closed``) from the reader thread.
    command : list of str or None
        The child's command line (tests); default runs this module with the current Python.
    env : dict or None
        The child's environment (e.g. another ``DISPLAY``); default inherits ours.
    stderr_path : str or Path or None
        File the child's stderr (its log, moderngl-window's included) is appended to; default
        inherits ours (the terminal).
    """

    def __init__(
        self,
        geometry: Any,
        *,
        mode: str = "window",
        screen: int | None = None,
        fullscreen: bool = False,
        skip_timing_check: bool = False,
        integer_scale: bool = False,
        phosphenes: dict[str, Any] | None = None,
        inputs: bool = False,
        on_event: Callable[[dict[str, Any]], None] | None = None,
        command: list[str] | None = None,
        env: dict[str, str] | None = None,
        start_timeout_s: float = START_TIMEOUT_S,
        reply_timeout_s: float = REPLY_TIMEOUT_S,
        stderr_path: str | os.PathLike | None = None,
    ) -> None:
        self.stderr_path = stderr_path
        gdict = geometry if isinstance(geometry, dict) else geometry.to_dict()
        args = ["--geometry", json.dumps(gdict), "--mode", mode]
        if screen is not None:
            args += ["--screen", str(screen)]
        if fullscreen:
            args.append("--fullscreen")
        if skip_timing_check:
            args.append("--skip-timing-check")
        if integer_scale:
            args.append("--integer-scale")
        if phosphenes:
            args += ["--phosphenes", json.dumps(phosphenes)]
        if inputs:
            args.append("--inputs")
        self.command = (command or [sys.executable, "-m", "experiment.presentation.process"]) + args
        self.env = env
        self.on_event = on_event
        self.reply_timeout_s = reply_timeout_s
        self.start_timeout_s = start_timeout_s
        self.info: dict[str, Any] = {}
        self.returncode: int | None = None
        self._next_id = 0
        self._proc: subprocess.Popen[str] | None = None
        self._replies: queue.Queue[dict[str, Any] | None] = queue.Queue()
        self._inputs: queue.Queue[dict[str, Any]] = queue.Queue()
        self._lock = threading.Lock()
        self.start()

    @property
    def pid(self) -> int | None:
        """Process id of the presenter (None when not running)."""
        return self._proc.pid if self._proc is not None else None

    @property
    def alive(self) -> bool:
        """Whether the presenter process is running."""
        return self._proc is not None and self._proc.poll() is None

    def start(self) -> None:
        """Start (or restart) the presenter process and wait for its ``ready`` event.

        Raises
        ------
        PresenterDied
            When it reports an error, exits, or is not ready within ``start_timeout_s``.
        """
        self._stop_process()
        self._replies = queue.Queue()
        err = None if self.stderr_path is None else open(self.stderr_path, "a", encoding="utf-8")
        try:
            self._proc = subprocess.Popen(
                self.command,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=err,
                env=self.env,
                text=True,
                encoding="utf-8",
                bufsize=1,
                preexec_fn=_child_setup(os.getpid()) if sys.platform.startswith("linux") else None,
            )
        finally:
            if err is not None:
                err.close()  # the child holds its own copy
        threading.Thread(
            target=self._read, args=(self._proc, self._replies), daemon=True, name="presenter-out"
        ).start()
        first = self._get(self.start_timeout_s, "start")
        if first.get("event") == "error":
            self._stop_process()
            env = self.env if self.env is not None else os.environ
            hint = (
                " (no display: DISPLAY is unset; run on the machine with the subject's screen, "
                "or use --presenter offscreen for a dry run)"
                if sys.platform.startswith("linux")
                and not env.get("DISPLAY")
                and not env.get("WAYLAND_DISPLAY")
                else ""
            )
            raise PresenterDied(f"the presenter could not start: {first.get('error')}{hint}")
        if first.get("event") != "ready" or first.get("protocol") != PROTOCOL_VERSION:
            self._stop_process()
            raise PresenterDied(f"the presenter spoke an unknown protocol: {first!r}")
        self.info = first

    def _read(self, proc: subprocess.Popen[str], replies: queue.Queue) -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                logger.warning("presenter wrote a non-protocol line: %r", line)
                continue
            if msg.get("event") == "input":
                self._inputs.put(msg)
                continue
            if msg.get("event") == "closed":
                if self.on_event is not None:
                    self.on_event(msg)
                replies.put(msg)
                continue
            replies.put(msg)
        replies.put(None)

    def _get(self, timeout_s: float, what: str) -> dict[str, Any]:
        try:
            msg = self._replies.get(timeout=timeout_s)
        except queue.Empty:
            self._stop_process()
            raise PresenterDied(
                f"the presenter did not answer {what} within {timeout_s:g} s"
            ) from None
        if msg is None or msg.get("event") == "closed":
            reason = "it exited" if msg is None else msg.get("reason", "closed")
            self._stop_process()
            raise PresenterDied(f"the presenter stopped ({reason}); restart it to continue")
        return msg

    def request(self, cmd: str, **fields: Any) -> dict[str, Any]:
        """Send one request and return its reply (``ok`` true).

        Raises
        ------
        PresenterDied
            When the process is gone or does not answer within ``reply_timeout_s``.
        ValueError
            When the presenter refuses the request (``ok`` false).
        """
        with self._lock:
            if not self.alive:
                raise PresenterDied("the presenter is not running; restart it to continue")
            self._next_id += 1
            msg = {"id": self._next_id, "cmd": cmd, **fields}
            try:
                assert self._proc is not None and self._proc.stdin is not None
                self._proc.stdin.write(json.dumps(msg) + "\n")
                self._proc.stdin.flush()
            except (BrokenPipeError, OSError):
                self._stop_process()
                raise PresenterDied("the presenter stopped (broken pipe); restart it") from None
            while True:
                reply = self._get(self.reply_timeout_s, cmd)
                if reply.get("id") == self._next_id:
                    break
            if not reply.get("ok"):
                raise ValueError(f"presenter refused {cmd}: {reply.get('error')}")
            return reply

    # -- Display ---------------------------------------------------------------------------------

    def show_stimulus(self, image: np.ndarray) -> FlipRecord:
        """Show a stimulus on the subject's screen; return its onset flip."""
        return flip_from_dict(self.request("stimulus", **encode_image(image))["flip"])

    def clear(self) -> FlipRecord:
        """Remove the stimulus; return the offset flip with the frame intervals since onset."""
        return flip_from_dict(self.request("clear")["flip"])

    def show_text(self, text: str) -> None:
        """Show an instruction, pause or end screen."""
        self.request("text", text=text)

    def show_blank(self) -> None:
        """Show the blank/fixation screen."""
        self.request("blank")

    def screenshot(self, path: str) -> str:
        """Save the subject's current frame as a PNG; return the path."""
        return self.request("screenshot", path=str(path))["path"]

    def poll_inputs(self) -> list[dict[str, Any]]:
        """Return the subject's inputs received since the last call, oldest first (``--inputs``)."""
        out = []
        while True:
            try:
                out.append(self._inputs.get_nowait())
            except queue.Empty:
                return out

    def inject(self, events: list[dict[str, Any]]) -> None:
        """Send input events to the presenter as if the subject typed them (tests, scripts)."""
        self.request("inject", events=list(events))

    def kill(self) -> None:
        """Kill the presenter process (tests: simulate a crash)."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait(timeout=10)

    def _stop_process(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            try:
                if proc.stdin is not None:
                    proc.stdin.close()
                proc.wait(timeout=5)
            except (subprocess.TimeoutExpired, OSError):
                proc.kill()
                proc.wait(timeout=5)
        self.returncode = proc.returncode

    def close(self) -> None:
        """Ask the presenter to close and wait for it to exit (kill after 5 s)."""
        if self.alive:
            try:
                self.request("close")
            except (PresenterDied, ValueError):
                pass
        self._stop_process()


if __name__ == "__main__":
    sys.exit(main())
