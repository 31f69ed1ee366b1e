"""Confocal de-cluttering: Sobel edge magnitude and a threshold (Jung et al. 2015, Sec. 2.2).

The blurred background of a confocal (narrow depth-of-field or refocused) image has weak
gradients, so thresholding the Sobel magnitude keeps the in-focus object's edges and drops the
background. The paper set the threshold by hand per confocal image and applied the same value to
the paired wide-DOF image.
"""

from __future__ import annotations

import numpy as np
from skimage.filters import sobel

from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = ["sobel_magnitude", "declutter"]


def sobel_magnitude(image: np.ndarray) -> np.ndarray:
    """Return the Sobel gradient magnitude of a grey image (``skimage.filters.sobel``).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]

    Returns
    -------
    ndarray of shape (rows, cols), float32 >= 0
        ``sqrt((Gx**2 + Gy**2) / 2)`` as scikit-image defines it (so a unit step gives about
        0.7 at the edge).
    """
    img = check_gray(image)
    return sobel(img).astype(np.float32)


def declutter(image: np.ndarray, *, threshold: float) -> np.ndarray:
    """Return the edge image: Sobel magnitude above ``threshold``.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    threshold : float >= 0
        On the scale of :func:`sobel_magnitude`.

    Returns
    -------
    ndarray of shape (rows, cols), bool

    References
    ----------
    Jung et al. (2015), Sec. 2.2 ("Sobel edge detection ... threshold").
    """
    try:
        t = float(threshold)
    except (TypeError, ValueError):
        raise InputError(f"threshold must be a number, got {threshold!r}") from None
    if not np.isfinite(t) or t < 0:
        raise InputError(f"threshold must be a finite number >= 0, got {threshold!r}")
    return sobel_magnitude(image) > t
