"""Numpy twins of the compiled loops a small scan runs after its answer, equal to the bit.

``confocal lightfield scan`` prints its planes before it refocuses (the plane sweep's numpy twin,
:mod:`stimuli.planesweep`); what it does next (one refocus per plane, the Sobel filter, the Otsu
histogram, the grid counts) would import numba and load its cache, which costs more CPU time than
the whole rest of the command on a capture of the shared Lytro size (ours: about 0.8-1.5 s of
numba start-up against tens of milliseconds of numpy work). Within :func:`numpy_kernels`, and
only while nothing has imported :mod:`stimuli.kernels`, the refocus and the Sobel filter run
here instead (the same float32 / float64 operations in the same order, so the images are the
same to the bit, tested against the compiled loops); the Otsu histogram and the grid counts take
their modules' own numpy paths.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

import numpy as np

__all__ = ["active", "numpy_kernels", "shift_add", "sobel"]

_ON = [False]


@contextlib.contextmanager
def numpy_kernels() -> Iterator[None]:
    """Within this block, :func:`active` is true while numba's loops are not loaded yet."""
    before = _ON[0]
    _ON[0] = True
    try:
        yield
    finally:
        _ON[0] = before


def active() -> bool:
    """Whether the twins here stand in for the compiled loops (see :func:`numpy_kernels`).

    Returns
    -------
    bool
        True within :func:`numpy_kernels` while :mod:`stimuli.kernels` is not imported.
    """
    return _ON[0] and "stimuli.kernels" not in sys.modules


def _add_shifted(acc: np.ndarray, src: np.ndarray, m: int, w: np.float32) -> None:
    """``acc[:, x] += w * src[:, x - m]`` wherever the index is inside (rows at once)."""
    cols = acc.shape[1]
    lo, hi = max(0, m), min(cols, cols + m)
    if hi > lo:
        acc[:, lo:hi] += w * src[:, lo - m : hi - m]


def _add_two_taps(acc: np.ndarray, src: np.ndarray, m: int, wa, wb) -> None:
    """``acc[:, x] += wa * src[:, x - m] + wb * src[:, x - m - 1]``, as the compiled loop."""
    cols = acc.shape[1]
    lo, hi = max(0, m + 1), min(cols, cols + m)
    if hi <= lo:
        _add_shifted(acc, src, m, wa)
        _add_shifted(acc, src, m + 1, wb)
        return
    acc[:, lo:hi] += wa * src[:, lo - m : hi - m] + wb * src[:, lo - m - 1 : hi - m - 1]
    if m >= 0:
        acc[:, m] += wa * src[:, 0]
    else:
        acc[:, cols + m] += wb * src[:, cols - 1]


def shift_add(
    views: np.ndarray,
    row_taps: tuple[np.ndarray, np.ndarray, np.ndarray],
    col_taps: tuple[np.ndarray, np.ndarray, np.ndarray],
    inv_rows: np.ndarray,
    inv_cols: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """Refocus grey float32 ``views`` (n_u, n_v, rows, cols) into ``out``, as the compiled loop.

    The twin of :func:`stimuli.kernels.shift_add_rows` over all rows: per output row, view by
    view in the same order, the same float32 products and sums; then the inverse weights and
    the clip to [0, 1].

    Parameters
    ----------
    views : ndarray, float32, C-contiguous
    row_taps, col_taps : tuple of ndarray
        Per view row / column: the first tap's integer shift, its weight, the next tap's weight.
    inv_rows, inv_cols : ndarray, float32
        One over the number of contributing views per row / column.
    out : ndarray, float32, (rows, cols)
        Written and returned.

    Returns
    -------
    ndarray
        ``out``.
    """
    n_u, n_v, rows, cols = views.shape
    row_m, row_w0, row_w1 = row_taps
    col_m, col_w0, col_w1 = col_taps
    acc = np.zeros((rows, cols), dtype=np.float32)
    y = np.arange(rows)
    zero = np.float32(0.0)
    for u in range(n_u):
        ya = y - int(row_m[u])
        yb = ya - 1
        wa = np.where((ya >= 0) & (ya < rows), row_w0[u], zero)
        wb = np.where((yb >= 0) & (yb < rows), row_w1[u], zero)
        both = np.flatnonzero((wa != 0) & (wb != 0))
        only_a = np.flatnonzero((wa != 0) & (wb == 0))
        only_b = np.flatnonzero((wa == 0) & (wb != 0))
        for v in range(n_v):
            ga, gb, m = col_w0[v], col_w1[v], int(col_m[v])
            view = views[u, v]
            if both.size:
                part = acc[both]
                _add_two_taps(part, view[ya[both]], m, row_w0[u] * ga, row_w0[u] * gb)
                _add_two_taps(part, view[yb[both]], m, row_w1[u] * ga, row_w1[u] * gb)
                acc[both] = part
            for rows_, src_rows, w in ((only_a, ya, row_w0[u]), (only_b, yb, row_w1[u])):
                if not rows_.size:
                    continue
                part = acc[rows_]
                src = view[src_rows[rows_]]
                if gb == 0.0:
                    _add_shifted(part, src, m, w * ga)
                elif ga == 0.0:
                    _add_shifted(part, src, m + 1, w * gb)
                else:
                    _add_two_taps(part, src, m, w * ga, w * gb)
                acc[rows_] = part
    acc *= inv_rows[:, None]
    acc *= inv_cols[None, :]
    np.clip(acc, zero, np.float32(1.0), out=out)
    return out


def _magnitude(gy: np.ndarray, gx: np.ndarray) -> np.ndarray:
    fy, fx = gy.astype(np.float32), gx.astype(np.float32)
    return np.sqrt(fy * fy + fx * fx) / np.float32(np.sqrt(np.float32(2.0)))


def sobel(img: np.ndarray, out: np.ndarray) -> int:
    """Sobel magnitude of a float32 image into ``out``; the number of values outside [0, 1].

    The twin of :func:`stimuli.kernels.sobel_rows` over all rows: the directional sums in
    float64 (exact), rounded to float32, then the float32 magnitude.

    Parameters
    ----------
    img : ndarray, float32, (rows, cols)
    out : ndarray, float32, (rows, cols)
        Written.

    Returns
    -------
    int
        Pixels outside [0, 1] or NaN.
    """
    rows, cols = img.shape
    outside = int(np.count_nonzero(~((img >= 0.0) & (img <= 1.0))))
    f = img.astype(np.float64)
    up = np.concatenate([f[:1], f[:-1]])
    down = np.concatenate([f[1:], f[-1:]])
    smooth = 0.25 * up + 0.5 * f + 0.25 * down
    diff = up - down
    if cols == 1:
        out[:, 0] = _magnitude(diff[:, 0], np.zeros(rows))
        return outside
    out[:, 0] = _magnitude(0.75 * diff[:, 0] + 0.25 * diff[:, 1], smooth[:, 0] - smooth[:, 1])
    out[:, -1] = _magnitude(0.25 * diff[:, -2] + 0.75 * diff[:, -1], smooth[:, -2] - smooth[:, -1])
    if cols > 2:
        gy = 0.25 * diff[:, :-2] + 0.5 * diff[:, 1:-1] + 0.25 * diff[:, 2:]
        out[:, 1:-1] = _magnitude(gy, smooth[:, :-2] - smooth[:, 2:])
    return outside
