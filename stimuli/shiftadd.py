"""The compiled shift-and-add of :mod:`stimuli.refocus`: one pass over the views, separable.

A view shifted by a constant ``s = n + f`` pixels with linear interpolation adds
``(1 - f) I(x - n) + f I(x - n - 1)``, the same two weights on every pixel, so the shift of a
whole grid is separable (as in the numpy path of :mod:`stimuli.refocus`): the views of each grid
row ``u`` are summed with their column shifts into a partial image, and the partial images are
summed with their row shifts. :func:`shift_add_rows` makes the output :data:`ROW_BLOCK` rows at a
time: for each grid row, the partial image's rows that the block needs (``ROW_BLOCK + 1`` at
most) are summed from the views' rows, each view's rows read as one run, and added with the
row taps into the block's sums; both buffers stay in the L2 cache while every view is read from
memory once. The inner loops run over contiguous columns with unsigned indices (no
negative-index test, so they vectorise), and the views of a grid row are added in groups of four
or three in one loop over the columns where all their taps fall inside the views (one load and
store of the partial row per group); the few columns at the edges where a tap falls outside
take each view's taps in turn (one scalar loop when they are narrow).

The sums are made in ``float32`` in the numpy path's order, per pixel: the views in order, each
view's first tap before its second, then the grid rows in order, then the row and column
normalisers and the clip to [0, 1] (multiplication and addition, never fused), so the compiled
and numpy images are equal to the bit (tested).

Importing this module imports numba and :mod:`stimuli.kernels` (whose presence marks the
compiled loops as loaded for :func:`stimuli.numpykernels.active` and the plane sweep's choice).
"""

from __future__ import annotations

import numpy as np
from numba import njit, uint64

import stimuli.kernels  # noqa: F401  (marks the compiled loops as loaded: see the docstring)

__all__ = ["shift_add_rows", "ROW_BLOCK"]

#: Output rows made together by :func:`shift_add_rows` (ours, measured on 2 cores with 9x9,
#: 7x7, 3x3 and 1x7 grids: 32 rows keep each view's run long, 64 KB for a 492-pixel row, while
#: the block's sums and partial rows, 2 x 32 rows of float32, stay in the L2 cache).
ROW_BLOCK = 32


@njit(nogil=True, cache=True, inline="always")
def _span(dst, d0, src, s0, n, w):  # pragma: no cover - compiled
    """``dst[d0 + i] += w * src[s0 + i]`` for ``i < n`` (unsigned indices: no wrap test)."""
    a = uint64(d0)
    b = uint64(s0)
    for i in range(uint64(n)):
        dst[a + i] = dst[a + i] + w * src[b + i]


@njit(nogil=True, cache=True, inline="always")
def _span2(dst, d0, src, s0, s1, n, wa, wb):  # pragma: no cover - compiled
    """``dst[d0 + i] = (dst[d0 + i] + wa * src[s0 + i]) + wb * src[s1 + i]`` for ``i < n``."""
    a = uint64(d0)
    b = uint64(s0)
    c = uint64(s1)
    for i in range(uint64(n)):
        dst[a + i] = (dst[a + i] + wa * src[b + i]) + wb * src[c + i]


@njit(nogil=True, cache=True, inline="always")
def _span4(dst, d0, src, s0, s1, s2, s3, n, wa, wb, wc, wd):  # pragma: no cover - compiled
    """Four taps added in turn: ``src[s0 + i]`` with weight ``wa`` first, ``s3`` last."""
    a = uint64(d0)
    b0 = uint64(s0)
    b1 = uint64(s1)
    b2 = uint64(s2)
    b3 = uint64(s3)
    for i in range(uint64(n)):
        t = (dst[a + i] + wa * src[b0 + i]) + wb * src[b1 + i]
        dst[a + i] = (t + wc * src[b2 + i]) + wd * src[b3 + i]


@njit(nogil=True, cache=True, inline="always")
def _span6(dst, d0, src, s, shift, n, w):  # pragma: no cover - compiled
    """Six taps added in turn: ``src[s[k] + shift + i]`` with weight ``w[k]``, ``k = 0 .. 5``."""
    a = uint64(d0)
    b0, b1, b2 = uint64(s[0] + shift), uint64(s[1] + shift), uint64(s[2] + shift)
    b3, b4, b5 = uint64(s[3] + shift), uint64(s[4] + shift), uint64(s[5] + shift)
    w0, w1, w2, w3, w4, w5 = w[0], w[1], w[2], w[3], w[4], w[5]
    for i in range(uint64(n)):
        t = (dst[a + i] + w0 * src[b0 + i]) + w1 * src[b1 + i]
        t = (t + w2 * src[b2 + i]) + w3 * src[b3 + i]
        dst[a + i] = (t + w4 * src[b4 + i]) + w5 * src[b5 + i]


@njit(nogil=True, cache=True, inline="always")
def _span8(dst, d0, src, s, shift, n, w):  # pragma: no cover - compiled
    """Eight taps added in turn: ``src[s[k] + shift + i]`` with weight ``w[k]``, ``k = 0 .. 7``."""
    a = uint64(d0)
    b0, b1, b2, b3 = (
        uint64(s[0] + shift),
        uint64(s[1] + shift),
        uint64(s[2] + shift),
        uint64(s[3] + shift),
    )
    b4, b5, b6, b7 = (
        uint64(s[4] + shift),
        uint64(s[5] + shift),
        uint64(s[6] + shift),
        uint64(s[7] + shift),
    )
    w0, w1, w2, w3, w4, w5, w6, w7 = w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]
    for i in range(uint64(n)):
        t = (dst[a + i] + w0 * src[b0 + i]) + w1 * src[b1 + i]
        t = (t + w2 * src[b2 + i]) + w3 * src[b3 + i]
        t = (t + w4 * src[b4 + i]) + w5 * src[b5 + i]
        dst[a + i] = (t + w6 * src[b6 + i]) + w7 * src[b7 + i]


@njit(nogil=True, cache=True)
def _taps_on(dst, d0, src, s0, cols, m, wa, wb, xlo, xhi):  # pragma: no cover - compiled
    """One view row's taps on output columns ``xlo:xhi`` only: ``wa`` at ``m``, then ``wb``.

    The row ``src[s0:s0 + cols]`` adds ``wa * src[x - m]`` and then (``wb != 0``)
    ``wb * src[x - m - 1]`` to ``dst[d0 + x]``, each where its index is inside the row.
    """
    lo = max(xlo, m, 0)
    hi = min(xhi, cols + m, cols)
    if hi > lo:
        _span(dst, d0 + lo, src, s0 + lo - m, hi - lo, wa)
    if wb != 0.0:
        lo = max(xlo, m + 1, 0)
        hi = min(xhi, cols + m + 1, cols)
        if hi > lo:
            _span(dst, d0 + lo, src, s0 + lo - m - 1, hi - lo, wb)


#: Edges (columns where some view's taps fall outside it) at most this wide are added by one
#: scalar loop over their columns and the group's views; wider ones view by view, vectorised
#: (ours: the scalar loop saves the short loops' set-up on small shifts).
_EDGE_SCALAR_COLS = 16


@njit(nogil=True, cache=True)
def _edge_cols(
    dst, d0, src, starts, shift, g, cols, col_m, col_w0, col_w1, v, xlo, xhi
):  # pragma: no cover - compiled
    """Columns ``xlo:xhi`` of one row: each view's taps in view order where they fall inside."""
    for x in range(xlo, xhi):
        t = dst[d0 + x]
        for q in range(g):
            i = x - col_m[v + q]  # the first tap's column in the view
            if 0 <= i < cols:
                t = t + col_w0[v + q] * src[starts[q] + shift + i]
            if col_w1[v + q] != 0.0 and 1 <= i <= cols:
                t = t + col_w1[v + q] * src[starts[q] + shift + i - 1]
        dst[d0 + x] = t


@njit(nogil=True, cache=True)
def _add_views(
    dst, d0, src, base, view_px, k, g, cols, col_m, col_w0, col_w1, v, scratch
):  # pragma: no cover - compiled
    """``k`` rows of ``g`` (1 to 4) consecutive views ``v ..``, added in view order.

    Row ``j`` of the views (from ``src[base + q * view_px + j * cols]``) goes to
    ``dst[d0 + j * cols:...]``; one vectorised pass per row where every tap of every view falls
    inside, then the edges.
    """
    starts, offs, ws = scratch
    lo = 0
    hi = cols
    for q in range(g):
        starts[q] = base + q * view_px
        lo = max(lo, col_m[v + q] + 1)
        hi = min(hi, cols + col_m[v + q])
    if hi <= lo:
        for j in range(k):
            for q in range(g):
                m, wa, wb = col_m[v + q], col_w0[v + q], col_w1[v + q]
                _taps_on(dst, d0 + j * cols, src, starts[q] + j * cols, cols, m, wa, wb, 0, cols)
        return
    for q in range(g):
        offs[2 * q] = starts[q] + lo - col_m[v + q]
        offs[2 * q + 1] = offs[2 * q] - 1
        ws[2 * q] = col_w0[v + q]
        ws[2 * q + 1] = col_w1[v + q]
    n = hi - lo
    for j in range(k):
        s = j * cols
        if g == 4:
            _span8(dst, d0 + s + lo, src, offs, s, n, ws)
        elif g == 3:
            _span6(dst, d0 + s + lo, src, offs, s, n, ws)
        elif g == 2:
            a, b = offs[0] + s, offs[2] + s
            _span4(dst, d0 + s + lo, src, a, a - 1, b, b - 1, n, ws[0], ws[1], ws[2], ws[3])
        else:
            _span2(dst, d0 + s + lo, src, offs[0] + s, offs[1] + s, n, ws[0], ws[1])
    if lo <= _EDGE_SCALAR_COLS and cols - hi <= _EDGE_SCALAR_COLS:
        for j in range(k):
            s = j * cols
            _edge_cols(dst, d0 + s, src, starts, s, g, cols, col_m, col_w0, col_w1, v, 0, lo)
            _edge_cols(dst, d0 + s, src, starts, s, g, cols, col_m, col_w0, col_w1, v, hi, cols)
        return
    for j in range(k):
        s = j * cols
        for q in range(g):
            m, wa, wb = col_m[v + q], col_w0[v + q], col_w1[v + q]
            _taps_on(dst, d0 + s, src, starts[q] + s, cols, m, wa, wb, 0, lo)
        for q in range(g):
            m, wa, wb = col_m[v + q], col_w0[v + q], col_w1[v + q]
            _taps_on(dst, d0 + s, src, starts[q] + s, cols, m, wa, wb, hi, cols)


@njit(nogil=True, cache=True)
def _sum_grid_row(
    flat, u, n_v, rows, cols, s_lo, k, col_m, col_w0, col_w1, dst, d0, scratch
):  # pragma: no cover - compiled
    """Rows ``s_lo:s_lo + k`` of grid row ``u``'s views, column-shifted, added into ``dst``.

    Source row ``s_lo + j`` goes to ``dst[d0 + j * cols:...]``; views in order, in groups of four
    or three views (one pass over the partial rows per group), then two, then one.
    """
    view_px = rows * cols
    v = 0
    while v < n_v:
        left = n_v - v  # fours and threes, fewest passes: 9 = 3 + 3 + 3, 7 = 4 + 3, 5 = 3 + 2
        g = min(left, 3 if left == 3 or left == 5 or left == 6 or left == 9 else 4)
        base = ((u * n_v + v) * rows + s_lo) * cols
        _add_views(dst, d0, flat, base, view_px, k, g, cols, col_m, col_w0, col_w1, v, scratch)
        v += g


@njit(nogil=True, cache=True)
def _taps(shifts):  # pragma: no cover - compiled
    """Per shift: the first tap's whole shift and weight, the second tap's weight (0: none).

    :func:`stimuli.refocus.shift_weights` in float64, the weights rounded to float32.
    """
    n_taps = shifts.shape[0]
    m = np.empty(n_taps, np.int64)
    w0 = np.empty(n_taps, np.float32)
    w1 = np.zeros(n_taps, np.float32)
    for i in range(n_taps):
        n = np.floor(shifts[i])
        f = shifts[i] - n
        if f < 1e-6:
            m[i], w0[i] = int(n), 1.0
        elif f > 1.0 - 1e-6:
            m[i], w0[i] = int(n) + 1, 1.0
        else:
            m[i], w0[i], w1[i] = int(n), 1.0 - f, f
    return m, w0, w1


@njit(nogil=True, cache=True)
def _inverse_weights(length, shifts):  # pragma: no cover - compiled
    """One over the views' summed tap weights per position, float32 (0 where none falls).

    :func:`stimuli.refocus.overlap_weights` (float64, the same sums in the same order), then
    ``1 / w`` where ``w > 1e-9``.
    """
    w = np.zeros(length, np.float64)
    for s in shifts:
        n = np.floor(s)
        f = s - n
        for t in range(2):
            if f < 1e-6:
                m, a = int(n), 1.0
            elif f > 1.0 - 1e-6:
                m, a = int(n) + 1, 1.0
            else:
                m, a = int(n) + t, (1.0 - f) if t == 0 else f
            if m < length and -m < length:
                for x in range(max(0, m), min(length, length + m)):
                    w[x] += a
            if f < 1e-6 or f > 1.0 - 1e-6:
                break
    inv = np.zeros(length, np.float32)
    for x in range(length):
        if w[x] > 1e-9:
            inv[x] = 1.0 / w[x]
    return inv


@njit(nogil=True, cache=True)
def shift_add_rows(views, row_shifts, col_shifts, out, r0, r1):  # pragma: no cover - compiled
    """Refocused rows ``r0:r1`` of ``out`` from grey, C-contiguous float32 ``views``.

    Parameters
    ----------
    views : ndarray, float32, (n_u, n_v, rows, cols), C-contiguous
    row_shifts, col_shifts : ndarray, float64, (n_u,) and (n_v,)
        The shift of each grid row's views along the rows and of each grid column's views along
        the columns, pixels: view ``(u, v)`` lands at ``(y + row_shifts[u], x + col_shifts[v])``
        (linear interpolation: the taps of :func:`stimuli.refocus.shift_weights`).
    out : ndarray, float32, (rows, cols)
        Rows ``r0:r1`` written: the sum over the views divided by the number of views (tap
        weights) falling on each pixel, clipped to [0, 1].
    r0, r1 : int
        The output rows to make (threads make separate ranges).

    Samples outside a view are left out. The taps, the normalisers and the sums are made as the
    numpy path of :mod:`stimuli.refocus` makes them, in the same order, so the result equals it
    to the bit.
    """
    n_u, n_v, rows, cols = views.shape
    row_m, row_w0, row_w1 = _taps(row_shifts)
    col_m, col_w0, col_w1 = _taps(col_shifts)
    inv_rows = _inverse_weights(rows, row_shifts)
    inv_cols = _inverse_weights(cols, col_shifts)
    flat = views.reshape(-1)
    acc = np.empty(ROW_BLOCK * cols, np.float32)
    part = np.empty((ROW_BLOCK + 1) * cols, np.float32)
    scratch = (np.empty(4, np.int64), np.empty(8, np.int64), np.empty(8, np.float32))
    for y0 in range(r0, r1, ROW_BLOCK):
        n = min(ROW_BLOCK, r1 - y0)
        acc[: n * cols] = 0.0
        first = True
        for u in range(n_u):
            m = row_m[u]
            w0 = row_w0[u]
            w1 = row_w1[u]
            two = w1 != 0.0
            s_lo = max(0, y0 - m - (1 if two else 0))  # the partial image's rows the block uses
            s_hi = min(rows, y0 + n - m)
            if s_hi <= s_lo:
                continue
            k = s_hi - s_lo
            if first and not two and w0 == 1.0:  # 0 + 1 * p is p: the views go straight to acc
                _sum_grid_row(
                    flat, u, n_v, rows, cols, s_lo, k, col_m, col_w0, col_w1,
                    acc, (s_lo + m - y0) * cols, scratch,
                )  # fmt: skip
                first = False
                continue
            first = False
            part[: k * cols] = 0.0
            _sum_grid_row(
                flat, u, n_v, rows, cols, s_lo, k, col_m, col_w0, col_w1, part, 0, scratch
            )
            for i in range(n):
                a = y0 + i - m - s_lo  # the partial row of the first tap, in part
                a_in = 0 <= a + s_lo < rows
                b_in = two and 0 <= a + s_lo - 1 < rows
                if a_in and b_in:
                    _span2(acc, i * cols, part, a * cols, (a - 1) * cols, cols, w0, w1)
                elif a_in:
                    _span(acc, i * cols, part, a * cols, cols, w0)
                elif b_in:
                    _span(acc, i * cols, part, (a - 1) * cols, cols, w1)
        for i in range(n):
            r = inv_rows[y0 + i]
            o = out[y0 + i]
            for x in range(cols):
                value = acc[i * cols + x] * r * inv_cols[x]
                o[x] = min(max(value, np.float32(0.0)), np.float32(1.0))
