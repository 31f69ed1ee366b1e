"""The numpy twins a small scan runs after its answer equal the compiled loops to the bit."""

from __future__ import annotations

import numpy as np
import pytest

import stimuli.refocus as rf
from stimuli import kernels, numpykernels, shiftadd


@pytest.mark.parametrize(
    "d", [0.0, 1.0, -2.0, 0.757, -0.4, 1.5, 7.3, -9.6]
)  # whole shifts (one tap), fractions, shifts past the whole view (no overlap on some rows)
def test_refocus_in_a_scans_last_steps_equals_the_compiled_pass(d, monkeypatch):
    """The numpy path a scan's last steps take gives the compiled pass's image to the bit."""
    rng = np.random.default_rng(3)
    views = rng.random((3, 5, 13, 17), dtype=np.float32)
    offsets = ([-1.3, 0.0, 1.3], [-2.0, -1.0, 0.0, 1.0, 2.0])  # rows and columns differ
    compiled = rf._refocus_views(views, d, 1, offsets=offsets)
    monkeypatch.setattr(numpykernels, "active", lambda: True)

    def not_in_a_scan(*args):
        raise AssertionError("the compiled refocus ran in a scan's last steps")

    monkeypatch.setattr(shiftadd, "shift_add_rows", not_in_a_scan)
    twin = rf._refocus_views(views, d, 1, offsets=offsets)
    np.testing.assert_array_equal(twin.view(np.uint32), compiled.view(np.uint32))


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (2, 2), (31, 47)])
def test_sobel_equals_the_compiled_loop(shape):
    img = np.random.default_rng(4).random(shape, dtype=np.float32)
    img.flat[0] = 1.5  # one value outside [0, 1]: counted by both
    compiled, twin = np.empty_like(img), np.empty_like(img)
    assert kernels.sobel_rows(img, compiled, 0, shape[0]) == numpykernels.sobel(img, twin) == 1
    np.testing.assert_array_equal(twin.view(np.uint32), compiled.view(np.uint32))


def test_block_mean_in_a_scans_last_steps_equals_the_compiled_counts(monkeypatch):
    from stimuli.compress import block_mean

    edges = np.random.default_rng(5).random((37, 53)) > 0.7
    compiled = block_mean(edges, (3, 4))
    monkeypatch.setattr(numpykernels, "active", lambda: True)

    def not_in_a_scan(*args):
        raise AssertionError("the compiled count ran in a scan's last steps")

    monkeypatch.setattr(kernels, "count_blocks", not_in_a_scan)
    np.testing.assert_array_equal(compiled, block_mean(edges, (3, 4)))


def test_active_only_inside_the_block_and_before_numba_is_loaded():
    assert not numpykernels.active()
    with numpykernels.numpy_kernels():
        assert not numpykernels.active()  # this process has loaded the compiled loops
