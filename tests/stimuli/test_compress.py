"""Compression to the prosthesis grid: paper sizes, and agreement with a loop reference."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli import jung2015
from stimuli.compress import block_mean, compress, compress_grey, grid_shape, quantize
from stimuli.errors import InputError


def test_eight_sizes_and_pixel_counts_match_paper() -> None:
    """Sec. 3.1: windows 1..40 on 492x327 give exactly the paper's sizes and pixel counts."""
    sizes = [grid_shape(jung2015.WORKING_SHAPE_PX, w) for w in jung2015.WINDOWS_PX]
    assert sizes == list(jung2015.RESOLUTIONS_PX)
    # the paper lists them as width x height
    paper_wxh = ["492x327", "246x164", "164x109", "98x65", "70x47", "38x25", "27x18", "12x8"]
    assert [f"{c}x{r}" for r, c in sizes] == paper_wxh
    assert [r * c for r, c in sizes] == [160884, 40344, 17876, 6370, 3290, 950, 486, 96]


def _reference_compress(edges: np.ndarray, window: int, ratio: float) -> np.ndarray:
    """Obviously correct reference: loop over every output cell, collect its pixels explicitly."""
    rows, cols = edges.shape
    n_r = max(1, int(rows / window + 0.5))
    n_c = max(1, int(cols / window + 0.5))
    out = np.zeros((n_r, n_c), dtype=bool)
    for i in range(n_r):
        r0 = int(i * rows / n_r + 0.5)
        r1 = int((i + 1) * rows / n_r + 0.5)
        for j in range(n_c):
            c0 = int(j * cols / n_c + 0.5)
            c1 = int((j + 1) * cols / n_c + 0.5)
            n_edge = 0
            n_all = 0
            for r in range(r0, r1):
                for c in range(c0, c1):
                    n_all += 1
                    n_edge += int(edges[r, c])
            out[i, j] = n_edge / n_all > ratio
    return out


@pytest.mark.parametrize(
    ("shape", "window"),
    [
        (shape, window)
        for shape in [(327, 492), (40, 61), (17, 23), (100, 100), (9, 130)]
        for window in jung2015.WINDOWS_PX
        if window <= min(shape)  # a window larger than the image has no cell to fill
    ],
)
def test_compress_matches_loop_reference(shape, window) -> None:
    """Vectorised compression equals the per-cell loop, including uneven windows."""
    rng = np.random.default_rng(shape[0] * 1000 + shape[1] * 10 + window)
    edges = rng.random(shape) < rng.uniform(0.02, 0.3)
    ratio = jung2015.EDGE_RATIO
    got = compress(edges, grid_shape(shape, window), edge_ratio=ratio)
    ref = _reference_compress(edges, window, ratio)
    np.testing.assert_array_equal(got, ref)


def test_windows_tile_the_image_without_loss() -> None:
    """Every pixel is counted once: the count-weighted mean of the cells is the image mean."""
    rng = np.random.default_rng(1)
    img = rng.random((327, 492)).astype(np.float32)
    for w in jung2015.WINDOWS_PX:
        shape = grid_shape(img.shape, w)
        from stimuli.compress import window_bounds

        rb, cb = window_bounds(327, shape[0]), window_bounds(492, shape[1])
        counts = np.outer(np.diff(rb), np.diff(cb))
        assert counts.sum() == img.size
        assert abs(np.diff(rb)).max() - w <= 1
        total = (block_mean(img, shape).astype(np.float64) * counts).sum()
        assert total == pytest.approx(img.astype(np.float64).sum(), rel=1e-5)


def test_all_zeros_give_all_off_and_strict_threshold() -> None:
    """Zero edges in -> all cells off; a cell exactly at the ratio stays off (strictly exceeds)."""
    assert not compress(np.zeros((327, 492), bool), (25, 38), edge_ratio=0.077).any()
    e = np.zeros((4, 4), bool)
    e[0, :2] = True  # 2 of 8 pixels in the left 4x2 window -> 0.25
    out = compress(e, (1, 2), edge_ratio=0.25)
    assert out.tolist() == [[False, False]]
    out = compress(e, (1, 2), edge_ratio=0.2)
    assert out.tolist() == [[True, False]]


def test_compress_does_not_modify_input() -> None:
    """Functions never modify their input (H6)."""
    e = np.random.default_rng(0).random((50, 60)) < 0.1
    before = e.copy()
    compress(e, (10, 12), edge_ratio=0.05)
    np.testing.assert_array_equal(e, before)


def test_quantize_levels() -> None:
    """Grey quantization to n levels uses exactly n equally spaced values including 0 and 1."""
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    for n in jung2015.GREY_LEVELS:
        q = quantize(x, n)
        np.testing.assert_allclose(np.unique(q), np.arange(n) / (n - 1), atol=1e-7)
    g = compress_grey(np.full((20, 30), 0.3, np.float32), (4, 6), grey_levels=2)
    assert g.shape == (4, 6) and np.all(g == 0.0)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: compress(np.zeros((4, 4)), (2, 2), edge_ratio=0.1), "edges must be a bool"),
        (lambda: compress(np.zeros((4, 4), bool), (2, 2), edge_ratio=1.5), "edge_ratio must"),
        (lambda: grid_shape((10, 10), 0), "window_px must be a positive integer"),
        (lambda: grid_shape((10, 10), 2.5), "window_px must be a positive integer"),
        (lambda: block_mean(np.zeros((4, 4)), (8, 2)), "cannot split 4 px into 8"),
        (lambda: block_mean(np.zeros(4), (1, 1)), "must be 2-D"),
        (lambda: quantize(np.zeros(3), 1), "grey_levels must be an integer >= 2"),
    ],
)
def test_compress_errors(call, match) -> None:
    """Bad arguments raise InputError naming the argument."""
    with pytest.raises(InputError, match=match):
        call()
