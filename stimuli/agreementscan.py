"""The agreement depth scan (ours, beyond the paper): plane sweep of view agreement with a null.

Where the scene lies is measured, not assumed (the default of
:func:`stimuli.planes.find_object_planes`). :func:`estimate_disparity_range` finds the
disparities the scene occupies with a coarse sweep; the fine sweep shifts the views on the
centre row and column onto the centre view at each plane and, per pixel, finds the plane where
they agree best (a pixel whose least cost is reached at two planes or more, a flat patch at
those shifts, cannot tell them apart and does not vote). The score is the smoothed fraction of
pixels per plane (support). The same sweep against a non-coincident reference (the centre view
mirrored and shifted) is the null. A plane is reported when its peak holds :data:`MIN_SUPPORT`
of the pixels, stands :data:`MIN_EVIDENCE` times above the null's largest peak, and is not a
shoulder of a higher hill. Each plane carries its ``support`` and ``evidence``; a pile-up of
pixels at either end of the range warns that it is too narrow. On Middlebury Baby1 and Aloe and
HCI antinous every ground-truth mode holding >= 5 % of the pixels is found within 0.5 px per
view step, with no other plane (``tests/stimuli/test_lf_real.py``).
"""

from __future__ import annotations

import contextlib
import itertools
import math
import sys
import threading
import warnings
from collections.abc import Iterator
from typing import NamedTuple

import numpy as np

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.haarscan import MIN_EDGE_PIXELS
from stimuli.lfload import as_lightfield
from stimuli.lfviews import LightField
from stimuli.planescan import Plane, PlaneScan, find_peaks, gaussian_smooth, median_spacing
from stimuli.rowthreads import default_workers, run_on_threads

__all__ = [
    "scan_binning",
    "scan_views",
    "answer_before_compiled_code",
    "agreement_scan",
    "estimate_disparity_range",
    "scene_span",
    "SceneSpan",
    "AGREEMENT_RATIO",
    "COST_WINDOW_PX",
    "MIN_CONTRAST",
    "MIN_SUPPORT",
    "MIN_EVIDENCE",
    "SHOULDER_FRACTION",
    "SHOULDER_FRACTION_STRONG",
    "STRONG_EVIDENCE",
    "SMOOTH_SHIFT_PX",
    "SCAN_SHORT_SIDE_PX",
    "COARSE_SHORT_SIDE_PX",
    "SCAN_BUDGET_PX",
    "scan_downsample",
    "RANGE_REFINE_STEPS",
    "best_plane_map",
]

#: A pixel's views *agree* at its best plane when their aggregated difference from the centre
#: view there is below this fraction of its mean over the scan (ours). Flat pixels match every
#: plane about equally and never pass; pixels with texture pass at their own depth only.
AGREEMENT_RATIO: float = 0.5

#: A pixel votes only when its views differ from the centre view by more than this on
#: average over the scan (per view, grey levels in [0, 1]; ours: two levels of 8-bit data), so
#: flat regions, which match every plane, never vote.
MIN_CONTRAST: float = 2.0 / 255.0

#: Side of the box over which view differences are summed before choosing a pixel's best
#: plane, pixels of the binned views (ours: the usual stereo matching window).
COST_WINDOW_PX: int = 5

#: A plane needs at least this fraction of the view's pixels agreeing on its hill (ours: one
#: percent, far below the 5 % clusters the ground-truth tests ask for, far above single edges).
MIN_SUPPORT: float = 0.01

#: A plane's peak must be this many times more prominent than the largest peak the same scan
#: gives against a non-coincident reference (ours: twice what chance alone produced).
MIN_EVIDENCE: float = 2.0

#: A peak whose prominence is less than this fraction of its height is a shoulder or a second
#: top of a neighbouring hill, i.e. the same object (ours).
SHOULDER_FRACTION: float = 0.5

#: Hysteresis of the shoulder rule (ours): a peak standing :data:`STRONG_EVIDENCE` times above
#: the null's largest peak is a plane of its own when its prominence is at least this fraction
#: of its height, so a real near plane whose hill sits on the flank of a bigger one is not
#: dropped on a knife edge of :data:`SHOULDER_FRACTION` (49 % against 50 %).
SHOULDER_FRACTION_STRONG: float = 0.25

#: A peak this many times more prominent than the null's largest peak is strong evidence (ours:
#: four times :data:`MIN_EVIDENCE`); it needs only :data:`SHOULDER_FRACTION_STRONG`.
STRONG_EVIDENCE: float = 4.0 * MIN_EVIDENCE

#: The support curve is smoothed by a Gaussian of this many binned pixels of the outermost
#: view's shift (ours: the precision of a sub-pixel match), at least one plane.
SMOOTH_SHIFT_PX: float = 0.25

#: The scan's views are binned until their short side is about this many pixels, but never by
#: more than the largest view offset (2 for a 3x3 grid), so that a quarter of a binned pixel of
#: the outermost view is at most a quarter pixel per view step (half on 3x3 grids; ours).
SCAN_SHORT_SIDE_PX: int = 100

#: The coarse range-finding sweep works on views about this small (short side, pixels; ours),
#: binned by at most four times the largest view offset (a 3x3 grid keeps 2 px steps).
COARSE_SHORT_SIDE_PX: int = 64


#: Large views are scanned downsampled (ours): when the views binned by :func:`scan_binning`
#: still hold more than this many pixels, every binning of the scan (the range stages and the
#: sweep) is multiplied by the smallest integer that brings them under it
#: (:func:`scan_downsample`). 320 x 320 bounds a 200-plane sweep of a 3x3 grid (four views)
#: near half a second on two cores, and leaves every capture up to 640 x 640 views on a 3x3 grid
#: (binned 2), or 1280 x 1280 on a 9x9 (binned 4), scanned exactly as before; a 3x3 grid of
#: 1024 x 1024 views is scanned at 256 x 256 (binned 4 instead of 2).
SCAN_BUDGET_PX: int = 320 * 320


#: The coarse range is refined by a finer sweep when it spans fewer than this many coarse steps
#: (ours: then a coarse step, which the range is widened by, is a sizeable part of the scene).
RANGE_REFINE_STEPS: int = 20


def scan_binning(lightfield: LightField) -> int:
    """Return the view binning of the agreement scan (:data:`SCAN_SHORT_SIDE_PX`)."""
    m = _max_offset(lightfield)
    return int(max(1, min(max(m, 2), min(lightfield.shape_px) // SCAN_SHORT_SIDE_PX)))


def scan_downsample(lightfield: LightField, binning: int | None = None) -> int:
    """Return the factor by which the agreement scan downsamples large views (1: not at all).

    The smallest integer ``f >= 1`` such that the views binned by ``binning * f`` (``binning``
    defaults to :func:`scan_binning`) hold at most :data:`SCAN_BUDGET_PX` pixels. Views that
    fit the budget at the scan's binning give 1, so small captures are scanned unchanged.
    """
    b = scan_binning(lightfield) if binning is None else int(binning)
    rows, cols = lightfield.shape_px
    f = 1
    while (rows // (b * f)) * (cols // (b * f)) > SCAN_BUDGET_PX:
        f += 1
    return f


def _max_offset(lf: LightField) -> int:
    n_u, n_v = lf.grid
    cu, cv = lf.centre_index
    return max(cu, n_u - 1 - cu, cv, n_v - 1 - cv, 1)


def _cross_offsets(lf: LightField) -> list[tuple[int, int]]:
    """Return the views used by the agreement scan.

    On the centre row and column, the outermost and the half-way view on each side. Views off the
    cross would need 2-D (four-tap) interpolation for little extra evidence.
    """
    out = _offsets_on_the_cross(lf.grid)
    if not out:
        raise InputError(f"{lf.source}: a light field needs at least two views, got grid {lf.grid}")
    return out


def scan_views(grid: tuple[int, int]) -> list[tuple[int, int]]:
    """Return the grid positions ``(u, v)`` of the views the agreement scan reads.

    The centre view (:attr:`LightField.centre_index`) and, on its row and column, the
    outermost and the half-way view on each side: what a loader needs to read for a scan and
    a plane choice (``load_lightfield(..., only_views=scan_views)``).

    Examples
    --------
    >>> scan_views((1, 7))
    [(0, 3), (0, 1), (0, 0), (0, 5), (0, 6)]
    """
    n_u, n_v = (int(n) for n in grid)
    cu, cv = n_u // 2, n_v // 2
    return [(cu, cv)] + [(cu + du, cv + dv) for du, dv in _offsets_on_the_cross((n_u, n_v))]


def _offsets_on_the_cross(grid: tuple[int, int]) -> list[tuple[int, int]]:
    n_u, n_v = grid
    cu, cv = n_u // 2, n_v // 2
    out: list[tuple[int, int]] = []
    for n, c, axis in ((n_u, cu, 0), (n_v, cv, 1)):
        for side in (-1, 1):
            far = c if side < 0 else n - 1 - c
            for k in sorted({far, (far + 1) // 2}):
                if k > 0:
                    out.append((side * k, 0) if axis == 0 else (0, side * k))
    return out


#: Which plane sweep :func:`_sweep` uses: ``"auto"`` (see :func:`_sweep_function`),
#: ``"compiled"`` (:func:`stimuli.kernels.agreement_sweep`) or ``"numpy"``
#: (:func:`stimuli.planesweep.agreement_sweep`). The two give the same result to the bit;
#: benchmarks and tests set it to time or compare one of them.
SWEEP_PATH: str = "auto"

#: The largest sweep (pixels x views x planes) that ``"auto"`` makes in numpy, within
#: :func:`answer_before_compiled_code` while the compiled code is not loaded (ours). Numpy takes
#: about 4-6 ns per unit on a 2 GHz core, the compiled sweep about 1.4 ns but only after
#: numba's start-up of about 0.75 s: below this bound (numpy at most about 0.5 s) numpy answers
#: first. A 200-plane scan of a Lytro 7x7 capture is about 4e7 units.
NUMPY_SWEEP_MAX_WORK: int = 100_000_000

_ANSWER_FIRST = threading.local()


@contextlib.contextmanager
def answer_before_compiled_code() -> Iterator[None]:
    """Within this block (on this thread), a small sweep runs in numpy if nothing compiled runs yet.

    For a command whose answer is the scan itself (``confocal lightfield scan``): the numpy
    sweep answers before numba's start-up would be over. Work that refocuses right after its
    scan (``stimuli build``, ``view``, active search) pays that start-up anyway and keeps the
    compiled sweep. The result is the same to the bit either way.
    """
    before = getattr(_ANSWER_FIRST, "on", False)
    _ANSWER_FIRST.on = True
    try:
        yield
    finally:
        _ANSWER_FIRST.on = before


#: The smallest views (pixels) the numpy sweep splits over threads (ours): on small views each
#: step is so short that handing the GIL between threads eats what the second core gives
#: (measured on the shared Lytro capture, whole detection: two threads 1.04x faster with
#: 383x552 views, no faster with 128x184; the sums are the same either way).
NUMPY_THREADS_MIN_PX: int = 16_000


def _sweep_path(work: int) -> str:
    """Which plane sweep runs a sweep of ``work`` units (pixels x views x planes)."""
    if SWEEP_PATH != "auto":
        return SWEEP_PATH
    small = work <= NUMPY_SWEEP_MAX_WORK and "stimuli.kernels" not in sys.modules
    return "numpy" if small and getattr(_ANSWER_FIRST, "on", False) else "compiled"


def _sweep_function(work: int):
    """Return the plane sweep for a sweep of ``work`` units (pixels x views x planes)."""
    return _load_sweep(_sweep_path(work))


def _load_sweep(path: str):
    """Return the plane sweep ``path`` names: ``"numpy"`` or ``"compiled"``."""
    if path == "numpy":
        from stimuli.planesweep import COST_BOX_PX, agreement_sweep
    elif path == "compiled":
        from stimuli.kernels import COST_BOX_PX, agreement_sweep
    else:
        raise ValueError(f"SWEEP_PATH must be 'auto', 'compiled' or 'numpy', got {path!r}")
    if COST_BOX_PX != COST_WINDOW_PX:  # pragma: no cover - the constants are one value
        raise RuntimeError(f"COST_WINDOW_PX must equal the sweep's COST_BOX_PX ({path})")
    return agreement_sweep


def _sweep(
    views: list[np.ndarray],
    offsets: list[tuple[int, int]],
    centre: np.ndarray,
    null_centre: np.ndarray,
    ds: np.ndarray,
    workers: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Plane sweep: per pixel, the index of the plane of best agreement and whether it agrees.

    Returns ``(best_index, agrees, null_best_index, null_agrees)``; the null uses
    ``null_centre`` as the reference.

    How it is fast: every view is shifted along one axis only (centre row and column), and each
    thread sweeps its share of the planes in one call of the sweep :func:`_sweep_function`
    chooses (compiled, or its numpy twin for a small sweep in a process that has not loaded
    the compiled code): per plane, the interpolated views' differences from both references,
    the box filter and the running best. The views that shift along columns are padded once by
    repeating their end columns, so that a shift is an offset into the padded row.
    """
    rows, cols = centre.shape
    path = _sweep_path(rows * cols * len(views) * len(ds))
    agreement_sweep = _load_sweep(path)
    m = max(max(abs(a), abs(b)) for a, b in offsets)
    pad = int(math.ceil(float(np.abs(ds).max()) * m)) + 2
    row_group = [(img, du) for img, (du, dv) in zip(views, offsets, strict=True) if du]
    col_group = [(img, dv) for img, (du, dv) in zip(views, offsets, strict=True) if not du]
    row_views = np.zeros((len(row_group), rows, cols), np.float32)
    col_views = np.zeros((len(col_group), rows, cols + 2 * pad), np.float32)
    for j, (img, _) in enumerate(row_group):
        row_views[j] = img
    for j, (img, _) in enumerate(col_group):
        col_views[j] = np.pad(np.asarray(img, np.float32), ((0, 0), (pad, pad)), mode="edge")
    row_steps = np.array([off for _, off in row_group], np.float64)
    col_steps = np.array([off for _, off in col_group], np.float64)
    refs = np.ascontiguousarray(np.stack([centre, null_centre]), dtype=np.float32)
    planes = np.ascontiguousarray(ds, dtype=np.float64)

    def run(idx: np.ndarray):
        best = np.full((2, rows, cols), np.inf, np.float32)
        best_i = np.zeros((2, rows, cols), np.int32)
        total = np.zeros((2, rows, cols), np.float32)
        tied = np.zeros((2, rows, cols), np.uint8)
        if idx.size:
            agreement_sweep(
                row_views, row_steps, col_views, col_steps, pad, refs,
                planes[idx[0] : idx[-1] + 1], int(idx[0]), best, best_i, total, tied,
            )  # fmt: skip
        return best, best_i, total, tied

    n_threads = max(1, min(workers, len(ds)))
    parts = np.array_split(np.arange(len(ds)), n_threads)
    if path == "compiled" or rows * cols >= NUMPY_THREADS_MIN_PX:
        results = run_on_threads(run, parts)
    else:  # the same parts in turn: the same sums, without the threads' hand-over of the GIL
        results = [run(part) for part in parts]
    out = []
    for j in (0, 1):
        best, best_i, total, tied = (np.array(results[0][q][j]) for q in range(4))
        for r in results[1:]:  # the threads' shares of the planes, in order
            better = r[0][j] < best
            tied[r[0][j] == best] = 1
            best[better] = r[0][j][better]
            best_i[better] = r[1][j][better]
            tied[better] = r[3][j][better]
            total += r[2][j]
        mean = total / np.float32(len(ds))
        agrees = (best < np.float32(AGREEMENT_RATIO) * mean) & (
            mean > np.float32(MIN_CONTRAST * len(offsets))
        )
        # A pixel whose least cost is reached at more than one plane (its box sees the same
        # thing there: flat surface around it at those shifts) cannot tell them apart; voting
        # for the first of them piled such pixels up at the end of the range.
        agrees &= tied == 0
        # A pixel whose views are sampled outside their image at its best plane (edge-
        # replicated there, which favours the planes that shift them least) does not vote.
        reach = np.abs(np.asarray(ds, np.float32))[best_i]
        yy = np.minimum(np.arange(rows), rows - 1 - np.arange(rows))[:, None]
        xx = np.minimum(np.arange(cols), cols - 1 - np.arange(cols))[None, :]
        my = max(abs(a) for a, _ in offsets)
        mx = max(abs(b) for _, b in offsets)
        agrees &= (reach * my <= yy) & (reach * mx <= xx)
        out += [best_i, agrees]
    return out[0], out[1], out[2], out[3]


#: The last sweep of :func:`agreement_scan` or :func:`best_plane_map`: ``{"last": (digest of
#: its inputs, its read-only result)}``. A plane scan followed by the plane choice (every
#: ``lightfield scan``, ``stimuli build`` and ``view``) sweeps the same views at the same planes
#: twice; the second time is a look-up.
_LAST_SWEEP: dict = {}


def _sweep_once(views, offsets, centre, null_centre, ds, workers: int):
    """:func:`_sweep`, or its last result when the inputs are the same to the bit.

    The key is a digest of the (binned) views, the references, the offsets, the planes and the
    number of threads (the null's mean is summed per thread), so a changed input never hits.
    """
    import hashlib

    h = hashlib.blake2b(digest_size=20)
    for a in (*views, centre, null_centre, np.asarray(ds, dtype=np.float64)):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.view(np.uint8).reshape(-1))
    h.update(repr((list(offsets), int(workers))).encode())
    key = h.digest()
    last = _LAST_SWEEP.get("last")  # one (key, result) pair: safe when threads scan at once
    if last is not None and last[0] == key:
        return last[1]
    out = _sweep(views, offsets, centre, null_centre, ds, workers)
    for a in out:
        a.setflags(write=False)
    _LAST_SWEEP["last"] = (key, out)
    return out


def _bin_view(view: np.ndarray, b: int) -> np.ndarray:
    if b == 1:
        return np.ascontiguousarray(view, dtype=np.float32)
    r, c = view.shape[0] // b, view.shape[1] // b
    v = view[: r * b, : c * b].reshape(r, b, c * b).sum(axis=1, dtype=np.float32)
    v = v.reshape(r, c, b).sum(axis=2, dtype=np.float32)
    return v * np.float32(1.0 / (b * b))


def _scan_inputs(lf: LightField, binning: int):
    """Return the views the agreement scan uses (only those are converted and binned)."""
    if lf.views.ndim == 5:
        lf = lf.gray()
    offsets = _cross_offsets(lf)
    cu, cv = lf.centre_index
    views = [_bin_view(lf.views[cu + du, cv + dv], binning) for du, dv in offsets]
    centre = _bin_view(lf.views[cu, cv], binning)
    small = lf  # grid and offsets are unchanged by binning pixels
    # Non-coincident reference: the centre view mirrored left-right and shifted (circularly) by
    # half its size plus a pixel has the same grey levels and texture statistics but no scene
    # point where the views put it, at any plane. (Turning it by 180 degrees is not enough: a
    # periodic texture turned is the same texture; views shuffled still agree at disparity 0;
    # mirroring changes the orientation of oblique periodic texture.)
    rows, cols = centre.shape
    null_centre = np.ascontiguousarray(
        np.roll(centre[:, ::-1], (rows // 2 + 1, cols // 2 + 1), (0, 1))
    )
    return small, views, offsets, centre, null_centre


def _support_curves(best_i, agrees, nbest_i, nagrees, n_planes: int, sigma_planes: float):
    n_px = best_i.size
    raw = np.bincount(best_i[agrees], minlength=n_planes).astype(np.float64) / n_px
    null = np.bincount(nbest_i[nagrees], minlength=n_planes).astype(np.float64) / n_px
    # A best plane at either end of the scan is censored (the optimum may lie beyond it): those
    # pixels do not vote; the caller warns when there are many.
    ends = (float(raw[0]), float(raw[-1]))
    raw[0] = raw[-1] = null[0] = null[-1] = 0.0
    smooth = gaussian_smooth(raw, sigma_planes, mode="nearest")
    nsmooth = gaussian_smooth(null, sigma_planes, mode="nearest")
    return raw, smooth, nsmooth, ends


def _occupied_span(ds: np.ndarray, best_i, agrees, nbest_i, nagrees) -> tuple[float, float] | None:
    """Return the disparities (of ``ds``) holding the scene: where more pixels agree than by chance.

    The histogram of the agreeing pixels' best planes is smoothed by one plane and compared
    with the same histogram against the non-coincident reference (the null): planes above the
    null's highest bin hold the scene, runs of them holding at least half of
    :data:`MIN_SUPPORT` count (so a plane the scan would report is never cut, and a stray
    bin is). The end planes are censored (their optimum may lie beyond them) and do not count.
    Returns ``(low, high)`` in the units of ``ds``, or None when nothing passes.
    """
    n_px = best_i.size
    h = np.bincount(best_i[agrees], minlength=len(ds)).astype(np.float64) / n_px
    nh = np.bincount(nbest_i[nagrees], minlength=len(ds)).astype(np.float64) / n_px
    ends = (float(h[0]), float(h[-1]))
    h[0] = h[-1] = nh[0] = nh[-1] = 0.0
    hs = gaussian_smooth(h, 1.0, mode="constant")
    level = MIN_EVIDENCE * max(float(gaussian_smooth(nh, 1.0, mode="constant").max()), 1.0 / n_px)
    idx = np.flatnonzero(hs > level)
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1) if idx.size else []
    runs = [r for r in runs if h[r[0] : r[-1] + 1].sum() >= 0.5 * MIN_SUPPORT]
    if not runs:
        return None
    lo, hi = int(runs[0][0]), int(runs[-1][-1])
    # A pile-up at an end plane means the scene goes on beyond it: keep that end open.
    if ends[0] >= MIN_SUPPORT:
        lo = 0
    if ends[1] >= MIN_SUPPORT:
        hi = len(ds) - 1
    return float(ds[lo]), float(ds[hi])


def estimate_disparity_range(
    lightfield: LightField | np.ndarray, *, workers: int | None = None
) -> tuple[float, float]:
    """Estimate the disparities the scene occupies, pixels per view step (full resolution).

    Measured from the views, not from the image size: the outermost and half-way views of the
    centre row and column are matched to the centre view over candidate shifts (the agreement
    sweep of :func:`agreement_scan`, with its null), twice:

    1. *coarse*: views binned to about :data:`COARSE_SHORT_SIDE_PX` pixels, every disparity that
       moves the outermost view by up to half the image, in steps of half a coarse pixel of the
       outermost view;
    2. *fine*: views binned as the scan bins them (:func:`scan_binning`), over the coarse span
       widened by two coarse steps, in steps of a quarter of a binned pixel of the outermost
       view (so small grids, whose coarse steps are whole pixels per view step, are bracketed
       to a fraction of a pixel).

    Large views (:func:`scan_downsample` ``f > 1``) are binned ``f`` times more in both stages.
    Each stage keeps the disparities where more pixels agree than against a non-coincident
    reference (runs holding at least half of :data:`MIN_SUPPORT`); the range is the fine span
    widened by one fine step on each side, and clipped to the geometry's ``near_m``/``far_m``
    when it has them.

    Returns
    -------
    (low, high) : tuple of float
        ``low < high``, pixels per view step.

    Raises
    ------
    InputError
        No pixel's views agree at any plane (a flat or non-light-field input).
    """
    return scene_span(lightfield, workers=workers).range(as_lightfield(lightfield).source)


class SceneSpan(NamedTuple):
    """What :func:`estimate_disparity_range` is made of, pixels per view step."""

    #: The disparities where more pixels agree than against the non-coincident reference (the
    #: last stage's span).
    lo: float
    hi: float
    #: By how much the range widens that span on each side (two coarse steps, or one fine step
    #: after the fine stage).
    margin: float
    #: The limits the range is clipped to: the geometry's ``near_m``/``far_m`` where it has
    #: them, within the largest disparity the views allow.
    limit_lo: float
    limit_hi: float

    def range(self, source: str) -> tuple[float, float]:
        """Return :func:`estimate_disparity_range`: the span widened by its margin, clipped.

        Raises
        ------
        InputError
            Nothing of the widened span lies within the limits (``source`` names the input).
        """
        lo = max(self.lo - self.margin, self.limit_lo)
        hi = min(self.hi + self.margin, self.limit_hi)
        if not hi > lo:
            raise InputError(f"{source}: the estimated disparity range is empty")
        return float(lo), float(hi)


def scene_span(lightfield: LightField | np.ndarray, *, workers: int | None = None) -> SceneSpan:
    """Return the span the scene occupies, its margin and its limits (:class:`SceneSpan`)."""
    lf = as_lightfield(lightfield).gray()
    n = workers or default_workers()
    m = _max_offset(lf)
    f = scan_downsample(lf)
    b = f * max(1, min(min(lf.shape_px) // COARSE_SHORT_SIDE_PX, 4 * m))
    _, views, offsets, centre, null_centre = _scan_inputs(lf, b)
    step = 0.5 / m  # binned px per view step
    dmax = min(centre.shape) / (2.0 * m)
    ds = np.arange(-dmax, dmax + step / 2, step)
    sweep = _sweep(views, offsets, centre, null_centre, ds, n)
    if (
        int(np.count_nonzero(sweep[1])) < MIN_EDGE_PIXELS
        or (span := _occupied_span(ds * b, *sweep)) is None
    ):
        raise InputError(
            f"{lf.source}: the views agree at no plane in [-{dmax * b:.3g}, {dmax * b:.3g}] px "
            "per view step (a flat scene, or not a light field); give the disparities to scan"
        )
    margin = 2 * step * b
    lo, hi = span[0] - margin, span[1] + margin
    fine_step = step * b  # full-resolution px per view step of the coarse stage
    b2 = min(scan_binning(lf) * f, b)
    step2 = 0.25 / m * b2  # full-resolution px per view step
    # Refine only where the coarse steps are coarse for the span found (small grids, whose
    # coarse step is whole pixels per view step); the fine sweep holds at most 64 planes.
    step2 = max(step2, (hi - lo) / 64)
    if fine_step > (hi - lo) / RANGE_REFINE_STEPS and step2 < fine_step:
        _, views, offsets, centre, null_centre = _scan_inputs(lf, b2)
        ds2 = np.arange(lo, hi + step2 / 2, step2)
        if ds2.size >= 3:
            sweep = _sweep(views, offsets, centre, null_centre, ds2 / b2, n)
            span2 = _occupied_span(ds2, *sweep)
            if span2 is not None:
                span, margin = span2, step2
    lim = float(lf.max_disparity_px())
    limit_lo, limit_hi = -lim, lim
    g = lf.geometry
    if g is not None and g.near_m is not None and g.far_m is not None:
        a, c = sorted((g.disparity_px(g.near_m), g.disparity_px(g.far_m)))
        limit_lo, limit_hi = max(limit_lo, a), min(limit_hi, c)
    return SceneSpan(
        float(span[0]), float(span[1]), float(margin), float(limit_lo), float(limit_hi)
    )


def _is_plane_peak(height: float, prominence: float, null_prominence: float) -> bool:
    """Return the peak rule with hysteresis: evidence against the null, and not a shoulder.

    A peak needs :data:`MIN_EVIDENCE` times the null's largest prominence and a prominence of
    :data:`SHOULDER_FRACTION` of its height; with :data:`STRONG_EVIDENCE`, a prominence of
    :data:`SHOULDER_FRACTION_STRONG` of its height is enough.
    """
    if prominence < MIN_EVIDENCE * null_prominence:
        return False
    if prominence >= SHOULDER_FRACTION * height:
        return True
    return (
        prominence >= SHOULDER_FRACTION_STRONG * height
        and prominence >= STRONG_EVIDENCE * null_prominence
    )


def agreement_scan(
    lf: LightField,
    ds: np.ndarray,
    *,
    binning: int,
    workers: int,
    downsample: int = 1,
) -> PlaneScan:
    """Scan the planes ``ds`` (full-resolution px per view step) by view agreement, with a null.

    The views are binned by ``binning * downsample`` and the planes' shifts divided by it
    (sub-pixel shifts); the support curve is smoothed as at ``binning`` (:data:`SMOOTH_SHIFT_PX`
    of a ``binning`` pixel), so downsampled views keep the same planes apart. Called by
    :func:`stimuli.planes.find_object_planes` (which checks the arguments); warns (stacklevel
    for that caller's caller) when many pixels agree best at either end.
    """
    total = binning * downsample
    small, views, offsets, centre, null_centre = _scan_inputs(lf, total)
    m = _max_offset(small)
    best_i, agrees, nbest_i, nagrees = _sweep_once(
        views, offsets, centre, null_centre, ds / total, workers
    )
    spacing = median_spacing(ds) / binning  # binned px per view step
    sigma = max(1.0, SMOOTH_SHIFT_PX / (m * spacing)) if spacing > 0 else 1.0
    raw, s, ns, ends = _support_curves(best_i, agrees, nbest_i, nagrees, len(ds), sigma)
    n_px = best_i.size
    _, nprops = find_peaks(ns, prominence=0.0)
    null_prom = max(float(nprops["prominences"].max(initial=0.0)), 1.0 / n_px)
    idx, props = find_peaks(s, prominence=0.0)
    prom = props["prominences"] if idx.size else np.zeros(0)
    keep = [
        (int(i), float(p))
        for i, p in zip(idx, prom, strict=True)
        if _is_plane_peak(float(s[i]), float(p), null_prom)
    ]
    # Hills: each kept peak owns the support between the lowest points towards its neighbours.
    bounds = [0]
    for (a, _), (b, _) in itertools.pairwise(keep):
        bounds.append(a + int(np.argmin(s[a : b + 1])))
    bounds.append(len(ds))
    # A plane's support is the smoothed support above its base (the peak's height minus its
    # prominence) within two smoothing widths of the peak: a plane is sharp in disparity, while
    # a long flat tail under a small wiggle, or the broad smear of pixels at occlusion
    # boundaries (which match between two depths), holds little there.
    depths = None
    if lf.geometry is not None:
        depths = np.array([lf.geometry.depth_m(d) for d in ds])
    peaks = []
    for k, (i, p) in enumerate(keep):
        base = s[i] - p
        w = int(math.ceil(2 * sigma))
        lo, hi = max(bounds[k], i - w), min(bounds[k + 1], i + w + 1)
        support = float(np.clip(s[lo:hi] - base, 0.0, None).sum())
        if support < MIN_SUPPORT:
            continue
        d = float(ds[i])
        if 0 < i < len(ds) - 1:  # sub-plane position: vertex of the parabola through 3 samples
            y0, y1, y2 = s[i - 1], s[i], s[i + 1]
            den = y0 - 2 * y1 + y2
            if den < 0:
                frac = float(np.clip(0.5 * (y0 - y2) / den, -0.5, 0.5))
                d = float(np.interp(i + frac, np.arange(len(ds)), ds))
        peaks.append(
            Plane(
                disparity_px=d,
                depth_m=None if lf.geometry is None else lf.geometry.depth_m(d),
                score=float(s[i]),
                prominence=p,
                index=i,
                support=support,
                evidence=p / null_prom,
            )
        )
    for end, name, mass in ((0, "first", ends[0]), (len(ds) - 1, "last", ends[1])):
        if mass >= MIN_SUPPORT:
            warnings.warn(
                f"{lf.source}: {100 * mass:.1f} % of the pixels agree best at the {name} "
                f"scanned plane ({float(ds[end]):.4g} px per view step): an object may lie "
                "beyond the scanned range; widen it",
                stacklevel=3,
            )
    peaks.sort(key=lambda p: -p.disparity_px)
    return PlaneScan(
        np.asarray(ds, dtype=np.float64),
        depths,
        s,
        tuple(peaks),
        total,
        jung2015.HAAR_EDGE_FRACTION,
        MIN_EVIDENCE * null_prom,
        0.0,
        "agreement",
        ns,
        downsample,
    )


def best_plane_map(
    lightfield: LightField, disparities_px: np.ndarray, *, binning: int, workers: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Return each (binned) pixel's best plane and whether its views agree there.

    The per-pixel answer of the same sweep :func:`agreement_scan` counts: ``best_index`` into
    ``disparities_px`` (full-resolution px per view step) and ``agrees`` (the pixel votes).
    Both are ``(rows // binning, cols // binning)``; the stimulus builder uses them to find
    where a detected plane's content lies (:mod:`stimuli.planechoice`).
    """
    lf = as_lightfield(lightfield).gray()
    _, views, offsets, centre, null_centre = _scan_inputs(lf, int(binning))
    ds = np.asarray(disparities_px, dtype=np.float64) / int(binning)
    best_i, agrees, _, _ = _sweep_once(
        views, offsets, centre, null_centre, ds, workers or default_workers()
    )
    return best_i.copy(), agrees.copy()
