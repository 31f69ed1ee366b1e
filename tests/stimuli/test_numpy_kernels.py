"""The numpy twins a small scan runs after its answer equal the compiled loops to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli import kernels, numpykernels
from stimuli.refocus import _inverse_weights, _tap_arrays


@pytest.mark.parametrize(
    "d", [0.0, 1.0, -2.0, 0.757, -0.4, 1.5, 7.3, -9.6]
)  # whole shifts (one tap), fractions, shifts past the whole view (no overlap on some rows)
def test_shift_add_equals_the_compiled_loop(d):
    rng = np.random.default_rng(3)
    views = rng.random((3, 5, 13, 17), dtype=np.float32)
    row_shifts = [d * (u - 1) * 1.3 for u in range(3)]  # rows and columns shift differently
    col_shifts = [d * (v - 2) for v in range(5)]
    taps_r, taps_c = _tap_arrays(row_shifts), _tap_arrays(col_shifts)
    inv_r, inv_c = _inverse_weights(13, row_shifts), _inverse_weights(17, col_shifts)
    compiled = np.empty((13, 17), np.float32)
    kernels.shift_add_rows(views, *taps_r, *taps_c, inv_r, inv_c, compiled, 0, 13)
    twin = numpykernels.shift_add(views, taps_r, taps_c, inv_r, inv_c, np.empty_like(compiled))
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
