"""Stop a command cleanly on SIGTERM or SIGINT, and let no worker process outlive its parent.

A terminal's Ctrl-C (SIGINT) or a job scheduler's ``kill`` (SIGTERM) must not leave a trial log
mid-transaction or a ``.tmp-*`` folder beside the output. :func:`stop_on_signals` turns either
signal into a :class:`Stopped` exception raised in the main thread, so every ``finally:`` block
and context manager on the way up runs (the trial log rolls back the open trial and closes;
the stimulus, scan and report writers remove their temporary folders). The ``confocal`` root
catches it and prints one line; the exit status is 128 + the signal number (130 for SIGINT,
143 for SIGTERM), the shell's convention.

:class:`Stopped` derives from :class:`BaseException`, like :class:`KeyboardInterrupt`, so that an
``except Exception`` meant for bad data never swallows it; it is not a ``KeyboardInterrupt``
because click turns those into "Aborted!" with status 1 before the root could name the signal.

:func:`die_with_parent` covers the case no handler can, a SIGKILLed parent: the presenter
subprocess and the demo's worker pool ask Linux to kill them when their parent dies.

From the first line to the last: when the process is the ``confocal`` command, the top of
:mod:`experiment` (before any heavy import) makes a stop signal during start-up print the same
line and exit at once (nothing is open or written yet). Once the command has ended (done,
failed or stopped), :func:`stop_on_signals` leaves :func:`_after_the_command` in place: a
signal then ends the process at once with the line (if not yet printed) and 128 + the signal.
The last exit function (:func:`_at_exit`) skips Python's own teardown after a stop (it frees
memory only, and takes up to seconds with the scientific stack loaded) and otherwise ignores
stop signals while the interpreter tears down, where Python's default handling would end the
process silently with ``-15``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator

__all__ = [
    "SECOND_SIGNAL_GRACE_S",
    "STOP_SIGNALS",
    "Stopped",
    "die_with_parent",
    "hold_stops",
    "report_stop",
    "stop_line",
    "stop_on_signals",
    "worker_init",
]

#: The signals that stop a command.
STOP_SIGNALS: tuple[int, ...] = (signal.SIGTERM, signal.SIGINT)


class Stopped(BaseException):  # noqa: N818 - a stop, like KeyboardInterrupt, not an error
    """A stop signal (SIGTERM, SIGINT) arrived; raised in the main thread by the handler.

    Attributes
    ----------
    signum : int
        The signal number.
    exit_code : int
        128 + ``signum``: 130 for SIGINT, 143 for SIGTERM.
    """

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        self.exit_code = 128 + self.signum
        super().__init__(f"stopped by {self.name}")

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``'SIGTERM'``."""
        try:
            return signal.Signals(self.signum).name
        except ValueError:  # pragma: no cover - only the stop signals are handled
            return f"signal {self.signum}"


#: A second stop signal this many seconds after the first ends the process at once: the clean-up
#: after a stop takes well under a second, so a stop still running then was lost (a library's
#: ``except BaseException`` took it) or hangs. Ending then is what SIGKILL does, and the output
#: folders and the trial log recover from that on their next use.
SECOND_SIGNAL_GRACE_S = 5.0

#: The first stop signal this process received (None: none yet), when, and whether its line
#: has been printed.
_stop: dict[str, float | int | bool | None] = {
    "signum": None,
    "at": None,
    "said": False,
    "raised": False,
}


def stop_line(signum: int) -> str:
    """Return the one line a stopped command prints (without a newline)."""
    try:
        name = signal.Signals(signum).name
    except ValueError:  # pragma: no cover - only the stop signals are handled
        name = f"signal {signum}"
    return f"confocal: stopped by {name}; the log is closed, nothing half-written"


def report_stop(stop: Stopped) -> None:
    """Print the stop's one line on stderr, once per process."""
    if not _stop["said"]:
        _stop["said"] = True
        print(stop_line(stop.signum), file=sys.stderr, flush=True)


def _exit_now(signum: int) -> None:
    """End the process at once with the first stop's line (if not printed) and its status."""
    first = int(_stop["signum"] or signum)
    for stream in (sys.stdout, sys.stderr):
        try:  # what the command printed must not be lost; a write cut short raises here
            stream.flush()
        except (OSError, ValueError, RuntimeError, AttributeError):
            pass
    if not _stop["said"]:
        _stop["said"] = True
        with contextlib.suppress(OSError):
            os.write(2, (stop_line(first) + "\n").encode())
    os._exit(128 + first)


#: How many :func:`hold_stops` blocks are open in the main thread.
_held = [0]


def _raise_stopped(signum: int, frame: object) -> None:
    if _stop["signum"] is not None:  # a second signal while the first unwinds
        at = _stop["at"]
        if at is not None and time.monotonic() - float(at) >= SECOND_SIGNAL_GRACE_S:
            _exit_now(signum)
        return  # the finally blocks (a rollback, a rmtree) must finish
    _stop["signum"], _stop["at"] = int(signum), time.monotonic()
    if _held[0] > 0:
        return  # raised where the outermost hold_stops block ends
    _stop["raised"] = True
    raise Stopped(signum)


@contextlib.contextmanager
def hold_stops() -> Iterator[None]:
    """Let a stop signal that arrives in the block stop the command only where the block ends.

    For steps that must not be cut in two (renaming a finished output into place, then
    recording it): :func:`stop_on_signals` raises :class:`Stopped` at any point of the code, and
    ``finally:`` blocks undo what a step left half done; a step that cannot be undone goes in
    this block. Blocks nest; the stop is raised when the outermost ends (not if it ends by an
    exception, which then carries on). Outside the main thread it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _held[0] += 1
    try:
        yield
    finally:
        _held[0] -= 1
    pending = _stop["signum"]
    if not _held[0] and pending is not None and not _stop["raised"]:
        _stop["raised"] = True
        raise Stopped(int(pending))


def _after_the_command(signum: int, frame: object) -> None:
    """Handle a signal once the command has ended: nothing is being written; end the process."""
    _exit_now(signum)


def _is_start_up_guard(handler: object) -> bool:
    package = sys.modules.get("experiment")
    return handler is not None and handler is getattr(package, "_stop_at_start", None)


def _at_exit() -> None:
    """Run as the ``confocal`` command's last exit function (registered by :mod:`experiment`)."""
    if _stop["signum"] is not None:
        _exit_now(int(_stop["signum"]))
    for s in STOP_SIGNALS:
        if signal.getsignal(s) is not signal.SIG_IGN:
            signal.signal(s, signal.SIG_IGN)


@contextlib.contextmanager
def stop_on_signals() -> Iterator[None]:
    """Raise :class:`Stopped` in the main thread on SIGTERM or SIGINT while the block runs.

    Outside the main thread (an embedding application) it does nothing: Python only runs
    signal handlers there. The previous handlers are restored on exit, except the ``confocal``
    command's start-up guard, which gives way to :func:`_after_the_command`. A second signal
    while a stop unwinds is ignored for :data:`SECOND_SIGNAL_GRACE_S` seconds.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    _stop.update(signum=None, at=None, said=False, raised=False)  # in-process callers run many
    for s in STOP_SIGNALS:
        if old[s] is signal.SIG_IGN and s == signal.SIGINT:
            continue  # started in the background with SIGINT ignored (``cmd &`` in sh): keep it
        signal.signal(s, _raise_stopped)
    try:
        yield
    finally:
        for s, h in old.items():
            if _is_start_up_guard(h):
                h = _after_the_command
            signal.signal(s, h if h is not None else signal.SIG_DFL)


#: ``PR_SET_PDEATHSIG`` from ``<linux/prctl.h>``: deliver a signal when the parent thread exits.
_PR_SET_PDEATHSIG = 1


_PRCTL: Callable[..., int] | bool | None = None


def _prctl() -> Callable[..., int] | None:
    """Return libc's ``prctl`` (Linux), or None.

    Loaded once, so that a child made by ``fork`` calls it without ``dlopen`` (not safe between
    ``fork`` and ``exec``).
    """
    global _PRCTL
    if _PRCTL is None and sys.platform.startswith("linux"):
        import ctypes

        try:
            _PRCTL = ctypes.CDLL(None, use_errno=True).prctl
        except (OSError, AttributeError):  # pragma: no cover - no prctl in this C library
            _PRCTL = False
    return _PRCTL or None


def die_with_parent(parent_pid: int | None = None, sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies (Linux only).

    The same request, parameters and return value as :func:`analysis.workers.die_with_parent`,
    kept here because importing ``analysis`` loads pandas and SciPy, too heavy for a
    ``preexec_fn`` or the presenter. The kernel tracks the parent *thread*: make children from a
    thread that lives as long as they should. For a ``preexec_fn``, call :func:`_prctl` once in
    the parent first.
    """
    prctl = _prctl()
    if prctl is None or prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) != 0:
        return False
    if parent_pid is not None and os.getppid() != parent_pid:
        os.kill(os.getpid(), sig)
    return True


def worker_init(parent_pid: int | None = None) -> None:
    """Initialise a pool worker: die with the parent; ignore SIGINT; default SIGTERM.

    A forked worker inherits :func:`stop_on_signals`' handler, and a terminal's Ctrl-C reaches
    the whole process group; the parent stops its pool itself.
    """
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _forked_child() -> None:
    """Give a child forked by the ``confocal`` command a pool worker's signal settings.

    In a child forked by the ``confocal`` command (its worker pools): a pool worker's signal
    settings from the first instruction, not only once its initializer runs (a Ctrl-C in
    between raised :class:`Stopped` in the child, whose traceback the pool printed).
    """
    if signal.getsignal(signal.SIGTERM) in (_raise_stopped, _after_the_command):
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


if getattr(sys.modules.get("experiment"), "_COMMAND", False) and hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forked_child)
