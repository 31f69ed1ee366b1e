"""Shift-and-add refocusing of a light field: confocal images at any depth plane.

The confocal image at disparity ``d`` (pixels per view step, convention in
:mod:`stimuli.lightfield`) is the average of all views, each shifted so that points of the plane
``d`` line up with the centre view::

    R_d(y, x) = sum_{u,v} I_uv(y - d du, x - d dv) / W(y, x)

Sub-pixel shifts use linear interpolation. Near the borders some shifted views fall outside
their image; those samples are left out and ``W`` counts only the views (and interpolation
weights) that contribute, so the image is a proper average everywhere ("normalised where views
do not overlap") instead of darkening towards the edges.

How it is fast
--------------
* The shift is separable: for every grid row ``u`` the views are summed over ``v`` with their
  column shifts ``d dv`` into a partial image, then the ``n_u`` partial images with their row
  shifts ``d du``; a shift by ``s = n + f`` is two weighted adds of integer-shifted rows,
  ``(1 - f) I(x - n) + f I(x - n - 1)``, in ``float32``.
* Grey float32 views take the compiled pass (:func:`stimuli.shiftadd.shift_add_rows`, numba):
  blocks of output rows, each view read from memory once, vectorised loops over columns, on
  one thread below :data:`_THREAD_MIN_PIXELS` (threads split the output rows above it).
* Otherwise (colour, other dtypes, and a scan's last steps in a process that has not loaded
  numba: :func:`stimuli.numpykernels.active`) the numpy-slice path, which makes the same
  float32 sums in the same order, so the two paths give the same image to the bit (tested);
  threads split its first pass by blocks of ``u``, the second by blocks of columns (numpy
  releases the GIL).
* The weight ``W`` is separable: ``W(y, x) = w_rows(y) w_cols(x)`` (:func:`overlap_weights`).

References
----------
Ng, R. et al. (2005). Light field photography with a hand-held plenoptic camera. Stanford Tech
Report CTSR 2005-02, Sec. 4 (shift-and-add). Jung et al. (2015), Sec. 4.1 (computational
integral-imaging reconstruction as confocal imaging).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

import numpy as np

from stimuli import numpykernels
from stimuli.errors import InputError
from stimuli.lfload import as_lightfield
from stimuli.lightfield import LightField
from stimuli.resources import finite_number
from stimuli.rowthreads import default_workers, run_on_row_strips

__all__ = [
    "refocus",
    "focal_stack",
    "iter_focal_stack",
    "centre_view",
    "default_workers",
    "shift_weights",
    "overlap_weights",
]

#: Views up to this many pixels are processed a whole view column at a time (ours, measured:
#: numpy call overhead dominates small views, cache misses large ones).
_BLOCK_MAX_PIXELS = 1 << 16

#: Light fields of fewer pixels than this are refocused on one thread (ours, measured on the
#: shared 2-core machine under load, medians in one process: the 1x7 of 555x620 took 1.25 ms on
#: one thread against 5.4 ms on two, the 9x9 of 327x492 15 ms against 21 ms, the 3x3 of
#: 1024x1024 12.4 ms against 12.7 ms: the pass is bound by memory, and handing a strip to a
#: second thread costs more than it saves until the light field is well past the cache).
_THREAD_MIN_PIXELS = 1 << 24

#: Grey float32 views take the compiled pass (:mod:`stimuli.shiftadd`); the numpy-slice path
#: serves colour and other dtypes, and the tests compare the two.
_COMPILED = True


def _int_slices(length: int, m: int) -> tuple[slice, slice] | None:
    """Slices (dst, src) such that ``dst[x] = src[x - m]`` for every valid x; None if empty."""
    if m >= length or -m >= length:
        return None
    if m >= 0:
        return slice(m, length), slice(0, length - m)
    return slice(0, length + m), slice(-m, length)


def shift_weights(shift_px: float) -> tuple[tuple[int, float], ...]:
    """Integer shifts and weights of a linear-interpolation shift by ``shift_px``.

    ``((n, 1 - f),  (n + 1, f))`` for ``shift_px = n + f``; one pair ``(m, 1.0)`` for a
    whole shift (within 1e-6 px).

    Examples
    --------
    >>> shift_weights(2.25)
    ((2, 0.75), (3, 0.25))
    >>> shift_weights(-1.0)
    ((-1, 1.0),)
    """
    n = math.floor(shift_px)
    f = shift_px - n
    if f < 1e-6:
        return ((n, 1.0),)
    if f > 1.0 - 1e-6:
        return ((n + 1, 1.0),)
    return ((n, 1.0 - f), (n + 1, f))


def _accumulate(dst: np.ndarray, src: np.ndarray, shift_px: float, axis: int, tmp: np.ndarray):
    """``dst += src`` shifted by ``shift_px`` along ``axis`` (linear interpolation, zero fill)."""
    length = src.shape[axis]
    for m, w in shift_weights(shift_px):
        sl = _int_slices(length, m)
        if sl is None:
            continue
        d_idx = [slice(None)] * src.ndim
        s_idx = [slice(None)] * src.ndim
        d_idx[axis], s_idx[axis] = sl
        d_idx, s_idx = tuple(d_idx), tuple(s_idx)
        if w == 1.0:
            np.add(dst[d_idx], src[s_idx], out=dst[d_idx])
        else:
            t = tmp[d_idx]
            np.multiply(src[s_idx], np.float32(w), out=t)
            np.add(dst[d_idx], t, out=dst[d_idx])


def overlap_weights(length: int, shifts: Sequence[float]) -> np.ndarray:
    """How many views (interpolation weights summed) fall on each position along one axis.

    The refocused image's normaliser along that axis: views shifted by ``shifts`` px, each
    sampled by :func:`shift_weights`, over ``length`` positions (float64; 0 where none falls).
    """
    w = np.zeros(length, dtype=np.float64)
    for s in shifts:
        for m, a in shift_weights(s):
            sl = _int_slices(length, m)
            if sl is not None:
                w[sl[0]] += a
    return w


def _check_disparity(lf: LightField, disparity_px: float) -> float:
    d = finite_number(disparity_px, "slope_px_per_view")
    dmax = lf.max_disparity_px()
    if abs(d) > dmax:
        raise InputError(
            f"slope_px_per_view {d:g} is outside the light field's range [-{dmax:.4g}, "
            f"{dmax:.4g}] px per view step (outer views would not overlap the centre view)"
        )
    return d


def _inverse_weights(length: int, shifts: Sequence[float]) -> np.ndarray:
    """One over the number of contributing views along one axis (0 where none contributes)."""
    w = overlap_weights(length, shifts)
    inv = np.zeros_like(w)
    np.divide(1.0, w, out=inv, where=w > 1e-9)
    return inv.astype(np.float32)


def _refocus_compiled(
    views: np.ndarray,
    row_shifts: Sequence[float],
    col_shifts: Sequence[float],
    workers: int,
    result: np.ndarray,
) -> np.ndarray:
    """Shift-and-add of grey, C-contiguous float32 views into ``result``, normalised and clipped.

    One compiled pass over the views (:func:`stimuli.shiftadd.shift_add_rows`, blocks of output
    rows); above :data:`_THREAD_MIN_PIXELS`, on strips of rows in threads
    (:func:`stimuli.rowthreads.run_on_row_strips`).
    """
    from stimuli.shiftadd import shift_add_rows

    n_u, n_v, rows, cols = views.shape
    shifts = (np.asarray(row_shifts, np.float64), np.asarray(col_shifts, np.float64))
    if n_u * n_v * rows * cols < _THREAD_MIN_PIXELS or workers <= 1:
        shift_add_rows(views, *shifts, result, 0, rows)
        return result

    def run(r0: int, r1: int) -> None:
        shift_add_rows(views, *shifts, result, r0, r1)

    run_on_row_strips(run, rows, workers)
    return result


def _refocus_views(
    views: np.ndarray,
    d: float,
    workers: int,
    out: np.ndarray | None = None,
    offsets: tuple[Sequence[float], Sequence[float]] | None = None,
    nearest: bool = False,
) -> np.ndarray:
    """Shift-and-add ``views`` at disparity ``d``; ``offsets``: (du per u, dv per v)."""
    n_u, n_v, rows, cols = views.shape[:4]
    extra = views.shape[4:]
    if offsets is None:
        offsets = ([u - n_u // 2 for u in range(n_u)], [v - n_v // 2 for v in range(n_v)])
    row_shifts = [d * du for du in offsets[0]]
    col_shifts = [d * dv for dv in offsets[1]]
    if nearest:  # whole-pixel shifts: one add per view instead of two weighted adds
        row_shifts = [float(math.floor(s + 0.5)) for s in row_shifts]
        col_shifts = [float(math.floor(s + 0.5)) for s in col_shifts]

    result = out if out is not None else np.empty((rows, cols, *extra), dtype=np.float32)
    grey = not extra and views.dtype == np.float32 and views.flags.c_contiguous
    if _COMPILED and grey and not numpykernels.active():  # active: a scan's last steps
        return _refocus_compiled(views, row_shifts, col_shifts, workers, result)
    partial = np.zeros((n_u, rows, cols, *extra), dtype=np.float32)
    scratch = np.empty_like(partial)
    n_threads = max(1, min(workers, n_u))
    if n_u * rows * cols * n_v < _THREAD_MIN_PIXELS:
        n_threads = 1

    def pass_cols(u0: int, u1: int) -> None:
        if rows * cols * max(1, len(extra)) <= _BLOCK_MAX_PIXELS:
            # Small views: all grid rows of one view column at once (fewer numpy calls).
            for v in range(n_v):
                _accumulate(partial[u0:u1], views[u0:u1, v], col_shifts[v], 2, scratch[u0:u1])
            return
        # Large views: one grid row at a time, so that its partial sum and scratch (one view
        # each) stay in cache while the row's views stream through once.
        for u in range(u0, u1):
            for v in range(n_v):
                _accumulate(partial[u], views[u, v], col_shifts[v], 1, scratch[u])

    def pass_rows(c0: int, c1: int) -> None:
        for u in range(n_u):
            _accumulate(
                result[:, c0:c1], partial[u][:, c0:c1], row_shifts[u], 0, scratch[0][:, c0:c1]
            )

    result[...] = 0.0
    run_on_row_strips(pass_cols, n_u, n_threads)  # strips of grid rows, then of columns
    run_on_row_strips(pass_rows, cols, n_threads)
    return _normalise(result, rows, cols, row_shifts, col_shifts, extra)


def _normalise(result, rows, cols, row_shifts, col_shifts, extra):
    """Divide by the number of contributing views and clip to [0, 1], in place.

    The weight is separable, ``W(y, x) = w_rows(y) w_cols(x)``, so its inverse is applied as a
    row factor and a column factor (0 where no view contributes).
    """
    r = _inverse_weights(rows, row_shifts)
    c = _inverse_weights(cols, col_shifts)
    if extra:
        result *= r[:, None, None]
        result *= c[None, :, None]
    else:
        result *= r[:, None]
        result *= c[None, :]
    np.clip(result, 0.0, 1.0, out=result)
    return result


def refocus(
    lightfield: LightField | np.ndarray,
    slope_px_per_view: float,
    *,
    workers: int | None = None,
) -> np.ndarray:
    """Return the confocal image of a light field focused at one disparity.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    slope_px_per_view : float
        Disparity of the plane brought into focus, pixels per view step (larger = nearer;
        :mod:`stimuli.lightfield`). Must keep the outer views overlapping the centre view.
    workers : int, optional
        Threads to use (default: :func:`default_workers`).

    Returns
    -------
    ndarray of shape (rows, cols[, C]), float32 in [0, 1]

    Raises
    ------
    InputError
        A non-finite disparity, or one so large that the outer views miss the centre view.

    References
    ----------
    Ng et al. (2005), Sec. 4; Jung et al. (2015), Sec. 4.1.

    Examples
    --------
    >>> import numpy as np
    >>> tex = np.random.default_rng(0).random((8, 12)).astype(np.float32)
    >>> views = np.stack([np.stack([np.roll(tex, -(v - 1), axis=1) for v in range(3)])])
    >>> bool(np.allclose(refocus(views, 1.0)[:, 2:-2], tex[:, 2:-2]))
    True
    """
    lf = as_lightfield(lightfield)
    d = _check_disparity(lf, slope_px_per_view)
    return _refocus_views(lf.views, d, workers or default_workers())


def iter_focal_stack(
    lightfield: LightField | np.ndarray,
    slopes_px_per_view: Sequence[float],
    *,
    workers: int | None = None,
) -> Iterator[tuple[float, np.ndarray]]:
    """Yield ``(slope, confocal_image)`` for each disparity in turn (the caller owns the loop)."""
    lf = as_lightfield(lightfield)
    slopes = [_check_disparity(lf, s) for s in slopes_px_per_view]
    n = workers or default_workers()
    for d in slopes:
        yield d, _refocus_views(lf.views, d, n)


def focal_stack(
    lightfield: LightField | np.ndarray,
    slopes_px_per_view: Sequence[float],
    *,
    workers: int | None = None,
) -> np.ndarray:
    """Return confocal images at several disparities.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    slopes_px_per_view : sequence of float
        Disparities, pixels per view step.
    workers : int, optional

    Returns
    -------
    ndarray of shape (n_planes, rows, cols[, C]), float32 in [0, 1]
    """
    images = [img for _, img in iter_focal_stack(lightfield, slopes_px_per_view, workers=workers)]
    if not images:
        raise InputError("slopes_px_per_view must not be empty")
    return np.stack(images)


def centre_view(lightfield: LightField | np.ndarray) -> np.ndarray:
    """Return the centre view ``(n_u // 2, n_v // 2)``: the all-in-focus ("cluttered") image.

    Returns
    -------
    ndarray of shape (rows, cols[, C]), float32 in [0, 1] (a copy)
    """
    return as_lightfield(lightfield).centre_view()
