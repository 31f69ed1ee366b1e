"""Depth for the edges a 1-D light field cannot measure, and the build's check that a stimulus
shows its object.

The scenes are rendered with :func:`stimuli.lfsynth.render_views`: a bright box at 3 px per view
step in front of a wall of stripes at 0, seen by a row of 7 views (a 1-D light field), a column
of 7 (the same, turned) or a 5x5 grid. With a row of views, the wall's horizontal stripes look
the same in every view at every depth, so the views "agree" on them at the box's plane; the
box's horizontal edges look the same too. The ground truth is the box's outline.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from stimuli.declutter import agreement_mask, declutter, declutter_depth, in_focus_evidence
from stimuli.lfsynth import render_views
from stimuli.lightfield import LightField
from stimuli.scene import Layer

SHAPE = (160, 240)
BOX = (40, 80, 80, 80)  # rows y0, x0, height, width in the view
D_BOX = 3.0


def _box_scene(grid=(1, 7), stripes="horizontal", seed=0):
    """The box in front of the striped wall; returns the light field and the box mask."""
    rng = np.random.default_rng(seed)
    rows, cols = SHAPE
    m = 40
    big = (rows + 2 * m, cols + 2 * m)
    yy, xx = np.mgrid[0 : big[0], 0 : big[1]]
    along = {"horizontal": yy, "vertical": xx, "diagonal": yy + xx}[stripes]
    wall = 0.15 + 0.35 * ((along // 7) % 2) + 0.03 * rng.random(big)
    box = 0.88 + 0.05 * rng.random(big)
    alpha = np.zeros(big, np.float32)
    y0, x0, h, w = BOX
    alpha[m + y0 : m + y0 + h, m + x0 : m + x0 + w] = 1.0
    layers = [
        Layer("wall", np.clip(wall, 0, 1).astype(np.float32), np.ones(big, np.float32), 10.0),
        Layer("box", box.astype(np.float32), alpha, 1.0),
    ]
    views = render_views(layers, [0.0, D_BOX], grid, SHAPE)
    truth = np.zeros(SHAPE, bool)
    truth[y0 : y0 + h, x0 : x0 + w] = True
    return LightField(views), truth


def _outline_band(truth, r=3):
    edge = truth ^ ndimage.binary_erosion(truth)
    return ndimage.binary_dilation(edge, iterations=r)


def _decluttered(lf, evidence):
    from stimuli.refocus import refocus

    img = np.clip(refocus(lf, D_BOX), 0, 1).astype(np.float32)
    return img, declutter_depth(img, evidence, threshold=0.1)


def _rows_covered(edges, row, c0, c1):
    return edges[row - 2 : row + 3, c0:c1].any(axis=0).mean()


def test_box_horizontal_edges_kept_and_the_stripes_dropped():
    """A row of views: the box's horizontal edges stay, the wall's horizontal stripes go."""
    lf, truth = _box_scene((1, 7))
    evidence, stats = in_focus_evidence(lf, D_BOX)
    img, edges = _decluttered(lf, evidence)
    sobel = declutter(img, threshold=0.1)
    band = _outline_band(truth)
    y0, x0, h, w = BOX
    assert (sobel & ~band).sum() > 5 * (sobel & band).sum()  # the stripes are strong edges
    # the box's top and bottom edges (parallel to the baseline) are kept along their length
    assert _rows_covered(edges, y0, x0 + 3, x0 + w - 3) >= 0.95
    assert _rows_covered(edges, y0 + h - 1, x0 + 3, x0 + w - 3) >= 0.95
    # and its sides
    assert edges[y0 + 3 : y0 + h - 3, x0 - 2 : x0 + 2].any(axis=1).mean() >= 0.95
    # the wall's stripes are gone: (almost) every white pixel lies on the box's outline
    assert (edges & ~band).sum() <= 0.02 * edges.sum()
    # what was dropped is counted: most unmeasured edge pixels were the wall's
    assert stats.unmeasured > 0 and stats.resolved_off_plane > 0.5 * stats.unmeasured
    assert 0 < stats.to_dict()["dropped_share"] < 1


def test_agreement_alone_keeps_the_stripes():
    """The failure the resolution fixes: the views' agreement keeps the horizontal stripes."""
    lf, truth = _box_scene((1, 7))
    _, edges = _decluttered(lf, agreement_mask(lf, D_BOX))
    band = _outline_band(truth)
    assert (edges & ~band).sum() > 2 * (edges & band).sum()


def test_a_column_of_views_resolves_vertical_edges():
    """The same scene turned: a column of views, vertical stripes and the box's sides."""
    lf, truth = _box_scene((1, 7))
    turned = LightField(np.ascontiguousarray(np.transpose(lf.views, (1, 0, 3, 2))))
    t_truth = truth.T
    evidence, _ = in_focus_evidence(turned, D_BOX)
    _, edges = _decluttered(turned, evidence)
    band = _outline_band(t_truth)
    y0, x0, h, w = BOX  # turned: the box's top and bottom are now columns y0, y0 + h - 1
    for col in (y0, y0 + h - 1):
        assert edges[x0 + 3 : x0 + w - 3, col - 2 : col + 3].any(axis=1).mean() >= 0.95
    assert (edges & ~band).sum() <= 0.02 * edges.sum()


def test_a_grid_of_views_is_left_as_the_views_say():
    """On a 2-D grid every edge direction is measured: the evidence is the views' agreement."""
    lf, _ = _box_scene((3, 3))
    evidence, stats = in_focus_evidence(lf, D_BOX)
    assert np.array_equal(evidence.astype(bool), agreement_mask(lf, D_BOX))
    assert stats.unmeasured == 0


# --------------------------------------------------------------------------------------------
# The build: on-plane share and object coverage, per object and level
# --------------------------------------------------------------------------------------------


def _build(tmp: Path, grid, *extra: str, stripes="horizontal"):
    from tests.conftest import run_cli

    lf, _ = _box_scene(grid, stripes=stripes)
    pairs = tmp / "caps"
    pairs.mkdir()
    np.savez(pairs / "box.npz", views=lf.views)
    assert run_cli(["stimuli", "build", pairs, "--out", tmp / "set", *extra]) == 0
    return json.loads((tmp / "set" / "stimulus_set.json").read_text())["objects"][0]


def _level(rec, level):
    return next(r for r in rec["visibility"]["levels"] if r["level"] == level)


# test_build_shows_the_box_on_the_plane: in tests/stimuli/test_lf_visibility_truth.py, judged
# against the box's outline as well as by the build's own measure.


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_a_stimulus_of_clutter_is_flagged(tmp_path: Path, capsys):
    """Built to fail: a row of views de-cluttered by Sobel alone keeps the wall's horizontal
    stripes at every depth, so most white pixels lie off the box's plane; the build says so on
    the console, in stimulus_set.json and on the contact sheet."""
    from PIL import Image

    from tests.stimuli.test_lf_visibility_truth import _on_outline

    rec = _build(tmp_path, (1, 7), "--declutter", "sobel")
    assert _level(rec, 8)["on_plane"] < 0.5, rec["visibility"]
    # the scene's own box says so too: most L8 white pixels lie off its outline
    _, truth = _box_scene((1, 7))
    l8 = np.asarray(Image.open(next((tmp_path / "set" / "box").glob("decluttered_L8_*.png"))))
    assert _on_outline(rec, l8 > 0, truth) < 0.5
    assert any("may not show its object" in w for w in rec["warnings"]), rec["warnings"]
    # the warning names the other detected planes to try (here the wall, at 0)
    assert rec["visibility"]["other_planes_px"], rec["visibility"]
    assert any("other detected planes: " in w for w in rec["warnings"]), rec["warnings"]
    # and which measure is low, and the option that changes the plane
    assert any("on_plane" in w and "--plane" in w for w in rec["warnings"]), rec["warnings"]
    out = capsys.readouterr()
    assert "may not show its object" in (out.out + out.err).replace("\n", " ")
    sheet = np.asarray(Image.open(tmp_path / "set" / "contact" / "box.png"))
    assert (sheet[14:26] == 0).mean() > 0.5  # the warning band under the title


@pytest.mark.parametrize("grid", [(1, 7), (3, 3), (7, 1)])
def test_compiled_agreement_is_the_numpy_twin(grid):
    """The compiled in-focus test gives the numpy chain's mask to the bit (random texture with
    sharp steps, a plane between the box and the wall and one on the box)."""
    lf, _ = _box_scene(grid)
    for d in (D_BOX, 1.3):
        fast = agreement_mask(lf, d)
        slow = agreement_mask(lf, d, compiled=False)
        assert np.array_equal(fast, slow)
