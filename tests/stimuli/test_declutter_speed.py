"""De-clutter and compress compiled: the Sobel kernel on threaded strips and the whole-count
windows give the same answer, to the bit, as scikit-image and numpy."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.filters import sobel

import stimuli.declutter as dc
import stimuli.rowthreads as rt
from stimuli.compress import block_mean, compress
from stimuli.errors import InputError


@pytest.mark.parametrize("shape", [(200, 150), (131, 257), (64, 90)])
def test_sobel_strips_on_threads_equal_the_whole_image(shape, monkeypatch):
    rng = np.random.default_rng(8)
    img = rng.random(shape).astype(np.float32)
    img[::7] = 0.0  # flat rows and steps across the strip boundaries
    img[:, ::5] = 1.0
    monkeypatch.setattr(dc, "_THREAD_MIN_PIXELS", 0)
    monkeypatch.setattr(dc, "_STRIP_MIN_ROWS", 8)
    monkeypatch.setattr(rt, "default_workers", lambda: 3)
    np.testing.assert_array_equal(dc.sobel_magnitude(img), sobel(img).astype(np.float32))


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (2, 2), (3, 7), (47, 33)])
def test_sobel_equals_scikit_image_on_small_and_thin_images(shape):
    """Borders reflected as ``scipy.ndimage`` does, for every size down to one pixel."""
    img = np.random.default_rng(3).random(shape).astype(np.float32)
    np.testing.assert_array_equal(dc.sobel_magnitude(img), sobel(img).astype(np.float32))


def test_sobel_of_bool_and_float64_images_is_that_of_their_float32_copy():
    rng = np.random.default_rng(4)
    on = rng.random((40, 50)) < 0.3
    np.testing.assert_array_equal(dc.sobel_magnitude(on), sobel(on.astype(np.float32)))
    grey = rng.random((40, 50))
    np.testing.assert_array_equal(dc.sobel_magnitude(grey), sobel(grey.astype(np.float32)))


@pytest.mark.parametrize(
    ("bad", "message"), [(np.nan, "NaN"), (1.5, r"\[0, 1\]"), (-0.2, r"\[0, 1\]")]
)
def test_sobel_refuses_values_outside_0_1_found_in_the_same_pass(bad, message, monkeypatch):
    monkeypatch.setattr(dc, "_THREAD_MIN_PIXELS", 0)
    monkeypatch.setattr(dc, "_STRIP_MIN_ROWS", 8)
    img = np.random.default_rng(5).random((80, 60)).astype(np.float32)
    img[71, 3] = bad  # in the last strip
    with pytest.raises(InputError, match=message):
        dc.sobel_magnitude(img)


@pytest.mark.parametrize(("shape", "grid"), [((1024, 1024), (79, 79)), ((327, 492), (25, 38))])
def test_bool_windows_count_exactly(shape, grid):
    edges = np.random.default_rng(9).random(shape) < 0.08
    as_float = block_mean(edges.astype(np.float64), grid)
    np.testing.assert_array_equal(block_mean(edges, grid), as_float)
    np.testing.assert_array_equal(
        compress(edges, grid, edge_ratio=1 / 13), as_float > np.float32(1 / 13)
    )
