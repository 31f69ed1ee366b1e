"""Refocusing made in blocks of rows on threads: every grid layout, every block boundary."""

from __future__ import annotations

import numpy as np
import pytest

import stimuli.refocus as rf


@pytest.mark.parametrize("grid", [(3, 3), (1, 7), (7, 1), (2, 5), (5, 5)])
@pytest.mark.parametrize("d", [0.0, 1.0, 2.37, -1.6])
def test_blocks_and_threads_match_the_slice_path(grid, d, monkeypatch):
    """Many small blocks split over threads give the one sum of the numpy-slice path."""
    views = np.random.default_rng(5).random((*grid, 53, 71)).astype(np.float32)
    monkeypatch.setattr(rf, "_THREAD_MIN_PIXELS", 0)
    monkeypatch.setattr(rf, "_BLOCK_BYTES", 1)  # the smallest block: 8 rows
    fast = rf._refocus_views(views, d, 3)
    monkeypatch.setattr(rf, "_saxpy", None)
    slow = rf._refocus_views(views, d, 3)
    np.testing.assert_allclose(fast, slow, atol=2e-6)


def test_one_view_row_reads_each_view_once_per_tap(monkeypatch):
    """A 1xN grid has no pass along its single-view axis: one saxpy per column tap and block."""
    views = np.random.default_rng(6).random((1, 7, 40, 60)).astype(np.float32)
    calls = []
    real = rf._saxpy

    def counting(*args, **kwargs):
        calls.append(kwargs.get("n"))
        return real(*args, **kwargs)

    monkeypatch.setattr(rf, "_saxpy", counting)
    rf._refocus_views(views, 0.6, 1)
    taps = sum(len(rf._shift_weights(0.6 * (v - 3))) for v in range(7))
    assert len(calls) == taps
