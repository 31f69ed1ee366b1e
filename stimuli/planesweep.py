"""The agreement scan's plane sweep in numpy: the compiled sweep's twin, equal to the bit.

:func:`stimuli.kernels.agreement_sweep` makes the sweep in one compiled pass, but numba's
start-up costs about 0.75 s in each new process (its import and the set-up before the first
call), more than a whole sweep of a small capture takes in numpy. A command that answers from
one scan (``confocal lightfield scan``) uses this twin when the compiled code is not loaded yet;
:func:`stimuli.agreementscan` chooses (:data:`stimuli.agreementscan.NUMPY_SWEEP_MAX_WORK`).

Equal to the bit: every value is computed by the same float32 operations in the same order as
in the compiled loop (the interpolation ``a + f (b - a)``, the views' absolute differences
added in view order, the box's five terms added from the first, the scale, the running total
and the first plane of least cost), so the two give the same planes on any input
(``tests/stimuli/test_agreement_sweep.py`` compares them).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["agreement_sweep"]

#: Side of the cost box, pixels (equal to :data:`stimuli.kernels.COST_BOX_PX`).
COST_BOX_PX: int = 5


def _row_pad(planes: np.ndarray, steps: np.ndarray) -> int:
    """Rows of edge padding that hold every row a plane's shift reads."""
    if planes.size == 0 or steps.size == 0:
        return 1
    reach = max(abs(float(d) * float(s)) for d in (planes.min(), planes.max()) for s in steps)
    return int(math.ceil(reach)) + 2


def agreement_sweep(
    row_views, row_steps, col_views, col_steps, pad, refs, planes, first, best, best_i, total
) -> None:
    """The plane sweep of :func:`stimuli.kernels.agreement_sweep`, with the same arguments.

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
    best, best_i, total : ndarray of shape (2, rows, cols)
        Updated in place: the least cost so far (float32), the index of the first plane that
        reached it (int32) and the sum of every plane's cost (float32).
    """
    _, rows, cols = refs.shape
    p = _row_pad(planes, row_steps)
    padded_rows = [np.pad(v, ((p, p), (0, 0)), mode="edge") for v in row_views]
    # b - a of the interpolation, for every pair of neighbouring rows (columns): the same
    # float32 subtraction the compiled loop makes per sample.
    row_diffs = [v[:-1] - v[1:] for v in padded_rows]
    col_diffs = [v[:, :-1] - v[:, 1:] for v in col_views]
    scale = np.float32(1.0 / (COST_BOX_PX * COST_BOX_PX))
    half = COST_BOX_PX // 2
    by_rows = np.empty((2, rows + 2 * half, cols), np.float32)  # cost, end rows repeated
    cost = by_rows[:, half : half + rows]
    by_cols = np.empty((2, rows, cols + 2 * half), np.float32)  # row sums, end columns repeated
    row_sums = by_cols[:, :, half : half + cols]
    box = np.empty((2, rows, cols), np.float32)
    sample = np.empty((rows, cols), np.float32)
    diff = np.empty((2, rows, cols), np.float32)
    lower = np.empty((2, rows, cols), bool)
    rows_in = zip(padded_rows, row_diffs, row_steps, strict=True)
    cols_in = zip(col_views, col_diffs, col_steps, strict=True)
    taps = [(v, dv, float(s), True) for v, dv, s in rows_in]
    taps += [(v, dv, float(s), False) for v, dv, s in cols_in]
    for k in range(planes.shape[0]):
        d = float(planes[k])
        n_added = 0
        for view, step_diff, step, along_rows in taps:
            s = d * step
            n = math.floor(s)
            f = np.float32(s - n)
            if along_rows:  # sample y - s: rows y - n and y - n - 1 of the unpadded view
                a = view[p - n : p - n + rows]
                b_minus_a = step_diff[p - n - 1 : p - n - 1 + rows]
            else:
                a = view[:, pad - n : pad - n + cols]
                b_minus_a = step_diff[:, pad - n - 1 : pad - n - 1 + cols]
            np.multiply(b_minus_a, f, out=sample)
            np.add(a, sample, out=sample)
            if n_added == 0:  # 0 + x is x: the compiled loop's first addition
                np.subtract(sample, refs, out=cost)
                np.abs(cost, out=cost)
            else:
                np.subtract(sample, refs, out=diff)
                np.abs(diff, out=diff)
                np.add(cost, diff, out=cost)
            n_added += 1
        if n_added == 0:
            cost[...] = 0.0
        by_rows[:, :half] = by_rows[:, half : half + 1]
        by_rows[:, half + rows :] = by_rows[:, half + rows - 1 : half + rows]
        np.add(by_rows[:, 0:rows], by_rows[:, 1 : rows + 1], out=row_sums)
        for i in range(2, COST_BOX_PX):
            np.add(row_sums, by_rows[:, i : i + rows], out=row_sums)
        by_cols[:, :, :half] = by_cols[:, :, half : half + 1]
        by_cols[:, :, half + cols :] = by_cols[:, :, half + cols - 1 : half + cols]
        np.add(by_cols[:, :, 0:cols], by_cols[:, :, 1 : cols + 1], out=box)
        for i in range(2, COST_BOX_PX):
            np.add(box, by_cols[:, :, i : i + cols], out=box)
        np.multiply(box, scale, out=box)
        np.add(total, box, out=total)
        np.less(box, best, out=lower)
        np.copyto(best, box, where=lower)
        np.copyto(best_i, first + k, where=lower)
