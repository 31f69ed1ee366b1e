"""LightField, its loaders, geometry, PFM and confocal_pair."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from PIL import Image

from stimuli.confocal import confocal_pair
from stimuli.errors import InputError
from stimuli.lightfield import (
    Geometry,
    LightField,
    elemental_from_views,
    load_lightfield,
    read_pfm,
    views_from_elemental,
    write_pfm,
)


def _views(n_u=3, n_v=3, rows=12, cols=16, seed=0):
    rng = np.random.default_rng(seed)
    return rng.random((n_u, n_v, rows, cols)).astype(np.float32)


def _write_views(folder, views, name="{u}_{v}"):
    """Write 8-bit PNG views; ``name`` is a format string of ``u, v`` or a function of them."""
    folder.mkdir(parents=True, exist_ok=True)
    for u in range(views.shape[0]):
        for v in range(views.shape[1]):
            a = np.round(views[u, v] * 255).astype(np.uint8)
            stem = name(u, v) if callable(name) else name.format(u=u, v=v)
            Image.fromarray(a).save(folder / (stem + ".png"))


def _u8(views):
    return (np.round(views * 255) / 255).astype(np.float32)


# --- LightField ----------------------------------------------------------------------------


def test_lightfield_properties():
    v = _views(3, 5)
    lf = LightField(v)
    assert lf.grid == (3, 5) and lf.shape_px == (12, 16) and lf.centre_index == (1, 2)
    np.testing.assert_array_equal(lf.centre_view(), v[1, 2])
    assert lf.max_disparity_px() == pytest.approx(11 / 2)


@pytest.mark.parametrize(
    ("array", "match"),
    [
        (np.zeros((3, 10, 10), np.float32), "must be \\(n_u, n_v, rows, cols"),
        (np.zeros((3, 3, 10, 10), np.uint8), "must be float in \\[0, 1\\]"),
        (np.full((3, 3, 4, 4), np.nan, np.float32), "NaN"),
        (np.full((3, 3, 4, 4), 1.5, np.float32), "must be in \\[0, 1\\]"),
        (np.zeros((3, 3, 4, 4, 2), np.float32), "channel axis"),
    ],
)
def test_lightfield_rejects_bad_arrays(array, match):
    with pytest.raises(InputError, match=match):
        LightField(array)


def test_gray_and_binned():
    rgb = np.stack([_views()] * 3, axis=-1)
    g = LightField(rgb).gray()
    assert g.views.shape == (3, 3, 12, 16)
    np.testing.assert_allclose(g.views, _views(), atol=1e-5)
    b = LightField(_views()).binned(2)
    assert b.shape_px == (6, 8)
    np.testing.assert_allclose(b.views[0, 0, 0, 0], _views()[0, 0, :2, :2].mean(), atol=1e-6)
    with pytest.raises(InputError, match="factor must be an integer"):
        LightField(_views()).binned(0)


def test_cropped_views():
    lf = LightField(_views(3, 3, 12, 16))
    c = lf.cropped((2, 3, 10, 6))
    np.testing.assert_array_equal(c.views, lf.views[:, :, 3:9, 2:12])
    with pytest.raises(InputError, match="inside the 16x12 views"):
        lf.cropped((10, 0, 10, 6))


# --- geometry ------------------------------------------------------------------------------


def test_camera_array_geometry_round_trip():
    g = Geometry(kind="camera_array", focal_length_px=500.0, baseline_m=0.02, near_m=0.5, far_m=10)
    assert g.disparity_px(2.0) == pytest.approx(5.0)
    assert g.depth_m(g.disparity_px(3.3)) == pytest.approx(3.3)
    assert Geometry.from_dict(g.to_dict()) == g


def test_lens_array_geometry_paper_values():
    """Paper's sim (Sec. 4.1): 1 mm pitch, 3 mm focal length, 40x relay, 10 px per lens."""
    g = Geometry(
        kind="lens_array",
        lens_pitch_mm=1.0,
        lens_focal_mm=3.0,
        relay_minification=40.0,
        pixel_mm=0.1,
    )
    # 1 m -> 25 mm after the relay -> 25 * 0.1 / (3 * 1) lenslets per view step, negative
    assert g.disparity_px(1.0) == pytest.approx(-25 * 0.1 / 3)
    assert g.depth_m(g.disparity_px(9.0)) == pytest.approx(9.0)
    assert g.disparity_px(1.0) > g.disparity_px(4.0)  # larger = nearer


def test_depth_outside_the_geometry_range_raises():
    g = Geometry(kind="camera_array", focal_length_px=500.0, baseline_m=0.02, near_m=0.5, far_m=10)
    with pytest.raises(InputError, match="outside the geometry's range"):
        g.disparity_px(25.0)
    with pytest.raises(InputError, match="depth_m must be a finite number > 0"):
        g.disparity_px(-1.0)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"kind": "hologram"}, "kind must be"),
        ({"kind": "camera_array", "focal_length_px": 100.0}, "baseline_m must be a number > 0"),
        ({"focal_length_px": 1.0}, "'kind' is required"),
        ({"kind": "camera_array", "focal": 1.0}, "unknown keys"),
        (
            {
                "kind": "camera_array",
                "focal_length_px": 1.0,
                "baseline_m": 1.0,
                "near_m": 5.0,
                "far_m": 1.0,
            },
            "near_m must be < far_m",
        ),
    ],
)
def test_bad_geometry_raises(data, match):
    with pytest.raises(InputError, match=match):
        Geometry.from_dict(data)


def test_depth_without_geometry_raises():
    with pytest.raises(InputError, match="no geometry"):
        LightField(_views()).disparity_px(1.0)


# --- loaders -------------------------------------------------------------------------------


def test_load_folder_row_col_with_toml(tmp_path):
    v = _views(3, 4)
    _write_views(tmp_path / "lf", v, "scene_{u:02d}_{v:02d}")
    (tmp_path / "lf" / "lightfield.toml").write_text(
        '[geometry]\nkind = "camera_array"\nfocal_length_px = 400.0\nbaseline_m = 0.01\n'
    )
    lf = load_lightfield(tmp_path / "lf")
    assert lf.views.shape == (3, 4, 12, 16, 3)
    np.testing.assert_allclose(lf.gray().views, _u8(v), atol=1e-5)
    assert lf.geometry.focal_length_px == 400.0


@pytest.mark.parametrize(
    "name",
    [
        # Lytro/EPINET style: rows and columns 02..04 become 0..2
        pytest.param(lambda u, v: f"2067_{u + 2:02d}_{v + 2:02d}", id="absolute-row-col"),
        # HCI: the 3x3 views at the centre of a 9x9 grid of numbered cameras
        pytest.param(lambda u, v: f"input_Cam{9 * (u + 3) + (v + 3):03d}", id="hci-camera-number"),
    ],
)
def test_load_folder_numbering_is_made_relative(tmp_path, name):
    v = _views(3, 3)
    _write_views(tmp_path / "lf", v, name)
    lf = load_lightfield(tmp_path / "lf", gray=True)
    np.testing.assert_allclose(lf.views, _u8(v), atol=1e-5)


def test_load_one_row_of_views(tmp_path):
    v = _views(1, 5)
    _write_views(tmp_path / "row", v, "view{v}")
    lf = load_lightfield(tmp_path / "row", gray=True)
    assert lf.grid == (1, 5)
    np.testing.assert_allclose(lf.views, _u8(v), atol=1e-5)


def test_load_custom_pattern(tmp_path):
    v = _views(2, 3)
    _write_views(tmp_path / "c", v, "r{u}c{v}")
    lf = load_lightfield(tmp_path / "c", pattern="r{row}c{col}.png", gray=True)
    np.testing.assert_allclose(lf.views, _u8(v), atol=1e-5)
    with pytest.raises(InputError, match="unknown field"):
        load_lightfield(tmp_path / "c", pattern="r{row}c{column}")


def test_load_npy_and_npz(tmp_path):
    v = _views()
    np.save(tmp_path / "a.npy", v)
    np.testing.assert_array_equal(load_lightfield(tmp_path / "a.npy").views, v)
    geometry = {"kind": "camera_array", "focal_length_px": 300.0, "baseline_m": 0.01}
    np.savez(tmp_path / "b.npz", views=v, geometry=json.dumps(geometry))
    lf = load_lightfield(tmp_path / "b.npz")
    np.testing.assert_array_equal(lf.views, v)
    assert lf.geometry.baseline_m == 0.01
    np.save(tmp_path / "u8.npy", np.round(v * 255).astype(np.uint8))
    np.testing.assert_allclose(load_lightfield(tmp_path / "u8.npy").views, _u8(v), atol=1e-6)


def test_elemental_round_trip_and_loader(tmp_path):
    views = _views(4, 4, 6, 7)
    ei = elemental_from_views(views)
    assert ei.shape == (24, 28)
    np.testing.assert_array_equal(views_from_elemental(ei, 4), views)
    np.testing.assert_array_equal(views_from_elemental(ei, 4, border_px=1), views[1:3, 1:3])
    Image.fromarray(np.round(ei * 255).astype(np.uint8)).save(tmp_path / "ei.png")
    (tmp_path / "ei.toml").write_text("[elemental]\npitch_px = 4\n")
    lf = load_lightfield(tmp_path / "ei.png", gray=True)
    np.testing.assert_allclose(lf.views, _u8(views), atol=1e-5)
    assert lf.meta["pitch_px"] == 4


def test_elemental_offset_skips_partial_lenslets():
    views = _views(4, 4, 5, 5)
    ei = np.pad(elemental_from_views(views), ((3, 0), (2, 0)))
    np.testing.assert_array_equal(views_from_elemental(ei, 4, offset_px=(3, 2)), views)


def test_input_arrays_are_not_modified():
    views = _views(4, 4, 6, 7)
    ei = elemental_from_views(views)
    before = ei.copy()
    views_from_elemental(ei, 4, border_px=1)
    np.testing.assert_array_equal(ei, before)


# --- bad input -----------------------------------------------------------------------------


def test_missing_views_raise(tmp_path):
    v = _views(3, 3)
    _write_views(tmp_path / "lf", v)
    (tmp_path / "lf" / "1_2.png").unlink()
    with pytest.raises(InputError, match=r"missing views at grid positions \(1, 2\)"):
        load_lightfield(tmp_path / "lf")


def test_empty_folder_raises(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match="missing views: no image files"):
        load_lightfield(tmp_path / "empty")


def test_views_of_different_sizes_raise(tmp_path):
    v = _views(1, 3)
    _write_views(tmp_path / "lf", v, "view{v}")
    Image.fromarray(np.zeros((12, 15), np.uint8)).save(tmp_path / "lf" / "view2.png")
    with pytest.raises(InputError, match="views of different sizes"):
        load_lightfield(tmp_path / "lf")


def test_grid_with_holes_raises(tmp_path):
    v = _views(1, 4)
    _write_views(tmp_path / "lf", v, "view{v}")
    (tmp_path / "lf" / "view2.png").rename(tmp_path / "lf" / "view5.png")
    with pytest.raises(InputError, match=r"grid has holes: no view at column index \[2, 4\]"):
        load_lightfield(tmp_path / "lf")


def test_partial_lenslets_are_dropped_and_too_few_raise(tmp_path):
    """A sensor is rarely a whole number of lenslets; the partial ones are dropped."""
    ei = np.arange(30 * 41, dtype=np.float32).reshape(30, 41) / (30 * 41)
    v = views_from_elemental(ei, 10)
    assert v.shape == (10, 10, 3, 4)
    np.testing.assert_array_equal(v[:, :, 2, 3], ei[20:30, 30:40])
    with pytest.raises(InputError, match="fewer than 2x2 whole lenslets"):
        views_from_elemental(ei[:15], 10)
    Image.fromarray(np.zeros((15, 41), np.uint8)).save(tmp_path / "ei.png")
    with pytest.raises(InputError, match=r"ei.png: lenslet pitch 10 px leaves fewer than 2x2"):
        load_lightfield(tmp_path / "ei.png", pitch_px=10)
    with pytest.raises(InputError, match="needs its lenslet pitch"):
        load_lightfield(tmp_path / "ei.png")
    with pytest.raises(InputError, match="border_px must be"):
        views_from_elemental(np.zeros((30, 40)), 10, border_px=5)


def test_nans_in_an_array_file_raise(tmp_path):
    v = _views()
    v[1, 1, 3, 3] = np.nan
    np.save(tmp_path / "nan.npy", v)
    with pytest.raises(InputError, match="NaN"):
        load_lightfield(tmp_path / "nan.npy")


def test_unknown_input_raises(tmp_path):
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(InputError, match="unknown light-field input"):
        load_lightfield(tmp_path / "x.txt")
    with pytest.raises(InputError, match="not found"):
        load_lightfield(tmp_path / "nothing")


# --- PFM -----------------------------------------------------------------------------------


def test_pfm_round_trip_top_row_first(tmp_path):
    a = np.arange(12, dtype=np.float32).reshape(3, 4) - 4.5
    write_pfm(a, tmp_path / "a.pfm")
    np.testing.assert_array_equal(read_pfm(tmp_path / "a.pfm"), a)
    raw = (tmp_path / "a.pfm").read_bytes()
    # stored bottom row first: the first value after the header is a[2, 0]
    assert np.frombuffer(raw[-48:-44], "<f4")[0] == a[2, 0]


def test_pfm_bad_header_raises(tmp_path):
    (tmp_path / "b.pfm").write_bytes(b"P6\n1 1\n255\n\x00\x00\x00")
    with pytest.raises(InputError, match="not a PFM file"):
        read_pfm(tmp_path / "b.pfm")


# --- confocal_pair -------------------------------------------------------------------------


def _plane_pair(tmp_path):
    """Textured near square (disparity 2) over a textured far wall (disparity 0)."""
    rng = np.random.default_rng(5)
    wall = rng.random((160, 200)).astype(np.float32) * 0.5
    square = 0.5 + rng.random((160, 200)).astype(np.float32) * 0.5
    mask = np.zeros((160, 200), bool)
    mask[20:40, 25:55] = True
    views = np.empty((5, 5, 160, 200), np.float32)
    for u in range(5):
        for v in range(5):
            sh = (-2 * (u - 2), -2 * (v - 2))
            s = np.roll(square, sh, axis=(0, 1))
            m = np.roll(mask, sh, axis=(0, 1))
            views[u, v] = np.where(m, s, wall)
    np.savez(tmp_path / "pair.npz", views=views)
    return tmp_path / "pair.npz", views, mask


def test_confocal_pair_at_a_given_disparity(tmp_path):
    path, views, mask = _plane_pair(tmp_path)
    centre, confocal = confocal_pair(path, disparity_px=2.0)
    assert centre.dtype == np.float32 and confocal.dtype == np.float32
    np.testing.assert_array_equal(centre, views[2, 2])
    inner = mask.copy()
    inner[:22] = inner[38:] = False
    inner[:, :27] = inner[:, 53:] = False
    np.testing.assert_allclose(confocal[inner], centre[inner], atol=1e-6)


def test_confocal_pair_finds_the_strongest_plane_itself(tmp_path):
    path, views, mask = _plane_pair(tmp_path)
    _, auto = confocal_pair(path)
    _, at_wall = confocal_pair(path, disparity_px=0.0)
    _, at_square = confocal_pair(path, disparity_px=2.0)
    err_wall = np.abs(auto - at_wall).mean()
    err_square = np.abs(auto - at_square).mean()
    assert min(err_wall, err_square) < 0.02  # it picked one of the two object planes


def test_confocal_pair_depth_needs_geometry_and_one_argument(tmp_path):
    path, _, _ = _plane_pair(tmp_path)
    with pytest.raises(InputError, match="no geometry"):
        confocal_pair(path, depth_m=1.0)
    with pytest.raises(InputError, match="not both"):
        confocal_pair(path, depth_m=1.0, disparity_px=1.0)
    with pytest.raises(InputError, match="disparity_px must be finite"):
        confocal_pair(path, disparity_px=math.nan)


def test_confocal_pair_with_depth(tmp_path):
    v = _views(3, 3, 20, 20)
    geometry = {"kind": "camera_array", "focal_length_px": 100.0, "baseline_m": 0.01}
    np.savez(tmp_path / "g.npz", views=v, geometry=json.dumps(geometry))
    _, by_depth = confocal_pair(tmp_path / "g.npz", depth_m=1.0)
    _, by_disp = confocal_pair(tmp_path / "g.npz", disparity_px=1.0)
    np.testing.assert_array_equal(by_depth, by_disp)


@pytest.mark.parametrize(
    "module", ["stimuli.lightfield", "stimuli.lfviews", "stimuli.lfload", "stimuli.elemental"]
)
def test_the_data_type_and_its_loaders_import_no_operation(module):
    """The light-field type, its loaders and the module that re-exports them import neither the
    scan nor refocusing, anywhere in the file (no import circle, no methods that import them
    back)."""
    import ast
    import importlib
    from pathlib import Path

    tree = ast.parse(Path(importlib.import_module(module).__file__).read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    operations = {"stimuli.planes", "stimuli.planescan", "stimuli.haarscan"}
    operations |= {"stimuli.agreementscan", "stimuli.refocus", "stimuli.declutter"}
    assert not names & operations, names
