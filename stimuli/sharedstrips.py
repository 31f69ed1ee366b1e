"""Work split into strips that a second thread starts on and the caller joins when it is free.

:class:`SharedStrips` hands out its parts one at a time, under a lock, to whichever thread asks
next: the pool's thread starts on them at once (:meth:`SharedStrips.start`), and the caller,
after its own work, takes the parts still left (:meth:`SharedStrips.finish`) and waits for the
part the other thread is on (not for a thread that never began: callers on several threads of
their own, a parallel build, share the pool's one thread). Each part runs once, on one thread;
the results are whatever the parts write (disjoint strips of rows of one image, in the depth
de-clutter).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Generic, TypeVar

__all__ = ["SharedStrips"]

T = TypeVar("T")


class SharedStrips(Generic[T]):
    """Parts of one job taken, one at a time, by a pool thread and by the caller.

    Parameters
    ----------
    work : callable
        ``work(part)``, run once per part, on whichever thread takes it; it must not itself
        call :func:`stimuli.rowthreads.run_on_threads` with more than one part.
    parts : sequence
        The parts, taken in order.

    Examples
    --------
    >>> done = []
    >>> job = SharedStrips(done.append, range(5))
    >>> job.start()
    >>> job.finish()
    >>> sorted(done)
    [0, 1, 2, 3, 4]
    """

    def __init__(self, work: Callable[[T], object], parts: Sequence[T]) -> None:
        self._work = work
        self._parts = list(parts)
        self._next = 0
        self._lock = threading.Lock()
        self._started = None

    def _take(self) -> None:
        while True:
            with self._lock:
                if self._next >= len(self._parts):
                    return
                part = self._parts[self._next]
                self._next += 1
            self._work(part)

    def start(self) -> None:
        """Start taking parts on the pool's thread (:func:`stimuli.rowthreads.start_on_thread`)."""
        from stimuli.rowthreads import start_on_thread

        if self._started is None:
            self._started = start_on_thread(self._take)

    def finish(self) -> None:
        """Take the parts left here, then wait for the other thread's (its error raised here).

        Where the pool's thread has not begun (busy with other work), it is not waited for:
        its start is cancelled, the parts being all taken here.
        """
        try:
            self._take()
        finally:
            if self._started is not None and not self._started.cancel():
                self._started.result()
