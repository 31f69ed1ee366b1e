"""The agreement scan's plane sweep in numpy: the compiled sweep's twin, equal to the bit.

:func:`stimuli.kernels.agreement_sweep` makes the sweep in one compiled pass, but numba's
start-up costs about 0.75 s in each new process (its import and the set-up before the first
call), more than a whole sweep of a small capture takes in numpy. A command that answers from
one scan (``confocal lightfield scan``) uses this twin when the compiled code is not loaded yet;
:func:`stimuli.agreementscan` chooses (:data:`stimuli.agreementscan.NUMPY_SWEEP_MAX_WORK`).

Equal to the bit: every value is computed by the same float32 operations in the same order as
in the compiled loop (the interpolation ``a + f (b - a)``, the views' absolute differences
added in view order, the box's five terms added from the first, the scale, the running total,
the first plane of least cost and whether a later plane reached it again), so the two give the
same planes on any input (``tests/stimuli/test_agreement_sweep.py`` compares them).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["agreement_sweep"]

#: Side of the cost box, pixels (equal to :data:`stimuli.kernels.COST_BOX_PX`).
COST_BOX_PX: int = 5


def _reach(planes: np.ndarray, steps: np.ndarray) -> int:
    """Return the largest whole-pixel shift of any plane for views ``steps`` from the centre."""
    if planes.size == 0 or np.size(steps) == 0:
        return 0
    return int(
        math.ceil(
            max(abs(float(d) * float(s)) for d in (planes.min(), planes.max()) for s in steps)
        )
    )


def agreement_sweep(
    row_views, row_steps, col_views, col_steps, pad, refs, planes, first, best, best_i, total, tied
) -> None:
    """Return the plane sweep of :func:`stimuli.kernels.agreement_sweep`, with the same arguments.

    Parameters
    ----------
    row_views : ndarray of shape (a, rows, cols), float32
        Views that shift along rows; ``row_steps`` (a,) their view steps from the centre.
    col_views : ndarray of shape (b, rows, cols + 2 pad), float32
        Views that shift along columns, padded by repeating their end columns; ``col_steps`` (b,).
    pad : int
        Columns of padding on each side of ``col_views``.
    refs : ndarray of shape (2, rows, cols), float32
        The two references (the centre view and the null).
    planes : ndarray of float64
        Shifts, binned px per view step; ``first`` is the index of ``planes[0]`` in the scan.
    best, best_i, total, tied : ndarray of shape (2, rows, cols)
        Updated in place: the least cost so far (float32), the index of the first plane that
        reached it (int32), the sum of every plane's cost (float32) and whether a later plane
        reached the least cost again (uint8, 1; 0 once a plane lowers it).
    """
    _, rows, cols = refs.shape
    half = COST_BOX_PX // 2
    p = _reach(planes, row_steps) + 2  # rows of padding of the row views
    q = _reach(planes, col_steps) + half + 2  # columns of padding of every array
    wide = cols + 2 * q
    size = rows * wide
    # Every image is laid out in rows of ``wide`` samples, its own columns at q .. q + cols, so
    # that a shift by whole pixels is an offset into the flat array and each step below is one
    # pass over contiguous memory; the columns outside hold values no pixel of ours reads.
    row_flat = [np.pad(v, ((p, p), (q, q)), mode="edge").reshape(-1) for v in np.asarray(row_views)]
    col_flat = [  # a row of zeros above and below keeps every offset inside the array
        np.pad(
            np.pad(v[:, pad : pad + cols], ((0, 0), (q, q)), mode="edge"),
            ((1, 1), (0, 0)),
        ).reshape(-1)
        for v in np.asarray(col_views)
    ]
    # b - a of the interpolation for every pair of neighbouring rows (columns): the same float32
    # subtraction the compiled loop makes per sample.
    row_diffs = [v[:-wide] - v[wide:] for v in row_flat]
    col_diffs = [v[:-1] - v[1:] for v in col_flat]
    refs_w = np.zeros((2, rows, wide), np.float32)
    refs_w[:, :, q : q + cols] = refs
    refs_w = refs_w.reshape(2, size)
    best_w = np.full((2, rows, wide), np.inf, np.float32)
    best_w[:, :, q : q + cols] = best
    best_i_w = np.zeros((2, rows, wide), np.int32)
    best_i_w[:, :, q : q + cols] = best_i
    total_w = np.zeros((2, rows, wide), np.float32)
    total_w[:, :, q : q + cols] = total
    tied_w = np.zeros((2, rows, wide), np.uint8)
    tied_w[:, :, q : q + cols] = tied
    best_f, best_i_f, total_f = (a.reshape(2, size) for a in (best_w, best_i_w, total_w))
    tied_f = tied_w.reshape(2, size)
    same = np.empty((2, size), bool)
    scale = np.float32(1.0 / (COST_BOX_PX * COST_BOX_PX))
    by_rows = np.empty((2, rows + 2 * half, wide), np.float32)  # cost, end rows repeated
    cost = by_rows[:, half : half + rows].reshape(2, size)
    row_sums = np.empty((2, rows, wide), np.float32)
    sums = row_sums.reshape(2, size)
    box = np.zeros((2, size), np.float32)  # its ends (padding columns, never read) stay 0
    sample = np.empty(size, np.float32)
    diff = np.empty((2, size), np.float32)
    lower = np.empty((2, size), bool)
    rows_in = zip(row_flat, row_diffs, row_steps, strict=True)
    cols_in = zip(col_flat, col_diffs, col_steps, strict=True)
    taps = [(v, dv, float(s), True) for v, dv, s in rows_in]
    taps += [(v, dv, float(s), False) for v, dv, s in cols_in]
    for k in range(planes.shape[0]):
        d = float(planes[k])
        for j, (view, step_diff, step, along_rows) in enumerate(taps):
            s = d * step
            n = math.floor(s)
            f = np.float32(s - n)
            # a: the sample at y - n (row views) or x - n (column views); b: one further.
            at = (p - n) * wide if along_rows else wide - n
            diff_at = at - wide if along_rows else at - 1
            np.multiply(step_diff[diff_at : diff_at + size], f, out=sample)
            np.add(view[at : at + size], sample, out=sample)
            if j == 0:  # 0 + x is x: the compiled loop's first addition
                np.subtract(sample, refs_w, out=cost)
                np.abs(cost, out=cost)
            else:
                np.subtract(sample, refs_w, out=diff)
                np.abs(diff, out=diff)
                np.add(cost, diff, out=cost)
        if not taps:
            cost[...] = 0.0
        by_rows[:, :half] = by_rows[:, half : half + 1]
        by_rows[:, half + rows :] = by_rows[:, half + rows - 1 : half + rows]
        np.add(by_rows[:, 0:rows], by_rows[:, 1 : rows + 1], out=row_sums)
        for i in range(2, COST_BOX_PX):
            np.add(row_sums, by_rows[:, i : i + rows], out=row_sums)
        row_sums[:, :, q - half : q] = row_sums[:, :, q : q + 1]  # the end columns repeated
        row_sums[:, :, q + cols : q + cols + half] = row_sums[:, :, q + cols - 1 : q + cols]
        inner = slice(half, size - half)
        np.add(sums[:, 0 : size - 2 * half], sums[:, 1 : size - 2 * half + 1], out=box[:, inner])
        for i in range(2, COST_BOX_PX):
            np.add(box[:, inner], sums[:, i : size - 2 * half + i], out=box[:, inner])
        np.multiply(box, scale, out=box)
        np.add(total_f, box, out=total_f)
        np.less(box, best_f, out=lower)
        np.equal(box, best_f, out=same)
        np.copyto(tied_f, 1, where=same)
        np.copyto(tied_f, 0, where=lower)
        np.copyto(best_f, box, where=lower)
        np.copyto(best_i_f, first + k, where=lower)
    best[...] = best_w[:, :, q : q + cols]
    best_i[...] = best_i_w[:, :, q : q + cols]
    total[...] = total_w[:, :, q : q + cols]
    tied[...] = tied_w[:, :, q : q + cols]
