"""Compiled passes of the depth de-clutter that read each image once (numba, ``cache=True``).

Each has a numpy twin elsewhere that it equals to the bit (tested in
``tests/stimuli/test_edge_kernels.py``):

* :func:`histogram_uniform`: ``numpy.histogram(a, bins=n)`` of a float32 image (the bins of
  scikit-image's ``threshold_otsu``), in one pass instead of a sort-free chain of numpy passes;
* :func:`edge_field`: the Sobel pair of ``scipy.ndimage.sobel``, its magnitude (``np.hypot``)
  and the edge-direction confidence of :func:`stimuli.edgedepth.edge_confidence`, in one call
  instead of a chain of full-image temporaries;
* :func:`label8`: ``scipy.ndimage.label`` with 8-connectivity (the same numbering);
* :func:`focus_agreement_with_limit`: :func:`stimuli.kernels.focus_agreement` at listed pixels
  only, with the test's threshold image, which does not depend on the plane, kept by the caller
  and made only where first needed (the same verdict to the bit).

Importing this module imports numba; callers import it inside the functions that need it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stimuli.kernels import central_differences, column_means, reflect_index

__all__ = [
    "histogram_uniform",
    "edge_field",
    "extrema",
    "label8",
    "find_root",
    "new_label",
    "focus_agreement_with_limit",
]


@njit(nogil=True, cache=True)
def extrema(a):  # pragma: no cover - compiled
    """Return the smallest and largest value of a float32 array (one pass; no NaN in it)."""
    flat = a.ravel()
    lo = flat[0]
    hi = flat[0]
    for i in range(1, flat.shape[0]):
        v = flat[i]
        if v < lo:
            lo = v
        if v > hi:
            hi = v
    return lo, hi


@njit(nogil=True, cache=True)
def histogram_uniform(a, first, last, edges, counts):  # pragma: no cover - compiled
    """Add ``numpy.histogram(a, bins=len(counts), range=(first, last))`` to ``counts``.

    Step for step as numpy's equal-bin path for float32 data (``first``, ``last`` and ``edges``
    float32, ``edges`` = ``np.linspace(first, last, n + 1)``): the bin from ``(v - first) /
    (last - first) * n`` truncated, then moved down or up by one where the edges say so; values
    outside ``[first, last]`` are left out, ``last`` goes to the last bin. The first bins of a
    block of values are made in a loop of their own (vectorised), and both edges of that bin
    read at once: the edges rise, so a value moved down is never moved up again and the two
    tests of numpy's (the second after the first's move) give the same bin as these two.
    """
    n = counts.shape[0]
    denom = last - first
    scale = np.float32(n)
    top = np.float32(n - 1)
    zero = np.float32(0.0)
    flat = a.ravel()
    m = flat.shape[0]
    block = 1024
    guess = np.empty(block, dtype=np.int32)
    for s in range(0, m, block):
        e = min(s + block, m)
        for j in range(s, e):  # numpy's bin, before its correction (n where v is last)
            t = ((flat[j] - first) / denom) * scale
            guess[j - s] = np.int32(min(max(t, zero), top))
        for j in range(s, e):
            v = flat[j]
            if not (v >= first and v <= last):
                continue
            i = guess[j - s]
            i = i - np.int32(v < edges[i]) + np.int32((v >= edges[i + 1]) & (i != n - 1))
            counts[i] += 1


@njit(nogil=True, cache=True)
def edge_field(img, axis, size, mag, conf):  # pragma: no cover - compiled
    """Sobel magnitude and edge-direction confidence of a float32 image, in one call.

    ``mag`` = ``np.hypot(gy, gx)`` of ``scipy.ndimage.sobel(img, axis=0)`` and ``axis=1`` (as
    :func:`stimuli.kernels.sobel_pair` makes them; float32: the square root of the float64 sum
    of squares, rounded once, as glibc's ``hypotf``, tested against numpy); ``conf`` =
    ``sqrt(E_axis / (E_0 + E_1))`` (1 where the sum is 0), ``E_a`` the ``size`` x ``size`` mean
    (``mode='reflect'``,
    as :func:`stimuli.kernels.box_mean_reflect`: float64 running sums rounded to float32) of
    the squared gradient along image axis ``a``. Every side at least ``size // 2`` pixels.
    """
    rows, cols = img.shape
    half = size // 2
    dy, dx = central_differences(img)
    e0 = np.empty((rows, cols), dtype=np.float32)
    e1 = np.empty((rows, cols), dtype=np.float32)
    for y in range(rows):
        dyr = dy[y]
        dxa = dx[reflect_index(y - 1, rows)]
        dxm = dx[y]
        dxb = dx[reflect_index(y + 1, rows)]
        mr = mag[y]
        e0r = e0[y]
        e1r = e1[y]
        for x in range(cols):
            if 0 < x < cols - 1:
                sy = np.float64(dyr[x - 1]) + np.float64(dyr[x + 1])
            else:
                sy = np.float64(dyr[reflect_index(x - 1, cols)]) + np.float64(
                    dyr[reflect_index(x + 1, cols)]
                )
            gy = np.float32(np.float64(dyr[x]) * 2.0 + sy)
            gx = np.float32(np.float64(dxm[x]) * 2.0 + (np.float64(dxa[x]) + np.float64(dxb[x])))
            fy = np.float64(gy)  # hypotf as glibc makes it: in double, rounded once
            fx = np.float64(gx)
            mr[x] = np.float32(np.sqrt(fy * fy + fx * fx))
            e0r[x] = gy * gy
            e1r[x] = gx * gx
    # the box means: along the rows (float64 running sums), then along each row
    t0, t1 = dy, dx  # reused
    acc0 = np.zeros(cols, dtype=np.float64)
    acc1 = np.zeros(cols, dtype=np.float64)
    for k in range(size):
        r = reflect_index(k - half, rows)
        for x in range(cols):
            acc0[x] += e0[r, x]
            acc1[x] += e1[r, x]
    for y in range(rows):
        if y > 0:
            a = reflect_index(y + half, rows)
            b = reflect_index(y - 1 - half, rows)
            for x in range(cols):
                acc0[x] += np.float64(e0[a, x]) - np.float64(e0[b, x])
                acc1[x] += np.float64(e1[a, x]) - np.float64(e1[b, x])
        for x in range(cols):
            t0[y, x] = np.float32(acc0[x] / size)
            t1[y, x] = np.float32(acc1[x] / size)
    for y in range(rows):
        r0 = t0[y]
        r1 = t1[y]
        c = conf[y]
        run0 = 0.0
        run1 = 0.0
        for k in range(size):
            run0 += r0[reflect_index(k - half, cols)]
            run1 += r1[reflect_index(k - half, cols)]
        for x in range(cols):
            if x > 0:
                xa = reflect_index(x + half, cols)
                xb = reflect_index(x - 1 - half, cols)
                run0 += np.float64(r0[xa]) - np.float64(r0[xb])
                run1 += np.float64(r1[xa]) - np.float64(r1[xb])
            m0 = np.float32(run0 / size)
            m1 = np.float32(run1 / size)
            total = m0 + m1
            along = m0 if axis == 0 else m1
            c[x] = np.sqrt(along / total) if total > 0 else np.float32(1.0)


@njit(nogil=True, cache=True)
def find_root(parent, i):  # pragma: no cover - compiled
    """Root of ``i`` in the union-find forest ``parent``, paths halved on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(nogil=True, cache=True, inline="always")
def new_label(parent, n):  # pragma: no cover - compiled
    """Add label ``n + 1`` as its own root, doubling ``parent`` when it is full.

    Returns ``(parent, n + 1)``: the union-find table (grown or not) and the new label, for the
    raster-order labellings (:func:`label8`, :func:`stimuli.edgevote.label8_extents`).
    """
    n += 1
    if n >= parent.shape[0]:
        grown = np.empty(2 * parent.shape[0], dtype=np.int32)
        grown[: parent.shape[0]] = parent
        parent = grown
    parent[n] = n
    return parent, n


@njit(nogil=True, cache=True)
def label8(mask, out):  # pragma: no cover - compiled
    """Label the 8-connected components of a uint8 mask into ``out`` (int32); return how many.

    ``scipy.ndimage.label(mask, np.ones((3, 3)))`` to the bit: components are numbered 1, 2,
    ... in the order of their first pixel in a row-by-row scan (two passes, union-find).
    """
    rows, cols = mask.shape
    parent = np.empty(rows * cols // 2 + 2, dtype=np.int32)
    n = 0
    for y in range(rows):
        for x in range(cols):
            if mask[y, x] == 0:
                out[y, x] = 0
                continue
            best = 0
            for dy, dx in ((-1, -1), (-1, 0), (-1, 1), (0, -1)):
                yy = y + dy
                xx = x + dx
                if yy < 0 or xx < 0 or xx >= cols:
                    continue
                v = out[yy, xx]
                if v == 0:
                    continue
                r = find_root(parent, v)
                if best == 0:
                    best = r
                elif r != best:
                    if r < best:
                        parent[best] = r
                        best = r
                    else:
                        parent[r] = best
            if best == 0:
                parent, n = new_label(parent, n)
                best = n
            out[y, x] = best
    final = np.zeros(n + 1, dtype=np.int32)
    count = 0
    for y in range(rows):
        for x in range(cols):
            v = out[y, x]
            if v == 0:
                continue
            r = find_root(parent, v)
            if final[r] == 0:
                count += 1
                final[r] = count
            out[y, x] = final[r]
    return count


@njit(nogil=True, cache=True)
def focus_agreement_with_limit(
    centre, nb, axis, side, ds, ratio, noise, limit, where, out
):  # pragma: no cover - compiled
    """:func:`stimuli.kernels.focus_agreement` at the pixels of ``where``, threshold image kept.

    ``limit``: the test's threshold for this neighbour (``axis``, ``side``), ``ratio`` times
    the 3x3 mean of ``|centre at x - side - centre|`` plus ``noise``, which does not depend on
    the plane; NaN where not made yet. The pixels of ``where`` (uint8) not yet in focus in
    ``out`` are taken in runs (row by row, consecutive pixels share their column means); a run
    with a NaN threshold has it made and stored, then is tested disparity by disparity in the
    order of ``ds`` (the plane's own first) until all agree: a run in focus costs one test, and
    only the pixels off the plane cost them all. The same verdict as the full-image test, to
    the bit.
    """
    rows, cols = centre.shape
    c = np.empty(cols + 2, dtype=np.float32)
    for y in range(rows):
        w = where[y]
        o = out[y]
        lim = limit[y]
        x0 = 0
        while x0 < cols:
            if w[x0] == 0 or o[x0]:
                x0 += 1
                continue
            x1 = x0
            while x1 < cols and w[x1] != 0 and not o[x1]:
                x1 += 1
            made = True
            for x in range(x0, x1):
                if np.isnan(lim[x]):
                    made = False
                    break
            if not made:
                column_means(centre, centre, axis, side, np.float32(0.0), y, x0, x1, c)
                for x in range(x0, x1):
                    i = x - x0 + 1
                    s = np.float64(c[i - 1]) + np.float64(c[i]) + np.float64(c[i + 1])
                    lim[x] = np.float32(ratio) * np.float32(s / 3.0) + np.float32(noise)
            left = x1 - x0
            for di in range(ds.shape[0]):
                sh = ds[di] * side
                k = int(np.floor(sh))
                f = np.float32(sh - k)
                column_means(nb, centre, axis, k, f, y, x0, x1, c)
                for x in range(x0, x1):
                    if o[x]:
                        continue
                    i = x - x0 + 1
                    s = np.float64(c[i - 1]) + np.float64(c[i]) + np.float64(c[i + 1])
                    if np.float32(s / 3.0) < lim[x]:
                        o[x] = True
                        left -= 1
                if left == 0:
                    break
            x0 = x1
