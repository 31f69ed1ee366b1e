"""Compression to the prosthesis grid: non-overlapping windows (Jung et al. 2015, Sec. 2.2).

How windows are formed
----------------------
An image of ``L`` pixels along an axis compressed with window ``w`` gets ``n = round(L / w)``
cells along that axis (round half up), which for the paper's 492x327 images gives exactly the
paper's eight sizes. Cell ``i`` covers pixels ``[round(i * L / n), round((i + 1) * L / n))``:
the ``n`` windows tile the image with no gaps and no overlap, and where ``w`` does not divide
``L`` the windows are ``floor(L / n)`` or ``ceil(L / n)`` pixels wide, spread evenly (for 492
with w = 13: 38 windows of 12 or 13 px). No pixel is dropped and none counted twice.

A binary cell is 1 (white) when the fraction of edge pixels in its window *exceeds* the edge
ratio (strictly greater), else 0.
"""

from __future__ import annotations

import numpy as np

from stimuli.errors import InputError

__all__ = [
    "grid_shape",
    "window_bounds",
    "block_mean",
    "compress",
    "compress_grey",
    "quantize",
    "resolution_ladder",
]


def _round_half_up(x: float) -> int:
    return int(np.floor(x + 0.5))


def grid_shape(shape_px: tuple[int, int], window_px: int) -> tuple[int, int]:
    """Return the compressed size ``(rows, cols)`` for an image of ``shape_px`` and a window.

    Parameters
    ----------
    shape_px : (rows, cols)
        Size of the full-resolution image, pixels.
    window_px : int
        Window side, pixels (1 = no compression).

    Returns
    -------
    (rows, cols)
        ``(round(rows / w), round(cols / w))``, rounding half up, each at least 1.

    Examples
    --------
    >>> grid_shape((327, 492), 13)
    (25, 38)
    """
    rows, cols = (int(v) for v in shape_px)
    if isinstance(window_px, bool) or not isinstance(window_px, (int, np.integer)):
        raise InputError(f"window_px must be a positive integer, got {window_px!r}")
    if window_px < 1:
        raise InputError(f"window_px must be a positive integer, got {window_px!r}")
    if rows < 1 or cols < 1:
        raise InputError(f"shape_px must be positive, got {shape_px!r}")
    return (max(1, _round_half_up(rows / window_px)), max(1, _round_half_up(cols / window_px)))


def window_bounds(length_px: int, n_cells: int) -> np.ndarray:
    """Return the ``n_cells + 1`` window boundaries ``round(i * length / n)`` along one axis."""
    if n_cells < 1 or n_cells > length_px:
        raise InputError(f"cannot split {length_px} px into {n_cells} windows")
    i = np.arange(n_cells + 1, dtype=np.float64)
    return np.floor(i * length_px / n_cells + 0.5).astype(np.intp)


def block_mean(image: np.ndarray, shape_px: tuple[int, int]) -> np.ndarray:
    """Average an image over the non-overlapping windows of a ``shape_px`` grid.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), bool or float
    shape_px : (rows, cols)
        Output grid size; at most the image size.

    Returns
    -------
    ndarray of shape ``shape_px``, float32
        Mean of each window (for a bool image: its fraction of True pixels).
    """
    a = np.asarray(image)
    if a.ndim != 2:
        raise InputError(f"image must be 2-D (rows, cols), got shape {a.shape}")
    n_r, n_c = (int(v) for v in shape_px)
    rb = window_bounds(a.shape[0], n_r)
    cb = window_bounds(a.shape[1], n_c)
    from stimuli import numpykernels

    nonempty = bool((np.diff(rb) > 0).all() and (np.diff(cb) > 0).all())
    # whole counts, exact: one compiled pass over the bytes; in a scan's last steps the sums
    # below instead (whole numbers in float64, exact: the same counts)
    if a.dtype == bool and not (numpykernels.active() and nonempty):
        from stimuli.kernels import count_blocks

        counts_on = np.zeros((n_r, n_c), dtype=np.int64)
        count_blocks(np.ascontiguousarray(a).view(np.uint8), rb, cb, counts_on)
        sums = counts_on.astype(np.float64)
    else:
        sums = np.add.reduceat(a.astype(np.float64, copy=False), rb[:-1], axis=0)
        sums = np.add.reduceat(sums, cb[:-1], axis=1)
    counts = np.outer(np.diff(rb), np.diff(cb))
    return (sums / counts).astype(np.float32)


def compress(edges: np.ndarray, shape_px: tuple[int, int], *, edge_ratio: float) -> np.ndarray:
    """Compress a binary edge image to a ``shape_px`` grid of on/off cells.

    Parameters
    ----------
    edges : ndarray of shape (rows, cols), bool
        Edge image (True = edge pixel).
    shape_px : (rows, cols)
        Output grid; use :func:`grid_shape` to get it from a window size.
    edge_ratio : float in [0, 1)
        A cell is on when the fraction of edge pixels in its window exceeds this
        (Jung et al. 2015 used the mean edge fraction of the wide-DOF set, 1/13).

    Returns
    -------
    ndarray of shape ``shape_px``, bool

    References
    ----------
    Jung et al. (2015), Sec. 2.2 and Fig. 3.
    """
    e = np.asarray(edges)
    if e.dtype != bool:
        raise InputError(f"edges must be a bool image, got dtype {e.dtype}")
    if not (0.0 <= float(edge_ratio) < 1.0):
        raise InputError(f"edge_ratio must be in [0, 1), got {edge_ratio!r}")
    return block_mean(e, shape_px) > np.float32(edge_ratio)


def quantize(image: np.ndarray, grey_levels: int) -> np.ndarray:
    """Quantize a [0, 1] image to ``grey_levels`` equally spaced grey levels (0 and 1 included).

    Parameters
    ----------
    image : ndarray, float in [0, 1]
    grey_levels : int >= 2

    Returns
    -------
    ndarray, float32
        Values ``k / (grey_levels - 1)``, ``k = min(floor(x * grey_levels), grey_levels - 1)``.
    """
    n = grey_levels
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise InputError(f"grey_levels must be an integer >= 2, got {n!r}")
    a = np.asarray(image, dtype=np.float32)
    k = np.minimum(np.floor(a * n), n - 1)
    return (k / (n - 1)).astype(np.float32)


def compress_grey(image: np.ndarray, shape_px: tuple[int, int], *, grey_levels: int) -> np.ndarray:
    """Compress a grey photo to a ``shape_px`` grid of ``grey_levels`` grey levels (Fig. 2).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    shape_px : (rows, cols)
    grey_levels : int >= 2

    Returns
    -------
    ndarray of shape ``shape_px``, float32 in [0, 1]
    """
    return quantize(block_mean(image, shape_px), grey_levels)


def resolution_ladder(
    shape_px: tuple[int, int], windows_px: tuple[int, ...]
) -> list[tuple[int, tuple[int, int]]]:
    """Return ``[(window_px, (rows, cols)), ...]`` sorted from fewest pixels to most."""
    ladder = [(int(w), grid_shape(shape_px, int(w))) for w in windows_px]
    return sorted(ladder, key=lambda t: (t[1][0] * t[1][1], -t[0]))
