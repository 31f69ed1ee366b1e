"""A folder of views loaded grey, one view at a time on threads, is the luminance of the colour
light field to the bit."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from stimuli.io import _LUMA_WEIGHTS
from stimuli.lightfield import load_lightfield


@pytest.mark.parametrize("mode", ["RGB", "RGBA", "L"])
def test_grey_folder_is_the_luminance_of_the_colour_folder(tmp_path, mode):
    rng = np.random.default_rng(14)
    channels = {"RGB": 3, "RGBA": 4, "L": 1}[mode]
    for r in range(3):
        for c in range(4):
            a = rng.integers(0, 256, (37, 53, channels), dtype=np.uint8)
            Image.fromarray(a[..., 0] if channels == 1 else a, mode).save(tmp_path / f"{r}_{c}.png")
    grey = load_lightfield(tmp_path, gray=True).views
    colour = load_lightfield(tmp_path, gray=False).views
    assert grey.shape == (3, 4, 37, 53) and grey.dtype == np.float32
    whole = np.clip(np.tensordot(colour, _LUMA_WEIGHTS, axes=([4], [0])), 0, 1)
    np.testing.assert_array_equal(grey, whole.astype(np.float32))
