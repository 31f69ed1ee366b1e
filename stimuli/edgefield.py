"""The edge classes of :func:`stimuli.edgedepth.resolve_edge_depth` in two lean passes (numba).

What :func:`stimuli.edgekernels.edge_field` makes (the Sobel magnitude of
``scipy.ndimage.sobel``'s pair and the edge-direction confidence) with the same operations in
the same order, so the same values to the bit, but without its four full-image temporaries and
without a reflected index per interior read: :func:`edge_energy` makes each row's magnitude
and gradient energies from the image directly (the central differences made again where a row
needs its neighbours', the same values) and the magnitude's extrema (for Otsu's histogram);
:func:`edge_classes` runs the box means down the columns into one row buffer and along it,
and the confidence in a loop without branches, sorting the edge pixels into measured and
unmeasured at once (neither the confidence nor the gradients' box means are kept).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stimuli.kernels import reflect_index

__all__ = ["edge_energy", "edge_classes"]


@njit(nogil=True, cache=True)
def _dy(img, y, x, rows):  # pragma: no cover - compiled
    """``scipy.ndimage.sobel``'s difference along axis 0 at (y, x), rounded to float32."""
    return np.float32(
        np.float64(img[reflect_index(y + 1, rows), x])
        - np.float64(img[reflect_index(y - 1, rows), x])
    )


@njit(nogil=True, cache=True)
def _dx(img, y, x, cols):  # pragma: no cover - compiled
    """Return the same difference along axis 1."""
    return np.float32(
        np.float64(img[y, reflect_index(x + 1, cols)])
        - np.float64(img[y, reflect_index(x - 1, cols)])
    )


@njit(nogil=True, cache=True)
def _pixel(img, y, x, rows, cols, mag, e0, e1):  # pragma: no cover - compiled
    """Magnitude and energies at one pixel, reflected reads (the border)."""
    ya = reflect_index(y - 1, rows)
    yb = reflect_index(y + 1, rows)
    xa = reflect_index(x - 1, cols)
    xb = reflect_index(x + 1, cols)
    gy = np.float32(
        np.float64(_dy(img, y, x, rows)) * 2.0
        + (np.float64(_dy(img, y, xa, rows)) + np.float64(_dy(img, y, xb, rows)))
    )
    gx = np.float32(
        np.float64(_dx(img, y, x, cols)) * 2.0
        + (np.float64(_dx(img, ya, x, cols)) + np.float64(_dx(img, yb, x, cols)))
    )
    fy = np.float64(gy)
    fx = np.float64(gx)
    mag[y, x] = np.float32(np.sqrt(fy * fy + fx * fx))
    e0[y, x] = gy * gy
    e1[y, x] = gx * gx


@njit(nogil=True, cache=True)
def edge_energy(img, mag, e0, e1):  # pragma: no cover - compiled
    """Sobel magnitude and squared gradients of a float32 image; return the magnitude's extrema.

    ``mag`` = ``np.hypot`` of ``scipy.ndimage.sobel(img, axis=0)`` and ``axis=1`` (float32,
    the square root of the float64 sum of squares rounded once), ``e0``, ``e1`` = the float32
    squares of the two gradients, as :func:`stimuli.edgekernels.edge_field` makes them. Every
    side at least 4 pixels.
    """
    rows, cols = img.shape
    lo = np.float32(np.inf)
    hi = np.float32(-np.inf)
    for y in range(rows):
        if y == 0 or y == rows - 1:
            for x in range(cols):
                _pixel(img, y, x, rows, cols, mag, e0, e1)
        else:
            _pixel(img, y, 0, rows, cols, mag, e0, e1)
            ra = img[y - 1]
            rm = img[y]
            rb = img[y + 1]
            mr = mag[y]
            e0r = e0[y]
            e1r = e1[y]
            for x in range(1, cols - 1):  # no reflection: the differences made in place
                dy_m = np.float32(np.float64(rb[x]) - np.float64(ra[x]))
                dy_a = np.float32(np.float64(rb[x - 1]) - np.float64(ra[x - 1]))
                dy_b = np.float32(np.float64(rb[x + 1]) - np.float64(ra[x + 1]))
                dx_m = np.float32(np.float64(rm[x + 1]) - np.float64(rm[x - 1]))
                dx_a = np.float32(np.float64(ra[x + 1]) - np.float64(ra[x - 1]))
                dx_b = np.float32(np.float64(rb[x + 1]) - np.float64(rb[x - 1]))
                gy = np.float32(np.float64(dy_m) * 2.0 + (np.float64(dy_a) + np.float64(dy_b)))
                gx = np.float32(np.float64(dx_m) * 2.0 + (np.float64(dx_a) + np.float64(dx_b)))
                fy = np.float64(gy)
                fx = np.float64(gx)
                mr[x] = np.float32(np.sqrt(fy * fy + fx * fx))
                e0r[x] = gy * gy
                e1r[x] = gx * gx
            _pixel(img, y, cols - 1, rows, cols, mag, e0, e1)
        mr = mag[y]
        for x in range(cols):
            v = mr[x]
            lo = min(lo, v)
            hi = max(hi, v)
    return lo, hi


@njit(nogil=True, cache=True, error_model="numpy")
def _means_down(e0, e1, size, y, acc0, acc1, t0, t1):  # pragma: no cover - compiled
    """Make row ``y`` of the ``size``-row means of ``e0`` and ``e1`` (reflected).

    As :func:`stimuli.kernels.box_mean_reflect`: float64 running sums ``acc`` (made at row 0,
    moved on one row per call after it), rounded to float32 into ``t0``, ``t1``.
    """
    rows, cols = e0.shape
    half = size // 2
    if y == 0:
        for x in range(cols):
            acc0[x] = 0.0
            acc1[x] = 0.0
        for k in range(size):
            r = reflect_index(k - half, rows)
            for x in range(cols):
                acc0[x] += e0[r, x]
                acc1[x] += e1[r, x]
    else:
        ea0 = e0[reflect_index(y + half, rows)]
        eb0 = e0[reflect_index(y - 1 - half, rows)]
        ea1 = e1[reflect_index(y + half, rows)]
        eb1 = e1[reflect_index(y - 1 - half, rows)]
        for x in range(cols):
            acc0[x] += np.float64(ea0[x]) - np.float64(eb0[x])
            acc1[x] += np.float64(ea1[x]) - np.float64(eb1[x])
    size_f = np.float64(size)
    for x in range(cols):
        t0[x] = np.float32(acc0[x] / size_f)
        t1[x] = np.float32(acc1[x] / size_f)


@njit(nogil=True, cache=True, error_model="numpy")
def edge_classes(
    e0, e1, mag, axis, size, threshold, min_confidence, low, measured
):  # pragma: no cover - compiled
    """Edge pixels whose depth the views measure, and those they cannot, in one pass.

    At the pixels where ``mag > threshold`` (float32 comparison) the confidence of
    :func:`stimuli.edgekernels.edge_field` (the same running sums, so the same value) is made,
    and ``low`` (uint8) set to 1 where it is below ``min_confidence`` (float32) and ``mag >
    0``, ``measured`` where not; both 0 elsewhere. The row sums run over every pixel (their
    rounding depends on the path), then the divisions and square roots in a loop without
    branches (the numpy error model: no test for a zero divisor, which a branch-free loop
    cannot afford; a zero total takes the value 1 as the twin does).
    Returns the numbers of edge pixels and of ``low`` pixels.
    """
    rows, cols = e0.shape
    half = size // 2
    acc0 = np.zeros(cols, dtype=np.float64)
    acc1 = np.zeros(cols, dtype=np.float64)
    t0 = np.empty(cols, dtype=np.float32)
    t1 = np.empty(cols, dtype=np.float32)
    r0 = np.empty(cols, dtype=np.float64)
    r1 = np.empty(cols, dtype=np.float64)
    size_f = np.float64(size)
    n_edges = 0
    n_low = 0
    for y in range(rows):
        _means_down(e0, e1, size, y, acc0, acc1, t0, t1)
        run0 = 0.0
        run1 = 0.0
        for k in range(size):
            run0 += t0[reflect_index(k - half, cols)]
            run1 += t1[reflect_index(k - half, cols)]
        r0[0] = run0
        r1[0] = run1
        for x in range(1, cols):  # the running sums alone: one dependent add per pixel
            if half < x < cols - half:
                run0 += np.float64(t0[x + half]) - np.float64(t0[x - 1 - half])
                run1 += np.float64(t1[x + half]) - np.float64(t1[x - 1 - half])
            else:
                xa = reflect_index(x + half, cols)
                xb = reflect_index(x - 1 - half, cols)
                run0 += np.float64(t0[xa]) - np.float64(t0[xb])
                run1 += np.float64(t1[xa]) - np.float64(t1[xb])
            r0[x] = run0
            r1[x] = run1
        mr = mag[y]
        lr = low[y]
        me = measured[y]
        for x in range(cols):  # no branch: every pixel's confidence, kept where an edge
            m0 = np.float32(r0[x] / size_f)
            m1 = np.float32(r1[x] / size_f)
            total = m0 + m1
            along = m0 if axis == 0 else m1
            c = np.sqrt(along / total) if total > 0 else np.float32(1.0)
            m = mr[x]
            edge = np.uint8(m > threshold)
            unmeasured = np.uint8(c < min_confidence) & np.uint8(m > 0)
            lr[x] = edge & unmeasured
            me[x] = edge & (np.uint8(1) - unmeasured)
            n_edges += edge
            n_low += edge & unmeasured
    return n_edges, n_low
