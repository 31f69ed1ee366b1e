"""Results of a depth-plane scan (:class:`Plane`, :class:`PlaneScan`) and peak detection.

Object planes are the local maxima of the score over the scan. A local maximum counts when its
*prominence* (as ``scipy.signal.find_peaks`` defines it; :func:`find_peaks` here gives the same
answer without importing ``scipy.signal``: its height above the higher of the two minima that
separate it from higher ground on either side) is at least :data:`MIN_PROMINENCE_FRACTION` of
the score's range over the scan (ours). Maxima at the two ends of the scan are not peaks: a
score still rising at the end of the range says the object lies beyond it. The score often has
a flat top about ``1 / (largest view offset)`` px per view step wide (edge positions are
quantised to the 2x2 Haar blocks); a flat-topped peak is reported at the middle of its top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.lfviews import LightField

__all__ = [
    "gaussian_smooth",
    "median_spacing",
    "Plane",
    "PlaneScan",
    "score_peaks",
    "find_peaks",
    "peak_prominences",
    "scan_result",
    "MIN_PROMINENCE_FRACTION",
    "DEFAULT_BINNING",
    "DEFAULT_PRESMOOTH_PX",
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
    downsample : int
        Agreement scan: the factor by which large views were binned beyond the scan's usual
        binning (``binning`` includes it; :func:`stimuli.agreementscan.scan_downsample`); 1 when
        the views were not downsampled.
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
    downsample: int = 1

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

    def notes(self) -> list[str]:
        """Return the lines a command prints about how the scan ran.

        The downsampling of large views (:attr:`downsample` > 1), or nothing.
        """
        if self.downsample <= 1:
            return []
        return [
            f"large views: scanned downsampled {self.downsample}x (binned {self.binning}); "
            "planes in full-resolution px/view"
        ]

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
            "downsample": self.downsample,
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
            downsample=int(data.get("downsample", 1)),
        )


def _local_maxima(x: np.ndarray) -> np.ndarray:
    """Interior local maxima of ``x``; a flat top counts once, at its middle (left of two)."""
    peaks = []
    i, i_max = 1, x.size - 1
    while i < i_max:
        if x[i - 1] < x[i]:
            ahead = i + 1
            while ahead < i_max and x[ahead] == x[i]:
                ahead += 1
            if x[ahead] < x[i]:
                peaks.append((i + ahead - 1) // 2)
                i = ahead
        i += 1
    return np.asarray(peaks, dtype=np.intp)


def median_spacing(disparities_px: np.ndarray) -> float:
    """Return the median gap between neighbouring planes (NaN for fewer than two).

    ``np.median(np.abs(np.diff(d)))`` to the bit, by a sort: ``np.median`` imports
    ``numpy.ma`` on first use (0.015 s in a scan that answers in under a second).

    Examples
    --------
    >>> median_spacing(np.array([0.0, 0.5, 1.5, 1.75]))
    0.5
    """
    gaps = np.sort(np.abs(np.diff(np.asarray(disparities_px, dtype=np.float64))))
    n = gaps.size
    if n == 0:
        return math.nan
    mid = n // 2
    return float(gaps[mid]) if n % 2 else float((gaps[mid - 1] + gaps[mid]) / 2.0)


def gaussian_smooth(curve: np.ndarray, sigma: float, *, mode: str = "nearest") -> np.ndarray:
    """Smooth a 1-D curve with a Gaussian, as ``scipy.ndimage.gaussian_filter1d`` does.

    The kernel reaches ``int(4 sigma + 0.5)`` samples to each side (scipy's ``truncate=4``)
    and sums to one; beyond the ends the curve repeats its end values (``mode='nearest'``) or
    is zero (``mode='constant'``). The symmetric taps are added pairwise, in scipy's order, so
    the result is scipy's to the bit; scipy.ndimage itself is not imported (it takes 0.4 s,
    longer than the whole plane scan).

    Examples
    --------
    >>> gaussian_smooth(np.array([0.0, 0.0, 1.0, 0.0, 0.0]), 0.5).round(3)
    array([0.   , 0.106, 0.787, 0.106, 0.   ])
    """
    x = np.asarray(curve, dtype=np.float64)
    radius = int(4.0 * float(sigma) + 0.5)
    taps = np.exp(-0.5 / (float(sigma) * float(sigma)) * np.arange(-radius, radius + 1) ** 2)
    taps = taps / taps.sum()
    if mode == "nearest":
        padded = np.pad(x, radius, mode="edge")
    elif mode == "constant":
        padded = np.pad(x, radius)
    else:
        raise ValueError(f"mode must be 'nearest' or 'constant', got {mode!r}")
    n = x.size
    out = taps[radius] * padded[radius : radius + n]
    for j in range(radius, 0, -1):  # the far pairs first, as scipy adds them
        out += (padded[radius - j : radius - j + n] + padded[radius + j : radius + j + n]) * taps[
            radius + j
        ]
    return out


def peak_prominences(x: np.ndarray, peaks: np.ndarray) -> tuple[np.ndarray]:
    """Return ``(prominences,)`` of the samples ``peaks`` of the curve ``x``.

    A peak's prominence is its height above the higher of the lowest points between it and
    higher ground on either side (or the curve's end): the definition and the arithmetic of
    ``scipy.signal.peak_prominences`` with no window, written here so that a plane scan does
    not import ``scipy.signal`` (half a second of a command's start-up).
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    out = np.empty(len(peaks), dtype=np.float64)
    for k, p in enumerate(int(v) for v in peaks):
        top = x[p]
        i, left = p, top
        while i >= 0 and x[i] <= top:
            left = min(left, x[i])
            i -= 1
        i, right = p, top
        while i < n and x[i] <= top:
            right = min(right, x[i])
            i += 1
        out[k] = top - max(left, right)
    return (out,)


def find_peaks(x: np.ndarray, *, prominence: float = 0.0) -> tuple[np.ndarray, dict]:
    """Return the interior local maxima of ``x`` whose prominence is at least ``prominence``.

    The same answer as ``scipy.signal.find_peaks(x, prominence=prominence)``: indices (flat tops
    at their middle) and ``{"prominences": ...}`` (:func:`peak_prominences`).
    """
    x = np.asarray(x, dtype=np.float64)
    idx = _local_maxima(x)
    prom = peak_prominences(x, idx)[0]
    keep = prom >= prominence
    return idx[keep], {"prominences": prom[keep]}


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
