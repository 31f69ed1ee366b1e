"""Depth de-cluttering from a light field against the paper's Sobel mode.

Measure: at the 38x25 grid, the fraction of white cells outside the object, and
how many of the object's cells stay white. A cell is *outside* when no object pixel falls in
it and *on the object* when at least a quarter of its pixels are object pixels. Both modes use
the same confocal image, the same Otsu threshold and the paper's edge ratio 1/13. Done when the
depth mode removes at least half of what the Sobel mode leaves outside while keeping >= 80 % of
the object cells the Sobel mode has.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import binary_closing
from skimage.filters import threshold_otsu

from stimuli.compress import block_mean, compress
from stimuli.declutter import auto_threshold, declutter, declutter_depth, in_focus_mask
from stimuli.errors import InputError
from stimuli.io import load_gray
from stimuli.lfsynth import layer_masks, render_camera_array, three_plane_scene
from stimuli.lightfield import LightField, load_lightfield
from stimuli.refocus import refocus
from tests.conftest import require_data

GRID = (25, 38)
EDGE_RATIO = 1.0 / 13.0


def _cells(edges, obj):
    white = compress(edges, GRID, edge_ratio=EDGE_RATIO)
    share = block_mean(obj, GRID)
    outside, on = share == 0, share >= 0.25
    return float(white[outside].mean()), int(white[on].sum())


def _compare(lf, d, obj):
    img = refocus(lf, d)
    t = auto_threshold(img)
    sobel = declutter(img, threshold=t)
    depth = declutter_depth(img, in_focus_mask(lf, d), threshold=t)
    assert not (depth & ~sobel).any()  # the depth mode only removes Sobel edges
    return _cells(sobel, obj), _cells(depth, obj)


def _check(name, sobel, depth):
    print(
        f"{name}: outside white {sobel[0]:.3f} -> {depth[0]:.3f}; object {sobel[1]} -> {depth[1]}"
    )
    assert sobel[0] > 0.02  # there is clutter to remove (else the test could not fail)
    assert depth[0] <= 0.5 * sobel[0]
    assert depth[1] >= 0.8 * sobel[1]


def test_three_plane_scene_one_row_of_views():
    """Simulated (Fig. 10 scene, 1x7 camera array, 30 mm baseline): focused on the tree, the
    pedestrian and building become horizontal ghost copies that survive Sobel. Measured:
    outside 0.258 -> 0.087, object cells 125 -> 125."""
    layers = three_plane_scene((327, 492))
    lf = render_camera_array(layers, grid=(1, 7), shape_px=(327, 492), baseline_m=0.03)
    obj = layer_masks(layers, (327, 492))["tree"]
    _check("three-plane tree", *_compare(lf, lf.geometry.disparity_px(4.0), obj))


@pytest.mark.data
def test_baby1_doll(data_dir):
    """Middlebury Baby1 at the doll's plane (median ground truth, 12.5 px per view step). The
    doll: Otsu foreground of ``disp1`` above the pedestal (as test_lf_real.py), moved from view 1
    to the centre view 3 by its own disparity (``x - 2 d``). Measured: outside 0.499 -> 0.127,
    object cells 109 -> 103."""
    root = require_data(data_dir, "lightfield", "middlebury_Baby1")
    disp = load_gray(require_data(root, "disp1.png")) * 255.0 / 8.0
    known = disp > 0
    fg = known & (disp > threshold_otsu(disp[known]))
    fg[int(np.argmax(fg.mean(axis=1) > 0.5)) :] = False
    ys, xs = np.nonzero(fg)
    obj = np.zeros_like(fg)
    obj[ys, np.clip(np.round(xs - 2 * disp[ys, xs]).astype(int), 0, fg.shape[1] - 1)] = True
    obj = binary_closing(obj, iterations=2)
    d = float(np.median(disp[fg]))
    lf = load_lightfield(root, gray=True)
    _check("Baby1 doll", *_compare(lf, d, obj))


def test_in_focus_mask_of_a_shifted_texture():
    """Analytic: views of one texture at disparity 2 agree at 2 and not at -2."""
    rng = np.random.default_rng(0)
    tex = rng.random((60, 90)).astype(np.float32)
    views = np.stack([np.roll(tex, -2 * (v - 2), axis=1) for v in range(5)])[None]
    lf = LightField(views)
    inner = np.s_[5:-5, 12:-12]
    assert in_focus_mask(lf, 2.0, tolerance_px=0)[inner].mean() > 0.99
    assert in_focus_mask(lf, -2.0, tolerance_px=0.5)[inner].mean() < 0.25  # chance matches
    with pytest.raises(InputError, match="tolerance_px"):
        in_focus_mask(lf, 2.0, tolerance_px=-1)
    with pytest.raises(InputError, match="focus_mask must be a bool image"):
        declutter_depth(tex, np.ones((3, 3), bool), threshold=0.1)
