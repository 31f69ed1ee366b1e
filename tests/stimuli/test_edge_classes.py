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


def _segment_masks(rng, shape):
    """Unmeasured edges (horizontal bars) and measured ones (vertical bars) that cross, touch
    and run off the frame, or random pixels split at random."""
    if rng.random() < 0.5:
        edges = rng.random(shape) < rng.uniform(0.05, 0.6)
        low = edges & (rng.random(shape) < 0.5)
        return low, edges & ~low
    low, measured = np.zeros(shape, bool), np.zeros(shape, bool)
    for _ in range(int(rng.integers(1, 12))):
        y, x, n = rng.integers(0, shape[0]), rng.integers(0, shape[1]), rng.integers(2, 40)
        if rng.random() < 0.5:
            low[y : y + 2, x : x + n] = True
        else:
            measured[y : y + n, x : x + 2] = True
    return low, measured & ~low


def test_compiled_segment_vote_is_the_filter_chain():
    """The segment vote in the lean compiled passes (junctions from running counts, labels
    with their boxes in one call, junction pixels settled from the labels around them) gives
    the kept and dropped masks and the verdict of the chain of scipy-equivalent filters, on
    random and bar-shaped edges, some images a few pixels wide."""
    from stimuli.edgedepth import _vote

    rng = np.random.default_rng(11)
    for _ in range(120):
        shape = (int(rng.integers(1, 50)), int(rng.integers(1, 70)))
        low, measured = _segment_masks(rng, shape)
        focus = rng.random(shape) < 0.5
        asked = []

        def at(pixels, focus=focus, asked=asked):
            asked.append(pixels.copy())
            return focus

        want = _vote(low, measured, at, compiled=False)
        got = _vote(low, measured, at, compiled=True)
        for w, g in zip(want, got, strict=True):
            assert g.dtype == bool and np.array_equal(w, g)
        assert np.array_equal(asked[0], asked[1])  # the views asked at the same pixels


def test_labels_with_boxes_are_scipys():
    """Labels (8-connected) numbered as ``scipy.ndimage.label`` and boxes as ``find_objects``."""
    from scipy import ndimage

    from stimuli.edgevote import label8_extents

    rng = np.random.default_rng(12)
    for _ in range(60):
        shape = (int(rng.integers(1, 40)), int(rng.integers(1, 40)))
        mask = rng.random(shape) < rng.uniform(0.1, 0.7)
        want, n = ndimage.label(mask, np.ones((3, 3)))
        out = np.empty(shape, np.int32)
        count, top, bottom, left, right = label8_extents(mask.view(np.uint8), out)
        assert count == n and np.array_equal(out, want)
        boxes = ndimage.find_objects(want)
        assert [
            (int(t), int(b) + 1, int(lf), int(r) + 1)
            for t, b, lf, r in zip(top, bottom, left, right, strict=True)
        ] == [(s[0].start, s[0].stop, s[1].start, s[1].stop) for s in boxes]
