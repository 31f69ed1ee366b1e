"""Layered-scene model: thin-lens camera geometry, disc PSFs, defocus rendering and occlusion."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.signal import fftconvolve

from stimuli import jung2015
from stimuli.declutter import sobel_magnitude
from stimuli.errors import InputError
from stimuli.scene import (
    Layer,
    ThinLensCamera,
    centre_crop_offset,
    disc_kernel,
    render_pair,
    render_thin_lens,
)

SMALL = (40, 60)


def _layer(name, texture, depth_m, alpha=None):
    t = np.asarray(texture, dtype=np.float32)
    a = np.ones_like(t) if alpha is None else np.asarray(alpha, dtype=np.float32)
    return Layer(name, t, a, depth_m)


def _edge_width_10_90(profile: np.ndarray) -> float:
    """Distance between the 10 % and 90 % crossings of a rising edge profile, pixels."""
    lo, hi = profile.min(), profile.max()
    p = (profile - lo) / (hi - lo)
    x = np.arange(p.size, dtype=np.float64)
    return float(np.interp(0.9, p, x) - np.interp(0.1, p, x))


def _disc_edge_width_10_90(diameter_px: float) -> float:
    """10-90 % width of a step edge blurred by a uniform disc, closed form.

    The fraction of a unit disc left of ``x = t`` is ``(t sqrt(1 - t^2) + asin t + pi/2) / pi``;
    the width is ``2 t90 R`` where that fraction is 0.9 (independent method: geometry of the
    circular segment, solved with Brent's method).
    """

    def frac(t):
        return (t * math.sqrt(1 - t * t) + math.asin(t) + math.pi / 2) / math.pi

    t90 = brentq(lambda t: frac(t) - 0.9, 0.0, 1.0, xtol=1e-12)
    return 2.0 * t90 * diameter_px / 2.0


# --- camera geometry -------------------------------------------------------------------------


def test_camera_defaults_are_the_papers() -> None:
    cam = ThinLensCamera()
    assert cam.shape_px == (327, 492)
    assert cam.focal_length_mm == 50.0 and cam.hfov_deg == 25.0 and cam.focus_m == 0.8
    # Pinhole projection: half the image width subtends half the field.
    assert math.degrees(2 * math.atan(246 / cam.focal_length_px)) == pytest.approx(25.0)


def test_coc_is_zero_at_focus_and_grows_away_from_it() -> None:
    cam = ThinLensCamera(f_number=jung2015.NARROW_F_NUMBER)
    assert cam.coc_diameter_px(cam.focus_m) == 0.0
    far = [cam.coc_diameter_px(z) for z in (1.0, 1.5, 2.0, 3.0)]
    assert np.all(np.diff(far) > 0)
    assert cam.coc_diameter_px(0.6) > 0
    wide = dataclasses.replace(cam, f_number=jung2015.WIDE_F_NUMBER)
    # The CoC scales with the aperture diameter, i.e. with 1 / N.
    assert wide.coc_diameter_px(2.0) == pytest.approx(cam.coc_diameter_px(2.0) * 1.7 / 22.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"focal_length_mm": 0.0}, "focal_length_mm must be a finite number > 0, got 0.0"),
        ({"f_number": -1.0}, "f_number must be a finite number > 0, got -1.0"),
        ({"f_number": float("nan")}, "f_number must be a finite number > 0"),
        ({"shape_px": (327,)}, "shape_px must be \\(rows, cols\\) of positive integers"),
        ({"shape_px": (0, 492)}, "shape_px must be \\(rows, cols\\) of positive integers"),
        ({"shape_px": [327, 492]}, "shape_px must be \\(rows, cols\\) of positive integers"),
        ({"shape_px": (327.0, 492)}, "shape_px must be \\(rows, cols\\) of positive integers"),
        ({"hfov_deg": 180.0}, "hfov_deg"),
        ({"focus_m": 0.01}, "focus_m"),
    ],
)
def test_camera_rejects_bad_fields(kwargs, match) -> None:
    with pytest.raises(InputError, match=match):
        ThinLensCamera(**kwargs)


def test_coc_rejects_nonpositive_depth() -> None:
    with pytest.raises(InputError, match="depth_m must be > 0"):
        ThinLensCamera().coc_diameter_px(0.0)


def test_layer_rejects_bad_shapes_and_depths() -> None:
    with pytest.raises(InputError, match="texture and alpha must be 2-D of one shape"):
        Layer("x", np.zeros((4, 4), np.float32), np.zeros((4, 5), np.float32), 1.0)
    with pytest.raises(InputError, match="depth_m must be > 0"):
        Layer("x", np.zeros((4, 4), np.float32), np.zeros((4, 4), np.float32), -1.0)


# --- disc kernel ------------------------------------------------------------------------------


@pytest.mark.parametrize("d", [0.0, 0.3, 0.999])
def test_disc_kernel_below_one_pixel_is_identity(d) -> None:
    np.testing.assert_array_equal(disc_kernel(d), [[1.0]])


def _fine_disc(d: float, sub: int = 200) -> np.ndarray:
    """Reference kernel: disc area per pixel on a 200x200 sub-pixel grid, separately coded."""
    r = d / 2.0
    n = 2 * math.ceil(r - 0.5) + 1
    edges = np.linspace(-n / 2, n / 2, n * sub + 1)
    centres = (edges[:-1] + edges[1:]) / 2
    inside = (centres[:, None] ** 2 + centres[None, :] ** 2) <= r * r
    k = inside.reshape(n, sub, n, sub).mean(axis=(1, 3))
    return k / k.sum()


@pytest.mark.parametrize("d", [1.0, 2.5, 7.0, 20.3, 31.9])
def test_disc_kernel_is_normalised_symmetric_and_physically_sized(d) -> None:
    k = disc_kernel(d)
    assert k.shape[0] == k.shape[1] and k.shape[0] % 2 == 1
    assert k.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(k, k[::-1, :])
    np.testing.assert_allclose(k, k.T)
    ref = _fine_disc(d)
    assert k.shape == ref.shape
    # 16x16 sub-samples misplace at most the boundary samples of each pixel: the total mass
    # moved is a few percent of one pixel row along the circumference, far below 2 %.
    assert np.abs(k - ref).sum() < 0.02


@pytest.mark.parametrize("d", [7.0, 20.3, 31.9])
def test_disc_kernel_second_moment_is_the_discs(d) -> None:
    # A uniform disc of radius R has variance R^2 / 4 along an axis (closed form); integrating
    # it over pixels adds the pixel's own 1/12. rtol 3 %: the sub-pixel sampling above.
    k = disc_kernel(d)
    x = np.arange(k.shape[0]) - k.shape[0] // 2
    var_x = float((k.sum(axis=0) * x**2).sum())
    assert var_x == pytest.approx((d / 2.0) ** 2 / 4.0 + 1.0 / 12.0, rel=0.03)


def test_disc_kernel_rejects_bad_diameter() -> None:
    with pytest.raises(InputError, match="diameter_px"):
        disc_kernel(-1.0)
    with pytest.raises(InputError, match="diameter_px"):
        disc_kernel(float("nan"))


def test_centre_crop_offset_and_its_error() -> None:
    assert centre_crop_offset((327, 492), (327, 492)) == (0, 0)
    assert centre_crop_offset((427, 593), (327, 492)) == (50, 50)
    with pytest.raises(InputError, match="texture_shape must be at least"):
        centre_crop_offset((10, 10), (11, 10))


# --- rendering --------------------------------------------------------------------------------


def test_in_focus_layer_is_reproduced_exactly() -> None:
    rng = np.random.default_rng(1)
    cam = ThinLensCamera(shape_px=SMALL, f_number=1.7)
    tex = rng.random((SMALL[0] + 10, SMALL[1] + 21)).astype(np.float32)
    out = render_thin_lens([_layer("obj", tex, cam.focus_m)], cam)
    r0, c0 = centre_crop_offset(tex.shape, SMALL)
    np.testing.assert_array_equal(out, tex[r0 : r0 + SMALL[0], c0 : c0 + SMALL[1]])
    assert out.dtype == np.float32 and out.shape == SMALL


def test_depth_just_off_focus_with_coc_below_one_pixel_is_identity() -> None:
    cam = ThinLensCamera(shape_px=SMALL, f_number=22.0)
    z = 0.81
    assert cam.coc_diameter_px(z) < 1.0
    tex = np.random.default_rng(2).random(SMALL).astype(np.float32)
    np.testing.assert_array_equal(render_thin_lens([_layer("a", tex, z)], cam), tex)


@pytest.mark.parametrize("depth_m", [1.5, 2.5, 4.0, 0.5])
def test_step_edge_blur_matches_the_closed_form_coc(depth_m) -> None:
    cam = ThinLensCamera(shape_px=(21, 201), f_number=jung2015.NARROW_F_NUMBER)
    tex = np.zeros(cam.shape_px, np.float32)
    tex[:, 100:] = 1.0
    out = render_thin_lens([_layer("step", tex, depth_m)], cam)
    d = cam.coc_diameter_px(depth_m)
    measured = _edge_width_10_90(out[10].astype(np.float64))
    expected = _disc_edge_width_10_90(d)
    # Tolerance: sampling the profile at pixel centres and interpolating linearly misplaces
    # each crossing by at most half a pixel.
    assert measured == pytest.approx(expected, abs=1.0)
    assert d > 8.0  # the case is not trivially sharp


def test_step_edge_widens_with_distance_from_focus() -> None:
    cam = ThinLensCamera(shape_px=(21, 241), f_number=jung2015.NARROW_F_NUMBER)
    tex = np.zeros(cam.shape_px, np.float32)
    tex[:, 120:] = 1.0
    widths = [
        _edge_width_10_90(render_thin_lens([_layer("s", tex, z)], cam)[10].astype(np.float64))
        for z in (0.9, 1.2, 1.8, 3.0)
    ]
    assert np.all(np.diff(widths) > 0.5)


def test_near_opaque_layer_hides_far_layer_whatever_the_list_order() -> None:
    cam = ThinLensCamera(shape_px=(60, 90), f_number=jung2015.NARROW_F_NUMBER)
    far = _layer("far", np.ones(cam.shape_px), 2.0)
    alpha = np.zeros(cam.shape_px, np.float32)
    alpha[10:50, 20:70] = 1.0
    near = _layer("near", np.zeros(cam.shape_px), cam.focus_m, alpha)
    for layers in ([far, near], [near, far]):
        out = render_thin_lens(layers, cam)
        assert out[10:50, 20:70].max() == 0.0
        assert out[:5].min() == pytest.approx(1.0, abs=1e-5)


def test_far_layer_in_front_would_hide_near_one() -> None:
    """The depth, not the list position, decides occlusion: swap the depths, swap the result."""
    cam = ThinLensCamera(shape_px=(60, 90), f_number=jung2015.WIDE_F_NUMBER)
    alpha = np.zeros(cam.shape_px, np.float32)
    alpha[10:50, 20:70] = 1.0
    black_patch_far = _layer("patch", np.zeros(cam.shape_px), 3.0, alpha)
    white_wall_near = _layer("wall", np.ones(cam.shape_px), 2.0)
    out = render_thin_lens([black_patch_far, white_wall_near], cam)
    np.testing.assert_allclose(out, 1.0, atol=1e-5)


def test_half_transparent_layer_composites_with_the_over_operator() -> None:
    cam = ThinLensCamera(shape_px=SMALL)
    back = _layer("back", np.full(SMALL, 0.8), 0.8)
    front = _layer("front", np.full(SMALL, 0.2), 0.8, np.full(SMALL, 0.25))
    out = render_thin_lens([back, front], cam)
    np.testing.assert_allclose(out, 0.25 * 0.2 + 0.75 * 0.8, atol=1e-6)


def test_blur_does_not_darken_the_image_border() -> None:
    cam = ThinLensCamera(shape_px=SMALL, f_number=1.7)
    out = render_thin_lens([_layer("wall", np.full(SMALL, 0.6), 3.0)], cam)
    np.testing.assert_allclose(out, 0.6, atol=1e-5)


def test_wide_aperture_pair_keeps_background_sharper_and_object_identical() -> None:
    rng = np.random.default_rng(3)
    cam = ThinLensCamera(shape_px=(80, 120))
    checker = ((np.indices((100, 140)).sum(axis=0) // 4) % 2).astype(np.float32)
    background = _layer("bg", checker, 2.5)
    alpha = np.zeros(cam.shape_px, np.float32)
    alpha[30:70, 40:80] = 1.0
    obj = _layer("obj", rng.random(cam.shape_px), cam.focus_m, alpha)
    wide, narrow = render_pair([background, obj], camera=cam)
    bg = np.ones(cam.shape_px, bool)
    bg[20:80, 30:90] = False
    assert sobel_magnitude(wide)[bg].mean() > 5 * sobel_magnitude(narrow)[bg].mean()
    np.testing.assert_array_equal(wide[30:70, 40:80], narrow[30:70, 40:80])


def test_render_does_not_modify_its_input() -> None:
    rng = np.random.default_rng(4)
    t = rng.random((50, 70)).astype(np.float32)
    a = rng.random((50, 70)).astype(np.float32)
    layer = Layer("x", t, a, 1.7)
    t0, a0 = t.copy(), a.copy()
    render_pair([layer], camera=ThinLensCamera(shape_px=SMALL))
    np.testing.assert_array_equal(t, t0)
    np.testing.assert_array_equal(a, a0)


def test_render_pair_uses_the_papers_apertures() -> None:
    cam = ThinLensCamera(shape_px=(21, 201))
    tex = np.zeros(cam.shape_px, np.float32)
    tex[:, 100:] = 1.0
    wide, narrow = render_pair([_layer("s", tex, 2.0)], camera=cam)
    for img, n in ((wide, 22.0), (narrow, 1.7)):
        ref = render_thin_lens([_layer("s", tex, 2.0)], dataclasses.replace(cam, f_number=n))
        np.testing.assert_array_equal(img, ref)


@pytest.mark.parametrize(
    ("layers", "match"),
    [
        ([], "at least one Layer"),
        ("wall", "sequence of Layer"),
        ([np.zeros(SMALL)], r"layers\[0\] must be a Layer"),
        ([Layer("tiny", np.zeros((4, 4), np.float32), np.ones((4, 4), np.float32), 1.0)],
         "smaller than the camera"),
        ([Layer("hot", np.full(SMALL, 2.0, np.float32), np.ones(SMALL, np.float32), 1.0)],
         "must be in"),
    ],
)  # fmt: skip
def test_render_rejects_bad_layers(layers, match) -> None:
    with pytest.raises(InputError, match=match):
        render_thin_lens(layers, ThinLensCamera(shape_px=SMALL))


def test_render_rejects_a_non_camera() -> None:
    layer = _layer("a", np.zeros(SMALL), 1.0)
    with pytest.raises(InputError, match="camera must be a ThinLensCamera"):
        render_thin_lens([layer], "camera")
    with pytest.raises(InputError, match="camera must be a ThinLensCamera"):
        render_pair([layer], camera="camera")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_render_output_is_float32_in_range_for_random_scenes(dtype, seed) -> None:
    rng = np.random.default_rng(seed)
    rows, cols = int(rng.integers(8, 40)), int(rng.integers(8, 40))
    cam = ThinLensCamera(shape_px=(rows, cols), f_number=float(rng.choice([1.7, 4.0, 22.0])))
    layers = []
    for i in range(int(rng.integers(1, 5))):
        shape = (rows + 2 * int(rng.integers(0, 6)), cols + 2 * int(rng.integers(0, 6)))
        layers.append(
            Layer(
                f"l{i}",
                rng.random(shape).astype(dtype),
                rng.random(shape).astype(dtype),
                float(rng.uniform(0.3, 5.0)),
            )
        )
    out = render_thin_lens(layers, cam)
    assert out.dtype == np.float32 and out.shape == (rows, cols)
    assert np.all(np.isfinite(out)) and out.min() >= 0.0 and out.max() <= 1.0


def test_zero_alpha_scene_renders_black() -> None:
    cam = ThinLensCamera(shape_px=SMALL, f_number=1.7)
    layer = _layer("ghost", np.ones(SMALL), 2.0, np.zeros(SMALL))
    np.testing.assert_array_equal(render_thin_lens([layer], cam), 0.0)


@pytest.mark.parametrize("depth_m", [3.0, 6.0])
def test_large_discs_at_reduced_resolution_match_the_full_resolution_blur(depth_m) -> None:
    cam = ThinLensCamera(shape_px=(300, 450), f_number=1.0)
    d = cam.coc_diameter_px(depth_m)
    assert d >= 48.0  # the reduced-resolution path is taken
    shape = (340, 510)
    yy, xx = np.indices(shape)
    tex = (((yy // 24) + (xx // 24)) % 2).astype(np.float32)
    out = render_thin_lens([_layer("checker", tex, depth_m)], cam)
    # Reference: the same disc applied at full resolution by one FFT (float64), written here
    # independently of the renderer. Tolerance: 0.01 (2.5 grey levels in 8 bits); the block
    # mean widens the PSF by under 0.5 % and linear interpolation of a disc-blurred image
    # (>= 24 low-resolution px across) errs by a few 1e-3 at the checker's corners.
    k = disc_kernel(d)
    h = k.shape[0] // 2
    padded = np.pad(tex.astype(np.float64), h, mode="reflect")
    r0, c0 = centre_crop_offset(shape, cam.shape_px)
    region = padded[r0 : r0 + 300 + 2 * h, c0 : c0 + 450 + 2 * h]
    ref = fftconvolve(region, k, mode="valid")
    assert ref.shape == out.shape
    assert np.abs(out - ref).max() < 0.01
    assert np.abs(out - ref).mean() < 0.003
