"""The views' agreement test at edge pixels, with a bound that rules out what cannot agree.

:func:`focus_agreement_at` gives the verdict of
:func:`stimuli.edgekernels.focus_agreement_with_limit` (and so of the full-image
:func:`stimuli.kernels.focus_agreement`) at the listed pixels, to the bit. A pixel is in focus
when the neighbour agrees at *any* of the disparities, so the order in which they are tried
and the pixels left out changes only the work, not the verdict. Each run of pixels
(consecutive listed pixels of a row, not yet in focus) is tried at the plane's own disparity
first, as the twin does (most edge pixels of an object in focus agree there); then, on each
stretch of the run still undecided, the other disparities in order, each pixel left at the
first that agrees and the column means made only over the span still undecided.

Before those, a *lower bound* of the test's difference over all of them is made from the few
neighbour samples that every disparity's two interpolation taps reach (read once per column
and row, and the disparities' means then made from them with the twin's float32 / float64
operations in the twin's order): every disparity samples the neighbour by linear
interpolation between two of them, so its value lies between their smallest and largest; the
distance from the centre view's pixel to that interval, averaged over the 3x3 box as the test
averages, is at most the test's difference at every disparity. A pixel whose bound exceeds
the test's threshold by more than :data:`BOUND_MARGIN` cannot agree at any of them and is not
tried. The bound costs about one disparity's test; where it rules out few pixels (the
synthetic layouts: 0-50 %) the kernel stops making it and reads the twin's way
(:data:`_PAYS`); on the Middlebury capture it rules out 65 %.

Why the margin keeps the verdict: views are in [0, 1] (``stimuli.lfviews.LightField``), so
each float32 operation of the interpolation, the difference and the two means rounds by at
most 2**-24 (6e-8); the test's difference is at least the exact mean of the distances less
about 4e-7 and the computed bound at most that mean plus 2e-7. A bound 1e-5 above the threshold
therefore means a difference above it (the test asks for one below it), with a factor of
about 15 to spare.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from stimuli.kernels import column_means

__all__ = ["BOUND_MARGIN", "focus_agreement_at"]

#: A pixel is not tried at the batch's disparities when the lower bound of its difference
#: exceeds the test's threshold by this much (grey levels in [0, 1]; the rounding of both is
#: below 6e-7).
BOUND_MARGIN: float = 1e-5

#: The bound is tried on the first this many pixels of a call, and then used only while it
#: rules out at least one pixel in :data:`_PAYS` (ours: reading the taps costs about one
#: disparity's test; measured, it pays on the Middlebury capture, where it rules out 65 % of
#: the pixels, and not on the synthetic layouts, where it rules out 0-50 %).
_TRIAL_PX = 512
_PAYS = 2


@njit(nogil=True, cache=True, inline="always")
def _make_limit(centre, axis, side, ratio, noise, y, x0, x1, lim, c):  # pragma: no cover
    """Make the threshold of pixels ``x0:x1`` of row ``y`` where any is NaN (as the twin)."""
    made = True
    for x in range(x0, x1):
        if np.isnan(lim[x]):
            made = False
            break
    if made:
        return
    column_means(centre, centre, axis, side, np.float32(0.0), y, x0, x1, c)
    for x in range(x0, x1):
        i = x - x0 + 1
        s = np.float64(c[i - 1]) + np.float64(c[i]) + np.float64(c[i + 1])
        lim[x] = np.float32(ratio) * np.float32(s / 3.0) + np.float32(noise)


@njit(nogil=True, cache=True, inline="always")
def _read_taps(nb, centre, axis, kmin, kmax, y, x0, x1, taps, cen, lb):  # pragma: no cover
    """Read each column's neighbour samples and centre pixels, and the bound's column means.

    For column ``x0 - 1 + i`` (clamped) and row ``y - 1 + r`` (clamped): ``taps[i, r, q]`` the
    neighbour at offset ``kmax + 1 - q`` back along ``axis`` (index clamped, as
    :func:`stimuli.kernels.column_means` clamps it), ``cen[i, r]`` the centre pixel, and
    ``lb[i]`` the mean over the rows of the centre's distance to the span of the taps.
    """
    rows, cols = centre.shape
    n = cols if axis == 1 else rows
    nq = kmax - kmin + 2
    for i in range(x1 - x0 + 2):
        xx = min(max(x0 - 1 + i, 0), cols - 1)
        s = 0.0
        for r in range(3):
            yy = min(max(y - 1 + r, 0), rows - 1)
            base = (xx if axis == 1 else yy) - kmax - 1
            lo = np.float32(np.inf)
            hi = np.float32(-np.inf)
            for q in range(nq):
                j = min(max(base + q, 0), n - 1)
                v = nb[yy, j] if axis == 1 else nb[j, xx]
                taps[i, r, q] = v
                lo = min(lo, v)
                hi = max(hi, v)
            cv = centre[yy, xx]
            cen[i, r] = cv
            s += np.float64(max(lo - cv, cv - hi, np.float32(0.0)))
        lb[i] = np.float32(s / 3.0)


@njit(nogil=True, cache=True, inline="always")
def _bounded(nb, centre, axis, ks, fs, kmin, kmax, y, x0, x1, lim, o, taps, cen, lb, cm, live):
    """Try pixels ``x0:x1`` of row ``y`` (none in focus yet) at ``ds[1:]``, bound first."""
    nd = ks.shape[0]
    margin = np.float32(BOUND_MARGIN)
    _read_taps(nb, centre, axis, kmin, kmax, y, x0, x1, taps, cen, lb)
    left = 0
    for x in range(x0, x1):
        i = x - x0 + 1
        s = np.float64(lb[i - 1]) + np.float64(lb[i]) + np.float64(lb[i + 1])
        live[x] = np.float32(s / 3.0) < lim[x] + margin
        left += live[x]
    skipped = (x1 - x0) - left
    if left == 0:
        return skipped
    # the disparities in order on the pixels the bound leaves, each pixel left at the first
    # that agrees; column means only over the span of the pixels still to decide
    a = x0
    b = x1
    row = cm[0]
    for di in range(1, nd):
        while a < b and live[a] == 0:
            a += 1
        while b > a and live[b - 1] == 0:
            b -= 1
        if a == b:
            return skipped
        f = fs[di]
        q0 = kmax - ks[di]  # taps[.., q0] the tap at x - k - 1, q0 + 1 the one at x - k
        for i in range(a - x0, b - x0 + 2):
            s = 0.0
            for r in range(3):
                vb = taps[i, r, q0]
                va = taps[i, r, q0 + 1]
                s += np.float64(abs((va + f * (vb - va)) - cen[i, r]))
            row[i] = np.float32(s / 3.0)
        for x in range(a, b):
            if live[x] == 0:
                continue
            i = x - x0 + 1
            s = np.float64(row[i - 1]) + np.float64(row[i]) + np.float64(row[i + 1])
            if np.float32(s / 3.0) < lim[x]:
                o[x] = True
                live[x] = 0
    return skipped


@njit(nogil=True, cache=True, inline="always")
def _in_order(nb, centre, axis, ks, fs, y, x0, x1, lim, o, c):  # pragma: no cover - compiled
    """Try pixels ``x0:x1`` of row ``y`` at ``ds[1:]`` in order, as the twin does.

    Each pixel left at the first disparity that agrees; the column means
    (:func:`stimuli.kernels.column_means`) only over the span of the pixels still to decide.
    """
    a = x0
    b = x1
    for di in range(1, ks.shape[0]):
        while a < b and o[a]:
            a += 1
        while b > a and o[b - 1]:
            b -= 1
        if a == b:
            return
        column_means(nb, centre, axis, ks[di], fs[di], y, a, b, c)
        for x in range(a, b):
            if o[x]:
                continue
            i = x - a + 1
            s = np.float64(c[i - 1]) + np.float64(c[i]) + np.float64(c[i + 1])
            if np.float32(s / 3.0) < lim[x]:
                o[x] = True


@njit(nogil=True, cache=True)
def focus_agreement_at(
    centre, nb, axis, side, ds, ratio, noise, limit, where, out, r0, r1
):  # pragma: no cover - compiled
    """:func:`stimuli.edgekernels.focus_agreement_with_limit`: the same arguments and verdict.

    ``out`` (bool) is set True at the pixels of ``where`` (uint8) where ``nb`` agrees with
    ``centre`` at one of the disparities ``ds`` (``ds[0]`` the plane's own, tried first; the
    rest after the bound, module notes); ``limit`` the test's threshold image, NaN where not made
    yet (made and stored here, as the twin does). Rows ``r0:r1`` only (their pixels read the
    rows around them; threads may take other strips of rows at once). Returns how many pixels
    the bound was made for and how many it ruled out (once it rules out fewer than one in
    :data:`_PAYS` after :data:`_TRIAL_PX` pixels, the rest take the twin's order).
    """
    rows, cols = centre.shape
    nd = ds.shape[0]
    ks = np.empty(nd, dtype=np.int64)
    fs = np.empty(nd, dtype=np.float32)
    kmin = 1 << 40
    kmax = -(1 << 40)
    for di in range(nd):
        sh = ds[di] * side
        k = int(np.floor(sh))
        ks[di] = k
        fs[di] = np.float32(sh - k)
        if di > 0:
            kmin = min(kmin, k)
            kmax = max(kmax, k)
    nq = kmax - kmin + 2 if nd > 1 else 1
    c = np.empty(cols + 2, dtype=np.float32)
    lb = np.empty(cols + 2, dtype=np.float32)
    cm = np.empty((1, cols + 2), dtype=np.float32)
    live = np.zeros(cols, dtype=np.uint8)
    taps = np.empty((cols + 2, 3, nq), dtype=np.float32)
    cen = np.empty((cols + 2, 3), dtype=np.float32)
    bounded = 0
    skipped = 0
    for y in range(r0, r1):
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
            _make_limit(centre, axis, side, ratio, noise, y, x0, x1, lim, c)
            # the plane's own disparity, as the twin tries it
            column_means(nb, centre, axis, ks[0], fs[0], y, x0, x1, c)
            left = 0
            for x in range(x0, x1):
                i = x - x0 + 1
                s = np.float64(c[i - 1]) + np.float64(c[i]) + np.float64(c[i + 1])
                if np.float32(s / 3.0) < lim[x]:
                    o[x] = True
                else:
                    left += 1
            if left == 0 or nd == 1:
                x0 = x1
                continue
            if bounded >= _TRIAL_PX and _PAYS * skipped < bounded:
                # the bound does not pay on this image: the rest in the twin's order
                _in_order(nb, centre, axis, ks, fs, y, x0, x1, lim, o, c)
                x0 = x1
                continue
            # the rest on each stretch of the run's pixels still out of focus: the taps read
            # once, pixels out of reach left out
            xa = x0
            while xa < x1:
                if o[xa]:
                    xa += 1
                    continue
                xb = xa
                while xb < x1 and not o[xb]:
                    xb += 1
                skipped += _bounded(
                    nb, centre, axis, ks, fs, kmin, kmax, y, xa, xb, lim, o, taps, cen, lb, cm, live
                )
                bounded += xb - xa
                xa = xb
            x0 = x1
    return bounded, skipped
