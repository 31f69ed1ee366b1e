"""Choosing a light field's plane from evidence, the crop that keeps it, one plane answer.

The scene (5x5 views, 480x640 px): a striped textured wall at disparity 0, a textured disc at
disparity 3 in the middle, and a textured strip 17 px high near the bottom border at disparity
6 (the nearest plane: a table edge at the frame's edge; 13 px above the border, where the
scan still sees it in every view). The plane-choice tests scan -1..8 px per view step; the
default range (the range estimate's) finds the same three planes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from stimuli.errors import InputError
from stimuli.lightfield import LightField
from stimuli.planechoice import choose_plane
from stimuli.stimset import BuildParams, build_stimulus_set
from stimuli.stimset.prepare import aspect_crop_box, content_crop_box

SHAPE = (480, 640)


def _scene(grid=(5, 5)) -> LightField:
    rng = np.random.default_rng(3)
    rows, cols = SHAPE
    yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
    wall = 0.3 + 0.15 * np.sign(np.sin(2 * np.pi * (xx + 0.6 * yy) / 9.0))
    wall = wall + 0.1 * (rng.random(SHAPE) > 0.8)
    disc = ((yy - 0.5 * rows) ** 2 + (xx - 0.5 * cols) ** 2 < (0.2 * rows) ** 2).astype(float)
    strip = ((yy >= rows - 30) & (yy < rows - 13) & (xx > 40) & (xx < cols - 40)).astype(float)
    tex_disc = 0.75 + 0.2 * rng.random(SHAPE)
    tex_strip = 0.1 + 0.4 * rng.random(SHAPE)
    views = np.zeros((*grid, *SHAPE), np.float32)
    cu, cv = grid[0] // 2, grid[1] // 2
    for u in range(grid[0]):
        for v in range(grid[1]):
            img = ndimage.shift(wall, (0, 0), order=1, mode="nearest")
            for mask, tex, d in ((disc, tex_disc, 3.0), (strip, tex_strip, 6.0)):
                sh = (-d * (u - cu), -d * (v - cv))
                m = ndimage.shift(mask, sh, order=1)
                t = ndimage.shift(tex, sh, order=1, mode="nearest")
                img = m * t + (1 - m) * img
            views[u, v] = np.clip(img, 0, 1)
    return LightField(views)


def _build_one(tmp_path: Path, lf: LightField, objects_csv: str | None = None, *, out="s", **kw):
    """Build a set of one object, ``thing``, from ``lf`` into ``tmp_path / out`` (``objects_csv``:
    the objects.csv text); return the build's result and the object's stimulus_set.json record."""
    out = tmp_path / out
    np.savez(tmp_path / "lf.npz", views=lf.views)
    (tmp_path / "pairs.csv").write_text("object,lightfield\nthing,lf.npz\n")
    if objects_csv is not None:
        (tmp_path / "objects.csv").write_text(objects_csv)
    r = build_stimulus_set(tmp_path / "pairs.csv", out, workers=1, **kw)
    return r, json.loads((out / "stimulus_set.json").read_text())["objects"][0]


@pytest.fixture(scope="module")
def scene():
    from stimuli.planes import find_object_planes

    lf = _scene()
    return lf, find_object_planes(lf, np.linspace(-1.0, 8.0, 200))


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_auto_rule_passes_over_a_border_band(scene):
    """The strip is the nearest detected plane (the old rule's pick); the default rule records
    it as a border band and takes the disc."""
    lf, scan = scene
    found = [round(p.disparity_px, 1) for p in scan.peaks]
    assert abs(scan.peaks[0].disparity_px - 6.0) < 0.3, found  # the strip, nearest
    nearest = choose_plane(lf, rule="nearest", scan=scan)
    assert abs(nearest.disparity_px - 6.0) < 0.3
    auto = choose_plane(lf, scan=scan)
    assert auto.rule == "auto" and abs(auto.disparity_px - 3.0) < 0.3, found
    strip = auto.candidates[0]
    assert "border frame" in strip.rejected and strip.border_share > 0.5
    assert auto.marginal == ""
    record = auto.to_dict()
    assert [a["disparity_px"] for a in record["alternatives"]] == [
        p.disparity_px for p in scan.peaks
    ]
    json.dumps(record)  # JSON-ready


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_plane_rules_disparity_and_region_of_interest(scene):
    lf, scan = scene
    strongest = choose_plane(lf, rule="strongest", scan=scan)
    assert abs(strongest.disparity_px) < 0.3  # the wall
    given = choose_plane(lf, rule="2.9", scan=scan)
    assert given.rule == "disparity_px" and given.disparity_px == 2.9 and not given.marginal
    roi = choose_plane(lf, roi=(280, 10, 80, 40), scan=scan)  # wall above the disc
    assert roi.rule == "roi" and abs(roi.disparity_px) < 0.3
    mask = np.zeros(SHAPE, bool)
    mask[220:260, 300:340] = True  # inside the disc
    roi = choose_plane(lf, roi=mask, scan=scan)
    assert abs(roi.disparity_px - 3.0) < 0.3 and roi.content is not None
    with pytest.raises(InputError, match="roi box x,y,w,h = 630,0,20,20 lies outside"):
        choose_plane(lf, roi=(630, 0, 20, 20), scan=scan)
    with pytest.raises(InputError, match="--plane must be one of auto, strongest, nearest"):
        choose_plane(lf, rule="middle", scan=scan)


def test_crop_keeps_content_the_centre_crop_cuts():
    """An object along the bottom edge: the centred aspect crop loses most of it."""
    m = np.zeros((300, 300), bool)
    m[250:295, 100:200] = True
    x, y, w, h = aspect_crop_box(m.shape, (200, 300))
    assert m[y : y + h, x : x + w].sum() / m.sum() < 0.8  # the old crop cuts it
    box, kept = content_crop_box(m, (200, 300))
    assert kept == 1.0 and box == (0, 95, 300, 200)  # the kept box nearest the centred one
    assert content_crop_box(np.zeros((300, 300), bool), (200, 300)) == ((0, 50, 300, 200), 1.0)


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_build_records_plane_crop_and_declutter(tmp_path: Path):
    lf = _scene(grid=(1, 7))
    r, rec = _build_one(tmp_path, lf, 'object,roi\nthing,"300,220,40,40"\n')
    assert rec["plane"]["rule"] == "roi" and abs(rec["plane"]["disparity_px"] - 3.0) < 0.3
    assert rec["declutter"] == "depth"  # a row of views: view agreement by default
    assert rec["content_kept"] == 1.0 and rec["plane"]["alternatives"]
    assert "roi" in (tmp_path / "s" / "objects.csv").read_text().splitlines()[0]
    assert any("around its plane's content" in n for n in r.notes)
    params = BuildParams(plane="strongest", declutter="sobel")
    (tmp_path / "objects.csv").unlink()
    _, rec = _build_one(tmp_path, lf, out="t", params=params)
    assert rec["plane"]["rule"] == "strongest" and abs(rec["plane"]["disparity_px"]) < 0.3
    assert rec["declutter"] == "sobel"


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_view_scan_and_build_report_the_same_planes(scene, tmp_path: Path):
    """One detector: ``confocal view``'s plane list, ``lightfield scan``'s planes.csv and the
    build's alternatives are the same planes."""
    from typer.testing import CliRunner

    from experiment.viewer.app import Viewer
    from experiment.viewer.source import LightFieldSource
    from stimuli.lightfield_cli import lightfield_app

    lf = scene[0]
    _, rec = _build_one(tmp_path, lf)
    viewer = Viewer(LightFieldSource(lf), ["argus2"], screen_shape_px=(120, 160))
    res = CliRunner().invoke(
        lightfield_app, ["scan", str(tmp_path / "lf.npz"), "-o", str(tmp_path / "scan")]
    )
    assert res.exit_code == 0, res.output
    scan = json.loads((tmp_path / "scan" / "scan.json").read_text())
    built = [a["disparity_px"] for a in rec["plane"]["alternatives"]]
    scanned = [p["disparity_px"] for p in scan["peaks"]]
    assert list(viewer.model.planes_px) == scanned == built
    np.testing.assert_allclose(built, [6.0, 3.0, 0.0], atol=0.05)  # strip, disc, wall
    chosen = rec["plane"]["disparity_px"]  # the disc: the strip is a border band
    number = scanned.index(chosen) + 1
    assert number == 2 and f"would use plane{number:02d} ({chosen:.3f}" in res.output


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_plane_on_no_object_is_marginal_and_marked(tmp_path: Path):
    """A plane between the wall and the disc (objects.csv): marginal, with a note, a record
    and a mark on the contact sheet; the de-cluttered image there is nearly empty."""
    from PIL import Image

    r, rec = _build_one(tmp_path, _scene(grid=(1, 7)), "object,plane_disparity_px\nthing,1.5\n")
    assert "lies on no detected plane" in rec["plane"]["marginal"]
    assert any("marginal plane" in w for w in rec["warnings"]), rec["warnings"]
    assert any("thing: marginal plane" in n for n in r.notes)
    sheet = np.asarray(Image.open(tmp_path / "s" / "contact" / "thing.png"))
    # the warning line: a black band under the title, which a sheet without warnings lacks
    assert (sheet[14:26] == 0).mean() > 0.5
