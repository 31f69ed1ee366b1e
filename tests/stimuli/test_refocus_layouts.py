"""Refocusing compiled row by row on threads: every grid layout, every overlap at the edges."""

from __future__ import annotations

import numpy as np
import pytest

import stimuli.refocus as rf


@pytest.mark.parametrize("grid", [(3, 3), (1, 7), (7, 1), (2, 5), (5, 5), (1, 1)])
@pytest.mark.parametrize("d", [0.0, 1.0, 2.37, -1.6, 0.5])
def test_compiled_rows_on_threads_match_the_slice_path(grid, d, monkeypatch):
    """Strips of rows on three threads give the sum of the numpy-slice path on every layout."""
    views = np.random.default_rng(5).random((*grid, 53, 71)).astype(np.float32)
    monkeypatch.setattr(rf, "_THREAD_MIN_PIXELS", 0)
    fast = rf._refocus_views(views, d, 3)
    monkeypatch.setattr(rf, "_COMPILED", False)
    slow = rf._refocus_views(views, d, 3)
    np.testing.assert_allclose(fast, slow, atol=5e-7)


@pytest.mark.parametrize("d", [16.5, -16.5, 17.2, -17.7, 17.99, -17.999])
def test_shifts_that_leave_one_column_or_row_of_overlap(d, monkeypatch):
    """Shifts of almost a whole view (one or two columns overlap) keep only the valid taps."""
    views = np.random.default_rng(7).random((3, 3, 19, 19)).astype(np.float32)
    fast = rf._refocus_views(views, d, 1)
    monkeypatch.setattr(rf, "_COMPILED", False)
    slow = rf._refocus_views(views, d, 1)
    np.testing.assert_allclose(fast, slow, atol=5e-7)


def test_offsets_and_whole_pixel_shifts_match_the_slice_path(monkeypatch):
    """The plane scan's calls (its own view offsets, shifts rounded to whole pixels) agree too."""
    views = np.random.default_rng(8).random((3, 4, 30, 41)).astype(np.float32)
    offsets = ([-2.0, 0.0, 2.0], [-1.5, -0.5, 0.5, 1.5])
    for nearest in (False, True):
        fast = rf._refocus_views(views, 1.3, 2, offsets=offsets, nearest=nearest)
        monkeypatch.setattr(rf, "_COMPILED", False)
        slow = rf._refocus_views(views, 1.3, 2, offsets=offsets, nearest=nearest)
        monkeypatch.setattr(rf, "_COMPILED", True)
        np.testing.assert_allclose(fast, slow, atol=5e-7)
