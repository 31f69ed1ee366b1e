"""Built light-field stimuli show their object, judged against the scene's known geometry.

The box of :mod:`tests.stimuli.test_edge_depth` (a bright box at 3 px per view step in front of
a striped wall at 0) is built with ``confocal stimuli build``'s defaults as a row of 7 views
with horizontal stripes (the box's top and bottom edges parallel to the baseline), a column of
7 views with vertical stripes (its sides parallel to the baseline) and a 5x5 grid. The L8
white pixels are judged against the box's outline from the scene itself (not from the build's
own depth evidence): at least 80 % of them lie within 3 working pixels of it, the build's own
on-plane share agrees, and the L3 coverage is recorded. (The same scene de-cluttered by Sobel
alone, all clutter, is flagged: ``test_edge_depth.test_a_stimulus_of_clutter_is_flagged``.)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from stimuli.stimset.prepare import to_working_size
from tests.conftest import run_cli
from tests.stimuli.test_edge_depth import _box_scene


def _build(tmp: Path, grid, stripes, *extra: str):
    lf, truth = _box_scene(grid, stripes=stripes)
    caps = tmp / "caps"
    caps.mkdir()
    np.savez(caps / "box.npz", views=lf.views)
    assert run_cli(["stimuli", "build", caps, "--out", tmp / "set", *extra]) == 0
    rec = json.loads((tmp / "set" / "stimulus_set.json").read_text())["objects"][0]
    l8 = np.asarray(Image.open(next((tmp / "set" / "box").glob("decluttered_L8_*.png")))) > 0
    return rec, l8, truth


def _working(mask: np.ndarray, rec: dict, shape) -> np.ndarray:
    box = rec.get("aspect_crop")
    x, y, w, h = box if box is not None else (0, 0, mask.shape[1], mask.shape[0])
    t, b, left, right = rec.get("aspect_pad") or (0, 0, 0, 0)
    m = np.pad(mask[y : y + h, x : x + w], ((t, b), (left, right)))
    return to_working_size(m.astype(np.float32), shape) >= 0.5


def _on_outline(rec, l8, truth) -> float:
    outline = truth ^ ndimage.binary_erosion(truth)
    band = ndimage.binary_dilation(_working(outline, rec, l8.shape), iterations=3)
    return float((l8 & band).sum() / max(int(l8.sum()), 1))


def _level(rec, level):
    return next(r for r in rec["visibility"]["levels"] if r["level"] == level)


@pytest.mark.filterwarnings("ignore:.*agree best at the")
@pytest.mark.parametrize(
    ("grid", "stripes"), [((1, 7), "horizontal"), ((7, 1), "vertical"), ((5, 5), "diagonal")]
)
def test_l8_white_lies_on_the_box(tmp_path: Path, grid, stripes):
    rec, l8, truth = _build(tmp_path, grid, stripes)
    assert abs(rec["plane"]["disparity_px"] - 3.0) < 0.3, rec["plane"]
    share = _on_outline(rec, l8, truth)
    assert l8.sum() > 100 and share >= 0.8, (share, int(l8.sum()))
    assert _level(rec, 8)["on_plane"] >= 0.8, rec["visibility"]
    assert _level(rec, 3)["object_coverage"] is not None  # L3 coverage reported
    assert not any("may not show its object" in w for w in rec["warnings"]), rec["warnings"]
    assert rec["declutter"] == ("sobel" if grid == (5, 5) else "depth")
    if grid != (5, 5):  # the edges the views could not measure are recorded
        assert rec["plane"]["edge_depth"]["unmeasured"] > 0
