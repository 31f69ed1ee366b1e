"""Depth-plane detection: Haar sub-bands, the 0.5 % rule, overlap score, peaks, scans."""

from __future__ import annotations

import json

import numpy as np
import pytest
import pywt
from scipy import ndimage

from stimuli.errors import InputError
from stimuli.lightfield import Geometry, LightField
from stimuli.planes import (
    MIN_PROMINENCE_FRACTION,
    PlaneScan,
    auto_binning,
    default_disparities,
    edge_overlap,
    estimate_disparity_range,
    find_object_planes,
    haar_details,
    haar_edges,
    iter_plane_scores,
    score_peaks,
)


@pytest.mark.parametrize("shape", [(8, 10), (33, 47), (64, 64)])
def test_haar_details_match_pywavelets(shape):
    """Reference: ``pywt.dwt2(image, 'haar')`` (independent implementation), even-size crop."""
    rng = np.random.default_rng(0)
    img = rng.random(shape).astype(np.float32)
    r, c = shape[0] // 2 * 2, shape[1] // 2 * 2
    _, (c_h, c_v, c_d) = pywt.dwt2(img[:r, :c].astype(np.float64), "haar")
    ours = haar_details(img)
    for a, b in zip(ours, (c_h, c_v, c_d), strict=True):
        np.testing.assert_allclose(np.abs(a), np.abs(b), atol=1e-6)


def test_haar_edges_keep_half_a_percent_of_each_band():
    rng = np.random.default_rng(1)
    img = rng.random((200, 300)).astype(np.float32)
    n = 100 * 150
    k = int(np.ceil(0.005 * n))
    for band in (0, 1, 2):
        e = haar_edges(img, bands=(band,))
        assert e.sum() == k  # continuous values: no ties
    union = haar_edges(img)
    assert k < union.sum() <= 3 * k


def test_haar_edges_of_a_flat_image_are_empty_and_step_edge_is_found():
    assert not haar_edges(np.full((20, 20), 0.3, np.float32)).any()
    img = np.zeros((40, 40), np.float32)
    img[:, 21:] = 1.0  # vertical step between columns 20 and 21: inside Haar block 10
    e = haar_edges(img, bands=(1,))
    assert e[:, 10].all() and e.sum() == 20


def test_haar_edges_bad_arguments():
    with pytest.raises(InputError, match="fraction must be in"):
        haar_edges(np.zeros((4, 4)), fraction=0.0)
    with pytest.raises(InputError, match="bands must be"):
        haar_edges(np.zeros((4, 4)), bands=(3,))
    with pytest.raises(InputError, match="at least 2x2"):
        haar_details(np.zeros((1, 5)))


def test_edge_overlap():
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    a[0, :4] = True
    b[0, :2] = True
    assert edge_overlap(a, b) == 0.5
    assert edge_overlap(np.zeros((4, 4), bool), b) == 0.0
    with pytest.raises(InputError, match="differ in shape"):
        edge_overlap(a, b[:2])


def test_score_peaks_prominence_rule():
    x = np.linspace(0, 1, 101)
    s = np.exp(-(((x - 0.3) / 0.03) ** 2)) + 0.5 * np.exp(-(((x - 0.7) / 0.03) ** 2))
    s += 0.02 * np.sin(x * 200)  # wiggles far below 10 % of the range
    idx, prom = score_peaks(s)
    assert list(idx) == [30, 70]
    assert np.all(prom >= MIN_PROMINENCE_FRACTION * (s.max() - s.min()))
    # a maximum at the end of the scan is not a peak
    idx, _ = score_peaks(np.linspace(0, 1, 20))
    assert idx.size == 0
    assert score_peaks(np.ones(10))[0].size == 0
    with pytest.raises(InputError, match="at least 3 planes"):
        score_peaks(np.ones(2))
    with pytest.raises(InputError, match="NaN"):
        score_peaks(np.array([0.0, np.nan, 1.0]))


def _two_plane_lf(d_near=3.0, d_far=-1.0, grid=(5, 5), shape=(240, 320), seed=0):
    """A textured square at ``d_near`` in front of a textured wall at ``d_far``."""
    rng = np.random.default_rng(seed)
    wall = ndimage.gaussian_filter(rng.random(shape), 1.0)
    wall = 0.1 + 0.4 * (wall - wall.min()) / np.ptp(wall)
    square = ndimage.gaussian_filter(rng.random(shape), 1.0)
    square = 0.5 + 0.5 * (square - square.min()) / np.ptp(square)
    mask = np.zeros(shape)
    mask[70:170, 100:220] = 1.0
    n_u, n_v = grid
    views = np.empty((n_u, n_v, *shape), np.float32)
    for u in range(n_u):
        for v in range(n_v):
            du, dv = u - n_u // 2, v - n_v // 2
            w = ndimage.shift(wall, (-d_far * du, -d_far * dv), order=1, mode="reflect")
            s = ndimage.shift(square, (-d_near * du, -d_near * dv), order=1, mode="reflect")
            m = ndimage.shift(mask, (-d_near * du, -d_near * dv), order=1)
            views[u, v] = m * s + (1 - m) * w
    return LightField(np.clip(views, 0, 1))


@pytest.mark.parametrize("method", ["agreement", "haar"])
def test_two_planes_give_two_peaks_at_their_disparities(method):
    lf = _two_plane_lf()
    ds = np.linspace(-3, 5, 81)  # step 0.1
    scan = find_object_planes(lf, ds, binning=1, method=method)
    assert scan.method == method
    found = sorted(p.disparity_px for p in scan.peaks)
    assert len(found) == 2, found
    assert found[0] == pytest.approx(-1.0, abs=0.1 + 1e-9)  # one plane step
    assert found[1] == pytest.approx(3.0, abs=0.1 + 1e-9)
    assert [p.disparity_px for p in scan.peaks] == sorted(found, reverse=True)  # nearest first


def test_scan_is_the_same_with_threads_and_as_a_generator():
    lf = _two_plane_lf(grid=(3, 3), shape=(160, 200))
    ds = np.linspace(-2, 4, 13)
    one = find_object_planes(lf, ds, workers=1, binning=1, method="haar")
    two = find_object_planes(lf, ds, workers=2, binning=1, method="haar")
    np.testing.assert_array_equal(one.scores, two.scores)
    gen = [s for _, _, s in iter_plane_scores(lf, ds, workers=1, binning=1)]
    np.testing.assert_array_equal(gen, one.scores)
    one = find_object_planes(lf, ds, workers=1, binning=1)
    two = find_object_planes(lf, ds, workers=2, binning=1)
    np.testing.assert_array_equal(one.scores, two.scores)
    np.testing.assert_array_equal(one.null_scores, two.null_scores)


def test_plane_scan_round_trip_and_rows():
    g = Geometry(kind="camera_array", focal_length_px=100.0, baseline_m=0.03, near_m=0.5, far_m=20)
    lf = LightField(_two_plane_lf(grid=(3, 3), shape=(160, 200)).views, g)
    for method in ("agreement", "haar"):
        scan = find_object_planes(lf, np.linspace(0.5, 5, 40), binning=1, method=method)
        again = PlaneScan.from_dict(json.loads(json.dumps(scan.to_dict())))
        np.testing.assert_array_equal(again.scores, scan.scores)
        np.testing.assert_allclose(again.depths_m, scan.depths_m)
        assert again.method == method
        assert [p.disparity_px for p in again.peaks] == [p.disparity_px for p in scan.peaks]
        rows = scan.rows()
        assert len(rows) == 40 and set(rows[0]) == {
            "index",
            "depth_m",
            "disparity_px",
            "score",
            "null_score",
            "peak",
            "support",
            "prominence",
            "evidence",
        }
        assert rows[0]["depth_m"] == pytest.approx(3.0 / 0.5)
        assert sum(r["peak"] for r in rows) == len(scan.peaks) >= 1
        for r in rows:
            assert (r["support"] != "") == (r["peak"] == 1 and method == "agreement")


def test_default_disparities_come_from_the_data():
    """The default range is the span the scene occupies, not a constant:
    two planes at -1 and 3 px per view step give a range that holds both with a margin of at
    most two coarse steps, and a geometry's near/far clips it. With a few planes far apart the
    censored end planes lie a spacing beyond both planes; with the default 200, the planes are
    the range's."""
    lf = _two_plane_lf(grid=(5, 5), shape=(200, 260))
    lo, hi = estimate_disparity_range(lf)
    assert -2.6 <= lo < -1.0 and 3.0 < hi <= 4.6, (lo, hi)
    ds = default_disparities(lf, 11)
    spacing = ds[1] - ds[0]
    assert ds.size == 11 and ds[0] <= min(lo, -1.0 - spacing) and ds[-1] >= max(hi, 3.0 + spacing)
    np.testing.assert_array_equal(default_disparities(lf), np.linspace(lo, hi, 200))
    g = Geometry(kind="camera_array", focal_length_px=100.0, baseline_m=0.01, near_m=0.5, far_m=2)
    lo2, hi2 = estimate_disparity_range(LightField(lf.views, g))
    assert (lo2, hi2) == pytest.approx((0.5, 2.0))  # 1 px at 1 m: depths 0.5-2 m
    with pytest.raises(InputError, match="n_planes"):
        default_disparities(lf, 2)
    with pytest.raises(InputError, match="agree at no plane"):
        estimate_disparity_range(LightField(np.full((3, 3, 80, 80), 0.5, np.float32)))


def test_peak_at_the_edge_of_the_range_warns():
    lf = _two_plane_lf()
    with pytest.warns(UserWarning, match="beyond the scanned range"):
        scan = find_object_planes(lf, np.linspace(-3, 2.0, 51), binning=1)
    assert [round(p.disparity_px) for p in scan.peaks] == [-1]


def test_a_single_texture_at_one_depth_is_one_plane_with_evidence():
    """One textured wall: exactly one plane, with its support and a null far below it."""
    rng = np.random.default_rng(3)
    tex = ndimage.gaussian_filter(rng.random((200, 300)), 1.0).astype(np.float32)
    tex = (tex - tex.min()) / np.ptp(tex)
    views = np.stack(
        [
            np.stack([ndimage.shift(tex, (0, -1.5 * (v - 3)), order=1, mode="reflect")])
            for v in range(7)
        ],
        axis=1,
    )[0][None]
    lf = LightField(np.clip(views, 0, 1).astype(np.float32))
    scan = find_object_planes(lf, np.linspace(-4, 5, 91))
    assert len(scan.peaks) == 1
    (p,) = scan.peaks
    assert p.disparity_px == pytest.approx(1.5, abs=0.1)
    assert p.support > 0.5 and p.evidence >= 2.0
    assert scan.null_scores.max() < 0.1 * scan.scores.max()


def test_small_views_warn_and_auto_binning_avoids_it():
    lf = LightField(np.random.default_rng(0).random((3, 3, 60, 80)).astype(np.float32))
    with pytest.warns(UserWarning, match="edge pixels per Haar sub-band"):
        find_object_planes(lf, np.linspace(-1, 1, 5), binning=2, method="haar")
    assert auto_binning(lf) == 1
    assert auto_binning(LightField(np.zeros((3, 3, 400, 400), np.float32))) == 2


def test_scan_arguments_checked():
    lf = LightField(np.zeros((3, 3, 40, 40), np.float32))
    with pytest.raises(InputError, match="at least 3 planes"):
        find_object_planes(lf, [0.0, 1.0])
    with pytest.raises(InputError, match="presmooth_px"):
        find_object_planes(lf, [0.0, 0.5, 1.0], presmooth_px=-1, binning=1, method="haar")
    with pytest.raises(InputError, match="method must be one of"):
        find_object_planes(lf, [0.0, 0.5, 1.0], method="sobel")
    with pytest.raises(InputError, match="binning must be"):
        find_object_planes(lf, [0.0, 0.5, 1.0], binning=0)


def test_equal_tops_of_one_hill_are_one_plane() -> None:
    """Two equal maxima with a shallow dip between them are one plane; a deep dip keeps two."""
    from stimuli.planes import score_peaks

    x = np.linspace(0, 1, 201)
    hill = np.exp(-0.5 * ((x - 0.5) / 0.1) ** 2)
    shallow = hill - 0.02 * np.exp(-0.5 * ((x - 0.5) / 0.01) ** 2)  # twin tops, 2 % dip
    idx, prom = score_peaks(shallow)
    assert len(idx) == 1 and abs(x[idx[0]] - 0.5) < 0.006  # the flat top's middle
    assert prom[0] > 0.9
    two = np.exp(-0.5 * ((x - 0.3) / 0.05) ** 2) + np.exp(-0.5 * ((x - 0.7) / 0.05) ** 2)
    idx, _ = score_peaks(two)
    assert np.allclose(x[idx], [0.3, 0.7], atol=0.01)


def test_range_outside_the_geometry_is_refused():
    """A scene the geometry's near/far cannot hold: one line saying the range is empty."""
    lf = _two_plane_lf(d_near=-1.0, d_far=-1.0, grid=(5, 5), shape=(160, 200))
    g = Geometry(kind="camera_array", focal_length_px=100.0, baseline_m=0.01, near_m=0.5, far_m=2)
    with pytest.raises(InputError, match="estimated disparity range is empty"):
        estimate_disparity_range(LightField(lf.views, g))


def test_median_spacing_is_numpys_median_of_the_gaps():
    from stimuli.planescan import median_spacing

    rng = np.random.default_rng(5)
    for n in range(2, 40):
        d = np.cumsum(rng.random(n) * rng.choice([1e-3, 1.0, 7.0], n)) * rng.choice([-1, 1])
        assert median_spacing(d) == float(np.median(np.abs(np.diff(d))))
    assert np.isnan(median_spacing(np.array([1.0])))
