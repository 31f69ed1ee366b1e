"""Find the depth planes that hold objects (Jung et al. 2015, Sec. 4.2; Aloni & Yitzhaky 2014).

Two scans (``find_object_planes(..., method=...)``):

* ``'agreement'`` (default; ours): where the scene lies is measured, not assumed; a plane
  sweep of view agreement against a null (:mod:`stimuli.agreementscan`).
* ``'haar'``: the paper's method, the overlap of Haar edges with the centre view's
  (:mod:`stimuli.haarscan`).

Both return a :class:`~stimuli.planescan.PlaneScan` (:mod:`stimuli.planescan`: the result types
and the peak detection). :func:`confocal_plane` picks the plane a stimulus is built at. The
scans' functions and result types are importable from here; the agreement scan's tuning
constants stay in :mod:`stimuli.agreementscan`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from stimuli import jung2015
from stimuli.agreementscan import (
    SceneSpan,
    agreement_scan,
    estimate_disparity_range,
    scan_binning,
    scan_downsample,
    scene_span,
)
from stimuli.errors import InputError
from stimuli.haarscan import (
    MIN_EDGE_PIXELS,
    auto_binning,
    edge_overlap,
    haar_details,
    haar_edges,
    iter_plane_scores,
)
from stimuli.lfload import as_lightfield
from stimuli.lfviews import LightField
from stimuli.planescan import (
    DEFAULT_BINNING,
    DEFAULT_PRESMOOTH_PX,
    MIN_PROMINENCE_FRACTION,
    Plane,
    PlaneScan,
    scan_result,
    score_peaks,
)
from stimuli.refocus import _check_disparity, default_workers

__all__ = [
    "Plane",
    "PlaneScan",
    "haar_details",
    "haar_edges",
    "edge_overlap",
    "default_disparities",
    "iter_plane_scores",
    "score_peaks",
    "find_object_planes",
    "scan_result",
    "MIN_PROMINENCE_FRACTION",
    "DEFAULT_BINNING",
    "DEFAULT_N_PLANES",
    "DEFAULT_PRESMOOTH_PX",
    "MIN_EDGE_PIXELS",
    "auto_binning",
    "scan_binning",
    "scan_downsample",
    "estimate_disparity_range",
    "SCAN_METHODS",
]

#: Depth-scan methods: ``'agreement'`` (ours, the default: plane sweep of view agreement with a
#: null) and ``'haar'`` (the paper's Haar-edge overlap score, Sec. 4.2).
SCAN_METHODS: tuple[str, ...] = ("agreement", "haar")


#: Number of planes scanned by default. Source: Jung et al. (2015), Fig. 15 (200 planes).
DEFAULT_N_PLANES: int = 200


def default_disparities(
    lightfield: LightField, n_planes: int = DEFAULT_N_PLANES, *, workers: int | None = None
) -> np.ndarray:
    """Return the disparities scanned when none are given: from the data, not a constant.

    ``n_planes`` disparities equally spaced over :func:`estimate_disparity_range` (the span the
    scene occupies, clipped to the geometry's ``near_m``/``far_m``). Equal disparity steps are
    equal steps of the outermost view's shift, so the spacing follows the grid's baseline.

    The scan does not count a best plane at either end (the optimum may lie beyond it), so
    each end plane is put at least one plane spacing beyond the scene's span as clipped to the
    geometry's limits (:func:`stimuli.agreementscan.scene_span`), within the largest disparity
    the views allow. The range's own margin is a fraction of a pixel per view step: with a few
    planes far apart, or where a limit cuts the span, a plane of the scene would otherwise be
    an end plane and lose its votes. With many planes (the default 200) the margin is usually
    wider than a spacing, and the planes are those of the range.
    """
    if isinstance(n_planes, bool) or not isinstance(n_planes, (int, np.integer)) or n_planes < 3:
        raise InputError(f"n_planes must be an integer >= 3, got {n_planes!r}")
    lf = as_lightfield(lightfield)
    span = scene_span(lf, workers=workers)
    a, b = _censored_ends(span, int(n_planes), lf.source)
    lim = float(lf.max_disparity_px())
    return np.linspace(max(a, -lim), min(b, lim), int(n_planes))


def _censored_ends(span: SceneSpan, n: int, source: str) -> tuple[float, float]:
    """Return the end planes of ``n`` planes over ``span``'s range (:func:`default_disparities`)."""
    lo, hi = span.range(source)
    core_lo, core_hi = max(span.lo, span.limit_lo), min(span.hi, span.limit_hi)
    if n < 5 or not core_hi > core_lo:  # too few planes for an end beyond each side
        return lo, hi
    s = (hi - lo) / (n - 1)
    a, b = lo, hi
    for _ in range(60):  # the spacing's fixed point; each step shrinks the change by 2/(n-1)
        a, b = min(lo, core_lo - s), max(hi, core_hi + s)
        s2 = (b - a) / (n - 1)
        if s2 - s <= 1e-12 * s:
            break
        s = s2
    return a, b


def find_object_planes(
    lightfield: LightField | np.ndarray,
    disparities_px: Sequence[float] | None = None,
    *,
    n_planes: int = DEFAULT_N_PLANES,
    method: str = "agreement",
    binning: int | None = None,
    fraction: float = jung2015.HAAR_EDGE_FRACTION,
    min_prominence_fraction: float = MIN_PROMINENCE_FRACTION,
    presmooth_px: float = DEFAULT_PRESMOOTH_PX,
    nearest_shifts: bool = False,
    workers: int | None = None,
    downsample: int | None = None,
) -> PlaneScan:
    """Scan planes and return the score versus depth and the detected object planes.

    ``method='agreement'`` (default, ours): a plane sweep of view agreement, tuned by the
    constants of :mod:`stimuli.agreementscan`. At each plane the views on the centre row and
    column are shifted onto the centre view and their absolute differences summed over a
    ``COST_WINDOW_PX`` box; each pixel's best plane counts when its views agree there
    (``AGREEMENT_RATIO``). The score is the smoothed fraction of pixels per plane (the support
    curve). The same sweep against the centre view turned by 180 degrees (non-coincident data)
    is the null: a peak is a plane only when its prominence is ``MIN_EVIDENCE`` times the
    null's largest, it holds ``MIN_SUPPORT`` of the pixels, and it is not a shoulder of a
    higher hill (``SHOULDER_FRACTION``).

    ``method='haar'``: the paper's overlap score of Haar edges with the centre view's (module
    notes), peaks by :func:`score_peaks`, with no null.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    disparities_px : sequence of float, optional
        Planes to scan, pixels per view step (default :func:`default_disparities`: the range the
        scene occupies).
    n_planes : int
        Number of planes when ``disparities_px`` is not given.
    method : {'agreement', 'haar'}
    binning : int >= 1, optional
        View binning for the scan (default :func:`scan_binning` for ``'agreement'``,
        :data:`DEFAULT_BINNING` for ``'haar'``).
    fraction, min_prominence_fraction, presmooth_px, nearest_shifts
        Haar scan only (see :func:`iter_plane_scores` and :func:`score_peaks`).
    workers : int, optional
    downsample : int >= 1, optional
        Agreement scan: large views are binned this many times more than ``binning`` (sub-pixel
        shifts divided by it; planes still reported in full-resolution px per view step, the
        support curve smoothed as at ``binning``). Default :func:`scan_downsample` (the
        smallest factor that brings the binned views under
        :data:`~stimuli.agreementscan.SCAN_BUDGET_PX` pixels, 1 for small views) when
        ``binning`` is not given, else 1. Recorded in ``PlaneScan.downsample``.

    Returns
    -------
    PlaneScan
        Peaks sorted nearest first (largest disparity first).

    Warns
    -----
    UserWarning
        Agreement scan: the support still rises at the first or last plane.

    References
    ----------
    Jung et al. (2015), Sec. 4.2 and Fig. 15 (the Haar scan).
    """
    if method not in SCAN_METHODS:
        raise InputError(f"method must be one of {SCAN_METHODS}, got {method!r}")
    lf = as_lightfield(lightfield)
    n = workers or default_workers()
    if disparities_px is None:
        ds = default_disparities(lf, n_planes, workers=n)
    else:
        ds = np.asarray(disparities_px, dtype=np.float64)
        if ds.ndim != 1 or ds.size < 3:
            raise InputError(f"disparities_px must list at least 3 planes, got {ds.size}")
        for d in ds:
            _check_disparity(lf, d)
    if method == "agreement":
        b = scan_binning(lf) if binning is None else binning
        if isinstance(b, bool) or not isinstance(b, (int, np.integer)) or b < 1:
            raise InputError(f"binning must be an integer >= 1, got {binning!r}")
        if downsample is None:
            f = scan_downsample(lf, int(b)) if binning is None else 1
        else:
            f = downsample
        if isinstance(f, bool) or not isinstance(f, (int, np.integer)) or f < 1:
            raise InputError(f"downsample must be an integer >= 1, got {downsample!r}")
        return agreement_scan(lf, ds, binning=int(b), workers=n, downsample=int(f))
    b = DEFAULT_BINNING if binning is None else binning
    scores = np.zeros(ds.size)
    for i, _, s in iter_plane_scores(
        lf,
        ds,
        binning=b,
        fraction=fraction,
        presmooth_px=presmooth_px,
        nearest_shifts=nearest_shifts,
        workers=n,
    ):
        scores[i] = s
    return scan_result(
        lf,
        ds,
        scores,
        binning=b,
        fraction=fraction,
        min_prominence_fraction=min_prominence_fraction,
        presmooth_px=presmooth_px,
    )
