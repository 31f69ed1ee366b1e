"""The paper's depth scan: Haar edges that coincide with the centre view's (Jung 2015, Sec. 4.2).

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

Peaks of the score curve are found by :func:`stimuli.planescan.score_peaks`.

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

import numpy as np

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.lfload import as_lightfield
from stimuli.lfviews import LightField
from stimuli.planescan import DEFAULT_BINNING, DEFAULT_PRESMOOTH_PX
from stimuli.refocus import _check_disparity, _refocus_views, default_workers

__all__ = [
    "haar_details",
    "haar_edges",
    "edge_overlap",
    "auto_binning",
    "iter_plane_scores",
    "MIN_EDGE_PIXELS",
]

#: Fewer edge pixels per sub-band than this make the overlap score too coarse to trust (ours):
#: the scan warns.
MIN_EDGE_PIXELS: int = 25


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


def auto_binning(lightfield: LightField, *, fraction: float = jung2015.HAAR_EDGE_FRACTION) -> int:
    """Return :data:`DEFAULT_BINNING`, or less for small views.

    Less when the binned views would leave fewer than :data:`MIN_EDGE_PIXELS` edge pixels per Haar
    sub-band.
    """
    rows, cols = lightfield.shape_px
    for b in range(DEFAULT_BINNING, 1, -1):
        if fraction * (rows // (2 * b)) * (cols // (2 * b)) >= MIN_EDGE_PIXELS:
            return b
    return 1


def _smooth(image: np.ndarray, sigma_px: float) -> np.ndarray:
    if sigma_px <= 0:
        return image
    from scipy.ndimage import gaussian_filter  # imported when used: it takes 0.4 s

    return gaussian_filter(image, sigma_px, mode="nearest")


def _prepare(
    lightfield: LightField | np.ndarray, binning: int, fraction: float, presmooth_px: float
) -> tuple[LightField, np.ndarray]:
    if not (isinstance(presmooth_px, (int, float)) and 0 <= presmooth_px <= 10):
        raise InputError(f"presmooth_px must be a number in [0, 10], got {presmooth_px!r}")
    lf = as_lightfield(lightfield).gray()
    small = lf.binned(binning)
    ref = haar_edges(
        _smooth(small.centre_view(), presmooth_px),
        fraction=fraction,
        bands=_informative_bands(small),
    )
    return small, ref


def _informative_bands(lf: LightField) -> tuple[int, ...]:
    """Return the sub-bands whose edges refocusing can blur.

    A single row of views (n_u = 1) has no vertical parallax, so its horizontal edges (cH) are sharp
    at every plane; likewise cV for a single column.
    """
    n_u, n_v = lf.grid
    return tuple(b for b, keep in ((0, n_u > 1), (1, n_v > 1), (2, True)) if keep)


def _scan_views(lf: LightField) -> tuple[np.ndarray, tuple[list[int], list[int]]]:
    """Return the views used by the scan: all but the centre row and column (see module notes)."""
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
    lf = as_lightfield(lightfield)
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
