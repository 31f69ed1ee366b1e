"""Otsu's (1979) threshold of a float32 image, scikit-image's to the bit, without importing it.

``skimage.filters.threshold_otsu`` imports SciPy (about 0.4 s of a command's start) and makes
its histogram in a chain of numpy passes; :func:`otsu_threshold` makes the same histogram in one
compiled pass (:func:`stimuli.edgekernels.histogram_uniform`) and the same arithmetic after it.

References
----------
Otsu, N. (1979). A threshold selection method from gray-level histograms. IEEE Trans. Syst. Man
Cybern. 9(1), 62-66.
"""

from __future__ import annotations

import numpy as np

__all__ = ["otsu_threshold", "OTSU_BINS"]

#: Histogram bins (as ``stimuli.declutter`` asks scikit-image for).
OTSU_BINS = 256


def otsu_threshold(values: np.ndarray, *, compiled: bool = True, extrema=None) -> float:
    """Return Otsu's threshold of a float32 image over :data:`OTSU_BINS` bins.

    ``skimage.filters.threshold_otsu(values, nbins=256)`` to the bit, with the histogram made in
    one compiled pass (:func:`stimuli.edgekernels.histogram_uniform`) instead of numpy's chain
    of passes, and without importing scikit-image and SciPy (about 0.4 s of a command's start).

    Parameters
    ----------
    values : ndarray, float32, no NaN
    compiled : bool
        The compiled histogram (default) or ``numpy.histogram``; the same counts.
    extrema : (float32, float32), optional
        The smallest and largest value, if the caller has them (the compiled path then does
        not look for them again).

    Returns
    -------
    float
        The centre of the bin that maximises the between-class variance; the value itself
        where every value is the same.
    """
    from stimuli import numpykernels

    compiled = compiled and not numpykernels.active()  # a scan's last steps: numpy, same counts
    a = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)
    if compiled and extrema is not None:
        first, last = (np.float32(v) for v in extrema)
    elif compiled:
        from stimuli.edgekernels import extrema as find_extrema

        first, last = (np.float32(v) for v in find_extrema(a))
    else:
        first, last = a.min(), a.max()
    if first == last:  # scikit-image returns the single value
        return float(first)
    edges = np.linspace(first, last, OTSU_BINS + 1, endpoint=True, dtype=np.float32)
    if compiled:
        from stimuli.edgekernels import histogram_uniform

        counts = np.zeros(OTSU_BINS, np.int64)
        histogram_uniform(a, first, last, edges, counts)
    else:
        counts = np.histogram(a, bins=OTSU_BINS)[0]
    counts = counts.astype(np.float32)  # as scikit-image, term for term
    centres = (edges[:-1] + edges[1:]) / 2.0
    weight1 = np.cumsum(counts)
    weight2 = np.cumsum(counts[::-1])[::-1]
    mean1 = np.cumsum(counts * centres) / weight1
    mean2 = (np.cumsum((counts * centres)[::-1]) / weight2[::-1])[::-1]
    variance12 = weight1[:-1] * weight2[1:] * (mean1[:-1] - mean2[1:]) ** 2
    return float(centres[np.argmax(variance12)])
