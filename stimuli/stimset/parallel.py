"""Run one step over every object, reporting progress (build and tune).

On a thread pool, or on worker processes / a Dask cluster (:class:`stimuli.lfbatch.CapturePool`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import closing
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from stimuli.lfbatch import CapturePool

__all__ = ["ProgressFn", "thread_count", "map_objects", "map_on_pool"]

#: ``progress(stage, done, total)``: called with 0 done before the first object, then after each.
ProgressFn = Callable[[str, int, int], None]

#: Threads used when the caller gives none (ours: reading and writing PNGs stops gaining
#: beyond about eight threads).
_MAX_DEFAULT_THREADS = 8

_In = TypeVar("_In")
_Out = TypeVar("_Out")


def thread_count(workers: int | None) -> int:
    """Return the threads to use: ``workers`` (at least 1), or the CPUs (at most 8) if ``None``."""
    if workers is None:
        return min(_MAX_DEFAULT_THREADS, os.cpu_count() or 1)
    return max(1, int(workers))


def map_objects(
    fn: Callable[[_In], _Out],
    items: Sequence[_In],
    workers: int,
    progress: ProgressFn | None,
    stage: str,
) -> list[_Out]:
    """Apply ``fn`` to every item, on ``workers`` threads, and return the results in order.

    Parameters
    ----------
    fn : callable
        One object's step.
    items : sequence
    workers : int >= 1
        Threads; 1 runs in the calling thread.
    progress : callable(stage, done, total), optional
        Told ``(stage, 0, n)`` first, then ``(stage, i, n)`` as the i-th result (in order) is in.
    stage : str
        Name of the step, passed to ``progress``.

    Returns
    -------
    list
        ``[fn(item) for item in items]``; the first exception raised by ``fn`` propagates.
    """
    total = len(items)
    if progress:
        progress(stage, 0, total)
    results = []
    if workers <= 1:
        for i, it in enumerate(items):
            results.append(fn(it))
            if progress:
                progress(stage, i + 1, total)
        return results
    with ThreadPoolExecutor(max_workers=workers) as ex:
        futures = [ex.submit(fn, it) for it in items]
        try:
            for i, fut in enumerate(futures):
                results.append(fut.result())
                if progress:
                    progress(stage, i + 1, total)
        except BaseException:
            # Stopped (a signal) or failed: drop the objects not started, so the caller's
            # cleanup of the temporary folder waits only for the ones being written.
            ex.shutdown(wait=True, cancel_futures=True)
            raise
    return results


def map_on_pool(
    pool: CapturePool,
    fn: Callable[..., Any],
    tasks: Sequence[tuple],
    progress: ProgressFn | None,
    stage: str,
    *,
    then: Callable[[int, Any], _Out] | None = None,
) -> list:
    """Run ``fn(*task)`` for every task on ``pool`` and return the results in task order.

    Parameters
    ----------
    pool : CapturePool
        Where the tasks run (``fn`` must be a module-level function).
    fn : callable
        One object's step.
    tasks : sequence of tuple
        Each object's arguments, in object order.
    progress : callable(stage, done, total), optional
        Told ``(stage, 0, n)`` first, then ``(stage, k, n)`` as the k-th object finishes (in
        whatever order they finish).
    stage : str
        Name of the step, passed to ``progress``.
    then : callable(index, result), optional
        Run here, in this process, on each result as it comes back (e.g. writing its files);
        its return value is kept instead of the result.

    Returns
    -------
    list
        One entry per task, in task order; the first exception raised propagates.
    """
    total = len(tasks)
    if progress:
        progress(stage, 0, total)
    results: list = [None] * total
    # closing: a failure here (in ``then``) stops the pool's other tasks before it propagates
    with closing(pool.imap(fn, tasks)) as finished:
        for done, (i, result) in enumerate(finished, start=1):
            results[i] = then(i, result) if then is not None else result
            if progress:
                progress(stage, done, total)
    return results
