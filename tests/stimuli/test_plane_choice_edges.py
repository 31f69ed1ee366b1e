"""The default plane rule passes over a near plane that holds agreeing pixels but no edges.

The case of Middlebury Baby1 (a doll on a faintly patterned drum in front of a map): a rendered
scene with a textured wall (0 px per view step), a textured square (2.5) and, nearest, a
pedestal with a faint texture (4.5, 5 % contrast). The pedestal's views agree on its faint
marks, so it holds the support and the evidence of a plane, and the nearest-plane rule took
it; its de-cluttered stimulus is then nearly empty. It holds almost none of the centre view's
edges, so it is passed over for the square. A pedestal with full contrast is still taken.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from stimuli.lfsynth import render_views
from stimuli.lightfield import LightField
from stimuli.planechoice import choose_plane
from stimuli.scene import Layer

SHAPE = (120, 160)


def _scene(grid, contrast: float, seed: int = 1) -> LightField:
    rng = np.random.default_rng(seed)
    m = 48
    big = (SHAPE[0] + 2 * m, SHAPE[1] + 2 * m)

    def texture(amp: float, sigma: float, base: float) -> np.ndarray:
        t = ndimage.gaussian_filter(rng.random(big), sigma)
        return (base + amp * ((t - t.min()) / np.ptp(t) - 0.5)).astype(np.float32)

    square = np.zeros(big, np.float32)
    square[m + 15 : m + 70, m + 50 : m + 110] = 1.0
    pedestal = np.zeros(big, np.float32)
    pedestal[m + 70 :, m + 25 : m + 135] = 1.0
    layers = [
        Layer("wall", texture(0.8, 1.0, 0.5), np.ones(big, np.float32), 10.0),
        Layer("square", texture(0.8, 1.5, 0.5), square, 3.0),
        Layer("pedestal", texture(contrast, 1.0, 0.6), pedestal, 2.0),
    ]
    return LightField(render_views(layers, [0.0, 2.5, 4.5], grid, SHAPE))


@pytest.mark.filterwarnings("ignore:.*agree best at the")
@pytest.mark.parametrize("grid", [(1, 7), (3, 3)])
def test_a_faint_near_plane_is_passed_over_for_the_object(grid):
    choice = choose_plane(_scene(grid, 0.05))
    assert abs(choice.disparity_px - 2.5) < 0.3, choice.candidates
    near = choice.candidates[0]
    assert abs(near.disparity_px - 4.5) < 0.3, choice.candidates
    # it passes the support and evidence cuts (the rule without edges took it) ...
    assert "support" not in near.rejected and "evidence" not in near.rejected, near
    # ... and holds almost none of the edges
    assert "edges" in near.rejected and near.edge_share < 0.01, near
    assert choice.to_dict()["alternatives"][0]["edge_share"] == near.edge_share


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_a_contrasted_near_plane_is_still_taken():
    choice = choose_plane(_scene((1, 7), 0.8))
    assert abs(choice.disparity_px - 4.5) < 0.3, choice.candidates
    assert not choice.candidates[0].rejected
