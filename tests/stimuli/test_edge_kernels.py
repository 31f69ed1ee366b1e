"""The depth de-clutter's fused compiled passes against their numpy twins, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.declutter import sobel_magnitude
from stimuli.otsu import otsu_threshold


def _images(seed):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(6, 90)), int(rng.integers(6, 90)))
    busy = rng.random(shape).astype(np.float32)
    steps = np.zeros(shape, np.float32)
    steps[shape[0] // 2 :, :] = 0.8  # a horizontal edge, a vertical one, and a flat patch
    steps[:, : shape[1] // 3] = 0.3
    grey = (rng.integers(0, 256, shape) / 255).astype(np.float32)
    return [busy, steps, grey, busy * (rng.random(shape) < 0.2)]


@pytest.mark.parametrize("seed", range(4))
def test_otsu_is_scikit_images(seed):
    """Random, stepped, 8-bit and sparse images and their Sobel magnitudes: the threshold of
    scikit-image's ``threshold_otsu`` (256 bins) to the bit, compiled histogram or numpy's."""
    from skimage.filters import threshold_otsu

    for img in _images(seed):
        for a in (img, sobel_magnitude(img), np.float32(img * 1e-3)):
            want = float(threshold_otsu(a, nbins=256))
            assert otsu_threshold(a) == want
            assert otsu_threshold(a, compiled=False) == want
    assert otsu_threshold(np.full((4, 5), 0.25, np.float32)) == 0.25


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("axis", [0, 1])
def test_fused_edge_field_is_the_numpy_chain(seed, axis):
    """The Sobel magnitude and edge-direction confidence of one compiled call equal ``np.hypot``
    of the Sobel pair and the box-filtered gradient energies, to the bit."""
    from stimuli.edgedepth import _confidence, _edge_field, _sobel_pair

    for img in _images(seed):
        mag, conf = _edge_field(img, (axis,))
        grads = _sobel_pair(img)
        assert np.array_equal(mag, np.hypot(*grads))
        assert np.array_equal(conf, _confidence(grads, (axis,)))


def test_depth_declutter_reuses_the_callers_edges():
    """Passing the Sobel edges the caller made gives the same depth edges as making them again;
    edges of the wrong shape or type are refused."""
    from stimuli.declutter import declutter, declutter_depth
    from stimuli.errors import InputError

    for img in _images(5):
        focus = np.random.default_rng(1).integers(0, 3, img.shape).astype(np.uint8)
        edges = declutter(img, threshold=0.1)
        want = declutter_depth(img, focus, threshold=0.1)
        assert np.array_equal(declutter_depth(img, focus, threshold=0.1, edges=edges), want)
    with pytest.raises(InputError, match="edges"):
        declutter_depth(img, focus, threshold=0.1, edges=edges[1:])


@pytest.mark.parametrize("seed", range(3))
def test_compiled_labels_are_scipys(seed):
    """8-connected components of random masks of every density (and empty, full, one-row and
    one-column masks): scipy's labels and count, numbering included, to the bit."""
    from scipy import ndimage

    from stimuli.edgedepth import _label8

    rng = np.random.default_rng(seed)
    masks = [np.zeros((3, 4), bool), np.ones((5, 2), bool), rng.random((1, 40)) < 0.5]
    masks += [rng.random((40, 1)) < 0.5]
    masks += [rng.random((60, 70)) < p for p in (0.05, 0.3, 0.6, 0.9)]
    for m in masks:
        want, n = ndimage.label(m, np.ones((3, 3), bool))
        got, k = _label8(m)
        assert k == n and got.dtype == want.dtype and np.array_equal(got, want)
