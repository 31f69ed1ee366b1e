"""The agreement sweep, compiled and in numpy: against a plain float64 numpy + scipy.ndimage
version of the same sums, and against each other (equal to the bit)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import uniform_filter

import stimuli.agreementscan as agreementscan
from stimuli.agreementscan import (
    AGREEMENT_RATIO,
    COST_WINDOW_PX,
    MIN_CONTRAST,
    _scan_inputs,
    _sweep,
)
from stimuli.lfsynth import render_camera_array, three_plane_scene

#: Costs this close (float64, here) are the same cost in the sweep's float32 sums.
TIE_TOLERANCE = 1e-6


def _reference_costs(views, offsets, ref, ds):
    """Cost of every plane (n_planes, rows, cols), written for clarity, in float64.

    Each view is sampled at ``x - d step`` along its axis (linear interpolation, its end samples
    repeated beyond it); the cost is the sum over views of the absolute differences from
    ``ref``, averaged over a box (the image's end rows and columns repeated).
    """
    out = []
    for d in ds:
        cost = np.zeros(ref.shape)
        for img, (du, dv) in zip(views, offsets, strict=True):
            axis, step = (0, du) if du else (1, dv)
            n = img.shape[axis]
            pos = np.arange(n) - d * step
            lo = np.floor(pos).astype(int)
            f = (pos - lo)[:, None] if axis == 0 else (pos - lo)[None, :]
            a = np.take(img, np.clip(lo, 0, n - 1), axis=axis).astype(np.float64)
            b = np.take(img, np.clip(lo + 1, 0, n - 1), axis=axis).astype(np.float64)
            cost += np.abs(a + f * (b - a) - ref)
        out.append(uniform_filter(cost, COST_WINDOW_PX, mode="nearest"))
    return np.stack(out)


@pytest.mark.parametrize("path", ["compiled", "numpy"])
@pytest.mark.parametrize(
    ("grid", "shape"), [((5, 5), (90, 120)), ((1, 7), (80, 100)), ((3, 3), (100, 90))]
)
def test_sweep_matches_the_reference(grid, shape, path, monkeypatch):
    monkeypatch.setattr(agreementscan, "SWEEP_PATH", path)
    lf = render_camera_array(three_plane_scene(shape), grid=grid, shape_px=shape, baseline_m=0.03)
    _, views, offsets, centre, null_centre = _scan_inputs(lf, 1)
    g = lf.geometry
    ds = np.linspace(g.disparity_px(12.0), g.disparity_px(0.8), 60)
    got = _sweep(views, offsets, centre, null_centre, ds, 2)
    rows, cols = centre.shape
    my = max(abs(du) for du, _ in offsets)
    mx = max(abs(dv) for _, dv in offsets)
    yy = np.minimum(np.arange(rows), rows - 1 - np.arange(rows))[:, None]  # to the nearest edge
    xx = np.minimum(np.arange(cols), cols - 1 - np.arange(cols))[None, :]
    for r, ref in enumerate((centre, null_centre)):
        costs = _reference_costs(views, offsets, ref.astype(np.float64), ds)
        best_i, agrees = got[2 * r], got[2 * r + 1]
        chosen = np.take_along_axis(costs, best_i[None].astype(np.int64), 0)[0]
        # The chosen plane is a plane of least cost (ties, common in flat regions, are broken
        # by rounding: float32 sums here, float64 there).
        np.testing.assert_allclose(chosen, costs.min(axis=0), atol=2e-5)
        mean = costs.mean(axis=0)
        reach = np.abs(ds)[best_i]  # views sampled inside their image at the chosen plane
        # a least cost reached at two planes or more (a flat box at those shifts) gives no vote
        tied = (costs <= costs.min(axis=0) + TIE_TOLERANCE).sum(axis=0) > 1
        expected = (
            (chosen < AGREEMENT_RATIO * mean)
            & (mean > MIN_CONTRAST * len(offsets))
            & (reach * my <= yy)
            & (reach * mx <= xx)
            & ~tied
        )
        assert np.mean(agrees == expected) > 0.999
        assert np.count_nonzero(agrees) >= 20  # not a vacuous comparison


@pytest.mark.parametrize(
    ("grid", "shape", "span"),
    [
        ((5, 5), (90, 120), (-6.0, 4.0)),
        ((1, 7), (40, 150), (-3.3, 2.9)),  # columns only
        ((7, 1), (150, 40), (-2.2, 3.7)),  # rows only
        ((3, 3), (23, 31), (-9.5, 9.5)),  # shifts far beyond the image
        ((9, 9), (3, 4), (-0.7, 0.4)),  # smaller than the cost box
    ],
)
def test_numpy_sweep_equals_the_compiled_sweep_to_the_bit(grid, shape, span, monkeypatch):
    rng = np.random.default_rng(sum(shape))
    views = rng.random((*grid, *shape), dtype=np.float32)
    views[..., : shape[0] // 2, :] *= np.float32(0.25)  # some contrast structure
    from stimuli.lightfield import LightField

    lf = LightField(views)
    _, sv, offsets, centre, null_centre = _scan_inputs(lf, 1)
    ds = np.linspace(*span, 37)
    got = {}
    for path in ("compiled", "numpy"):
        monkeypatch.setattr(agreementscan, "SWEEP_PATH", path)
        for workers in (1, 3):
            got[path, workers] = _sweep(sv, offsets, centre, null_centre, ds, workers)
    for workers in (1, 3):
        for a, b in zip(got["compiled", workers], got["numpy", workers], strict=True):
            np.testing.assert_array_equal(a, b)
    assert len(np.unique(got["numpy", 1][0])) > 3  # the best plane varies: not a flat answer


def test_auto_sweep_is_numpy_only_for_a_small_answer_before_compiled_code_runs(monkeypatch):
    import sys

    def home(fn) -> str:
        return getattr(fn, "py_func", fn).__module__

    import stimuli.kernels  # noqa: F401 - loaded, as after any compiled call

    monkeypatch.setattr(agreementscan, "SWEEP_PATH", "auto")
    small, large = 10**6, agreementscan.NUMPY_SWEEP_MAX_WORK + 1
    with agreementscan.answer_before_compiled_code():
        assert home(agreementscan._sweep_function(small)) == "stimuli.kernels"  # loaded
    monkeypatch.delitem(sys.modules, "stimuli.kernels")
    with agreementscan.answer_before_compiled_code():
        assert home(agreementscan._sweep_function(small)) == "stimuli.planesweep"
    assert home(agreementscan._sweep_function(small)) == "stimuli.kernels"  # outside the block
    monkeypatch.delitem(sys.modules, "stimuli.kernels")
    with agreementscan.answer_before_compiled_code():
        assert home(agreementscan._sweep_function(large)) == "stimuli.kernels"
    monkeypatch.setattr(agreementscan, "SWEEP_PATH", "gpu")
    with pytest.raises(ValueError, match="SWEEP_PATH"):
        agreementscan._sweep_function(small)


def test_pixels_that_match_many_planes_equally_do_not_pile_up_at_the_range_end():
    """The paper's scene on a 9x9 array: the building's flat walls, seen through a 5x5 box, match
    every plane from the far end of the range to the building's equally; such pixels once voted
    for the first plane scanned (15 % of the pixels), a false "widen the range" warning."""
    import warnings

    from stimuli.planes import find_object_planes

    shape = (327, 492)
    lf = render_camera_array(three_plane_scene(shape), grid=(9, 9), shape_px=shape, baseline_m=0.03)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no pile-up warning at either end
        scan = find_object_planes(lf)
    truth = [lf.geometry.disparity_px(z) for z in (1.0, 4.0, 9.0)]  # pedestrian, tree, building
    np.testing.assert_allclose([p.disparity_px for p in scan.peaks], truth, atol=0.1)
