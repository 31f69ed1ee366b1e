"""Shift-and-add refocusing: analytic cases, a reference implementation, borders, errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from stimuli.errors import InputError
from stimuli.lightfield import LightField
from stimuli.refocus import centre_view, focal_stack, iter_focal_stack, refocus


def _texture(shape=(64, 80), seed=0, smooth=1.0):
    rng = np.random.default_rng(seed)
    t = ndimage.gaussian_filter(rng.random(shape), smooth)
    t = (t - t.min()) / (t.max() - t.min())
    return t.astype(np.float32)


def _one_plane_lf(tex, d, grid=(5, 5)):
    """Views of one plane at disparity d: view (du, dv) sees texture(y + d du, x + d dv)."""
    n_u, n_v = grid
    views = np.empty((n_u, n_v, *tex.shape), np.float32)
    for u in range(n_u):
        for v in range(n_v):
            du, dv = u - n_u // 2, v - n_v // 2
            # ndimage.shift(a, s)(y) = a(y - s): shift by -d*du to sample texture(y + d du)
            views[u, v] = ndimage.shift(tex, (-d * du, -d * dv), order=3, mode="reflect")
    return np.clip(views, 0, 1)


def _psnr(a, b):
    mse = float(np.mean((a.astype(np.float64) - b) ** 2))
    return 10 * np.log10(1.0 / mse)


def _sharpness(img):
    return float(np.mean(np.abs(ndimage.laplace(img.astype(np.float64)))))


@pytest.mark.parametrize("d", [2.0, -1.0, 0.0])
def test_integer_disparity_reproduces_texture_exactly(d):
    tex = _texture(smooth=0.0)  # white noise: the hardest case, exact for whole pixels
    lf = _one_plane_lf(tex, d)
    out = refocus(lf, d)
    m = int(abs(d) * 2) + 1
    np.testing.assert_allclose(out[m:-m, m:-m], tex[m:-m, m:-m], atol=2e-6)


@pytest.mark.parametrize("d", [0.5, 1.3, -0.7])
def test_subpixel_disparity_psnr_above_40db_and_blurred_elsewhere(d):
    tex = _texture(smooth=1.5)
    lf = _one_plane_lf(tex, d)
    centre = lf[2, 2]
    out = refocus(lf, d)
    m = 6
    inner = np.s_[m:-m, m:-m]
    assert _psnr(out[inner], centre[inner]) > 40.0
    for other in (d - 1.0, d + 1.5):
        off = refocus(lf, other)
        assert _psnr(off[inner], centre[inner]) < 30.0
        assert _sharpness(off[inner]) < 0.7 * _sharpness(out[inner])


def test_matches_per_view_scipy_shift_reference():
    """Reference: average of ``scipy.ndimage.shift(order=1)`` of each view (independent code)."""
    rng = np.random.default_rng(3)
    views = rng.random((3, 5, 40, 50)).astype(np.float32)
    d = 1.37
    ref = np.zeros((40, 50))
    for u in range(3):
        for v in range(5):
            ref += ndimage.shift(views[u, v], (d * (u - 1), d * (v - 2)), order=1, mode="constant")
    ref /= 15
    out = refocus(views, d)
    m = 4  # away from the border, where the reference darkens and ours renormalises
    np.testing.assert_allclose(out[m:-m, m:-m], ref[m:-m, m:-m], atol=1e-5)


def test_normalised_where_views_do_not_overlap():
    views = np.full((3, 3, 30, 40), 0.6, np.float32)
    out = refocus(views, 4.25)
    np.testing.assert_allclose(out, 0.6, atol=1e-6)  # no darkening at the borders


def test_colour_light_field_refocuses_each_channel():
    tex = _texture()
    lf = _one_plane_lf(tex, 1.0, grid=(3, 3))
    rgb = np.stack([lf, 0.5 * lf, 1 - lf], axis=-1)
    out = refocus(rgb, 1.0)
    assert out.shape == (*tex.shape, 3) and out.dtype == np.float32
    np.testing.assert_allclose(out[..., 0], refocus(lf, 1.0), atol=1e-6)
    np.testing.assert_allclose(out[..., 2], 1 - refocus(lf, 1.0), atol=1e-5)


def test_input_not_modified_and_output_in_range():
    rng = np.random.default_rng(1)
    views = rng.random((3, 3, 20, 24)).astype(np.float32)
    before = views.copy()
    out = refocus(views, 0.8)
    np.testing.assert_array_equal(views, before)
    assert out.dtype == np.float32 and out.min() >= 0 and out.max() <= 1


def test_threads_give_the_same_result():
    rng = np.random.default_rng(2)
    views = rng.random((9, 9, 64, 96)).astype(np.float32)
    np.testing.assert_array_equal(refocus(views, 1.1, workers=1), refocus(views, 1.1, workers=2))


def test_focal_stack_and_centre_view():
    tex = _texture()
    lf = LightField(_one_plane_lf(tex, 1.0, grid=(3, 3)))
    stack = focal_stack(lf, [0.0, 1.0, 2.0])
    assert stack.shape == (3, *tex.shape)
    np.testing.assert_array_equal(stack[1], refocus(lf, 1.0))
    assert [d for d, _ in iter_focal_stack(lf, [0.5, 1.5])] == [0.5, 1.5]
    np.testing.assert_array_equal(centre_view(lf), lf.views[1, 1])
    with pytest.raises(InputError, match="must not be empty"):
        focal_stack(lf, [])


@pytest.mark.parametrize("bad", [np.nan, np.inf, "x"])
def test_bad_disparity_raises(bad):
    views = np.zeros((3, 3, 10, 10), np.float32)
    with pytest.raises(InputError, match="slope_px_per_view"):
        refocus(views, bad)


def test_disparity_outside_the_light_field_raises():
    views = np.zeros((3, 3, 10, 10), np.float32)
    with pytest.raises(InputError, match="outside the light field's range"):
        refocus(views, 12.0)
