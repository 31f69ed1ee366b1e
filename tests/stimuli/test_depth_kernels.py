"""The depth de-clutter's compiled passes against their numpy twins, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.declutter import declutter_depth


@pytest.mark.parametrize("seed", range(6))
def test_compiled_vote_is_the_numpy_twin(seed):
    """Random images, edge densities and evidence (bool, and uint8 with dropped pixels): the
    kept edges are the two box filters' to the bit, ties of the local majority included."""
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 160)), int(rng.integers(1, 160)))
    img = rng.random(shape).astype(np.float32)
    img[:, : shape[1] // 2] *= 0.2  # a flat half and a busy half
    evidence = rng.integers(0, 3, shape).astype(np.uint8)
    for focus in (evidence, evidence == 1):
        for t in (0.05, 0.2):
            fast = declutter_depth(img, focus, threshold=t)
            slow = declutter_depth(img, focus, threshold=t, compiled=False)
            assert np.array_equal(fast, slow)
    # blocks of ties: half the edges of each box in focus
    img = np.tile(np.array([[0.0, 1.0]], np.float32), (40, 30))
    focus = np.zeros(img.shape, bool)
    focus[:, ::4] = True
    focus[:, 1::4] = True
    fast = declutter_depth(img, focus, threshold=0.1)
    assert np.array_equal(fast, declutter_depth(img, focus, threshold=0.1, compiled=False))
    assert 0 < fast.sum() < img.size
