"""The depth de-clutter's lean edge passes against the numpy chain they replace, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.edgedepth import MIN_CONFIDENCE, _confidence, _edge_classes, _sobel_pair
from stimuli.otsu import otsu_threshold


def _images(seed):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(6, 60)), int(rng.integers(6, 60)))
    busy = rng.random(shape).astype(np.float32)
    steps = np.full(shape, 0.2, np.float32)
    steps[shape[0] // 2 :, :] = 0.8  # a horizontal edge, a vertical one and flat patches
    steps[:, : shape[1] // 3] = 0.5
    grey = (rng.integers(0, 256, shape) / 255).astype(np.float32)
    return [busy, steps, grey, busy * (rng.random(shape) < 0.2), np.zeros(shape, np.float32)]


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("axis", [0, 1])
def test_edge_classes_are_the_numpy_chains(seed, axis):
    """Edge pixels (magnitude above half Otsu's threshold) split by confidence below the
    minimum: the numpy chain from scipy's Sobel pair (``np.hypot``, box means, ``np.where``)
    gives the same pixels and counts as the two compiled passes."""
    for img in _images(seed):
        grads = _sobel_pair(img)
        mag = np.hypot(*grads)
        got = _edge_classes(img, axis)
        if mag.max() <= 0:
            assert got is None
            continue
        conf = _confidence(grads, (axis,))
        edges = mag > 0.5 * otsu_threshold(mag, compiled=False)
        low_all = (conf < MIN_CONFIDENCE) & (mag > 0)
        low, measured, n = got
        assert np.array_equal(low, edges & low_all)
        assert np.array_equal(measured, edges & ~low_all)
        assert n == int(edges.sum())


def test_energy_pass_gives_the_magnitude_and_its_extrema():
    """The first pass's magnitude is ``np.hypot`` of scipy's Sobel pair and its squares the
    gradients' squares; the extrema it returns are the magnitude's."""
    from stimuli.edgefield import edge_energy

    for img in _images(7):
        gy, gx = _sobel_pair(img)
        mag, e0, e1 = (np.empty_like(img) for _ in range(3))
        lo, hi = edge_energy(img, mag, e0, e1)
        assert np.array_equal(mag, np.hypot(gy, gx))
        assert np.array_equal(e0, gy * gy) and np.array_equal(e1, gx * gx)
        assert (lo, hi) == (mag.min(), mag.max())
