"""Find the depth planes that hold objects (Jung et al. 2015, Sec. 4.2; Aloni & Yitzhaky 2014).

Two scans (``find_object_planes(..., method=...)``):

* ``'agreement'`` (default; ours, issue 12): where the scene lies is measured, not assumed.
  :func:`estimate_disparity_range` finds the disparities the scene occupies with a coarse
  sweep; the fine sweep shifts the views on the centre row and column onto the centre view at
  each plane and, per pixel, finds the plane where they agree best. The score is the smoothed
  fraction of pixels per plane (support). The same sweep against a non-coincident reference
  (the centre view mirrored and shifted) is the null. A plane is reported when its peak holds
  :data:`MIN_SUPPORT` of the pixels, stands :data:`MIN_EVIDENCE` times above the null's largest
  peak, and is not a shoulder of a higher hill. Each plane carries its ``support`` and
  ``evidence``; a pile-up of pixels at either end of the range warns that it is too narrow.
  On Middlebury Baby1 and Aloe and HCI antinous every ground-truth mode holding >= 5 % of the
  pixels is found within 0.5 px per view step, with no other plane
  (``tests/stimuli/test_lf_real.py``).
* ``'haar'``: the paper's method, below.

The paper's method: for the centre view and for the confocal image at each scanned plane:

1. first-scale Haar wavelet transform (``pywt.dwt2(image, 'haar')``, computed here with the
   identical closed form on 2x2 blocks), three detail sub-bands (horizontal, vertical,
   diagonal);
2. in each sub-band, an adaptive threshold that keeps the 0.5 % of its coefficients with the
   largest magnitude as edges (:data:`stimuli.jung2015.HAAR_EDGE_FRACTION`); an image's edge
   map is the union of its three sub-band maps (ours: the paper does not say how the sub-bands
   are combined);
3. the plane's *overlap score* = the fraction of its edge pixels that are also centre-view edge
   pixels.

Two choices of ours, and one option, make the score curve usable on real light fields (each
documented where it is made):

* the scan's confocal images leave out the centre row and column of views (for a single row
  of views: the centre view). Those views are never shifted across one axis, so their edges
  along it coincide with the centre view's at every plane and add a little false focus to
  every plane; the displayed confocal images use all views;
* a single row of views has no vertical parallax, so its horizontal-detail sub-band (cH) is
  sharp at every plane and is not used (likewise cV for a single column);
* optionally, a small Gaussian pre-smoothing before the Haar transform
  (:data:`DEFAULT_PRESMOOTH_PX`).

Object planes are the local maxima of the score over the scan. A local maximum counts when its
*prominence* (``scipy.signal.find_peaks``: its height above the higher of the two minima that
separate it from higher ground on either side) is at least :data:`MIN_PROMINENCE_FRACTION` of
the score's range over the scan (ours). Maxima at the two ends of the scan are not peaks: a
score still rising at the end of the range says the object lies beyond it. The score often has
a flat top about ``1 / (largest view offset)`` px per view step wide (edge positions are
quantised to the 2x2 Haar blocks); a flat-topped peak is reported at the middle of its top.

Detection at reduced cost
-------------------------
The scan runs on views box-binned by ``binning`` (default 2): a quarter of the pixels, and
disparities divide by ``binning``. The Haar first scale of the binned image is close to the
Haar second scale of the full image; focused edges still coincide with the centre view's and
blurred ones still do not. ``binning=1`` is the paper's procedure at full resolution. Leaving
out the centre row and column also saves work (64 of 81 views for a 9x9 grid), planes run in
parallel threads, and ``nearest_shifts=True`` shifts by whole binned pixels (one add per view
instead of two weighted adds; about 2x faster, views misregistered by up to half a binned
pixel).
"""

from __future__ import annotations

import itertools
import math
import os
import warnings
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter, gaussian_filter1d, uniform_filter1d
from scipy.signal import find_peaks, peak_prominences

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.lightfield import LightField, _as_lightfield
from stimuli.refocus import _check_disparity, _refocus_views, default_workers, refocus

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
    "estimate_disparity_range",
    "AGREEMENT_RATIO",
    "COST_WINDOW_PX",
    "MIN_CONTRAST",
    "MIN_SUPPORT",
    "MIN_EVIDENCE",
    "SHOULDER_FRACTION",
    "SMOOTH_SHIFT_PX",
    "SCAN_SHORT_SIDE_PX",
    "COARSE_SHORT_SIDE_PX",
    "SCAN_METHODS",
    "ConfocalPlane",
    "confocal_plane",
    "confocal_pair",
]

#: Depth-scan methods: ``'agreement'`` (ours, the default: plane sweep of view agreement with a
#: null) and ``'haar'`` (the paper's Haar-edge overlap score, Sec. 4.2).
SCAN_METHODS: tuple[str, ...] = ("agreement", "haar")

#: A local maximum of the overlap score is an object plane when its prominence is at least this
#: fraction of the score's range over the scan (ours, not the paper's: the paper picks the
#: maxima by eye in Fig. 15; 0.1 keeps both of its peaks and drops noise wiggles).
MIN_PROMINENCE_FRACTION: float = 0.1

#: Fewer edge pixels per sub-band than this make the overlap score too coarse to trust (ours):
#: the scan warns.
MIN_EDGE_PIXELS: int = 25

#: Box binning of the views during the scan (ours; see "Detection at reduced cost").
DEFAULT_BINNING: int = 2

#: Optional Gaussian pre-smoothing (sigma, pixels of the binned views) of every image before
#: the Haar transform (ours; 0 = the paper's plain first-scale Haar, the default). Linear
#: interpolation blurs a shifted view by an amount that depends on the sub-pixel phase of its
#: shift, which makes the score wobble from plane to plane; a common small blur (0.8 px)
#: removes that wobble on scenes with pixel-fine texture (the simulated three-plane scene) but
#: flattens the peaks of smoother scenes, so it is an option, not the default.
DEFAULT_PRESMOOTH_PX: float = 0.0

#: Number of planes scanned by default. Source: Jung et al. (2015), Fig. 15 (200 planes).
DEFAULT_N_PLANES: int = 200


def haar_details(image: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the first-scale Haar detail sub-bands ``(cH, cV, cD)`` of a grey image.

    Identical to ``pywt.dwt2(image, 'haar')[1]`` for even sizes; an odd last row or column is
    dropped (pywt would pad it symmetrically, which makes a zero-detail border).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float

    Returns
    -------
    cH, cV, cD : ndarrays of shape (rows // 2, cols // 2), float32
    """
    a = np.asarray(image, dtype=np.float32)
    if a.ndim != 2 or a.shape[0] < 2 or a.shape[1] < 2:
        raise InputError(f"image must be 2-D with at least 2x2 pixels, got shape {a.shape}")
    r, c = (a.shape[0] // 2) * 2, (a.shape[1] // 2) * 2
    tl, tr = a[0:r:2, 0:c:2], a[0:r:2, 1:c:2]
    bl, br = a[1:r:2, 0:c:2], a[1:r:2, 1:c:2]
    top, bot = tl + tr, bl + br
    left, right = tl + bl, tr + br
    half = np.float32(0.5)
    c_h = (top - bot) * half
    c_v = (left - right) * half
    c_d = (tl - tr - bl + br) * half
    return c_h, c_v, c_d


def _top_fraction(band: np.ndarray, fraction: float) -> np.ndarray:
    mag = np.abs(band).ravel()
    k = max(1, int(math.ceil(fraction * mag.size)))
    thr = np.partition(mag, mag.size - k)[mag.size - k]
    # Ties at the threshold are kept; a flat sub-band (threshold 0) has no edges at all.
    return (np.abs(band) >= thr) & (np.abs(band) > 0)


def haar_edges(
    image: np.ndarray,
    *,
    fraction: float = jung2015.HAAR_EDGE_FRACTION,
    bands: tuple[int, ...] = (0, 1, 2),
) -> np.ndarray:
    """Return the sharp-edge map of an image: the top ``fraction`` of each Haar detail sub-band.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float
    fraction : float in (0, 1)
        Fraction of each sub-band's coefficients kept as edges (Jung et al. 2015: 0.5 %).
    bands : tuple of {0, 1, 2}
        Sub-bands used: 0 = horizontal (cH), 1 = vertical (cV), 2 = diagonal (cD).

    Returns
    -------
    ndarray of shape (rows // 2, cols // 2), bool
        Union of the sub-band edge maps.

    References
    ----------
    Jung et al. (2015), Sec. 4.2; Mallat (1989) for the Haar wavelet.
    """
    if not (0.0 < float(fraction) < 1.0):
        raise InputError(f"fraction must be in (0, 1), got {fraction!r}")
    details = haar_details(image)
    if not bands or any(b not in (0, 1, 2) for b in bands):
        raise InputError(f"bands must be a non-empty subset of (0, 1, 2), got {bands!r}")
    out = _top_fraction(details[bands[0]], fraction)
    for b in bands[1:]:
        out |= _top_fraction(details[b], fraction)
    return out


def edge_overlap(edges: np.ndarray, reference_edges: np.ndarray) -> float:
    """Return the fraction of ``edges`` pixels that are also ``reference_edges`` pixels."""
    e = np.asarray(edges, dtype=bool)
    r = np.asarray(reference_edges, dtype=bool)
    if e.shape != r.shape:
        raise InputError(f"edge maps differ in shape: {e.shape} vs {r.shape}")
    n = int(np.count_nonzero(e))
    return float(np.count_nonzero(e & r)) / n if n else 0.0


@dataclass(frozen=True)
class Plane:
    """One detected object plane.

    Attributes
    ----------
    disparity_px : float
        Pixels per view step at full resolution.
    depth_m : float or None
        Metres, when the light field has a geometry.
    score : float
        Overlap score in [0, 1].
    prominence : float
        Prominence of the peak, score units.
    index : int
        Position in the scan.
    support : float
        Agreement scan: fraction of the (binned) view's pixels whose views agree best within two
        smoothing widths of this plane, above the base of its peak (NaN for the Haar scan).
    evidence : float
        Agreement scan: the peak's prominence divided by the largest prominence the same scan
        gives on non-coincident data (the centre view mirrored and shifted); NaN for Haar.
    """

    disparity_px: float
    depth_m: float | None
    score: float
    prominence: float
    index: int
    support: float = math.nan
    evidence: float = math.nan


@dataclass(frozen=True)
class PlaneScan:
    """Score versus depth and the object planes found in it.

    Attributes
    ----------
    disparities_px : ndarray of shape (n_planes,), float64
    depths_m : ndarray of shape (n_planes,) or None
    scores : ndarray of shape (n_planes,), float64 in [0, 1]
        ``method='agreement'``: smoothed fraction of the view's pixels whose views agree best
        at each plane (the support curve); ``method='haar'``: the paper's overlap score.
    peaks : tuple of Plane
        Detected object planes, nearest first.
    binning : int
        View binning used for the scan.
    fraction : float
        Haar edge fraction used (Haar scan only).
    min_prominence : float
        Smallest prominence a peak needed, score units.
    presmooth_px : float
        Haar scan only.
    method : {'agreement', 'haar'}
    null_scores : ndarray of shape (n_planes,) or None
        The agreement scan's support curve on non-coincident data (the null).
    """

    disparities_px: np.ndarray
    depths_m: np.ndarray | None
    scores: np.ndarray
    peaks: tuple[Plane, ...]
    binning: int = DEFAULT_BINNING
    fraction: float = jung2015.HAAR_EDGE_FRACTION
    min_prominence: float = field(default=0.0)
    presmooth_px: float = DEFAULT_PRESMOOTH_PX
    method: str = "haar"
    null_scores: np.ndarray | None = None

    def rows(self) -> list[dict]:
        """Return one dict per scanned plane, for ``planes.csv``.

        Columns: ``index``, ``depth_m`` (m, empty without geometry), ``disparity_px`` (px per
        view step), ``score``, ``null_score`` (empty for the Haar scan), ``peak`` (1 for a
        detected plane), and for detected planes ``support`` (fraction of pixels),
        ``prominence`` (score units) and ``evidence`` (prominence over the null's largest).
        """
        peaks = {p.index: p for p in self.peaks}
        out = []
        for i, (d, s) in enumerate(zip(self.disparities_px, self.scores, strict=True)):
            z = None if self.depths_m is None else float(self.depths_m[i])
            p = peaks.get(i)

            def num(v: float | None) -> float | str:
                return "" if v is None or not math.isfinite(v) else round(float(v), 6)

            out.append(
                {
                    "index": i,
                    "depth_m": "" if z is None or not math.isfinite(z) else round(z, 6),
                    "disparity_px": round(float(d), 6),
                    "score": round(float(s), 6),
                    "null_score": ""
                    if self.null_scores is None
                    else round(float(self.null_scores[i]), 6),
                    "peak": int(p is not None),
                    "support": num(p.support if p else None),
                    "prominence": num(p.prominence if p else None),
                    "evidence": num(p.evidence if p else None),
                }
            )
        return out

    def to_dict(self) -> dict:
        """Return a JSON-friendly dict."""

        def plane(p: Plane) -> dict:
            d = p.__dict__.copy()
            for k in ("support", "evidence"):
                if not math.isfinite(d[k]):
                    d[k] = None
            return d

        return {
            "method": self.method,
            "disparities_px": [float(d) for d in self.disparities_px],
            "depths_m": None if self.depths_m is None else [float(z) for z in self.depths_m],
            "scores": [float(s) for s in self.scores],
            "null_scores": None
            if self.null_scores is None
            else [float(s) for s in self.null_scores],
            "peaks": [plane(p) for p in self.peaks],
            "binning": self.binning,
            "fraction": self.fraction,
            "min_prominence": self.min_prominence,
            "presmooth_px": self.presmooth_px,
        }

    @classmethod
    def from_dict(cls, data: dict) -> PlaneScan:
        """Inverse of :meth:`to_dict`."""
        z = data.get("depths_m")
        ns = data.get("null_scores")

        def plane(p: dict) -> Plane:
            p = dict(p)
            for k in ("support", "evidence"):
                if p.get(k) is None:
                    p[k] = math.nan
            return Plane(**p)

        return cls(
            disparities_px=np.asarray(data["disparities_px"], dtype=np.float64),
            depths_m=None if z is None else np.asarray(z, dtype=np.float64),
            scores=np.asarray(data["scores"], dtype=np.float64),
            peaks=tuple(plane(p) for p in data["peaks"]),
            binning=int(data["binning"]),
            fraction=float(data["fraction"]),
            min_prominence=float(data["min_prominence"]),
            presmooth_px=float(data.get("presmooth_px", DEFAULT_PRESMOOTH_PX)),
            method=str(data.get("method", "haar")),
            null_scores=None if ns is None else np.asarray(ns, dtype=np.float64),
        )


def auto_binning(lightfield: LightField, *, fraction: float = jung2015.HAAR_EDGE_FRACTION) -> int:
    """Return :data:`DEFAULT_BINNING`, or less when the binned views would leave fewer than
    :data:`MIN_EDGE_PIXELS` edge pixels per Haar sub-band."""
    rows, cols = lightfield.shape_px
    for b in range(DEFAULT_BINNING, 1, -1):
        if fraction * (rows // (2 * b)) * (cols // (2 * b)) >= MIN_EDGE_PIXELS:
            return b
    return 1


def default_disparities(
    lightfield: LightField, n_planes: int = DEFAULT_N_PLANES, *, workers: int | None = None
) -> np.ndarray:
    """Return the disparities scanned when none are given: from the data, not a constant.

    ``n_planes`` disparities equally spaced over :func:`estimate_disparity_range` (the span the
    scene occupies, clipped to the geometry's ``near_m``/``far_m``). Equal disparity steps are
    equal steps of the outermost view's shift, so the spacing follows the grid's baseline.
    """
    if isinstance(n_planes, bool) or not isinstance(n_planes, (int, np.integer)) or n_planes < 3:
        raise InputError(f"n_planes must be an integer >= 3, got {n_planes!r}")
    lo, hi = estimate_disparity_range(lightfield, workers=workers)
    return np.linspace(lo, hi, int(n_planes))


def _smooth(image: np.ndarray, sigma_px: float) -> np.ndarray:
    return gaussian_filter(image, sigma_px, mode="nearest") if sigma_px > 0 else image


def _prepare(
    lightfield: LightField | np.ndarray, binning: int, fraction: float, presmooth_px: float
) -> tuple[LightField, np.ndarray]:
    if not (isinstance(presmooth_px, (int, float)) and 0 <= presmooth_px <= 10):
        raise InputError(f"presmooth_px must be a number in [0, 10], got {presmooth_px!r}")
    lf = _as_lightfield(lightfield).gray()
    small = lf.binned(binning)
    ref = haar_edges(
        _smooth(small.centre_view(), presmooth_px),
        fraction=fraction,
        bands=_informative_bands(small),
    )
    return small, ref


def _informative_bands(lf: LightField) -> tuple[int, ...]:
    """Sub-bands whose edges refocusing can blur: a single row of views (n_u = 1) has no
    vertical parallax, so its horizontal edges (cH) are sharp at every plane; likewise cV for a
    single column."""
    n_u, n_v = lf.grid
    return tuple(b for b, keep in ((0, n_u > 1), (1, n_v > 1), (2, True)) if keep)


def _scan_views(lf: LightField) -> tuple[np.ndarray, tuple[list[int], list[int]]]:
    """Views used by the scan: all but the centre row and column (see module notes)."""
    n_u, n_v = lf.grid
    cu, cv = lf.centre_index
    us = [u for u in range(n_u) if not (n_u > 1 and u == cu)]
    vs = [v for v in range(n_v) if not (n_v > 1 and v == cv)]
    views = np.ascontiguousarray(lf.views[us][:, vs])
    return views, ([u - cu for u in us], [v - cv for v in vs])


def iter_plane_scores(
    lightfield: LightField | np.ndarray,
    disparities_px: Sequence[float],
    *,
    binning: int = DEFAULT_BINNING,
    fraction: float = jung2015.HAAR_EDGE_FRACTION,
    presmooth_px: float = DEFAULT_PRESMOOTH_PX,
    nearest_shifts: bool = False,
    workers: int | None = None,
) -> Iterator[tuple[int, float, float]]:
    """Yield ``(index, disparity_px, score)`` for each plane, in order (the caller owns the loop).

    Planes are computed in parallel threads, each refocusing one plane single-threaded.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C])
    disparities_px : sequence of float
        Full-resolution disparities, pixels per view step.
    binning : int >= 1
    fraction : float in (0, 1)
    presmooth_px : float >= 0
        Gaussian sigma applied before the Haar transform (:data:`DEFAULT_PRESMOOTH_PX`).
    nearest_shifts : bool
        Shift the (binned) views by whole pixels instead of interpolating: about 1.5x faster,
        views misregistered by up to half a binned pixel.
    workers : int, optional
    """
    lf = _as_lightfield(lightfield)
    ds = [_check_disparity(lf, d) for d in disparities_px]
    small, ref = _prepare(lf, binning, fraction, presmooth_px)
    r2, c2 = small.shape_px[0] // 2, small.shape_px[1] // 2
    k = math.ceil(fraction * r2 * c2)
    if k < MIN_EDGE_PIXELS:
        warnings.warn(
            f"only {k} edge pixels per Haar sub-band ({small.shape_px[0]}x{small.shape_px[1]} px "
            f"views after binning {binning}): the overlap score will be coarse; use a smaller "
            "binning or a larger light field",
            stacklevel=2,
        )
    n = workers or default_workers()
    views, offsets = _scan_views(small)
    bands = _informative_bands(small)

    def score(d: float) -> float:
        img = _refocus_views(views, d / binning, 1, offsets=offsets, nearest=nearest_shifts)
        img = _smooth(img, presmooth_px)
        return edge_overlap(haar_edges(img, fraction=fraction, bands=bands), ref)

    if n == 1:
        for i, d in enumerate(ds):
            yield i, d, score(d)
        return
    with ThreadPoolExecutor(n) as ex:
        for i, (d, s) in enumerate(zip(ds, ex.map(score, ds), strict=True)):
            yield i, d, s


def score_peaks(
    scores: np.ndarray, *, min_prominence_fraction: float = MIN_PROMINENCE_FRACTION
) -> tuple[np.ndarray, np.ndarray]:
    """Return the indices and prominences of the object-plane peaks of a score curve.

    A peak is an interior local maximum whose prominence is at least
    ``min_prominence_fraction * (max(scores) - min(scores))``. Plateaus count once (their
    middle sample, as ``scipy.signal.find_peaks``). Two peaks separated by a dip shallower than
    that same threshold are one object plane and are merged (the higher is kept):
    ``find_peaks`` does not count a neighbour of *equal* height as higher, so two equal tops of
    one hill would otherwise both pass (seen on the simulated scene's 4 m plane). Tops of nearly
    equal height (within a quarter of the threshold) are one flat top: its middle is kept, as
    for a plateau.

    Returns
    -------
    indices : ndarray of int
    prominences : ndarray of float
    """
    s = np.asarray(scores, dtype=np.float64)
    if s.ndim != 1 or s.size < 3:
        raise InputError(f"scores must be 1-D with at least 3 planes, got shape {s.shape}")
    if not np.all(np.isfinite(s)):
        raise InputError("scores have NaN or infinite values")
    span = float(s.max() - s.min())
    if span <= 0:
        return np.zeros(0, dtype=int), np.zeros(0)
    thr = min_prominence_fraction * span
    idx, _ = find_peaks(s, prominence=thr)
    merged: list[tuple[int, int]] = []  # (reported index, index of the hill's highest top)
    for i in (int(v) for v in idx):
        if merged and s[merged[-1][1] : i + 1].min() >= min(s[merged[-1][1]], s[i]) - thr:
            pos, top = merged[-1]
            best = i if s[i] > s[top] else top
            merged[-1] = ((pos + i) // 2 if abs(s[i] - s[top]) <= 0.25 * thr else best, best)
        else:
            merged.append((i, i))
    if not merged:
        return np.zeros(0, dtype=int), np.zeros(0)
    out = np.asarray([m[0] for m in merged], dtype=int)
    return out, peak_prominences(s, np.asarray([m[1] for m in merged], dtype=int))[0]


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
) -> PlaneScan:
    """Scan planes and return the score versus depth and the detected object planes.

    ``method='agreement'`` (default, ours): a plane sweep of view agreement. At each plane the
    views on the centre row and column are shifted onto the centre view and their absolute
    differences summed over a :data:`COST_WINDOW_PX` box; each pixel's best plane counts when
    its views agree there (:data:`AGREEMENT_RATIO`). The score is the smoothed fraction of
    pixels per plane (the support curve). The same sweep against the centre view turned by
    180 degrees (non-coincident data) is the null: a peak is a plane only when its prominence
    is :data:`MIN_EVIDENCE` times the null's largest, it holds :data:`MIN_SUPPORT` of the
    pixels, and it is not a shoulder of a higher hill (:data:`SHOULDER_FRACTION`).

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
    lf = _as_lightfield(lightfield)
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
        return _agreement_scan(lf, ds, binning=int(b), workers=n)
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


def scan_result(
    lightfield: LightField,
    disparities_px: np.ndarray,
    scores: np.ndarray,
    *,
    binning: int = DEFAULT_BINNING,
    fraction: float = jung2015.HAAR_EDGE_FRACTION,
    min_prominence_fraction: float = MIN_PROMINENCE_FRACTION,
    presmooth_px: float = DEFAULT_PRESMOOTH_PX,
) -> PlaneScan:
    """Assemble a :class:`PlaneScan` (peaks, depths) from scores computed by the caller."""
    ds = np.asarray(disparities_px, dtype=np.float64)
    s = np.asarray(scores, dtype=np.float64)
    idx, prom = score_peaks(s, min_prominence_fraction=min_prominence_fraction)
    depths = None
    if lightfield.geometry is not None:
        depths = np.array([lightfield.geometry.depth_m(d) for d in ds])
    peaks = [
        Plane(
            disparity_px=float(ds[i]),
            depth_m=None if depths is None else float(depths[i]),
            score=float(s[i]),
            prominence=float(p),
            index=int(i),
        )
        for i, p in zip(idx, prom, strict=True)
    ]
    peaks.sort(key=lambda p: -p.disparity_px)
    span = float(s.max() - s.min()) if s.size else 0.0
    return PlaneScan(
        ds, depths, s, tuple(peaks), binning, fraction, min_prominence_fraction * span, presmooth_px
    )


# --------------------------------------------------------------------------------------------
# The agreement scan (ours, beyond the paper): plane sweep of view agreement with a null
# --------------------------------------------------------------------------------------------

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


def scan_binning(lightfield: LightField) -> int:
    """Return the view binning of the agreement scan (:data:`SCAN_SHORT_SIDE_PX`)."""
    m = _max_offset(lightfield)
    return int(max(1, min(max(m, 2), min(lightfield.shape_px) // SCAN_SHORT_SIDE_PX)))


def _max_offset(lf: LightField) -> int:
    n_u, n_v = lf.grid
    cu, cv = lf.centre_index
    return max(cu, n_u - 1 - cu, cv, n_v - 1 - cv, 1)


def _cross_offsets(lf: LightField) -> list[tuple[int, int]]:
    """Views used by the agreement scan: on the centre row and column, the outermost and the
    half-way view on each side. Views off the cross would need 2-D (four-tap) interpolation for
    little extra evidence."""
    n_u, n_v = lf.grid
    cu, cv = lf.centre_index
    out: list[tuple[int, int]] = []
    for n, c, axis in ((n_u, cu, 0), (n_v, cv, 1)):
        for side in (-1, 1):
            far = c if side < 0 else n - 1 - c
            for k in sorted({far, (far + 1) // 2}):
                if k > 0:
                    out.append((side * k, 0) if axis == 0 else (0, side * k))
    if not out:
        raise InputError(f"{lf.source}: a light field needs at least two views, got grid {lf.grid}")
    return out


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

    How it is fast: every view is shifted along one axis only (centre row and column), so each
    view is stored padded along that axis and *transposed* when it shifts along columns; a shift
    by ``n + f`` pixels is then a contiguous block copy plus one BLAS ``saxpy`` of the
    precomputed pixel differences (linear interpolation ``I(x - n) + f (I(x - n - 1) - I(x - n))``).
    Column-shifted views are compared with the transposed centre view, and their cost is
    transposed once per plane.
    """
    from stimuli.refocus import _one_blas_thread, _saxpy

    rows, cols = centre.shape
    m = max(max(abs(a), abs(b)) for a, b in offsets)
    pad = int(math.ceil(float(np.abs(ds).max()) * m)) + 2
    groups: dict[int, list] = {0: [], 1: []}
    for img, (du, dv) in zip(views, offsets, strict=True):
        axis = 0 if du else 1
        a = np.ascontiguousarray(img if axis == 0 else img.T, dtype=np.float32)
        p = np.pad(a, ((pad, pad), (0, 0)), mode="edge")
        g = np.zeros_like(p)  # g[j] = p[j - 1] - p[j]: the linear-interpolation increment
        np.subtract(p[:-1], p[1:], out=g[1:])
        groups[axis].append((p, g.reshape(-1), du or dv))
    refs = {
        0: (centre, null_centre),
        1: (np.ascontiguousarray(centre.T), np.ascontiguousarray(null_centre.T)),
    }

    def run(idx: np.ndarray):
        # Index 0 of the stacked buffers is the scan against the centre view, 1 the null.
        best = np.full((2, rows, cols), np.inf, np.float32)
        best_i = np.zeros((2, rows, cols), np.int32)
        total = np.zeros((2, rows, cols), np.float32)
        cost = np.empty((2, rows, cols), np.float32)
        agg = np.empty_like(cost)
        mask = np.empty((2, rows, cols), bool)
        bufs = {}
        for axis, items in groups.items():
            if items:
                shape = (len(items), rows, cols) if axis == 0 else (len(items), cols, rows)
                bufs[axis] = (
                    np.empty(shape, np.float32),
                    np.empty(shape, np.float32),
                    np.empty(shape[1:], np.float32),
                )
        for k in idx:
            d = float(ds[k])
            first = True
            for axis, items in groups.items():
                if not items:
                    continue
                shifted, diff, part = bufs[axis]
                length = shifted.shape[1]
                size = shifted.shape[1] * shifted.shape[2]
                width = shifted.shape[2]
                for j, (p, gflat, off) in enumerate(items):
                    s = d * off  # sample the view at x - s
                    n = math.floor(s)
                    f = float(s - n)
                    np.copyto(shifted[j], p[pad - n : pad - n + length])
                    if f > 0.0:
                        _saxpy(gflat, shifted[j].reshape(-1), n=size, a=f, offx=(pad - n) * width)
                for r in (0, 1):
                    np.subtract(shifted, refs[axis][r], out=diff)
                    np.abs(diff, out=diff)
                    np.sum(diff, axis=0, out=part)
                    view = part if axis == 0 else part.T
                    if first:
                        np.copyto(cost[r], view)
                    else:
                        cost[r] += view
                first = False
            uniform_filter1d(cost, COST_WINDOW_PX, axis=1, output=agg, mode="nearest")
            uniform_filter1d(agg, COST_WINDOW_PX, axis=2, output=cost, mode="nearest")
            total += cost
            np.less(cost, best, out=mask)
            np.copyto(best, cost, where=mask)
            np.copyto(best_i, np.int32(k), where=mask)
        return best, best_i, total

    n_threads = max(1, min(workers, len(ds)))
    parts = np.array_split(np.arange(len(ds)), n_threads)
    with _one_blas_thread():
        if n_threads == 1:
            results = [run(parts[0])]
        else:
            with ThreadPoolExecutor(n_threads) as ex:
                results = list(ex.map(run, parts))
    out = []
    for j in (0, 1):
        best, best_i, total = (np.array(results[0][q][j]) for q in range(3))
        for r in results[1:]:
            better = r[0][j] < best
            best[better] = r[0][j][better]
            best_i[better] = r[1][j][better]
            total += r[2][j]
        mean = total / np.float32(len(ds))
        agrees = (best < np.float32(AGREEMENT_RATIO) * mean) & (
            mean > np.float32(MIN_CONTRAST * len(offsets))
        )
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


def _bin_view(view: np.ndarray, b: int) -> np.ndarray:
    if b == 1:
        return np.ascontiguousarray(view, dtype=np.float32)
    r, c = view.shape[0] // b, view.shape[1] // b
    v = view[: r * b, : c * b].reshape(r, b, c * b).sum(axis=1, dtype=np.float32)
    v = v.reshape(r, c, b).sum(axis=2, dtype=np.float32)
    return v * np.float32(1.0 / (b * b))


def _scan_inputs(lf: LightField, binning: int):
    """The views the agreement scan uses (only those are converted and binned)."""
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
    smooth = gaussian_filter1d(raw, sigma_planes, mode="nearest")
    nsmooth = gaussian_filter1d(null, sigma_planes, mode="nearest")
    return raw, smooth, nsmooth, ends


def estimate_disparity_range(
    lightfield: LightField | np.ndarray, *, workers: int | None = None
) -> tuple[float, float]:
    """Estimate the disparities the scene occupies, pixels per view step (full resolution).

    A coarse plane sweep of view agreement (:func:`find_object_planes`, ``method='agreement'``)
    on views binned to about :data:`COARSE_SHORT_SIDE_PX` pixels, over every disparity that
    moves the outermost view by up to half the image, in steps of half a coarse pixel of the
    outermost view. The range is the 1-99 % span of the best planes of the pixels whose views
    agree, widened by one coarse step on each side, and clipped to the geometry's
    ``near_m``/``far_m`` when it has them.

    Returns
    -------
    (low, high) : tuple of float
        ``low < high``, pixels per view step.

    Raises
    ------
    InputError
        No pixel's views agree at any plane (a flat or non-light-field input).
    """
    lf = _as_lightfield(lightfield).gray()
    m = _max_offset(lf)
    b = max(1, min(min(lf.shape_px) // COARSE_SHORT_SIDE_PX, 4 * m))
    small, views, offsets, centre, null_centre = _scan_inputs(lf, b)
    step = 0.5 / m  # binned px per view step
    dmax = min(centre.shape) / (2.0 * m)
    ds = np.arange(-dmax, dmax + step / 2, step)
    best_i, agrees, _, _ = _sweep(
        views, offsets, centre, null_centre, ds, workers or default_workers()
    )
    if int(np.count_nonzero(agrees)) < MIN_EDGE_PIXELS:
        raise InputError(
            f"{lf.source}: the views agree at no plane in [-{dmax * b:.3g}, {dmax * b:.3g}] px "
            "per view step (a flat scene, or not a light field); give the disparities to scan"
        )
    lo, hi = np.quantile(ds[best_i[agrees]], [0.01, 0.99])
    lo, hi = (lo - step) * b, (hi + step) * b
    g = lf.geometry
    if g is not None and g.near_m is not None and g.far_m is not None:
        a, c = sorted((g.disparity_px(g.near_m), g.disparity_px(g.far_m)))
        lo, hi = max(lo, a), min(hi, c)
    lim = lf.max_disparity_px()
    lo, hi = max(lo, -lim), min(hi, lim)
    if not hi > lo:
        raise InputError(f"{lf.source}: the estimated disparity range is empty")
    return float(lo), float(hi)


def _agreement_scan(
    lf: LightField,
    ds: np.ndarray,
    *,
    binning: int,
    workers: int,
) -> PlaneScan:
    small, views, offsets, centre, null_centre = _scan_inputs(lf, binning)
    m = _max_offset(small)
    best_i, agrees, nbest_i, nagrees = _sweep(
        views, offsets, centre, null_centre, ds / binning, workers
    )
    spacing = float(np.median(np.abs(np.diff(ds)))) / binning  # binned px per view step
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
        if p >= SHOULDER_FRACTION * s[i] and p >= MIN_EVIDENCE * null_prom
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
        binning,
        jung2015.HAAR_EDGE_FRACTION,
        MIN_EVIDENCE * null_prom,
        0.0,
        "agreement",
        ns,
    )


@dataclass(frozen=True)
class ConfocalPlane:
    """A light field's centre view and its confocal image at one plane, with that plane.

    Parameters
    ----------
    centre_view, confocal_image : ndarray of shape (rows, cols), float32 in [0, 1]
    disparity_px : float
        The plane, pixels per view step.
    depth_m : float or None
        The plane's depth, metres (None without geometry).
    chosen_by : {'depth_m', 'disparity_px', 'nearest detected plane'}
        How the plane was chosen (provenance).
    focus_mask : ndarray of shape (rows, cols), bool, or None
        Where the light field is in focus at the plane (:func:`stimuli.declutter.in_focus_mask`),
        when asked for.
    """

    centre_view: np.ndarray
    confocal_image: np.ndarray
    disparity_px: float
    depth_m: float | None
    chosen_by: str
    focus_mask: np.ndarray | None = None

    def describe(self) -> str:
        """One-line provenance: ``disparity=...px,depth=...m,<chosen_by>``."""
        depth = "" if self.depth_m is None else f",depth={self.depth_m:.4g}m"
        return f"disparity={self.disparity_px:.4g}px{depth},{self.chosen_by}"


def confocal_plane(
    path: str | os.PathLike | LightField,
    *,
    depth_m: float | None = None,
    disparity_px: float | None = None,
    focus_mask: bool = False,
) -> ConfocalPlane:
    """Return a light field's centre view and its confocal image at one plane, with the plane.

    The confocal image is the shift-and-add refocus at ``depth_m`` (needs a geometry) or at
    ``disparity_px``; with neither, at the *nearest* object plane found by
    :func:`find_object_planes` (defaults: range from the data, agreement scan; every plane it
    reports has support and evidence against a null, so no prominence floor is needed): the
    object of interest stands in front of the clutter (Jung et al. 2015, Sec. 4), so the nearest
    plane is the object's, even when a large background wall scores higher.

    Parameters
    ----------
    path : str, path-like or LightField
        Any input :func:`load_lightfield` reads.
    depth_m : float, optional
        Depth of the plane, metres.
    disparity_px : float, optional
        Disparity of the plane, pixels per view step.
    focus_mask : bool
        Also return where the light field is in focus at the plane (depth de-cluttering).

    Returns
    -------
    ConfocalPlane

    Raises
    ------
    InputError
        Both ``depth_m`` and ``disparity_px`` given, a depth without geometry or out of range,
        no object plane found, or any loading error.

    References
    ----------
    Jung et al. (2015), Sec. 4.1-4.2; Ng et al. (2005) for shift-and-add refocusing.
    """
    if depth_m is not None and disparity_px is not None:
        raise InputError("give depth_m or disparity_px, not both")
    lf = _as_lightfield(path).gray()
    if depth_m is not None:
        d, how = lf.disparity_px(depth_m), "depth_m"
    elif disparity_px is not None:
        d, how = float(disparity_px), "disparity_px"
        if not math.isfinite(d):
            raise InputError(f"disparity_px must be finite, got {disparity_px!r}")
    else:
        scan = find_object_planes(lf)
        if not scan.peaks:
            raise InputError(f"{lf.source}: no object plane found in the depth scan")
        d, how = scan.peaks[0].disparity_px, "nearest detected plane"  # peaks: nearest first
    confocal = np.clip(refocus(lf, d), 0.0, 1.0).astype(np.float32)
    mask = None
    if focus_mask:
        from stimuli.declutter import in_focus_mask

        mask = in_focus_mask(lf, d)
    return ConfocalPlane(lf.centre_view(), confocal, float(d), lf.depth_m(d), how, mask)


def confocal_pair(
    path: str | os.PathLike | LightField,
    *,
    depth_m: float | None = None,
    disparity_px: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(centre_view, confocal_image)`` of a light field, grey float32 in [0, 1].

    The same as :func:`confocal_plane` without the plane: at ``depth_m``, at ``disparity_px``,
    or at the nearest detected object plane.

    Returns
    -------
    centre_view, confocal_image : ndarray of shape (rows, cols), float32 in [0, 1]

    Raises
    ------
    InputError
        As :func:`confocal_plane`.
    """
    c = confocal_plane(path, depth_m=depth_m, disparity_px=disparity_px)
    return c.centre_view, c.confocal_image
