"""Refocusing compiled row by row on threads: every grid layout, every overlap at the edges.

The compiled pass makes the numpy-slice path's float32 sums in the same order: equal to the bit.
"""

from __future__ import annotations

import numpy as np
import pytest

import stimuli.refocus as rf
from stimuli.shiftadd import ROW_BLOCK, shift_add_rows


def _assert_same_bits(a, b):
    assert a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))


@pytest.mark.parametrize("grid", [(3, 3), (1, 7), (7, 1), (2, 5), (5, 5), (1, 1)])
@pytest.mark.parametrize("d", [0.0, 1.0, 2.37, -1.6, 0.5])
def test_compiled_rows_on_threads_match_the_slice_path(grid, d, monkeypatch):
    """Strips of rows on three threads give the sum of the numpy-slice path on every layout."""
    views = np.random.default_rng(5).random((*grid, 53, 71)).astype(np.float32)
    monkeypatch.setattr(rf, "_THREAD_MIN_PIXELS", 0)
    fast = rf._refocus_views(views, d, 3)
    monkeypatch.setattr(rf, "_COMPILED", False)
    slow = rf._refocus_views(views, d, 3)
    _assert_same_bits(fast, slow)


@pytest.mark.parametrize("d", [16.5, -16.5, 17.2, -17.7, 17.99, -17.999])
def test_shifts_that_leave_one_column_or_row_of_overlap(d, monkeypatch):
    """Shifts of almost a whole view (one or two columns overlap) keep only the valid taps."""
    views = np.random.default_rng(7).random((3, 3, 19, 19)).astype(np.float32)
    fast = rf._refocus_views(views, d, 1)
    monkeypatch.setattr(rf, "_COMPILED", False)
    slow = rf._refocus_views(views, d, 1)
    _assert_same_bits(fast, slow)


def test_offsets_and_whole_pixel_shifts_match_the_slice_path(monkeypatch):
    """The plane scan's calls (its own view offsets, shifts rounded to whole pixels) agree too."""
    views = np.random.default_rng(8).random((3, 4, 30, 41)).astype(np.float32)
    offsets = ([-2.0, 0.0, 2.0], [-1.5, -0.5, 0.5, 1.5])
    for nearest in (False, True):
        fast = rf._refocus_views(views, 1.3, 2, offsets=offsets, nearest=nearest)
        monkeypatch.setattr(rf, "_COMPILED", False)
        slow = rf._refocus_views(views, 1.3, 2, offsets=offsets, nearest=nearest)
        monkeypatch.setattr(rf, "_COMPILED", True)
        _assert_same_bits(fast, slow)


def _direct(views, row_shifts, col_shifts):
    """Float64 reference: every view shifted by its own bilinear weights, summed, normalised."""
    n_u, n_v, rows, cols = views.shape
    acc = np.zeros((rows, cols))
    weight = np.zeros((rows, cols))
    ys, xs = np.arange(rows)[:, None], np.arange(cols)[None, :]
    for u in range(n_u):
        for v in range(n_v):
            for m, a in rf.shift_weights(row_shifts[u]):
                for k, b in rf.shift_weights(col_shifts[v]):
                    sy, sx = ys - m + 0 * xs, xs - k + 0 * ys
                    inside = (sy >= 0) & (sy < rows) & (sx >= 0) & (sx < cols)
                    acc[inside] += a * b * views[u, v][sy[inside], sx[inside]]
                    weight[inside] += a * b
    return np.clip(np.divide(acc, weight, out=np.zeros_like(acc), where=weight > 1e-9), 0, 1)


def test_random_grids_shifts_and_strips_match_both_references():
    """Random grids (1-9 views a side), sizes, shifts and row strips (across the block size):
    the compiled pass equals the numpy-slice path to the bit and a direct float64 sum to float32
    rounding."""
    rng = np.random.default_rng(11)
    for _ in range(40):
        n_u, n_v = (int(n) for n in rng.integers(1, 10, 2))
        rows = int(rng.integers(1, 2 * ROW_BLOCK + 5))
        cols = int(rng.integers(1, 40))
        views = rng.random((n_u, n_v, rows, cols), dtype=np.float32)
        d = float(rng.uniform(-1, 1) * rng.choice([0.6, 3.0, 12.0]))
        d = float(round(d)) if rng.random() < 0.2 else d
        offsets = ([u - n_u // 2 for u in range(n_u)], [v - n_v // 2 for v in range(n_v)])
        row_shifts = [d * du for du in offsets[0]]
        col_shifts = [d * dv for dv in offsets[1]]
        out = np.full((rows, cols), np.nan, np.float32)
        shifts = (np.array(row_shifts), np.array(col_shifts))
        cuts = sorted({0, rows, *(int(c) for c in rng.integers(0, rows + 1, 2))})
        for r0, r1 in zip(cuts[:-1], cuts[1:], strict=True):
            shift_add_rows(views, *shifts, out, r0, r1)
        rf._COMPILED = False
        try:
            slow = rf._refocus_views(views, d, 1, offsets=offsets)
        finally:
            rf._COMPILED = True
        _assert_same_bits(out, slow)
        np.testing.assert_allclose(out, _direct(views, row_shifts, col_shifts), atol=2e-6)
