"""One capture, one answer: every command that reads a light field, with its defaults, uses the
same view crop, the same de-cluttering rule and so the same planes and plane choice.

The commands: ``confocal lightfield scan``, ``confocal lightfield refocus``, ``confocal stimuli
build``, the viewer (``confocal view``: :func:`experiment.viewer.source.open_source` with its
default ``view_crop='auto'`` and :class:`experiment.viewer.app.Viewer`) and active search
(:func:`experiment.active.adapter.load_scene` of a capture and its plane scan). The real
captures are those of ``$CONFOCAL_DATA/lightfield`` that load without loader options; a small
synthetic capture with a dark rim checks the same without the data.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.conftest import require_data, run_cli

#: The shared captures that load with every command's defaults (the elemental image needs its
#: lens pitch).
CAPTURES = (
    "lytro_illum_2067_epinet",
    "hci_antinous_3x3_gt",
    "middlebury_Baby1",
    "middlebury_Aloe",
)


def _vignetted_capture(path: Path) -> Path:
    """A 3x3 capture: a textured square at +2 px per view step in front of a striped wall at 0,
    the views' corners and a 12 px rim black (the rim of a plenoptic capture)."""
    rng = np.random.default_rng(3)
    rows, cols = 120, 160
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    wall = 0.35 + 0.2 * (np.sin(2 * np.pi * xx / 11.0) > 0) + 0.05 * rng.random((rows, cols))
    tex = 0.6 + 0.35 * rng.random((rows, cols))
    views = np.empty((3, 3, rows, cols), np.float32)
    for u in range(3):
        for v in range(3):
            du, dv = u - 1, v - 1
            sq = (np.abs(yy + 2 * du - 60) < 22) & (np.abs(xx + 2 * dv - 80) < 28)
            t = np.roll(tex, (-2 * du, -2 * dv), axis=(0, 1))
            img = np.where(sq, t, wall)
            img[:12] = img[-12:] = 0.0
            img[:, :12] = img[:, -12:] = 0.0
            views[u, v] = img
    np.savez(path, views=np.clip(views, 0, 1))
    return path


def _answers(capture: Path, tmp: Path) -> dict:
    """What each command, with its defaults, says about ``capture``."""
    from experiment.active.adapter import detect_planes, load_scene
    from experiment.viewer.app import Viewer
    from experiment.viewer.source import open_source

    out: dict = {}
    assert run_cli(["lightfield", "scan", capture, "--out", tmp / "scan", "--no-plot"]) == 0
    scan = json.loads((tmp / "scan" / "scan.json").read_text())
    out["scan"] = (scan["view_crop"], [p["disparity_px"] for p in scan["peaks"]])
    out["scan_mode"] = scan["declutter"]

    pairs = tmp / "pairs"
    pairs.mkdir()
    (pairs / capture.name).symlink_to(capture.resolve())
    assert run_cli(["stimuli", "build", pairs, "--out", tmp / "set"]) == 0
    (obj,) = json.loads((tmp / "set" / "stimulus_set.json").read_text())["objects"]
    plane = obj["plane"]
    out["build"] = (plane["view_crop"], [a["disparity_px"] for a in plane["alternatives"]])
    out["build_choice"] = plane["disparity_px"]
    out["build_mode"] = obj["declutter"]

    viewer = Viewer(open_source(capture), ["argus2"], screen_shape_px=(120, 160))
    crop = viewer.source.view_crop
    out["viewer"] = (None if crop is None else list(crop), list(viewer.model.planes_px))

    scene = load_scene(str(capture))
    _, planes = detect_planes(scene, n_planes=200)
    out["active"] = (scene.lightfield.meta.get("view_crop"), list(planes))

    # refocus at the build's plane de-clutters as the scan does at the same plane
    k = out["scan"][1].index(out["build_choice"])
    png = tmp / "refocus.png"
    args = ["lightfield", "refocus", capture, "--disparity", repr(out["build_choice"])]
    assert run_cli([*args, "--grid", "38x25", "--out", png]) == 0
    out["refocus_edges"] = np.asarray(Image.open(tmp / "refocus_edges.png"))
    out["scan_edges"] = np.asarray(Image.open(tmp / "scan" / f"plane{k + 1:02d}_edges.png"))
    return out


def _check_one_answer(a: dict) -> None:
    assert a["scan"] == a["build"] == a["viewer"] == a["active"], a
    assert a["scan_mode"] == a["build_mode"]
    assert a["refocus_edges"].shape == a["scan_edges"].shape
    assert np.array_equal(a["refocus_edges"], a["scan_edges"])


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_synthetic_vignetted_capture_gives_one_answer(tmp_path: Path):
    cap = _vignetted_capture(tmp_path / "rim.npz")
    a = _answers(cap, tmp_path)
    _check_one_answer(a)
    x, y, w, h = a["scan"][0]
    assert x >= 12 and y >= 12 and x + w <= 160 - 12 and y + h <= 120 - 12  # the rim is out
    assert abs(a["build_choice"] - 2.0) < 0.3  # the square, not the rim's false plane at 0


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.filterwarnings("ignore:.*agree best at the")
@pytest.mark.parametrize("name", CAPTURES)
def test_shared_captures_give_one_answer(data_dir, tmp_path: Path, name: str):
    cap = require_data(data_dir, "lightfield", name)
    a = _answers(cap, tmp_path)
    _check_one_answer(a)
    if name == "lytro_illum_2067_epinet":
        # EPINET's estimate on the stegosaurus: median 0.79 px (quartiles 0.70-0.89); the
        # background plane (about 0.1 px) gave blank stimuli before the crop was shared
        assert 0.6 < a["build_choice"] < 1.0, a["build_choice"]
        assert a["scan"][0] is not None


@pytest.mark.slow
@pytest.mark.data
@pytest.mark.filterwarnings("ignore:.*agree best at the")
@pytest.mark.parametrize("name", CAPTURES[1:])
def test_planes_do_not_depend_on_the_range_asked_for(data_dir, name: str):
    """The planes of the default scan are found again, within 0.5 px per view step, by scans
    over wider ranges that contain them, and every plane has support. Measured (vignette crop
    applied): Baby1 16.89, 12.15, 7.07 (default) against 16.88, 12.21, 7.08 (range widened by
    5 px each side) and 16.88, 12.22, 7.08 (0..30); Aloe 13.60, 6.11 / 13.59, 6.12 / 13.59,
    6.12; antinous 1.29, -2.68 / 1.16, -2.67 / 1.31, -2.68 (-4..4). A guard: the range
    dependence seen on other captures does not show on these."""
    from stimuli.lightfield import load_lightfield
    from stimuli.planes import find_object_planes
    from stimuli.vignette import apply_view_crop

    lf = apply_view_crop(load_lightfield(require_data(data_dir, "lightfield", name)).gray())
    default = find_object_planes(lf)
    lo, hi = float(np.min(default.disparities_px)), float(np.max(default.disparities_px))
    planes = [p.disparity_px for p in default.peaks]
    assert planes and all(p.support > 0 for p in default.peaks)
    wide = (0.0, 30.0) if name.startswith("middlebury") else (-4.0, 4.0)
    for a, b in ((lo - 5, hi + 5), wide):
        other = find_object_planes(lf, np.linspace(a, b, 200))
        found = [p.disparity_px for p in other.peaks]
        assert all(p.support > 0 for p in other.peaks)
        for d in planes:
            if a <= d <= b:
                assert min(abs(d - f) for f in found) <= 0.5, (name, (a, b), planes, found)


def test_view_crop_option_takes_auto_none_or_a_box(tmp_path: Path, capsys):
    """``--view-crop auto`` was refused with a message about ``--zoom``; now auto, none and a box
    work, and anything else is one line naming ``--view-crop``."""
    cap = _vignetted_capture(tmp_path / "rim.npz")
    for value, box in (("auto", [12, 12, 136, 96]), ("none", None), ("20,20,100,80", None)):
        out = tmp_path / f"scan_{value.replace(',', '_')}"
        args = ["lightfield", "scan", cap, "--out", out, "--no-plot", "--view-crop", value]
        assert run_cli(args) == 0
        rec = json.loads((out / "scan.json").read_text())
        assert rec["view_crop"] == (box if value != "20,20,100,80" else [20, 20, 100, 80])
    capsys.readouterr()
    bad = ["lightfield", "scan", cap, "--out", tmp_path / "bad", "--view-crop", "corners"]
    assert run_cli(bad) == 2
    err = capsys.readouterr().err
    assert "--view-crop must be auto, none or x,y,w,h" in err and "--zoom" not in err
    assert not (tmp_path / "bad").exists()
