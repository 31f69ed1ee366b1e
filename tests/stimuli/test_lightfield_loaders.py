"""Loaders that say what they see: one test per input case (patterns, axes, alpha, bit depth).

Each case ends in a correct light field or in one line on stderr naming the file and what was
expected, exit status 2.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from experiment.cli import main
from stimuli.errors import InputError
from stimuli.lightfield import load_lightfield, read_pfm
from tests.conftest import require_data


def _code(args, capsys):
    try:
        main(args)
    except SystemExit as exc:
        return exc.code or 0, capsys.readouterr()
    return 0, capsys.readouterr()


def _refocus_at_zero(lightfield, out, *options, capsys):
    """Run ``confocal lightfield refocus LIGHTFIELD --disparity 0 OPTIONS --out OUT``."""
    args = ["lightfield", "refocus", str(lightfield), "--disparity", "0", *options]
    return _code([*args, "--out", str(out)], capsys)


def _grid(n_u=2, n_v=3, rows=24, cols=32, seed=0):
    return np.random.default_rng(seed).integers(0, 256, (n_u, n_v, rows, cols), dtype=np.uint8)


def _outside(tmp_path: Path) -> Path:
    """A folder beside ``tmp_path``: an output never lies inside the light field it reads."""
    out = tmp_path.parent / f"{tmp_path.name}-out"
    out.mkdir(exist_ok=True)
    return out


def test_pattern_format_widths(tmp_path, capsys):
    """``{row:02d}{col:02d}`` reads ``0101.png``: two digits each, not a greedy split."""
    g = _grid()
    for u in range(2):
        for v in range(3):
            Image.fromarray(g[u, v]).save(tmp_path / f"{u + 1:02d}{v + 1:02d}.png")
    lf = load_lightfield(tmp_path, pattern="{row:02d}{col:02d}.png")
    assert lf.grid == (2, 3)
    np.testing.assert_allclose(lf.gray().views, g / 255.0, atol=1e-6)
    code, out = _refocus_at_zero(
        tmp_path, _outside(tmp_path) / "r.png", "--pattern", "{row:02d}{col:02d}", capsys=capsys
    )
    assert code == 0, out.err
    with pytest.raises(InputError, match=r"field \{row:x\} must be an integer format"):
        load_lightfield(tmp_path, pattern="{row:x}{col}")


def test_pattern_wildcard(tmp_path):
    g = _grid()
    for u in range(2):
        for v in range(3):
            name = f"out_{u:02d}_{v:02d}_{-12.3 + u:.1f}_{45.6 * v:.1f}_.png"
            Image.fromarray(g[u, v]).save(tmp_path / name)
    lf = load_lightfield(tmp_path, pattern="out_{row:02d}_{col:02d}_*.png")
    assert lf.grid == (2, 3)
    np.testing.assert_allclose(lf.gray().views[1, 2], g[1, 2] / 255.0, atol=1e-6)


def test_npy_axis_order_checked(tmp_path, capsys):
    """A (rows, cols, n_u, n_v) array is refused with the expected order named; --axes reads it."""
    views = _grid(3, 3, 40, 50).astype(np.float32) / 255.0
    np.save(tmp_path / "hwuv.npy", np.transpose(views, (2, 3, 0, 1)))
    code, out = _code(
        ["lightfield", "scan", str(tmp_path / "hwuv.npy"), "--out", str(tmp_path / "s")], capsys
    )
    assert code == 2
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and "hwuv.npy" in lines[0] and "(n_u, n_v, rows, cols[, C])" in lines[0]
    assert not (tmp_path / "s").exists()
    lf = load_lightfield(tmp_path / "hwuv.npy", axes="hwuv")
    np.testing.assert_array_equal(lf.views, views)
    with pytest.raises(InputError, match="--axes must be one of"):
        load_lightfield(tmp_path / "hwuv.npy", axes="xyz")


def test_alpha_is_composited_over_the_background(tmp_path, capsys):
    """Transparent pixels take the background grey, whatever colour they store."""
    for v in range(3):
        rgba = np.zeros((20, 30, 4), np.uint8)
        rgba[..., :3] = 255  # white where transparent: dropping alpha would show white
        rgba[5:15, 10:20] = (0, 0, 0, 255)  # an opaque black square
        Image.fromarray(rgba, "RGBA").save(tmp_path / f"view{v}.png")
    lf = load_lightfield(tmp_path, gray=True, background=0.5)
    np.testing.assert_allclose(lf.views[0, 1, 0, 0], 0.5, atol=1e-6)
    np.testing.assert_allclose(lf.views[0, 1, 10, 15], 0.0, atol=1e-6)
    assert lf.meta["alpha_background"] == 0.5
    code, _ = _refocus_at_zero(
        tmp_path, _outside(tmp_path) / "r.png", "--background", "0.25", capsys=capsys
    )
    assert code == 0
    assert np.asarray(Image.open(_outside(tmp_path) / "r.png"))[0, 0] == round(0.25 * 255)


def test_sixteen_bit_data_scaled_by_its_bit_depth(tmp_path, capsys):
    """12-bit values in 16-bit PNGs fill [0, 1]; --bit-depth overrides; too small is refused."""
    rng = np.random.default_rng(1)
    raw = rng.integers(0, 4096, (1, 3, 20, 30)).astype(np.uint16)
    raw[0, 0, 0, 0] = 4095
    for v in range(3):
        Image.fromarray(raw[0, v]).save(tmp_path / f"view{v}.png")
    assert Image.open(tmp_path / "view0.png").mode.startswith("I")
    lf = load_lightfield(tmp_path, gray=True)
    assert lf.meta["bit_depth"] == 12
    np.testing.assert_allclose(lf.views, raw / 4095.0, atol=1e-6)
    lf16 = load_lightfield(tmp_path, gray=True, bit_depth=16)
    np.testing.assert_allclose(lf16.views, raw / 65535.0, atol=1e-6)
    code, out = _refocus_at_zero(
        tmp_path, _outside(tmp_path) / "r.png", "--bit-depth", "10", capsys=capsys
    )
    assert code == 2 and "view0.png: value 4095 does not fit --bit-depth 10" in out.err


def test_zoom_box_aspect_refused_with_a_fitting_grid(tmp_path, capsys):
    views = _grid(1, 3, 120, 160).astype(np.float32) / 255.0
    source, png, zoom = tmp_path / "lf.npy", tmp_path / "r.png", ("--zoom", "10,10,40,100")
    np.save(source, views)
    code, out = _refocus_at_zero(source, png, *zoom, "--grid", "38x25", capsys=capsys)
    assert code == 2
    assert "--zoom box 40x100 px" in out.err and "use --grid 10x25" in out.err
    assert not png.exists()
    code, out = _refocus_at_zero(source, png, *zoom, "--grid", "10x25", capsys=capsys)
    assert code == 0, out.err
    assert np.asarray(Image.open(tmp_path / "r_grid.png")).shape == (25, 10)


def test_synth_writes_ground_truth_disparity_and_depth(tmp_path, capsys):
    """Simulated scene: the maps hold the three layers' depths and their disparities."""
    from stimuli.lfsynth import layer_masks, three_plane_scene

    code, out = _code(
        ["lightfield", "synth", "--out", str(tmp_path / "sim.png"), "--size", "48x40"], capsys
    )
    assert code == 0, out.err
    depth = read_pfm(tmp_path / "sim_depth.pfm")
    disp = read_pfm(tmp_path / "sim_disparity.pfm")
    lf = load_lightfield(tmp_path / "sim.png")
    masks = layer_masks(three_plane_scene((40, 48)), (40, 48))
    for name, z in (("pedestrian", 1.0), ("tree", 4.0), ("building", 9.0)):
        m = masks[name]
        assert m.any()
        np.testing.assert_allclose(depth[m], z)
        np.testing.assert_allclose(disp[m], lf.geometry.disparity_px(z), rtol=1e-6)
    code, _ = _code(
        ["lightfield", "synth", "--out", str(tmp_path / "s.npz"), "--size", "48x40"], capsys
    )
    with np.load(tmp_path / "s.npz") as z:
        np.testing.assert_array_equal(z["depth_m"], depth)
    _code(
        [
            "lightfield",
            "synth",
            "--out",
            str(tmp_path / "f"),
            "--size",
            "48x40",
            "--kind",
            "camera",
        ],
        capsys,
    )
    assert read_pfm(tmp_path / "f" / "depth.pfm").shape == (40, 48)


def test_errors_name_the_file(tmp_path, capsys):
    (tmp_path / "v").mkdir()
    for v in range(3):
        Image.fromarray(_grid(1, 1, 20, 30)[0, 0]).save(tmp_path / "v" / f"view{v}.png")
    (tmp_path / "v" / "view1.png").write_bytes(b"not a png")
    code, out = _code(
        ["lightfield", "scan", str(tmp_path / "v"), "--out", str(tmp_path / "o")], capsys
    )
    assert code == 2 and "view1.png" in out.err and len(out.err.strip().splitlines()) == 1
    (tmp_path / "bad.npy").write_bytes(b"garbage")
    code, out = _code(
        ["lightfield", "scan", str(tmp_path / "bad.npy"), "--out", str(tmp_path / "o")], capsys
    )
    assert code == 2 and "bad.npy" in out.err


@pytest.mark.data
def test_ms_elemental_image_opens_from_the_command_line(data_dir, tmp_path, capsys):
    """The real lens-array image: 41 px lenslets, 3 px invalid border, grid offset (18, 37)
    (test_lf_real.py), a partial lenslet at the edges dropped, 5x5 views averaged (--view-bin).
    Geometry from SOURCES.md (1 mm pitch, 3.3 mm focal length, 41 px per lenslet) in a TOML
    beside a link to the image. The scan finds the M plane: independently (test_lf_real.py, the
    maximum of the mean Sobel magnitude in M's crop) -0.56 lenslet per original view step, i.e.
    -2.8 px per binned view step; measured -2.76, 75 mm (SOURCES.md: useful depths 35-80 mm)."""
    src = require_data(data_dir, "lightfield", "integral_imaging_MS_elemental", "MS_eleImg.JPG")
    link = tmp_path / "MS_eleImg.JPG"
    link.symlink_to(src)
    link.with_suffix(".toml").write_text(
        '[geometry]\nkind = "lens_array"\nlens_pitch_mm = 1.0\nlens_focal_mm = 3.3\n'
        f"pixel_mm = {1 / 41}\n[elemental]\npitch_px = 41\nborder_px = 3\noffset_px = [18, 37]\n"
    )
    out = tmp_path / "scan"
    code, res = _code(
        ["lightfield", "scan", str(link), "--view-bin", "5", "--out", str(out)], capsys
    )
    assert code == 0, res.err
    with open(out / "planes.csv") as f:
        peaks = [r for r in csv.DictReader(f) if r["peak"] == "1"]
    assert peaks
    best = max(peaks, key=lambda r: float(r["support"]))
    assert abs(float(best["disparity_px"]) - (-0.56 * 5)) <= 0.3
    assert 0.035 <= float(best["depth_m"]) <= 0.080
    assert json.loads((out / "scan.json").read_text())["method"] == "agreement"


def test_remaining_loader_and_option_errors(tmp_path, capsys):
    """One line each, naming what was expected."""
    from stimuli.declutter import bokeh_guard
    from stimuli.lightfield import LightField
    from stimuli.planes import find_object_planes

    v = np.random.default_rng(0).random((3, 3, 40, 50)).astype(np.float32)
    np.save(tmp_path / "lf.npy", v)
    with pytest.raises(InputError, match="--axes 'hwuvc' names 5 axes, array has 4"):
        load_lightfield(tmp_path / "lf.npy", axes="hwuvc")
    np.save(tmp_path / "three.npy", v[0])
    with pytest.raises(InputError, match="three.npy: a light-field array must be 4-D"):
        load_lightfield(tmp_path / "three.npy")
    np.save(tmp_path / "big.npy", v * 2)
    with pytest.raises(InputError, match=r"big.npy: float light field must be in \[0, 1\]"):
        load_lightfield(tmp_path / "big.npy")
    with pytest.raises(InputError, match="background must be a grey level"):
        load_lightfield(tmp_path / "lf.npy", background=2.0)
    Image.fromarray(np.zeros((20, 30), np.uint16)).save(tmp_path / "e.png")
    with pytest.raises(InputError, match="--bit-depth must be an integer in 1..16"):
        load_lightfield(tmp_path / "e.png", pitch_px=10, bit_depth=20)
    lf = LightField(v)
    with pytest.raises(InputError, match="view binning must be an integer"):
        lf.view_binned(0)
    with pytest.raises(InputError, match="cannot bin a 3x3 grid of views by 4"):
        lf.view_binned(4)
    with pytest.raises(InputError, match="at least two views"):
        find_object_planes(LightField(v[:1, :1]), [0.0, 0.5, 1.0])
    with pytest.raises(InputError, match="radius_px must be"):
        bokeh_guard(np.zeros((4, 4), bool), np.zeros((4, 4), bool), radius_px=-1)
    for opt, bad, msg in (
        ("--declutter", "canny", "--declutter must be one of auto, sobel, depth"),
        ("--method", "sift", "--method must be one of agreement, haar"),
    ):
        code, out = _code(
            [
                "lightfield",
                "scan",
                str(tmp_path / "lf.npy"),
                "--out",
                str(tmp_path / "o"),
                opt,
                bad,
            ],
            capsys,
        )
        assert code == 2 and msg in out.err


def test_view_binning_scales_disparity_and_geometry():
    """Averaging 2x2 blocks of views: one new view step is two old ones, so a scene at 1 px
    per view step is at 2 px per new step, and the camera baseline doubles."""
    from stimuli.lightfield import Geometry, LightField
    from stimuli.refocus import refocus

    rng = np.random.default_rng(2)
    tex = rng.random((60, 80)).astype(np.float32)
    views = np.stack(
        [np.stack([np.roll(tex, (-(u - 2), -(v - 2)), (0, 1)) for v in range(4)]) for u in range(4)]
    )
    g = Geometry(kind="camera_array", focal_length_px=100.0, baseline_m=0.01)
    lf = LightField(views, g).view_binned(2)
    assert lf.grid == (2, 2) and lf.geometry.baseline_m == pytest.approx(0.02)
    assert lf.geometry.disparity_px(10.0) == pytest.approx(2 * g.disparity_px(10.0))
    np.testing.assert_allclose(lf.views[0, 0], views[:2, :2].mean(axis=(0, 1)), atol=1e-6)
    inner = np.s_[6:-6, 6:-6]
    sharp = refocus(lf, 2.0)[inner]
    blurred = refocus(lf, 0.0)[inner]
    assert np.std(sharp) > 1.2 * np.std(blurred)
