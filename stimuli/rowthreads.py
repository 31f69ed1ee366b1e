"""Row strips of an image on a pool of threads that lives as long as the process.

The compiled kernels (:mod:`stimuli.kernels`) release the GIL, so threads running them on
different strips of rows work in parallel. Starting a thread pool costs about 0.1 ms, as much as
a whole refocused plane of a small light field, so the pools are made once and kept (a forked
child makes its own).
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TypeVar

import numpy as np

__all__ = [
    "default_workers",
    "run_on_row_strips",
    "run_on_threads",
    "start_on_thread",
    "cores_free",
    "one_blas_thread",
]

T = TypeVar("T")
R = TypeVar("R")

_POOLS: dict[int, ThreadPoolExecutor] = {}
_BLAS: dict = {}
_POOLS_LOCK = threading.Lock()


def _forget_pools_in_child() -> None:
    """Forget the parent's pools in a forked child: it starts its own when needed.

    (Work handed to a pool whose threads stayed in the parent would wait for ever; the kill
    test forks its runs from one warm process.)
    """
    global _POOLS_LOCK
    _POOLS.clear()
    _POOLS_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools_in_child)


def default_workers() -> int:
    """Return the number of threads used by default: the CPUs available to this process, <= 8."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(8, n))


def _pool(n_threads: int) -> ThreadPoolExecutor:
    with _POOLS_LOCK:
        if n_threads not in _POOLS:
            _POOLS[n_threads] = ThreadPoolExecutor(n_threads, thread_name_prefix="confocal-rows")
        return _POOLS[n_threads]


def run_on_row_strips(work: Callable[[int, int], object], rows: int, n_threads: int) -> list:
    """Call ``work(r0, r1)`` on ``n_threads`` even strips of ``range(rows)``; return the results.

    With one thread (or one row) the call runs here, in order. ``work`` must not itself call
    this function (the pool's threads would wait on each other).
    """
    n = max(1, min(int(n_threads), rows))
    if n == 1:
        return [work(0, rows)]
    bounds = np.linspace(0, rows, n + 1).astype(int)
    return run_on_threads(lambda ab: work(*ab), list(zip(bounds[:-1], bounds[1:], strict=True)))


def run_on_threads(work: Callable[[T], R], parts: Sequence[T]) -> list[R]:
    """Return ``[work(p) for p in parts]``, the parts run at once on the pool's threads.

    The calling thread takes the last part itself (one hand-over fewer to wait for); the
    results come in the order of ``parts``. ``work`` must not itself call this function.
    """
    if len(parts) <= 1:
        return [work(p) for p in parts]
    others = [_pool(len(parts) - 1).submit(work, p) for p in parts[:-1]]
    last = work(parts[-1])
    return [f.result() for f in others] + [last]


def cores_free() -> float:
    """Return the CPUs of :func:`default_workers` less the load average of the last minute.

    About how many cores stand idle (negative where more work waits than there are cores;
    :func:`default_workers` where the load is unknown). For work that pays on a second thread
    only where a core is free: on a shared machine, a second thread of ours that has to wait
    for a core delays the first by a whole time slice (measured: a 0.6 ms pass took 3.6 ms).
    """
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # not on Unix
        load = 0.0
    return default_workers() - load


def start_on_thread(work: Callable[[], R]) -> Future:
    """Start ``work()`` on the pool's thread and return its future (``.result()`` waits).

    For work that runs beside the caller's own (the caller then does something else before
    it asks for the result). ``work`` must not itself call :func:`run_on_threads` with more
    than one part (the pool's thread would wait on itself).
    """
    return _pool(1).submit(work)


def one_blas_thread():
    """Context: BLAS runs single-threaded inside (our own threads split the work).

    OpenBLAS would otherwise split each call over its own threads, which then spin after the
    call and slow whatever runs next (measured: a 3 ms Sobel pass took 17 ms after a ``saxpy``).
    """
    if "ctl" not in _BLAS:
        try:
            from threadpoolctl import ThreadpoolController

            _BLAS["ctl"] = ThreadpoolController()
        except ImportError:  # pragma: no cover - declared dependency
            _BLAS["ctl"] = None
    ctl = _BLAS["ctl"]
    return contextlib.nullcontext() if ctl is None else ctl.limit(limits=1, user_api="blas")
