"""A folder of views loaded grey, one view at a time on threads, is the luminance of the colour
light field to the bit; a folder read at the agreement scan's views only gives the same scan."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from stimuli.errors import InputError
from stimuli.io import _LUMA_WEIGHTS, luma
from stimuli.lightfield import load_lightfield


@pytest.mark.parametrize("mode", ["RGB", "RGBA", "L"])
def test_grey_folder_is_the_luminance_of_the_colour_folder(tmp_path, mode):
    rng = np.random.default_rng(14)
    channels = {"RGB": 3, "RGBA": 4, "L": 1}[mode]
    for r in range(3):
        for c in range(4):
            a = rng.integers(0, 256, (37, 53, channels), dtype=np.uint8)
            Image.fromarray(a[..., 0] if channels == 1 else a, mode).save(tmp_path / f"{r}_{c}.png")
    grey = load_lightfield(tmp_path, gray=True).views
    colour = load_lightfield(tmp_path, gray=False).views
    assert grey.shape == (3, 4, 37, 53) and grey.dtype == np.float32
    np.testing.assert_array_equal(grey, luma(colour))
    np.testing.assert_array_equal(grey, load_lightfield(tmp_path, gray=False).gray().views)
    weights = _LUMA_WEIGHTS.astype(np.float64)
    exact = np.clip(np.tensordot(colour.astype(np.float64), weights, 1), 0, 1)
    np.testing.assert_allclose(grey, exact, rtol=0, atol=2e-7)  # float32 rounding only


def _folder_of_views(tmp_path, grid, dtype=np.uint8):
    from stimuli.lfsynth import render_camera_array, three_plane_scene

    shape = (60, 90)
    lf = render_camera_array(three_plane_scene(shape), grid=grid, shape_px=shape, baseline_m=0.03)
    top = np.iinfo(dtype).max
    for u in range(grid[0]):
        for v in range(grid[1]):
            a = np.round(lf.views[u, v] * top).astype(dtype)
            Image.fromarray(a).save(tmp_path / f"view_{u}_{v}.png")
    return tmp_path


@pytest.mark.parametrize("grid", [(5, 5), (1, 7), (3, 3)])
def test_a_folder_read_at_the_scan_views_gives_the_same_scan(tmp_path, grid):
    import warnings

    from stimuli.agreementscan import scan_views
    from stimuli.planechoice import choose_plane, detect_planes

    folder = _folder_of_views(tmp_path, grid)
    whole = load_lightfield(folder, gray=True)
    some = load_lightfield(folder, gray=True, only_views=scan_views)
    read = some.meta["views_read"]
    assert sorted(read) == sorted(scan_views(grid)) and len(read) < grid[0] * grid[1]
    for u in range(grid[0]):
        for v in range(grid[1]):
            expected = whole.views[u, v] if (u, v) in read else np.zeros_like(whole.views[u, v])
            np.testing.assert_array_equal(some.views[u, v], expected)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scans = [detect_planes(lf) for lf in (whole, some)]
        choices = [choose_plane(lf, scan=s) for lf, s in zip((whole, some), scans, strict=True)]
    np.testing.assert_array_equal(scans[0].scores, scans[1].scores)
    assert scans[0].peaks == scans[1].peaks and len(scans[0].peaks) >= 2
    assert choices[0] == choices[1]


def test_sixteen_bit_views_are_read_whole(tmp_path):
    """16-bit views are scaled by the largest value of all of them: none can be left out."""
    from stimuli.agreementscan import scan_views

    folder = _folder_of_views(tmp_path, (3, 3), dtype=np.uint16)
    some = load_lightfield(folder, gray=True, only_views=scan_views)
    assert "views_read" not in some.meta
    np.testing.assert_array_equal(some.views, load_lightfield(folder, gray=True).views)


def test_eight_bit_size_reads_the_header_as_pillow_does(tmp_path):
    from stimuli.lfload import _eight_bit_size

    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (21, 34, 3), dtype=np.uint8)
    Image.fromarray(rgb).save(tmp_path / "rgb.png")
    Image.fromarray(rgb).convert("P").save(tmp_path / "palette.png")
    Image.fromarray(rgb[..., 0] > 128).save(tmp_path / "bits.png")
    Image.fromarray(rgb).save(tmp_path / "rgb.jpg")
    Image.fromarray(rgb[..., 0].astype(np.uint16) * 257).save(tmp_path / "deep.png")
    (tmp_path / "cut.png").write_bytes((tmp_path / "rgb.png").read_bytes()[:10])
    for name in ("rgb.png", "palette.png", "bits.png", "rgb.jpg"):
        assert _eight_bit_size(tmp_path / name) == Image.open(tmp_path / name).size == (34, 21)
    assert _eight_bit_size(tmp_path / "deep.png") is None  # 16-bit: every view sets the scale
    assert _eight_bit_size(tmp_path / "cut.png") is None


def test_views_cropped_as_read_and_a_scans_two_reads_equal_a_whole_read_cropped(tmp_path):
    """A box applied while reading (every view, or the scan's views then the others, merged as
    ``lightfield scan`` merges them) gives the whole light field's crop to the bit."""
    from stimuli.agreementscan import scan_views
    from stimuli.lightfield_steps import LoaderOptions, _with_the_other_views, load_grey

    folder = _folder_of_views(tmp_path, (3, 5))
    box = (7, 4, 70, 49)
    whole = load_lightfield(folder, gray=True).cropped(box)
    read_cropped = load_lightfield(folder, gray=True, view_box=box)
    np.testing.assert_array_equal(read_cropped.views, whole.views)
    assert read_cropped.meta["crop"] == list(box)
    some = load_lightfield(folder, gray=True, only_views=scan_views).cropped(box)
    for u, v in some.meta["views_read"]:
        np.testing.assert_array_equal(some.views[u, v], whole.views[u, v])
    options = LoaderOptions(view_crop=",".join(map(str, box)))
    first = load_grey(folder, options, scan_views)
    merged = _with_the_other_views(first, folder, options)
    np.testing.assert_array_equal(merged.views, whole.views)
    assert merged.meta["view_crop"] == list(box) and "views_read" not in merged.meta
    with pytest.raises(InputError, match="crop box 7,4,90,49"):
        load_lightfield(folder, gray=True, view_box=(7, 4, 90, 49))


def test_the_vignette_median_is_numpys_without_numpy_ma():
    from stimuli.vignette import _median

    rng = np.random.default_rng(2)
    for n in (1, 2, 3, 10, 11, 4097):
        a = rng.random(n, dtype=np.float32)
        b = np.round(a * 255) / np.float32(255)  # ties, as in 8-bit views
        assert _median(a) == float(np.median(a)) and _median(b) == float(np.median(b))
