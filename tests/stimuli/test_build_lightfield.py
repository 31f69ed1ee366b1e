"""``confocal stimuli build`` with objects given as light fields (the builder's contract).

A small synthetic light field (``.npz``): a bright textured disc at disparity 3 px per view step
in front of a striped wall at disparity 0. Object ``lfplane`` gives its plane in objects.csv,
object ``lfauto`` leaves it to the depth scan (``confocal_pair`` with neither argument).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from stimuli.confocal import confocal_pair
from stimuli.errors import InputError
from stimuli.io import sha256_file
from stimuli.manifest import read_manifest
from stimuli.stimset import build_stimulus_set


def _write_lightfield(path: Path, d_near: float = 3.0, shape=(200, 300), grid=(5, 5)) -> Path:
    rng = np.random.default_rng(7)
    rows, cols = shape
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    wall = 0.3 + 0.15 * np.sign(np.sin(2 * np.pi * (xx + 0.6 * yy) / 9.0))
    wall = wall + 0.1 * (rng.random(shape) > 0.8)
    disc = ((yy - 0.65 * rows) ** 2 + (xx - 0.5 * cols) ** 2 < (0.2 * rows) ** 2).astype(float)
    obj = 0.75 + 0.2 * rng.random(shape)
    views = np.empty((*grid, rows, cols), np.float32)
    for u in range(grid[0]):
        for v in range(grid[1]):
            du, dv = u - grid[0] // 2, v - grid[1] // 2
            sh = (-d_near * du, -d_near * dv)
            m = ndimage.shift(disc, sh, order=1)
            o = ndimage.shift(obj, sh, order=1, mode="reflect")
            views[u, v] = m * o + (1 - m) * wall
    np.savez(path, views=np.clip(views, 0, 1))
    return path


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("lfbuild")
    lf = _write_lightfield(root / "scene.npz")
    with open(root / "pairs.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["object", "lightfield"])
        w.writerow(["lfplane", "scene.npz"])
        w.writerow(["lfauto", "scene.npz"])
    with open(root / "objects.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["object", "plane_disparity_px"])
        w.writerow(["lfplane", "3.0"])
        w.writerow(["lfauto", ""])
    result = build_stimulus_set(root / "pairs.csv", root / "set", workers=1)
    return root, lf, result


def test_manifest_rows_for_light_field_objects(built):
    root, lf, _ = built
    recs = read_manifest(root / "set" / "manifest.csv")
    for obj in ("lfplane", "lfauto"):
        rows = [r for r in recs if r.object == obj]
        expected = {(c, lv) for c in ("cluttered", "decluttered") for lv in range(1, 9)}
        assert {(r.condition, r.level) for r in rows} - {("photo", 8)} == expected
        for r in rows:
            assert Path(r.source.split("#")[0]).name == "scene.npz"
            assert r.source_sha256 == sha256_file(lf)
            assert (root / "set" / r.path).is_file()
            assert sha256_file(root / "set" / r.path) == r.sha256


def test_decluttered_is_the_confocal_image_and_drops_the_wall(built):
    """Full-resolution (level 8) edges: the refocused image loses the wall's stripes."""
    from PIL import Image

    root, _, _ = built
    recs = read_manifest(root / "set" / "manifest.csv")

    def edge_fraction(obj, cond):
        (r,) = [x for x in recs if x.object == obj and x.condition == cond and x.level == 8]
        return (np.asarray(Image.open(root / "set" / r.path)) > 0).mean()

    assert edge_fraction("lfplane", "decluttered") < 0.5 * edge_fraction("lfplane", "cluttered")


def test_auto_plane_is_the_nearest_detected_plane(built):
    """Without a plane in objects.csv the *nearest* detected plane is used ("the
    object's plane ... or the nearest detected plane"): the disc at disparity 3 in front of the
    striped wall at 0, even though the wall's stripes outscore the disc. The manifest records
    the plane it used (H15)."""
    from stimuli.confocal import confocal_plane
    from stimuli.lightfield import load_lightfield
    from stimuli.planes import find_object_planes

    root, lf, _ = built
    field = load_lightfield(lf)
    scan = find_object_planes(field)
    found = sorted(p.disparity_px for p in scan.peaks)
    assert any(abs(d) < 0.2 for d in found) and any(abs(d - 3.0) < 0.3 for d in found), found
    strongest = max(scan.peaks, key=lambda p: p.score)
    assert abs(strongest.disparity_px) < 0.2  # the wall scores higher: the old rule's trap
    plane = confocal_plane(lf)
    assert plane.chosen_by == "auto"
    assert abs(plane.disparity_px - 3.0) < 0.3
    _, auto = confocal_pair(lf)
    _, expect = confocal_pair(lf, disparity_px=plane.disparity_px)
    np.testing.assert_array_equal(auto, expect)
    recs = read_manifest(root / "set" / "manifest.csv")
    (auto_row,) = [
        r for r in recs if r.object == "lfauto" and r.condition == "decluttered" and r.level == 8
    ]
    assert auto_row.source.endswith(f"#confocal@{plane.describe()}")
    (given_row,) = [
        r for r in recs if r.object == "lfplane" and r.condition == "decluttered" and r.level == 8
    ]
    assert given_row.source.endswith("#confocal@disparity=3px,disparity_px")


def test_depth_declutter_mode_is_used_and_recorded(tmp_path):
    """``BuildParams(declutter='depth')``: a light-field object's de-cluttered images keep only
    edges where the views agree at the plane. Simulated three-plane scene through one row of 7
    cameras, focused on the tree: the pedestrian and building leave horizontal ghost edges that
    Sobel keeps and the depth mode drops. The mode is in stimulus_set.json and each row's
    source."""
    from stimuli.lfsynth import render_camera_array, three_plane_scene
    from stimuli.stimset import BuildParams

    field = render_camera_array(
        three_plane_scene((164, 246)), grid=(1, 7), shape_px=(164, 246), baseline_m=0.03
    )
    lf = tmp_path / "scene.npz"
    np.savez(lf, views=field.views, geometry=json.dumps(field.geometry.to_dict()))
    (tmp_path / "pairs.csv").write_text("object,lightfield\ntree,scene.npz\n")
    (tmp_path / "objects.csv").write_text("object,plane_depth_m\ntree,4.0\n")
    sets = {}
    for mode in ("sobel", "depth"):
        build_stimulus_set(
            tmp_path / "pairs.csv",
            tmp_path / mode,
            params=BuildParams(declutter=mode),
            workers=1,
        )
        meta = json.loads((tmp_path / mode / "stimulus_set.json").read_text())
        assert meta["parameters"]["declutter"] == mode
        recs = read_manifest(tmp_path / mode / "manifest.csv")
        (row,) = [r for r in recs if r.condition == "decluttered" and r.level == 8]
        assert row.source.endswith(",declutter=depth") == (mode == "depth")
        sets[mode] = np.asarray(Image.open(tmp_path / mode / row.path)) > 0
    assert lf.exists()
    assert sets["depth"].sum() < 0.8 * sets["sobel"].sum()
    with pytest.raises(InputError, match="`declutter` must be one of"):
        BuildParams(declutter="canny")


def test_bokeh_guard_drops_rims_absent_from_the_wide_photo():
    """A sharp ring only in the narrow photo goes; an edge in both photos stays."""
    from stimuli.declutter import bokeh_guard

    narrow = np.zeros((40, 60), bool)
    wide = np.zeros((40, 60), bool)
    narrow[10:30, 20] = wide[10:30, 21] = True  # a real edge, one pixel apart
    yy, xx = np.mgrid[0:40, 0:60]
    ring = np.abs(np.hypot(yy - 20, xx - 45) - 8) < 0.7
    narrow |= ring
    kept = bokeh_guard(narrow, wide)
    assert kept[10:30, 20].all() and not (kept & ring).any()
    with pytest.raises(InputError, match="must be bool images of one shape"):
        bokeh_guard(narrow, wide[:10])


def test_build_command_offers_the_depth_mode_and_bokeh_guard(tmp_path, capsys):
    """``confocal stimuli build --declutter depth --bokeh-guard``: both reach the build and are
    recorded in stimulus_set.json; a bad mode is one line, exit 2, nothing written."""
    from experiment import cli
    from stimuli.lfsynth import render_camera_array, three_plane_scene

    field = render_camera_array(
        three_plane_scene((82, 123)), grid=(1, 5), shape_px=(82, 123), baseline_m=0.03
    )
    np.savez(
        tmp_path / "scene.npz", views=field.views, geometry=json.dumps(field.geometry.to_dict())
    )
    (tmp_path / "pairs.csv").write_text("object,lightfield\ntree,scene.npz\n")
    (tmp_path / "objects.csv").write_text("object,plane_depth_m\ntree,4.0\n")
    argv = ["stimuli", "build", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "set")]
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--declutter", "canny"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "declutter must be one of" in err[0]
    assert not (tmp_path / "set").exists()
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--declutter", "depth", "--bokeh-guard"])
    assert exc.value.code in (0, None), capsys.readouterr().err
    meta = json.loads((tmp_path / "set" / "stimulus_set.json").read_text())
    assert meta["parameters"]["declutter"] == "depth"
    assert meta["parameters"]["bokeh_guard"] is True
    (row,) = [
        r
        for r in read_manifest(tmp_path / "set" / "manifest.csv")
        if r.condition == "decluttered" and r.level == 8
    ]
    assert row.source.endswith(",declutter=depth")
