"""The built-in de-clutter methods: sobel, depth, mask, segment and saliency.

Each takes one object's images at the working size (:class:`~stimuli.methods.base.MethodInput`)
and returns its edge image with what it measured. None needs model weights. Every method's edges
are Sobel edges of the narrow-DOF photo at the object's own threshold (the set's threshold
rule), kept where the method says the object is, so the methods differ only in how they find
the object:

- ``sobel``: nowhere removed; the defocus of the narrow photo does the de-cluttering (the
  paper's);
- ``depth``: where a light field's views agree at the plane (:func:`declutter_depth`);
- ``mask``: the object's own mask, given by the user;
- ``segment``: a random walker's region grown from the edges both photos have sharp (in focus)
  against the edges only the wide photo has sharp (the clutter the narrow photo blurs);
- ``saliency``: the spectral-residual saliency map (Hou & Zhang 2007) above three times its
  mean.

``mask``, ``segment`` and ``saliency`` cut the narrow photo to their region first (the outside
set to the grey furthest from the region's mean), so the region's outline is an edge too.
"""

from __future__ import annotations

import numpy as np

from stimuli.declutter import declutter, declutter_depth, sobel_magnitude
from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.methods.base import MethodInput, MethodResult

__all__ = [
    "sobel_method",
    "depth_method",
    "mask_method",
    "segment_method",
    "saliency_method",
    "region_edges",
    "spectral_residual",
    "SEGMENT_SCALE",
    "RW_BETA",
    "SALIENCY_WIDTH_PX",
    "SALIENCY_FACTOR",
]


def sobel_method(images: MethodInput) -> MethodResult:
    """Apply the paper's de-clutter: Sobel edges of the narrow-DOF photo above the threshold.

    References
    ----------
    Jung et al. (2015), Sec. 2.2.
    """
    edges = declutter(images.narrow, threshold=images.threshold)
    return MethodResult(edges, {"threshold": float(images.threshold)})


def depth_method(images: MethodInput) -> MethodResult:
    """Sobel edges kept where a light field's views agree at the plane (the build's depth mode).

    Raises
    ------
    InputError
        For a photo pair (no views to compare), or a light field built without its in-focus
        mask (``declutter='sobel'``).
    """
    if images.focus is None:
        what = (
            "is a photo pair; depth needs a light field (views to compare)"
            if images.kind == "photos"
            else f"was de-cluttered by sobel; build with {param('declutter', 'depth')}"
        )
        raise InputError(f"condition depth: object {images.object!r} {what}")
    edges = declutter_depth(images.narrow, images.focus, threshold=images.threshold)
    return MethodResult(
        edges, {"threshold": float(images.threshold), "in_focus_share": float(images.focus.mean())}
    )


def region_edges(narrow: np.ndarray, region: np.ndarray, threshold: float) -> np.ndarray:
    """Return the Sobel edges of the narrow photo cut to a region (its outline included).

    The outside of the region is set to the grey furthest from the region's mean (0 or 1), so
    the region's outline is an edge wherever the object is not of that grey; edges more than
    one pixel outside the region are dropped.

    Parameters
    ----------
    narrow : ndarray of shape (rows, cols), float32 in [0, 1]
    region : ndarray of shape (rows, cols), bool
    threshold : float >= 0

    Returns
    -------
    ndarray of shape (rows, cols), bool
        All False for an empty region.

    Examples
    --------
    >>> img = np.full((20, 20), 0.8, np.float32)
    >>> r = np.zeros((20, 20), bool); r[5:15, 5:15] = True
    >>> e = region_edges(img, r, 0.1)
    >>> bool(e[10, 4:6].any()), bool(e[0, 0]), bool(e[10, 10])
    (True, False, False)
    """
    from scipy.ndimage import binary_dilation

    r = np.asarray(region, dtype=bool)
    if not r.any():
        return np.zeros(r.shape, bool)
    fill = np.float32(0.0 if float(narrow[r].mean()) >= 0.5 else 1.0)
    cut = np.where(r, narrow, fill).astype(np.float32)
    return declutter(cut, threshold=threshold) & binary_dilation(r, iterations=1)


def mask_method(images: MethodInput) -> MethodResult:
    """Edges of the narrow photo cut to the object's own mask (``OBJECT/mask.png``).

    Raises
    ------
    InputError
        If the object has no mask.
    """
    if images.mask is None:
        raise InputError(
            f"condition mask: object {images.object!r} has no mask (expected "
            f"{images.object}/mask.png, non-zero = object)"
        )
    m = np.asarray(images.mask, dtype=bool)
    if m.shape != images.narrow.shape:
        raise InputError(
            f"condition mask: object {images.object!r}: mask is {m.shape}, expected "
            f"{images.narrow.shape}"
        )
    return MethodResult(
        region_edges(images.narrow, m, images.threshold),
        {"threshold": float(images.threshold), "region_share": float(m.mean())},
    )


#: The random walker of ``segment`` runs on the photos shrunk by this factor (ours: it solves a
#: sparse system per pixel; at a quarter of the paper's working size it takes about a tenth of
#: a second per object, and its region's outline is drawn at the working size by the photo's own
#: edges).
SEGMENT_SCALE: int = 4

#: The random walker's edge weight (scikit-image's ``beta``; ours: its default).
RW_BETA: float = 130.0


def _segment_region(images: MethodInput) -> tuple[np.ndarray, int, int]:
    """Segment the object's region by a random walker; also return the numbers of seeds.

    The numbers are those of the object seeds and of the clutter seeds.
    """
    from scipy.ndimage import binary_fill_holes, label
    from skimage.segmentation import random_walker
    from skimage.transform import resize

    s = SEGMENT_SCALE
    shape = images.narrow.shape
    small = (max(8, shape[0] // s), max(8, shape[1] // s))
    narrow = resize(images.narrow, small, order=1, anti_aliasing=True).astype(np.float64)
    wide = resize(images.wide, small, order=1, anti_aliasing=True).astype(np.float64)
    t = float(images.threshold)
    gn, gw = sobel_magnitude(narrow.astype(np.float32)), sobel_magnitude(wide.astype(np.float32))
    # in focus: sharp in both photos; clutter: sharp in the wide photo only (the narrow blurs it)
    obj = (gn > t) & (gw > t)
    clutter = (gw > t) & (gn < 0.5 * t)
    labels = np.zeros(small, np.int32)
    labels[clutter] = 2
    labels[obj] = 1
    n_obj, n_clu = int(obj.sum()), int(clutter.sum())
    if n_obj == 0:
        return np.zeros(shape, bool), 0, n_clu
    if n_clu == 0:
        region_small = np.ones(small, bool)
    else:
        # prob_tol 1: no warning on probabilities a little outside [0, 1] (labels are argmax)
        seg = random_walker(narrow, labels, beta=RW_BETA, mode="cg_j", tol=1e-2, prob_tol=1.0)
        region_small = binary_fill_holes(seg == 1)
        lab, n = label(region_small)
        if n > 1:  # the component holding most object seeds
            counts = np.bincount(lab[obj], minlength=n + 1)
            counts[0] = 0
            region_small = lab == int(np.argmax(counts))
    region = resize(region_small.astype(np.float32), shape, order=1) >= 0.5
    return region, n_obj, n_clu


def segment_method(images: MethodInput) -> MethodResult:
    """Edges of the narrow photo cut to a weight-free segmentation of the object.

    Seeds: object where both photos are sharp (the in-focus region of the narrow-DOF photo),
    clutter where only the wide-DOF photo is (the background the narrow photo blurs); a random
    walker on the narrow photo (Grady 2006, scikit-image) labels every other pixel; the object's
    region is its component holding most object seeds, holes filled.

    References
    ----------
    Grady, L. (2006). Random walks for image segmentation. IEEE TPAMI 28(11), 1768-1783.
    """
    region, n_obj, n_clu = _segment_region(images)
    return MethodResult(
        region_edges(images.narrow, region, images.threshold),
        {
            "threshold": float(images.threshold),
            "region_share": float(region.mean()),
            "object_seeds": n_obj,
            "clutter_seeds": n_clu,
        },
    )


#: Spectral-residual saliency is computed on the narrow photo shrunk to this width (Hou & Zhang
#: 2007 used 64 px).
SALIENCY_WIDTH_PX: int = 64

#: A pixel is salient where the saliency map exceeds this multiple of its mean (Hou & Zhang
#: 2007, Sec. 3.2: "three times the average intensity of the saliency map").
SALIENCY_FACTOR: float = 3.0


def spectral_residual(image: np.ndarray) -> np.ndarray:
    """Return the spectral-residual saliency map of a grey image (Hou & Zhang 2007).

    The log amplitude spectrum minus its 3x3 local mean, back-transformed with the original
    phase, squared and smoothed (Gaussian, sigma 2.5 px at 64 px width; ours), computed at
    :data:`SALIENCY_WIDTH_PX` wide and resized to the image.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float in [0, 1]

    Returns
    -------
    ndarray of shape (rows, cols), float32 >= 0, mean 1 (all zeros for a flat image)

    References
    ----------
    Hou, X., & Zhang, L. (2007). Saliency detection: a spectral residual approach. CVPR.
    """
    from scipy.ndimage import gaussian_filter, uniform_filter
    from skimage.transform import resize

    img = np.asarray(image, dtype=np.float64)
    rows, cols = img.shape
    w = min(SALIENCY_WIDTH_PX, cols)
    h = max(1, round(rows * w / cols))
    small = resize(img, (h, w), order=1, anti_aliasing=True)
    f = np.fft.fft2(small)
    amp = np.abs(f)
    log_amp = np.log(amp + 1e-12)
    residual = log_amp - uniform_filter(log_amp, 3, mode="wrap")
    sal = np.abs(np.fft.ifft2(np.exp(residual + 1j * np.angle(f)))) ** 2
    sal = gaussian_filter(sal, 2.5 * w / 64.0)
    out = resize(sal, (rows, cols), order=1).astype(np.float32)
    m = float(out.mean())
    return out / m if m > 0 and np.isfinite(m) else np.zeros_like(out)


def saliency_method(images: MethodInput) -> MethodResult:
    """Edges of the narrow photo cut to its salient region (spectral residual, 3x the mean)."""
    sal = spectral_residual(images.narrow)
    region = sal > SALIENCY_FACTOR
    return MethodResult(
        region_edges(images.narrow, region, images.threshold),
        {"threshold": float(images.threshold), "region_share": float(region.mean())},
    )
