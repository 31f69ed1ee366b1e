"""Row strips on the process's thread pool: order, the calling thread's share, and fork."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

from stimuli.rowthreads import run_on_row_strips, run_on_threads


def test_strips_cover_the_rows_in_order_and_the_caller_takes_the_last():
    seen = []

    def work(r0, r1):
        seen.append((r0, r1, threading.current_thread() is threading.main_thread()))
        return r1 - r0

    assert run_on_row_strips(work, 10, 3) == [3, 3, 4]
    assert sorted((a, b) for a, b, _ in seen) == [(0, 3), (3, 6), (6, 10)]
    assert [main for a, _, main in seen if a == 6] == [True]
    assert run_on_threads(lambda x: x * x, [1, 2, 3]) == [1, 4, 9]


def test_errors_in_a_strip_reach_the_caller():
    def work(r0, r1):
        if r0 == 0:
            raise ValueError("strip 0")
        return r0

    with pytest.raises(ValueError, match="strip 0"):
        run_on_row_strips(work, 8, 2)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_a_forked_child_runs_strips_on_its_own_threads():
    """The pool's threads stay in the parent: a child that used them would wait for ever."""
    run_on_row_strips(lambda a, b: np.arange(a, b).sum(), 100, 2)  # the parent's pool exists
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        try:
            ok = run_on_row_strips(lambda a, b: b - a, 100, 2) == [50, 50]
        finally:
            os._exit(0 if ok else 1)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            return
        time.sleep(0.05)
    os.kill(pid, 9)
    os.waitpid(pid, 0)
    pytest.fail("the forked child hung on the parent's thread pool")
