"""Photo pairs written at another zlib level hold the same pixels; a bad level is refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from stimuli.errors import InputError
from stimuli.io import load_gray
from stimuli.synth import write_pairs


def test_pairs_at_the_fastest_zlib_level_hold_the_same_pixels(tmp_path: Path) -> None:
    kw = {"n_objects": 1, "n_training": 0, "seed": 3, "shape_px": (64, 96)}
    usual = write_pairs(tmp_path / "six", **kw)
    fast = write_pairs(tmp_path / "one", compress_level=1, **kw)
    for name in ("wide.png", "narrow.png", "mask.png"):
        a, b = load_gray(usual / "obj01_cup" / name), load_gray(fast / "obj01_cup" / name)
        assert np.array_equal(a, b), name
    assert (usual / "objects.csv").read_bytes() == (fast / "objects.csv").read_bytes()


@pytest.mark.parametrize("level", [-1, 10, 1.5, True])
def test_a_bad_zlib_level_is_refused_before_anything_is_written(tmp_path: Path, level) -> None:
    with pytest.raises(InputError, match="compress_level must be an integer 0..9"):
        write_pairs(tmp_path / "p", n_objects=1, n_training=0, compress_level=level)
    assert not (tmp_path / "p").exists()
