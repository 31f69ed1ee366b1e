"""Strips of one job taken by the pool's thread and the caller: each part once, errors raised
to the caller, and no wait for a pool thread that is busy with other work."""

from __future__ import annotations

import threading

import pytest

from stimuli.rowthreads import start_on_thread
from stimuli.sharedstrips import SharedStrips


def test_each_part_runs_once_on_either_thread():
    seen, names = [], set()

    def work(part):
        seen.append(part)
        names.add(threading.current_thread().name)

    job = SharedStrips(work, range(50))
    job.start()
    job.finish()
    assert sorted(seen) == list(range(50))


def test_an_error_on_the_pool_thread_is_raised_by_finish():
    def work(part):
        if part == 0:
            raise ValueError("bad strip")

    job = SharedStrips(work, [0])
    job.start()
    with pytest.raises(ValueError, match="bad strip"):
        job.finish()


def test_a_busy_pool_thread_is_not_waited_for():
    """The pool's one thread held by other work: the caller takes every part and returns
    without waiting for it (the cancelled start never runs)."""
    release = threading.Event()
    blocker = start_on_thread(release.wait)  # the pool's thread busy
    try:
        done = []
        job = SharedStrips(done.append, range(5))
        job.start()
        finisher = threading.Thread(target=job.finish)
        finisher.start()
        finisher.join(timeout=5)
        assert not finisher.is_alive() and done == list(range(5))
    finally:
        release.set()
        blocker.result(timeout=5)
