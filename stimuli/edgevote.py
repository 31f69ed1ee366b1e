"""Compiled passes of :func:`stimuli.edgedepth._vote` (numba), the same masks to the bit.

The segment vote of the edges a 1-D light field cannot measure made in a few lean passes
instead of a chain of full-image numpy temporaries:

* :func:`split_junctions`: the junction pixels (unmeasured edge pixels with a measured one in
  the ``size`` x ``size`` box) and the rest of the unmeasured edges, from running counts;
* :func:`label8_extents`: :func:`stimuli.edgekernels.label8` (``scipy.ndimage.label``'s
  numbering) with each label's bounding box made in its relabelling pass;
* :func:`touch_pairs`: the measured pixels near a segment, and for each one its segment and
  component (the order of ``numpy.nonzero``);
* :func:`settle`: the segments' verdicts painted back, the junction pixels given to the
  segments they touch;
* :func:`vote_lean`: the local majority of :func:`stimuli.kernels.focus_vote`, evaluated only
  at the edge pixels from exact running counts (the depth de-clutter's last step, on every
  layout; its numpy twin is ``stimuli.declutter.declutter_depth(..., compiled=False)``).

Grown masks are made from exact integer running counts (a pixel is in the grown mask when the
count of set pixels in its box is above 0), the same pixels as ``scipy.ndimage``'s maximum
filter of a 0/1 image.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stimuli.edgekernels import find_root, new_label

__all__ = ["split_junctions", "label8_extents", "touch_pairs", "settle", "vote_lean"]


@njit(nogil=True, cache=True)
def _grown_row(mask, y, size, cnt, row):  # pragma: no cover - compiled
    """Set ``row`` to 1 where ``mask`` (uint8 0/1) has a set pixel in the box around (y, x).

    ``cnt`` holds, per column, the set pixels of rows ``y - 1 - half .. y - 1 + half`` (all 0
    before row 0); moved on to row ``y`` here.
    """
    rows, cols = mask.shape
    half = size // 2
    if y == 0:
        cnt[:] = 0
        for r in range(0, min(half, rows)):
            m = mask[r]
            for x in range(cols):
                cnt[x] += m[x]
    y_in = y + half
    if y_in < rows:
        m = mask[y_in]
        for x in range(cols):
            cnt[x] += m[x]
    y_out = y - half - 1
    if y_out >= 0:
        m = mask[y_out]
        for x in range(cols):
            cnt[x] -= m[x]
    run = 0
    for x in range(min(half, cols)):
        run += cnt[x] > 0
    for x in range(cols):
        x_in = x + half
        if x_in < cols:
            run += cnt[x_in] > 0
        x_out = x - half - 1
        if x_out >= 0:
            run -= cnt[x_out] > 0
        row[x] = run > 0


@njit(nogil=True, cache=True)
def split_junctions(low, measured, size, junction, rest):  # pragma: no cover - compiled
    """``junction`` = ``low & grow(measured, size)``, ``rest`` = ``low & ~junction`` (uint8)."""
    rows, cols = low.shape
    cnt = np.zeros(cols, dtype=np.int32)
    row = np.empty(cols, dtype=np.uint8)
    for y in range(rows):
        _grown_row(measured, y, size, cnt, row)
        lo = low[y]
        j = junction[y]
        r = rest[y]
        for x in range(cols):
            j[x] = lo[x] & row[x]
            r[x] = lo[x] & (1 - row[x])


@njit(nogil=True, cache=True)
def label8_extents(mask, out):  # pragma: no cover - compiled
    """Label 8-connected components as :func:`stimuli.edgekernels.label8`, with their boxes.

    Returns ``(n, top, bottom, left, right)``: the number of labels and, for label ``i``, the
    first and last row and column of its pixels at index ``i - 1`` (``scipy.ndimage
    .find_objects``'s extents, as :func:`stimuli.kernels.label_extents` gives them).
    """
    rows, cols = mask.shape
    parent = np.empty(rows * cols // 2 + 2, dtype=np.int32)
    n = 0
    for y in range(rows):
        m = mask[y]
        o = out[y]
        up = out[y - 1] if y > 0 else o  # not read on row 0
        for x in range(cols):
            if m[x] == 0:
                o[x] = 0
                continue
            # the neighbours already seen: a b c above, d to the left; b joins a, c and d
            # (each touches it), a joins d, so at most one union is needed (Wu et al. 2005)
            a = up[x - 1] if y > 0 and x > 0 else 0
            b = up[x] if y > 0 else 0
            c = up[x + 1] if y > 0 and x + 1 < cols else 0
            d = o[x - 1] if x > 0 else 0
            if b != 0:
                o[x] = b
            elif c != 0:
                o[x] = c
                other = a if a != 0 else d
                if other != 0:
                    ra = find_root(parent, c)
                    rb = find_root(parent, other)
                    if ra != rb:
                        if ra < rb:
                            parent[rb] = ra
                        else:
                            parent[ra] = rb
            elif a != 0:
                o[x] = a
            elif d != 0:
                o[x] = d
            else:
                parent, n = new_label(parent, n)
                o[x] = n
    # every union hangs the larger root under the smaller, so a label's parent is smaller than
    # it and each component's root is its first label in raster order: numbered in one sweep
    final = np.zeros(n + 1, dtype=np.int32)
    count = 0
    for i in range(1, n + 1):
        p = parent[i]
        if p == i:
            count += 1
            final[i] = count
        else:
            final[i] = final[p]
    big = np.iinfo(np.int64).max
    top = np.full(count, big, dtype=np.int64)
    left = np.full(count, big, dtype=np.int64)
    bottom = np.full(count, -1, dtype=np.int64)
    right = np.full(count, -1, dtype=np.int64)
    for y in range(rows):
        o = out[y]
        x = 0
        while x < cols:  # runs of one label, relabelled as read: one update of its box per run
            v = o[x]
            if v == 0:
                x += 1
                continue
            v = final[v]
            o[x] = v
            x1 = x + 1
            while x1 < cols and o[x1] != 0 and final[o[x1]] == v:
                o[x1] = v
                x1 += 1
            i = v - 1
            if y < top[i]:
                top[i] = y
            bottom[i] = y
            if x < left[i]:
                left[i] = x
            if x1 - 1 > right[i]:
                right[i] = x1 - 1
            x = x1
    return count, top[:count], bottom[:count], left[:count], right[:count]


@njit(nogil=True, cache=True)
def touch_pairs(measured, near):  # pragma: no cover - compiled
    """Return the measured pixels where ``near`` > 0 (uint8 image) and their rows and columns.

    ``touch`` = ``measured & (near > 0)``; ``ys``, ``xs`` its pixels in raster order (as
    ``numpy.nonzero``).
    """
    rows, cols = measured.shape
    touch = np.empty((rows, cols), dtype=np.uint8)
    n = 0
    for y in range(rows):
        m = measured[y]
        nr = near[y]
        t = touch[y]
        for x in range(cols):
            v = np.uint8(m[x] != 0 and nr[x] > 0)
            t[x] = v
            n += v
    ys = np.empty(n, dtype=np.int64)
    xs = np.empty(n, dtype=np.int64)
    k = 0
    for y in range(rows):
        t = touch[y]
        for x in range(cols):
            if t[x]:
                ys[k] = y
                xs[k] = x
                k += 1
    return touch, ys, xs


@njit(nogil=True, cache=True)
def settle(seg, keep, off, junction, size, kept, dropped):  # pragma: no cover - compiled
    """Paint the segments' verdicts and give each junction pixel to a segment it touches.

    ``kept`` = ``keep[seg]``, ``dropped`` = ``off[seg]`` (``keep``, ``off`` uint8 per label,
    0 for the background); then ``kept |= junction & grow(kept, size)`` and ``dropped |=
    junction & ~kept & grow(dropped, size)`` (the grown masks of the painted verdicts, before
    the junction pixels join them), all uint8 0/1. The grown masks are read only at the
    junction pixels, from the labels in their box (junction pixels have none: they are not in
    a segment), the rows after a kept label left unread.
    """
    rows, cols = seg.shape
    keep0 = keep[0]
    off0 = off[0]
    for y in range(rows):
        s = seg[y]
        k = kept[y]
        d = dropped[y]
        for x in range(cols):  # the background first (no read of the tables per pixel)
            k[x] = keep0
            d[x] = off0
        for x in range(cols):
            v = s[x]
            if v != 0:
                k[x] = keep[v]
                d[x] = off[v]
    half = size // 2
    for y in range(rows):  # only the junction pixels look around them (the painted verdicts)
        j = junction[y]
        k = kept[y]
        d = dropped[y]
        for x in range(cols):
            if j[x] == 0:
                continue
            near_k = 0
            near_d = 0
            x_a = max(x - half, 0)
            x_b = min(x + half + 1, cols)
            for yy in range(max(y - half, 0), min(y + half + 1, rows)):
                for xx in range(x_a, x_b):
                    v = seg[yy, xx]
                    near_k |= keep[v]
                    near_d |= off[v]
                if near_k:  # kept: what is dropped nearby no longer matters
                    break
            k[x] |= near_k
            d[x] |= (1 - k[x]) & near_d


@njit(nogil=True, cache=True)
def _count_row(edges, focus, y, sign, n_all, n_in):  # pragma: no cover - compiled
    """Add (``sign`` 1) or take away (-1) row ``y``'s edges and in-focus edges per column."""
    er = edges[y]
    fr = focus[y]
    if sign > 0:
        for x in range(er.shape[0]):
            e = np.int32(er[x])
            n_all[x] += e
            n_in[x] += e & np.int32(fr[x] == 1)
    else:
        for x in range(er.shape[0]):
            e = np.int32(er[x])
            n_all[x] -= e
            n_in[x] -= e & np.int32(fr[x] == 1)


@njit(nogil=True, cache=True)
def _float_vote(n_all, n_in, lut, x, size):  # pragma: no cover - compiled
    """Return the float verdict of :func:`vote_lean` at column ``x`` from the column counts."""
    cols = n_all.shape[0]
    half = size // 2
    # four partial sums: the sums are exact (vote_lean's notes), so in any order the same
    a0 = a1 = a2 = a3 = 0.0
    i0 = i1 = i2 = i3 = 0.0
    j = max(x - half, 0)
    j1 = min(x + half + 1, cols)
    while j + 4 <= j1 and size <= 16384:
        a0 += lut[n_all[j]]
        a1 += lut[n_all[j + 1]]
        a2 += lut[n_all[j + 2]]
        a3 += lut[n_all[j + 3]]
        i0 += lut[n_in[j]]
        i1 += lut[n_in[j + 1]]
        i2 += lut[n_in[j + 2]]
        i3 += lut[n_in[j + 3]]
        j += 4
    while j < j1:
        a0 += lut[n_all[j]]
        i0 += lut[n_in[j]]
        j += 1
    s_all = (a0 + a1) + (a2 + a3)
    s_in = (i0 + i1) + (i2 + i3)
    agree = np.float32(s_in / size)
    total = np.float32(s_all / size)
    return agree >= np.float32(0.5) * total


#: Windows up to this size take :func:`vote_lean`'s integer verdict outside ties (ours: the
#: rounding of the float means, below ``2 size**2 * 2**-22`` of the box, stays far below the
#: smallest gap ``1 / (2 size**2)`` between a majority and a tie up to here).
_INT_VOTE_MAX_SIZE = 255


@njit(nogil=True, cache=True)
def vote_lean(edges, focus, size, out):  # pragma: no cover - compiled
    """Take the local majority of :func:`stimuli.kernels.focus_vote` at the edge pixels only.

    ``edges`` (uint8 0/1), ``focus`` (uint8: 1 in focus, 2 dropped). ``out`` (bool) is True
    where ``edges`` and ``focus != 2`` and ``agree >= 0.5 * total``, the two the ``size`` x
    ``size`` means (zeros beyond the image) of the in-focus edges and of the edges as
    ``scipy.ndimage.uniform_filter`` makes them (the numpy twin: ``declutter_depth(...,
    compiled=False)``), to the bit. The column counts are exact int32 running counts, moved on
    row by row without a branch; each edge pixel then sums the ``size`` column means around it,
    each a float32 ``k / size`` from a table, in four partial sums: for ``size`` up to 2**14
    every mean is a multiple of 2**-38 and a sum of up to ``size`` of them is below 2**15, so
    it has at most 53 significant bits and is exact in float64, in any order (larger windows
    are summed in one chain).

    Most pixels are decided from the integer counts alone: with ``N_in`` and ``N_all`` the
    in-focus and all edge pixels of the box, each float32 mean is ``N / size**2`` within a
    relative 2**-22, so for ``size`` up to :data:`_INT_VOTE_MAX_SIZE` the verdict is ``2 N_in
    >= N_all`` wherever the two differ (their gap, at least ``1 / (2 size**2)``, is far above
    the rounding); each row's box counts come from prefix sums of the column counts in one
    loop without a branch, and only the ties ``2 N_in == N_all`` at edge pixels take the
    float sums above (:func:`_float_vote`), the same verdict to the bit.
    """
    rows, cols = edges.shape
    half = size // 2
    lut = np.empty(size + 1, dtype=np.float64)
    for k in range(size + 1):
        lut[k] = np.float64(np.float32(k / size))
    n_all = np.zeros(cols, dtype=np.int32)
    n_in = np.zeros(cols, dtype=np.int32)
    for k in range(min(half, rows)):
        _count_row(edges, focus, k, 1, n_all, n_in)
    p_all = np.zeros(cols + 1, dtype=np.int32)
    p_in = np.zeros(cols + 1, dtype=np.int32)
    gap = np.empty(cols, dtype=np.int32)
    tie = np.empty(cols, dtype=np.uint8)
    exact_ints = size <= _INT_VOTE_MAX_SIZE
    for y in range(rows):
        if y + half < rows:
            _count_row(edges, focus, y + half, 1, n_all, n_in)
        if y - half - 1 >= 0:
            _count_row(edges, focus, y - half - 1, -1, n_all, n_in)
        er = edges[y]
        fr = focus[y]
        o = out[y]
        if not exact_ints:
            for x in range(cols):
                o[x] = er[x] != 0 and fr[x] != 2 and _float_vote(n_all, n_in, lut, x, size)
            continue
        # the box counts of every pixel from prefix sums, the verdict without a branch; the
        # ties (rare at edge pixels) then take the float sums
        run_all = 0
        run_in = 0
        for x in range(cols):
            run_all += n_all[x]
            run_in += n_in[x]
            p_all[x + 1] = run_all
            p_in[x + 1] = run_in
        for x in range(min(half, cols)):
            hi = min(x + half + 1, cols)
            gap[x] = 2 * p_in[hi] - p_all[hi]
        if cols > 2 * half:  # the interior: no clamped index, shifted views (vectorised)
            hi_in = p_in[2 * half + 1 :]
            lo_in = p_in[: cols - 2 * half]
            hi_all = p_all[2 * half + 1 :]
            lo_all = p_all[: cols - 2 * half]
            mid = gap[half : cols - half]
            for i in range(cols - 2 * half):
                mid[i] = 2 * (hi_in[i] - lo_in[i]) - (hi_all[i] - lo_all[i])
        for x in range(max(cols - half, half), cols):
            gap[x] = 2 * (p_in[cols] - p_in[x - half]) - (p_all[cols] - p_all[x - half])
        o8 = o.view(np.uint8)
        n_ties = 0
        for x in range(cols):
            live = np.uint8(er[x] != 0) & np.uint8(fr[x] != 2)
            o8[x] = live & np.uint8(gap[x] > 0)
            tie[x] = live & np.uint8(gap[x] == 0)
            n_ties += np.int32(tie[x])
        if n_ties == 0:
            continue
        for x in range(cols):
            if tie[x]:
                o[x] = _float_vote(n_all, n_in, lut, x, size)
