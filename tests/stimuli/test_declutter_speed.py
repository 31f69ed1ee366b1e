"""De-clutter and compress on large images: threaded Sobel strips and whole-count windows give
the same answer, to the bit, as the one-piece computation."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.filters import sobel

import stimuli.declutter as dc
from stimuli.compress import block_mean, compress


@pytest.mark.parametrize("shape", [(200, 150), (131, 257), (64, 90)])
def test_sobel_strips_on_threads_equal_the_whole_image(shape, monkeypatch):
    rng = np.random.default_rng(8)
    img = rng.random(shape).astype(np.float32)
    img[::7] = 0.0  # flat rows and steps across the strip boundaries
    img[:, ::5] = 1.0
    monkeypatch.setattr(dc, "_THREAD_MIN_PIXELS", 0)
    monkeypatch.setattr(dc, "_STRIP_MIN_ROWS", 8)
    monkeypatch.setattr(dc, "_sobel_workers", lambda: 3)
    np.testing.assert_array_equal(dc.sobel_magnitude(img), sobel(img).astype(np.float32))


@pytest.mark.parametrize(("shape", "grid"), [((1024, 1024), (79, 79)), ((327, 492), (25, 38))])
def test_bool_windows_count_exactly(shape, grid):
    edges = np.random.default_rng(9).random(shape) < 0.08
    as_float = block_mean(edges.astype(np.float64), grid)
    np.testing.assert_array_equal(block_mean(edges, grid), as_float)
    np.testing.assert_array_equal(
        compress(edges, grid, edge_ratio=1 / 13), as_float > np.float32(1 / 13)
    )
