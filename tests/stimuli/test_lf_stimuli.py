"""Built light-field stimuli against ground truth: plane, crop, de-cluttered edges, coarse level.

For each light field with a known disparity map (Middlebury Baby1 and Aloe, HCI antinous from
``$CONFOCAL_DATA``; the simulated three-plane scene of :mod:`stimuli.lfsynth` as a 1-D row of
views and as a 5x5 grid) ``build_stimulus_set`` runs with its defaults, and:

* the plane it chose lies on real ground-truth support: at least 5 % of the known pixels are
  within 1.5 px per view step of it;
* the aspect crop keeps at least 80 % of those plane pixels;
* at least 80 % of the white pixels of the de-cluttered level-8 image (on known pixels) lie on
  the plane, the plane mask grown by 2 working pixels (a Sobel edge on an object's outline is
  centred on its boundary, half of it off the object);
* the de-cluttered level-3 image has white cells on the plane's pixels.

The plane pixels are those of the ground truth, never of our own scan. Ground truth of the
real captures: ``tests/stimuli/_lf_truth.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.ndimage import binary_dilation

from stimuli.compress import block_mean
from stimuli.lfsynth import ground_truth_maps, render_camera_array, three_plane_scene
from stimuli.stimset import BuildParams, build_stimulus_set
from stimuli.stimset.prepare import to_working_size
from tests.conftest import require_data
from tests.stimuli._lf_truth import TRUTH_CAPTURES, centre_truth

#: Tolerance of "on the plane", px per view step (the task's criterion).
ON_PLANE_PX = 1.5


def _build(tmp_path: Path, lightfield: Path, params: BuildParams | None = None):
    tmp_path.mkdir(parents=True, exist_ok=True)
    (tmp_path / "pairs.csv").write_text(f"object,lightfield\nobj,{lightfield}\n")
    out = tmp_path / "set"
    build_stimulus_set(tmp_path / "pairs.csv", out, params=params, workers=1)
    meta = json.loads((out / "stimulus_set.json").read_text())
    return out, meta["objects"][0]


def _check_stimulus(
    out: Path, record: dict, truth: np.ndarray, name: str, *, check: bool = True
) -> dict:
    d = record["plane"]["disparity_px"]
    known = np.isfinite(truth)
    with np.errstate(invalid="ignore"):
        plane = known & (np.abs(truth - d) <= ON_PLANE_PX)
    share = plane.sum() / known.sum()
    box = record["aspect_crop"]
    x, y, w, h = box if box is not None else (0, 0, truth.shape[1], truth.shape[0])
    kept = plane[y : y + h, x : x + w].sum() / plane.sum()
    t, b, left, right = record.get("aspect_pad") or (0, 0, 0, 0)
    l8 = np.asarray(Image.open(out / "obj" / "decluttered_L8_w01.png")) > 0
    shape = l8.shape

    def working(mask):
        m = np.pad(mask[y : y + h, x : x + w], ((t, b), (left, right)))
        return to_working_size(m.astype(np.float32), shape) >= 0.5

    on = binary_dilation(working(plane), iterations=2)
    white = l8 & working(known)
    precision = (white & on).sum() / max(white.sum(), 1)
    l3 = np.asarray(Image.open(out / "obj" / "decluttered_L3_w13.png")) > 0
    cells_on_plane = block_mean(working(plane), l3.shape) >= 0.5
    l3_on = int((l3 & cells_on_plane).sum())
    print(
        f"{name}: plane {d:.3f} px ({record['plane']['rule']}), truth share {share:.3f}, "
        f"crop keeps {kept:.3f} (recorded {record['content_kept']:.3f}), L8 precision "
        f"{precision:.2f} of {white.sum()} white, L3 white cells on plane {l3_on}, "
        f"declutter {record['declutter']}"
    )
    if not check:
        return {"share": share, "kept": kept, "precision": precision}
    assert share >= 0.05, (name, d, share)
    assert kept >= 0.8, (name, box, kept)
    assert precision >= 0.8, (name, precision)
    assert l3_on > 0, name
    return {"share": share, "kept": kept, "precision": precision}


@pytest.mark.data
@pytest.mark.parametrize("name", TRUTH_CAPTURES)
def test_built_stimulus_is_right_on_real_light_fields(data_dir, tmp_path, name):
    """Measured: Baby1 16.9 px (the drum pedestal, 22 % of the known pixels; crop keeps 100 %,
    L8 precision 0.86), Aloe 13.6 px (the plant; 99 %, 0.92), antinous 1.3 px (the bust, taller
    than any crop to the aspect keeps: padded; 100 %, 1.00)."""
    root = require_data(data_dir, "lightfield", name)
    out, record = _build(tmp_path, root)
    assert record["plane"]["rule"] == "auto" and record["plane"]["alternatives"]
    _check_stimulus(out, record, centre_truth(root), name)
    levels = {r["level"]: r for r in record["visibility"]["levels"]}
    assert all("object_coverage" in levels[k] for k in (1, 2, 3))  # L3 coverage reported


@pytest.mark.parametrize("grid", [(1, 7), (5, 5)])
def test_built_stimulus_is_right_on_the_simulated_scene(tmp_path, grid):
    """The three-plane scene (pedestrian 1 m, tree 4 m, building 9 m), small views."""
    shape = (164, 246)
    layers = three_plane_scene(shape, margin_px=64)
    lf = render_camera_array(layers, grid=grid, shape_px=shape, baseline_m=0.01)
    np.savez(tmp_path / "lf.npz", views=lf.views)
    truth, _ = ground_truth_maps(layers, lf.geometry, shape)
    out, record = _build(tmp_path, tmp_path / "lf.npz")
    _check_stimulus(out, record, truth.astype(np.float64), f"synthetic {grid}")


@pytest.mark.data
@pytest.mark.parametrize("name", ["middlebury_Baby1", "middlebury_Aloe"])
def test_view_agreement_beats_sobel_on_a_row_of_views(data_dir, tmp_path, name):
    """Why 1-D light fields are de-cluttered by view agreement by default: at the same plane
    the paper's Sobel mode keeps background edges parallel to the baseline, which refocusing
    cannot blur. Measured L8 precision, Sobel -> default: Baby1 0.50 -> 0.67, Aloe 0.63 ->
    0.92."""
    root = require_data(data_dir, "lightfield", name)
    truth = centre_truth(root)
    out, rec = _build(tmp_path / "sobel", root, BuildParams(declutter="sobel"))
    sobel = _check_stimulus(out, rec, truth, f"{name} sobel", check=False)
    out, rec = _build(tmp_path / "auto", root)
    assert rec["declutter"] == "depth"
    auto = _check_stimulus(out, rec, truth, f"{name} default", check=False)
    assert auto["precision"] >= sobel["precision"] + 0.1
