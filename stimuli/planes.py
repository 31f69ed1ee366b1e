"""Find the depth planes that hold objects (Jung et al. 2015, Sec. 4.2; Aloni & Yitzhaky 2014).

For the centre view and for the confocal image at each scanned plane:

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

import math
import warnings
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.signal import find_peaks, peak_prominences

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.lightfield import LightField, _as_lightfield
from stimuli.refocus import _check_disparity, _refocus_views, default_workers

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
]

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
    """

    disparity_px: float
    depth_m: float | None
    score: float
    prominence: float
    index: int


@dataclass(frozen=True)
class PlaneScan:
    """Overlap score versus depth and the object planes found in it.

    Attributes
    ----------
    disparities_px : ndarray of shape (n_planes,), float64
    depths_m : ndarray of shape (n_planes,) or None
    scores : ndarray of shape (n_planes,), float64 in [0, 1]
    peaks : tuple of Plane
        Detected object planes, nearest first.
    binning : int
        View binning used for the scan.
    fraction : float
        Haar edge fraction used.
    """

    disparities_px: np.ndarray
    depths_m: np.ndarray | None
    scores: np.ndarray
    peaks: tuple[Plane, ...]
    binning: int = DEFAULT_BINNING
    fraction: float = jung2015.HAAR_EDGE_FRACTION
    min_prominence: float = field(default=0.0)
    presmooth_px: float = DEFAULT_PRESMOOTH_PX

    def rows(self) -> list[dict]:
        """Return one dict per plane: depth_m, disparity_px, score, peak (for ``planes.csv``)."""
        peak_idx = {p.index for p in self.peaks}
        out = []
        for i, (d, s) in enumerate(zip(self.disparities_px, self.scores, strict=True)):
            z = None if self.depths_m is None else float(self.depths_m[i])
            out.append(
                {
                    "index": i,
                    "depth_m": "" if z is None or not math.isfinite(z) else round(z, 6),
                    "disparity_px": round(float(d), 6),
                    "score": round(float(s), 6),
                    "peak": int(i in peak_idx),
                }
            )
        return out

    def to_dict(self) -> dict:
        """Return a JSON-friendly dict."""
        return {
            "disparities_px": [float(d) for d in self.disparities_px],
            "depths_m": None if self.depths_m is None else [float(z) for z in self.depths_m],
            "scores": [float(s) for s in self.scores],
            "peaks": [p.__dict__.copy() for p in self.peaks],
            "binning": self.binning,
            "fraction": self.fraction,
            "min_prominence": self.min_prominence,
            "presmooth_px": self.presmooth_px,
        }

    @classmethod
    def from_dict(cls, data: dict) -> PlaneScan:
        """Inverse of :meth:`to_dict`."""
        z = data.get("depths_m")
        return cls(
            disparities_px=np.asarray(data["disparities_px"], dtype=np.float64),
            depths_m=None if z is None else np.asarray(z, dtype=np.float64),
            scores=np.asarray(data["scores"], dtype=np.float64),
            peaks=tuple(Plane(**p) for p in data["peaks"]),
            binning=int(data["binning"]),
            fraction=float(data["fraction"]),
            min_prominence=float(data["min_prominence"]),
            presmooth_px=float(data.get("presmooth_px", DEFAULT_PRESMOOTH_PX)),
        )


def auto_binning(lightfield: LightField, *, fraction: float = jung2015.HAAR_EDGE_FRACTION) -> int:
    """Return :data:`DEFAULT_BINNING`, or less when the binned views would leave fewer than
    :data:`MIN_EDGE_PIXELS` edge pixels per Haar sub-band."""
    rows, cols = lightfield.shape_px
    for b in range(DEFAULT_BINNING, 1, -1):
        if fraction * (rows // (2 * b)) * (cols // (2 * b)) >= MIN_EDGE_PIXELS:
            return b
    return 1


def default_disparities(lightfield: LightField, n_planes: int = DEFAULT_N_PLANES) -> np.ndarray:
    """Return the disparities scanned when none are given.

    With a geometry that has ``near_m`` and ``far_m``: ``n_planes`` planes equally spaced in
    depth between them (as Fig. 15: equal depth steps). Otherwise ``n_planes`` disparities equally
    spaced in ``[-D, D]`` with ``D = min(rows, cols) / (8 * largest view offset)`` (ours: a
    shift of an eighth of the image between the centre and the outermost view).
    """
    if isinstance(n_planes, bool) or not isinstance(n_planes, (int, np.integer)) or n_planes < 3:
        raise InputError(f"n_planes must be an integer >= 3, got {n_planes!r}")
    g = lightfield.geometry
    if g is not None and g.near_m is not None and g.far_m is not None:
        depths = np.linspace(g.near_m, g.far_m, n_planes)
        return np.array([g.disparity_px(z) for z in depths])
    cu, cv = lightfield.centre_index
    n_u, n_v = lightfield.grid
    max_off = max(cu, n_u - 1 - cu, cv, n_v - 1 - cv, 1)
    dmax = min(lightfield.shape_px) / (8.0 * max_off)
    return np.linspace(-dmax, dmax, n_planes)


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
    binning: int = DEFAULT_BINNING,
    fraction: float = jung2015.HAAR_EDGE_FRACTION,
    min_prominence_fraction: float = MIN_PROMINENCE_FRACTION,
    presmooth_px: float = DEFAULT_PRESMOOTH_PX,
    nearest_shifts: bool = False,
    workers: int | None = None,
) -> PlaneScan:
    """Scan confocal planes and return the overlap score and the detected object planes.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    disparities_px : sequence of float, optional
        Planes to scan, pixels per view step (default :func:`default_disparities`).
    n_planes : int
        Number of planes when ``disparities_px`` is not given.
    binning : int >= 1
        View binning for the scan (see module notes).
    fraction : float in (0, 1)
        Haar edge fraction (paper: 0.5 %).
    min_prominence_fraction : float in [0, 1]
    presmooth_px : float >= 0
        Gaussian sigma before the Haar transform (:data:`DEFAULT_PRESMOOTH_PX`; 0 = paper).
    nearest_shifts : bool
        Whole-pixel shifts during the scan (faster; see :func:`iter_plane_scores`).
    workers : int, optional

    Returns
    -------
    PlaneScan
        Peaks sorted nearest first (largest disparity first).

    References
    ----------
    Jung et al. (2015), Sec. 4.2 and Fig. 15.
    """
    lf = _as_lightfield(lightfield)
    if disparities_px is None:
        ds = default_disparities(lf, n_planes)
    else:
        ds = np.asarray(disparities_px, dtype=np.float64)
        if ds.ndim != 1 or ds.size < 3:
            raise InputError(f"disparities_px must list at least 3 planes, got {ds.size}")
    scores = np.zeros(ds.size)
    for i, _, s in iter_plane_scores(
        lf,
        ds,
        binning=binning,
        fraction=fraction,
        presmooth_px=presmooth_px,
        nearest_shifts=nearest_shifts,
        workers=workers,
    ):
        scores[i] = s
    return scan_result(
        lf,
        ds,
        scores,
        binning=binning,
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
