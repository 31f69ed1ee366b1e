"""The depth de-clutter with the agreement test's threshold image kept per light field equals
the test made afresh at every plane, to the bit."""

from __future__ import annotations

import numpy as np

from stimuli.declutter import (
    _LIMITS,
    agreement_mask,
    auto_threshold,
    declutter,
    declutter_depth,
    in_focus_evidence,
)
from stimuli.lfsynth import render_camera_array, three_plane_scene
from stimuli.refocus import refocus


def test_cached_threshold_image_gives_the_uncached_depth_edges():
    """A synthetic 1x7 light field de-cluttered at three planes (on, between and beyond its
    layers) through the cached threshold image: the agreement at the edge pixels equals the
    uncached edge-pixel kernel's and the full-image kernel's, and the depth edges equal those
    of the evidence tested everywhere; the cache is made once and kept with the light field."""
    shape = (64, 96)
    lf = render_camera_array(three_plane_scene(shape), grid=(1, 7), shape_px=shape)
    ds = [lf.geometry.disparity_px(z) for z in (1.0, 4.0)]
    assert lf not in _LIMITS
    for d in (ds[0], 0.5 * (ds[0] + ds[1]) + 0.13, ds[1] - 0.37):
        img = np.clip(refocus(lf, d), 0.0, 1.0).astype(np.float32)
        t = auto_threshold(img)
        at = declutter(img, threshold=t)
        assert 0 < at.sum() < at.size
        cached = agreement_mask(lf, d, where=at)
        assert np.array_equal(cached, agreement_mask(lf, d, where=at, cache=False))
        assert np.array_equal(cached, agreement_mask(lf, d) & at)
        fast, _ = in_focus_evidence(lf, d, confocal=img, where=at)
        full, _ = in_focus_evidence(lf, d, confocal=img)
        got = declutter_depth(img, fast, threshold=t, edges=at)
        assert np.array_equal(got, declutter_depth(img, full, threshold=t))
        assert got.any()
    assert set(_LIMITS[lf]) == {(1, -1, 0.5, 2 / 255), (1, 1, 0.5, 2 / 255)}
