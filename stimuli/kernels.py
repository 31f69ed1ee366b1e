"""Compiled loops for the pixel work that numpy would do in several passes.

Each kernel makes one pass over its input, so that a light field is read from memory once and
an image's rows stay in the cache while they are used (numba, ``nogil``: the callers split the
rows, or the planes, over threads). They are compiled on first use and the machine code is
cached on disk (``cache=True``), so only the first run on a machine pays for the compilation.

* :func:`sobel_rows`: the Sobel magnitude exactly as ``skimage.filters.sobel`` computes it for a
  float32 image (each directional sum in float64, rounded to float32, then squared, summed and
  divided in float32), for a range of rows;
* :func:`count_blocks`: the number of True pixels in each window of a grid (exact integers);
* :func:`agreement_sweep`: the agreement scan's plane sweep (:mod:`stimuli.agreementscan`),
  every plane's view differences, box filter and running best in one call;
* :func:`focus_agreement`: the in-focus test of :func:`stimuli.declutter.agreement_mask` for
  one neighbouring view, every disparity of the tolerance in one call;
* :func:`focus_vote`: the local majority of :func:`stimuli.declutter.declutter_depth` (two
  box means and the comparison in one call).

Importing this module imports numba (about 0.3 s), so the modules that use it import it inside
the functions that need it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "sobel_rows",
    "count_blocks",
    "agreement_sweep",
    "focus_agreement",
    "focus_vote",
    "label_extents",
    "box_max",
    "sobel_pair",
    "central_differences",
    "reflect_index",
    "column_means",
    "box_mean_reflect",
    "COST_BOX_PX",
]

#: Side of the box over which :func:`agreement_sweep` averages view differences, pixels of the
#: binned views (ours: the usual stereo matching window;
#: ``stimuli.agreementscan.COST_WINDOW_PX`` is this value).
COST_BOX_PX = 5


@njit(nogil=True, cache=True)
def _magnitude(gy, gx):  # pragma: no cover - compiled
    """``sqrt(gy**2 + gx**2) / sqrt(2)`` from float64 sums rounded to float32, as skimage."""
    fy = np.float32(gy)
    fx = np.float32(gx)
    return np.float32(np.sqrt(fy * fy + fx * fx)) / np.float32(np.sqrt(np.float32(2.0)))


@njit(nogil=True, cache=True)
def sobel_rows(img, out, r0, r1):  # pragma: no cover - compiled
    """Sobel magnitude of rows ``r0:r1`` of a float32 image into ``out``; count bad values.

    ``sqrt(Gy**2 + Gx**2) / sqrt(2)`` with ``Gy = [1, 0, -1]`` across rows times ``[1, 2, 1] / 4``
    along them (and ``Gx`` the transpose), the image reflected at its borders (``d c b a | a b
    c d``): scikit-image's ``sobel`` term for term. Each directional sum is taken in float64,
    where the products of float32 values by 1/4 and 1/2 and their sums are exact, and rounded to
    float32 as ``scipy.ndimage.convolve`` does, so the order of the terms does not matter. Per
    row, the column sums ``up + 2 mid + down`` and differences ``up - down`` are formed first,
    then combined along the row: two passes that vectorise instead of one with nine loads.

    Returns the number of pixels of rows ``r0:r1`` outside [0, 1] or NaN (the input check, in the
    same pass).
    """
    rows, cols = img.shape
    smooth = np.empty(cols, dtype=np.float64)  # (up + 2 mid + down) / 4: Gx's vertical part
    diff = np.empty(cols, dtype=np.float64)  # up - down: Gy's vertical part
    outside = 0
    for y in range(r0, r1):
        up = img[y - 1] if y > 0 else img[0]
        mid = img[y]
        down = img[y + 1] if y < rows - 1 else img[rows - 1]
        for x in range(cols):
            value = mid[x]
            outside += not (0.0 <= value <= 1.0)
            smooth[x] = (
                0.25 * np.float64(up[x]) + 0.5 * np.float64(value) + 0.25 * np.float64(down[x])
            )
            diff[x] = np.float64(up[x]) - np.float64(down[x])
        o = out[y]
        if cols == 1:
            o[0] = _magnitude(diff[0], 0.0)
            continue
        o[0] = _magnitude(0.75 * diff[0] + 0.25 * diff[1], smooth[0] - smooth[1])
        last = cols - 1
        o[last] = _magnitude(
            0.25 * diff[last - 1] + 0.75 * diff[last], smooth[last - 1] - smooth[last]
        )
        left = smooth[: cols - 2]
        right = smooth[2:]
        d0 = diff[: cols - 2]
        d1 = diff[1 : cols - 1]
        d2 = diff[2:]
        inner = o[1:last]
        for i in range(cols - 2):  # indices from 0 up, so that it vectorises
            inner[i] = _magnitude(0.25 * d0[i] + 0.5 * d1[i] + 0.25 * d2[i], left[i] - right[i])
    return outside


@njit(nogil=True, cache=True)
def count_blocks(edges, row_bounds, col_bounds, counts):  # pragma: no cover - compiled
    """Add the True pixels of ``edges`` (uint8 0/1) in each grid window to ``counts`` (int64).

    Window ``(i, j)`` covers rows ``row_bounds[i]:row_bounds[i + 1]`` and columns
    ``col_bounds[j]:col_bounds[j + 1]``.
    """
    n_r = row_bounds.shape[0] - 1
    n_c = col_bounds.shape[0] - 1
    line = np.zeros(edges.shape[1], dtype=np.int64)
    for i in range(n_r):
        line[:] = 0
        for y in range(row_bounds[i], row_bounds[i + 1]):
            row = edges[y]
            for x in range(edges.shape[1]):
                line[x] += row[x]
        for j in range(n_c):
            s = 0
            for x in range(col_bounds[j], col_bounds[j + 1]):
                s += line[x]
            counts[i, j] += s


@njit(nogil=True, cache=True)
def _accumulate_differences(a, b, f, ref0, ref1, cost0, cost1):  # pragma: no cover - compiled
    """``cost_r += |a + f (b - a) - ref_r|`` for both references (one row)."""
    for x in range(a.shape[0]):
        v = a[x] + f * (b[x] - a[x])
        cost0[x] += abs(v - ref0[x])
        cost1[x] += abs(v - ref1[x])


@njit(nogil=True, cache=True)
def _box5_row(src, dst):  # pragma: no cover - compiled
    """``dst[x] = sum of src[x - 2 .. x + 2]``, the row's end samples repeated beyond it."""
    cols = src.shape[0]
    last = cols - 1
    for x in (0, 1, cols - 2, cols - 1):  # the ends (assigned twice on short rows: harmless)
        if 0 <= x < cols:
            dst[x] = (
                src[max(x - 2, 0)]
                + src[max(x - 1, 0)]
                + src[x]
                + src[min(x + 1, last)]
                + src[min(x + 2, last)]
            )
    if cols > 4:
        d = dst[2 : cols - 2]
        s0 = src[: cols - 4]
        s1 = src[1 : cols - 3]
        s2 = src[2 : cols - 2]
        s3 = src[3 : cols - 1]
        s4 = src[4:]
        for i in range(cols - 4):  # indices from 0 up, so that it vectorises
            d[i] = s0[i] + s1[i] + s2[i] + s3[i] + s4[i]


@njit(nogil=True, cache=True)
def agreement_sweep(
    row_views, row_steps, col_views, col_steps, pad, refs, planes, first, best, best_i, total, tied
):  # pragma: no cover - compiled
    """Return the agreement scan's plane sweep over ``planes`` (binned px per view step).

    One pass over the data.

    ``row_views`` (a, rows, cols) are the views that shift along rows (``row_steps`` view steps
    from the centre), ``col_views`` (b, rows, cols + 2 pad) those that shift along columns,
    padded by repeating their end columns. At plane ``d`` a view is sampled at ``x - d step``
    by linear interpolation (its end rows or columns repeated beyond it), and the cost of a
    pixel against each of the two references ``refs`` (2, rows, cols) is the sum over views of
    the absolute differences, then the mean over a :data:`COST_BOX_PX` square box (the image's
    end rows and columns repeated). ``total`` (2, rows, cols) adds every plane's cost; ``best``
    and ``best_i`` keep the smallest cost and the index (``first`` + position in ``planes``) of
    the first plane that reached it; ``tied`` (uint8) is 1 where a later plane reached the same
    cost again (0 once a plane lowers it).
    """
    rows = refs.shape[1]
    cols = refs.shape[2]
    cost = np.empty((2, rows, cols), dtype=np.float32)
    tmp = np.empty((rows, cols), dtype=np.float32)
    line = np.empty(cols, dtype=np.float32)
    scale = np.float32(1.0 / (COST_BOX_PX * COST_BOX_PX))
    for k in range(planes.shape[0]):
        d = planes[k]
        cost[:] = 0.0
        for j in range(row_views.shape[0]):
            s = d * row_steps[j]
            n = int(np.floor(s))
            f = np.float32(s - n)
            for y in range(rows):
                ya = min(max(y - n, 0), rows - 1)
                yb = min(max(y - n - 1, 0), rows - 1)
                _accumulate_differences(
                    row_views[j, ya],
                    row_views[j, yb],
                    f,
                    refs[0, y],
                    refs[1, y],
                    cost[0, y],
                    cost[1, y],
                )
        for j in range(col_views.shape[0]):
            s = d * col_steps[j]
            n = int(np.floor(s))
            f = np.float32(s - n)
            for y in range(rows):
                padded = col_views[j, y]
                _accumulate_differences(
                    padded[pad - n : pad - n + cols],
                    padded[pad - n - 1 : pad - n - 1 + cols],
                    f,
                    refs[0, y],
                    refs[1, y],
                    cost[0, y],
                    cost[1, y],
                )
        for r in range(2):
            c = cost[r]
            for y in range(rows):  # the box along the rows ...
                t = tmp[y]
                c0 = c[max(y - 2, 0)]
                c1 = c[max(y - 1, 0)]
                c2 = c[y]
                c3 = c[min(y + 1, rows - 1)]
                c4 = c[min(y + 2, rows - 1)]
                for x in range(cols):
                    t[x] = c0[x] + c1[x] + c2[x] + c3[x] + c4[x]
            for y in range(rows):  # ... then along the columns, and the running best
                _box5_row(tmp[y], line)
                tot = total[r, y]
                b = best[r, y]
                bi = best_i[r, y]
                ti = tied[r, y]
                for x in range(cols):
                    v = line[x] * scale
                    tot[x] += v
                    if v < b[x]:
                        b[x] = v
                        bi[x] = first + k
                        ti[x] = 0
                    elif v == b[x]:
                        ti[x] = 1


@njit(nogil=True, cache=True)
def _box3_cols(src, dst):  # pragma: no cover - compiled
    """Mean of 3 along axis 0 (rows), edge rows repeated, in float64 then float32."""
    rows, cols = src.shape
    for y in range(rows):
        ya, yb = max(y - 1, 0), min(y + 1, rows - 1)
        for x in range(cols):
            s = np.float64(src[ya, x]) + np.float64(src[y, x]) + np.float64(src[yb, x])
            dst[y, x] = np.float32(s / 3.0)


@njit(nogil=True, cache=True)
def focus_agreement(centre, nb, axis, side, ds, ratio, noise, out):  # pragma: no cover
    """Run the views' agreement test of :func:`stimuli.declutter.agreement_mask` for one neighbour.

    ``out |= box3(|nb sampled at x - d * side - centre|) < ratio * box3(|centre at x - side -
    centre|) + noise`` for every ``d`` of ``ds``, along image ``axis`` (0 rows, 1 columns),
    edge pixels repeated and linear interpolation as ``stimuli.declutter._sample``; box3 is the
    3x3 mean (rows first, then columns, each in float64 rounded to float32, as
    ``scipy.ndimage.uniform_filter``), in passes over whole images held in two buffers instead
    of a chain of numpy temporaries.
    """
    rows, cols = centre.shape
    n = cols if axis == 1 else rows
    a = np.empty((rows, cols), np.float32)
    b = np.empty((rows, cols), np.float32)
    limit = np.empty((rows, cols), np.float32)
    for y in range(rows):  # the texture: a one-pixel shift of the centre view
        for x in range(cols):
            if axis == 1:
                j = min(max(x - side, 0), n - 1)
                v = centre[y, j]
            else:
                j = min(max(y - side, 0), n - 1)
                v = centre[j, x]
            a[y, x] = abs(v - centre[y, x])
    _box3_cols(a, b)
    for y in range(rows):
        for x in range(cols):
            xa, xb = max(x - 1, 0), min(x + 1, cols - 1)
            s = np.float64(b[y, xa]) + np.float64(b[y, x]) + np.float64(b[y, xb])
            limit[y, x] = np.float32(ratio) * np.float32(s / 3.0) + np.float32(noise)
    for di in range(ds.shape[0]):
        sh = ds[di] * side
        k = int(np.floor(sh))
        f = np.float32(sh - k)
        for y in range(rows):
            for x in range(cols):
                if axis == 1:
                    ja = min(max(x - k, 0), n - 1)
                    jb = min(max(x - k - 1, 0), n - 1)
                    va, vb = nb[y, ja], nb[y, jb]
                else:
                    ja = min(max(y - k, 0), n - 1)
                    jb = min(max(y - k - 1, 0), n - 1)
                    va, vb = nb[ja, x], nb[jb, x]
                a[y, x] = abs((va + f * (vb - va)) - centre[y, x])
        _box3_cols(a, b)
        for y in range(rows):
            for x in range(cols):
                xa, xb = max(x - 1, 0), min(x + 1, cols - 1)
                s = np.float64(b[y, xa]) + np.float64(b[y, x]) + np.float64(b[y, xb])
                if np.float32(s / 3.0) < limit[y, x]:
                    out[y, x] = True


@njit(nogil=True, cache=True)
def _running_mean_rows(src, size, dst):  # pragma: no cover - compiled
    """``scipy.ndimage.uniform_filter1d(src, size, axis=0, mode='constant')`` step for step.

    A running sum in float64 over the window (zeros beyond the image), updated by
    ``(entering - leaving) / size`` as scipy does, rounded to float32; every column at once.
    """
    rows, cols = src.shape
    half = size // 2
    tmp = np.zeros(cols, dtype=np.float64)
    for k in range(size):  # the first window, summed in order
        y = k - half
        if 0 <= y < rows:
            s = src[y]
            for x in range(cols):
                tmp[x] += s[x]
    for y in range(rows):
        if y > 0:
            y_in = y + size - 1 - half
            y_out = y - 1 - half
            for x in range(cols):
                a = np.float64(src[y_in, x]) if y_in < rows else 0.0
                b = np.float64(src[y_out, x]) if y_out >= 0 else 0.0
                tmp[x] += a - b
        d = dst[y]
        for x in range(cols):
            d[x] = np.float32(tmp[x] / size)


@njit(nogil=True, cache=True)
def _running_mean_line(src, size, dst):  # pragma: no cover - compiled
    """Do the same along one line (``axis=-1``), float32 in and out, float64 running sum."""
    n = src.shape[0]
    half = size // 2
    tmp = 0.0
    for k in range(size):
        x = k - half
        if 0 <= x < n:
            tmp += src[x]
    dst[0] = np.float32(tmp / size)
    for x in range(1, n):
        x_in = x + size - 1 - half
        x_out = x - 1 - half
        a = np.float64(src[x_in]) if x_in < n else 0.0
        b = np.float64(src[x_out]) if x_out >= 0 else 0.0
        tmp += a - b
        dst[x] = np.float32(tmp / size)


@njit(nogil=True, cache=True)
def focus_vote(edges, focus, size, out):  # pragma: no cover - compiled
    """Take the local majority of :func:`stimuli.declutter.declutter_depth` in one call.

    ``edges`` (uint8 0/1) and ``focus`` (uint8: 1 in focus, 2 dropped, else out of focus);
    ``out[y, x]`` (bool) is set where ``edges`` and ``agree >= 0.5 * total`` and ``focus`` is
    not 2, ``agree`` and ``total`` the ``size`` x ``size`` means (zeros beyond the image) of
    the in-focus edges and of the edges, made as ``scipy.ndimage.uniform_filter`` makes them
    (rows first, each pass a float64 running sum rounded to float32), so the same to the bit.
    """
    rows, cols = edges.shape
    e_in = np.empty((rows, cols), dtype=np.float32)
    e_all = np.empty((rows, cols), dtype=np.float32)
    for y in range(rows):
        for x in range(cols):
            e = np.float32(edges[y, x])
            e_all[y, x] = e
            e_in[y, x] = e if focus[y, x] == 1 else np.float32(0.0)
    a_rows = np.empty((rows, cols), dtype=np.float32)
    t_rows = np.empty((rows, cols), dtype=np.float32)
    _running_mean_rows(e_in, size, a_rows)
    _running_mean_rows(e_all, size, t_rows)
    agree = np.empty(cols, dtype=np.float32)
    total = np.empty(cols, dtype=np.float32)
    for y in range(rows):
        _running_mean_line(a_rows[y], size, agree)
        _running_mean_line(t_rows[y], size, total)
        o = out[y]
        e = edges[y]
        f = focus[y]
        for x in range(cols):
            o[x] = e[x] != 0 and f[x] != 2 and agree[x] >= np.float32(0.5) * total[x]


@njit(nogil=True, cache=True, inline="always")
def column_means(src, centre, axis, k, f, y, x0, x1, c):  # pragma: no cover - compiled
    """Set ``c[i]`` to a mean over rows ``y - 1 .. y + 1``, for the columns ``x0 - 1 .. x1``.

    ``c[i]`` = the mean over rows ``y - 1 .. y + 1`` of ``|src sampled at - k - f along axis
    - centre|`` at column ``x0 - 1 + i`` (columns and rows clamped to the image), for the
    columns ``x0 - 1 .. x1``; each sum in float64 rounded to float32, as :func:`_box3_cols`.
    """
    rows, cols = centre.shape
    n = cols if axis == 1 else rows
    for i in range(x1 - x0 + 2):
        xx = min(max(x0 - 1 + i, 0), cols - 1)
        s = 0.0
        for dy in range(-1, 2):
            yy = min(max(y + dy, 0), rows - 1)
            if axis == 1:
                ja = min(max(xx - k, 0), n - 1)
                jb = min(max(xx - k - 1, 0), n - 1)
                va, vb = src[yy, ja], src[yy, jb]
            else:
                ja = min(max(yy - k, 0), n - 1)
                jb = min(max(yy - k - 1, 0), n - 1)
                va, vb = src[ja, xx], src[jb, xx]
            s += np.float64(abs((va + f * (vb - va)) - centre[yy, xx]))
        c[i] = np.float32(s / 3.0)


@njit(nogil=True, cache=True)
def label_extents(labels, n, top, bottom, left, right):  # pragma: no cover - compiled
    """Find the bounding box of each label ``1..n`` of a label image, in one pass.

    ``top[i - 1]``, ``bottom[i - 1]`` (the last row), ``left[i - 1]`` and ``right[i - 1]`` (the
    last column) of label ``i``: the extents of ``scipy.ndimage.find_objects``; labels that do
    not occur keep the values the caller filled in.
    """
    rows, cols = labels.shape
    for y in range(rows):
        row = labels[y]
        for x in range(cols):
            v = row[x]
            if 0 < v <= n:
                i = v - 1
                if y < top[i]:
                    top[i] = y
                if y > bottom[i]:
                    bottom[i] = y
                if x < left[i]:
                    left[i] = x
                if x > right[i]:
                    right[i] = x


@njit(nogil=True, cache=True)
def box_max(src, size, out):  # pragma: no cover - compiled
    """Set ``out`` to the largest value of ``src`` in the ``size`` x ``size`` box around each pixel.

    ``size`` is odd and the box clipped to the image; columns first, then along the rows.

    For values >= 0 it is ``scipy.ndimage.maximum_filter`` with ``mode='constant'`` (zeros
    beyond the image) and ``grey_dilation``'s default ``mode='reflect'`` (whose reflected
    pixels lie inside the clipped box), to the bit.
    """
    rows, cols = src.shape
    half = size // 2
    tmp = np.empty((rows, cols), dtype=src.dtype)
    for y in range(rows):
        t = tmp[y]
        t[:] = src[y]
        for yy in range(max(y - half, 0), min(y + half + 1, rows)):
            s = src[yy]
            for x in range(cols):
                t[x] = max(t[x], s[x])
    for y in range(rows):
        t = tmp[y]
        o = out[y]
        o[:] = t
        for dx in range(1, min(half, cols - 1) + 1):
            lo = o[: cols - dx]  # from the right, then from the left
            hi = t[dx:]
            for x in range(cols - dx):
                lo[x] = max(lo[x], hi[x])
            lo = o[dx:]
            hi = t[: cols - dx]
            for x in range(cols - dx):
                lo[x] = max(lo[x], hi[x])


@njit(nogil=True, cache=True)
def reflect_index(i, n):  # pragma: no cover - compiled
    """Return ``i`` reflected into ``range(n)`` (``d c b a | a b c d``; ``-n <= i < 2 n``)."""
    if i < 0:
        return -i - 1
    if i >= n:
        return 2 * n - i - 1
    return i


@njit(nogil=True, cache=True)
def central_differences(img):  # pragma: no cover - compiled
    """Return ``(dy, dx)``: the differences ``[-1, 0, 1]`` along rows and columns, float32.

    As ``scipy.ndimage.sobel`` makes them before smoothing: each in float64, rounded to
    float32, the image reflected at its borders.
    """
    rows, cols = img.shape
    dy = np.empty((rows, cols), dtype=np.float32)
    dx = np.empty((rows, cols), dtype=np.float32)
    for y in range(rows):
        ya = reflect_index(y - 1, rows)
        yb = reflect_index(y + 1, rows)
        for x in range(cols):
            dy[y, x] = np.float32(np.float64(img[yb, x]) - np.float64(img[ya, x]))
            xa = reflect_index(x - 1, cols)
            xb = reflect_index(x + 1, cols)
            dx[y, x] = np.float32(np.float64(img[y, xb]) - np.float64(img[y, xa]))
    return dy, dx


@njit(nogil=True, cache=True)
def sobel_pair(img, gy, gx):  # pragma: no cover - compiled
    """``scipy.ndimage.sobel(img, axis=0)`` into ``gy`` and ``axis=1`` into ``gx``, to the bit.

    As scipy makes each: the difference ``[-1, 0, 1]`` along the axis, rounded to float32, then
    the smoothing ``[1, 2, 1]`` across it (``2 mid + (before + after)`` in float64, rounded),
    the image reflected at its borders.
    """
    rows, cols = img.shape
    dy, dx = central_differences(img)
    for y in range(rows):
        ya = reflect_index(y - 1, rows)
        yb = reflect_index(y + 1, rows)
        for x in range(cols):
            xa = reflect_index(x - 1, cols)
            xb = reflect_index(x + 1, cols)
            gy[y, x] = np.float32(
                np.float64(dy[y, x]) * 2.0 + (np.float64(dy[y, xa]) + np.float64(dy[y, xb]))
            )
            gx[y, x] = np.float32(
                np.float64(dx[y, x]) * 2.0 + (np.float64(dx[ya, x]) + np.float64(dx[yb, x]))
            )


@njit(nogil=True, cache=True)
def box_mean_reflect(src, size, out):  # pragma: no cover - compiled
    """Compute ``scipy.ndimage.uniform_filter(src, size)`` (``mode='reflect'``) of a float32 image.

    Step for step: along rows, then columns, each a float64 running sum (``+ entering -
    leaving``) divided by ``size`` and rounded to float32. Odd ``size``, at most one
    reflection: every side at least ``size // 2`` pixels.
    """
    rows, cols = src.shape
    half = size // 2
    tmp = np.empty((rows, cols), dtype=np.float32)
    acc = np.zeros(cols, dtype=np.float64)
    for k in range(size):
        s = src[reflect_index(k - half, rows)]
        for x in range(cols):
            acc[x] += s[x]
    for y in range(rows):
        if y > 0:
            a = src[reflect_index(y + half, rows)]
            b = src[reflect_index(y - 1 - half, rows)]
            for x in range(cols):
                acc[x] += np.float64(a[x]) - np.float64(b[x])
        t = tmp[y]
        for x in range(cols):
            t[x] = np.float32(acc[x] / size)
    for y in range(rows):
        t = tmp[y]
        o = out[y]
        run = 0.0
        for k in range(size):
            run += t[reflect_index(k - half, cols)]
        o[0] = np.float32(run / size)
        for x in range(1, cols):
            run += np.float64(t[reflect_index(x + half, cols)]) - np.float64(
                t[reflect_index(x - 1 - half, cols)]
            )
            o[x] = np.float32(run / size)
