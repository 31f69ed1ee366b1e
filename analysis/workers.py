"""Worker processes that die with their parent and leave stop signals to it.

A ``confocal`` command killed with SIGKILL (the OOM killer, ``kill -9``, a batch system's hard
limit) runs no ``finally:`` block, so it cannot stop its pool. On Linux the kernel can do it:
``prctl(PR_SET_PDEATHSIG, SIGKILL)`` in the child asks for a SIGKILL when the parent dies.
Process pools pass :func:`worker_init` as their initializer, and a ``subprocess.Popen`` passes
:func:`die_with_parent` (through ``preexec_fn``).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from typing import Any

__all__ = ["die_with_parent", "stop_pool", "worker_init"]

#: ``PR_SET_PDEATHSIG`` from ``<linux/prctl.h>``: deliver a signal when the parent thread exits.
_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int | None = None, sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies (Linux only).

    Call it at the start of a child process. The kernel tracks the parent *thread* that made
    the child, so make children from a thread that lives as long as they should.

    Parameters
    ----------
    parent_pid : int or None
        The parent's process id as the parent saw it before starting the child; when the
        child's parent is already another process (the parent died before the request), the
        child sends ``sig`` to itself.
    sig : int
        The signal to receive.

    Returns
    -------
    bool
        True where the request was made (Linux with a C library), False elsewhere.
    """
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(_PR_SET_PDEATHSIG, int(sig), 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):  # pragma: no cover - no prctl in this C library
        return False
    if parent_pid is not None and os.getppid() != parent_pid:
        os.kill(os.getpid(), sig)
    return True


def worker_init(parent_pid: int | None = None) -> None:
    """Initialise a pool worker: die with the parent; ignore SIGINT; default SIGTERM.

    A terminal's Ctrl-C reaches the whole process group. The parent stops (and shuts down)
    its pool itself, so a worker must not raise its own ``KeyboardInterrupt`` and print a
    traceback; a SIGTERM sent to the worker alone still ends it.

    Parameters
    ----------
    parent_pid : int or None
        ``os.getpid()`` of the process that makes the pool (see :func:`die_with_parent`).
    """
    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def stop_pool(executor: Any) -> None:
    """End a :class:`concurrent.futures.ProcessPoolExecutor` now: its workers, then the pool.

    For a stop signal or a failure, when no result of the pool will be kept: the workers get
    SIGTERM (:func:`worker_init` leaves its default action), the tasks not started are
    dropped and the workers are reaped, so none writes after this returns and the caller may
    remove what they were writing into. Waiting for tasks in flight instead (``shutdown``)
    kept a stopped command running until they ended (24 s for the figures on a busy machine).

    Parameters
    ----------
    executor : concurrent.futures.ProcessPoolExecutor
    """
    for proc in list((getattr(executor, "_processes", None) or {}).values()):
        with contextlib.suppress(OSError, AttributeError):
            proc.terminate()
    executor.shutdown(wait=True, cancel_futures=True)
