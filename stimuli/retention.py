"""Propose the Sobel threshold of a photo pair: the minimum edge retention.

The paper set the Sobel threshold by hand for each confocal (narrow-DOF) photo, "aiming to fully
remove the suppressed background clutter and leave only the OI", and applied it to the paired
wide-DOF photo (Jung et al. 2015, Sec. 3.1). The builder's automatic threshold
(``confocal stimuli build``, ``--threshold-method retention``) and the tuner
(``confocal stimuli tune``) both propose it from the pair itself, here.

Method: minimum edge retention (ours, not the paper's)
------------------------------------------------------
Both photos show the same scene. The in-focus object has sharp edges in both; the background
has sharp edges in the wide photo only, because the narrow aperture blurs it. For a threshold
``t`` let ``f_wide(t)`` and ``f_narrow(t)`` be the fractions of pixels whose Sobel magnitude
exceeds ``t``. Their ratio, the *edge retention* ``f_narrow(t) / f_wide(t)``, falls as ``t``
rises past the weak gradients of the blurred background (they vanish from the narrow edge image
but their sharp twins stay in the wide one), and stops falling, or rises again, once only the
object's edges, present in both photos, are left to remove. The proposed threshold is the one
with the lowest retention: the point where the narrow photo has shed the largest share of the
wide photo's edges, i.e. where the blurred background is gone and nothing is gained by cutting
further into the in-focus edges.

Candidates run from Otsu's threshold on the narrow photo's Sobel magnitude
(:func:`stimuli.declutter.auto_threshold`: the split between its weak gradients, flat regions
and blur, and its strong ones) up to the magnitude's 0.99 quantile (:data:`UPPER_QUANTILE`), in
steps of equal pixel counts, so the search range comes from the photo in front of it, not from
constants on the Sobel scale. Ties go to the lowest threshold, which keeps the most edges. When
the narrow photo's blurred background is already below Otsu's threshold (strong blur, as in the
synthetic pairs of ``stimuli synth``) the retention rises from there on and the proposal is
Otsu's threshold itself; when the blur leaves gradients above it (real photos at 492x327) the
proposal moves up until they are gone.

On the six real pairs in ``dof_pairs/`` (VABD and EBB!, 492x327) this gives a mean wide-DOF
edge fraction of 0.068 (paper: 1/13 = 0.077), against 0.28 with Otsu's threshold alone, and the
share of edge pixels inside the in-focus mask rises from 1-30 % (wide) to 5-90 % (narrow) for
every pair; see ``tests/stimuli/test_tune.py``. The upper quantile matters for three of the six
pairs, whose retention still falls there: with 0.97, 0.98 or 0.995 instead of 0.99 the mean is
0.098, 0.085 or 0.060, still in the paper's range. Where the retention curve is flat (EBB! 2979,
whose background is hardly blurred) the proposal can move by 20 % with the candidate grid; the
contact sheet shows the neighbours for such cases.

References
----------
Jung, J.-H., Aloni, D., Yitzhaky, Y., & Peli, E. (2015). Active confocal imaging for visual
prostheses. Vision Research 111, 182-196, Sec. 2.2 and 3.1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stimuli.declutter import auto_threshold, sobel_magnitude
from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = [
    "UPPER_QUANTILE",
    "N_CANDIDATES",
    "RetentionCurve",
    "pair_magnitudes",
    "retention_curve",
    "retention_threshold",
]

#: Quantile of the narrow photo's Sobel magnitude that bounds the threshold search from above
#: (ours, not the paper's). Above it fewer than 1 % of the pixels stay edges, about the outline
#: of an object a third of the frame wide (at 492x327 a 160x160 px outline is ~0.4 % of the
#: pixels), so a higher threshold would start to erase the object itself.
UPPER_QUANTILE: float = 0.99

#: Number of candidate thresholds between Otsu's threshold and the upper quantile (ours): at
#: most 0.5 % of the pixels apart, finer than a viewer can tell apart on the contact sheet.
N_CANDIDATES: int = 100


@dataclass(frozen=True)
class RetentionCurve:
    """Edge fractions of a photo pair over candidate thresholds.

    Parameters
    ----------
    thresholds : ndarray of shape (n,), float
        Candidate Sobel thresholds, ascending (scale of :func:`stimuli.declutter.sobel_magnitude`).
    wide_fraction, narrow_fraction : ndarray of shape (n,), float in [0, 1]
        Fraction of pixels above each threshold in the wide and narrow photo.
    """

    thresholds: np.ndarray
    wide_fraction: np.ndarray
    narrow_fraction: np.ndarray

    @property
    def retention(self) -> np.ndarray:
        """Return ``narrow_fraction / wide_fraction`` (dimensionless; ``inf`` where wide is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            r = self.narrow_fraction / self.wide_fraction
        return np.where(self.wide_fraction > 0, r, np.inf)

    def best_index(self) -> int:
        """Return the index of the lowest retention (the lowest threshold among ties)."""
        return int(np.argmin(self.retention))

    def best_threshold(self) -> float:
        """Return the threshold of the lowest retention; Otsu's (the first) if none is finite."""
        # thresholds[0] is Otsu's threshold (retention_curve), the fallback when no wide edges
        if not np.isfinite(self.retention).any():
            return float(self.thresholds[0])
        return float(self.thresholds[self.best_index()])


def pair_magnitudes(wide: np.ndarray, narrow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the Sobel magnitudes of a pair's two photos, checked to be grey and of one shape.

    Raises
    ------
    InputError
        If an image is not a grey image in [0, 1] or the shapes differ.
    """
    w, n = check_gray(wide), check_gray(narrow)
    if w.shape != n.shape:
        raise InputError(
            f"wide and narrow images must have the same shape, got {w.shape} and {n.shape}"
        )
    return sobel_magnitude(w), sobel_magnitude(n)


def _fraction_above(sorted_values: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    n = sorted_values.size
    return 1.0 - np.searchsorted(sorted_values, thresholds, side="right") / n


def retention_curve(
    wide: np.ndarray, narrow: np.ndarray, *, n_candidates: int = N_CANDIDATES
) -> RetentionCurve:
    """Return the edge fractions of a pair at thresholds spread over the narrow photo's range.

    Parameters
    ----------
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The wide-DOF and narrow-DOF (confocal) photos of one object, at the working size.
    n_candidates : int >= 2
        Number of candidate thresholds: quantiles of the narrow photo's Sobel magnitude evenly
        spaced in probability from Otsu's threshold to :data:`UPPER_QUANTILE` (repeated
        values dropped; only Otsu's threshold when it is above that quantile).

    Returns
    -------
    RetentionCurve

    Raises
    ------
    InputError
        If an image is not a grey image in [0, 1], the shapes differ or ``n_candidates < 2``.
    """
    if int(n_candidates) < 2:
        raise InputError(f"n_candidates must be >= 2, got {n_candidates!r}")
    sw, sn = pair_magnitudes(wide, narrow)
    sorted_n = np.sort(sn.ravel())
    t_otsu = auto_threshold(narrow)
    q_otsu = 1.0 - float(_fraction_above(sorted_n, np.array([t_otsu]))[0])
    if q_otsu < UPPER_QUANTILE:
        q = np.linspace(q_otsu, UPPER_QUANTILE, int(n_candidates))[1:]
        # quantiles of the sorted values by index (nearest rank): np.quantile would sort again
        idx = np.clip(np.round(q * (sorted_n.size - 1)).astype(np.int64), 0, sorted_n.size - 1)
        ts = np.unique(np.concatenate([[t_otsu], sorted_n[idx]]).astype(np.float64))
        ts = ts[ts >= t_otsu]
    else:
        ts = np.array([t_otsu], np.float64)
    return RetentionCurve(
        thresholds=ts,
        wide_fraction=_fraction_above(np.sort(sw.ravel()), ts),
        narrow_fraction=_fraction_above(sorted_n, ts),
    )


def retention_threshold(wide: np.ndarray, narrow: np.ndarray) -> float:
    """Propose the Sobel threshold that removes the blurred background of a photo pair.

    The threshold with the lowest edge retention ``f_narrow(t) / f_wide(t)`` (module docstring).

    Parameters
    ----------
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The wide-DOF and narrow-DOF photos of one object, at the working size.

    Returns
    -------
    float >= 0
        On the scale of :func:`stimuli.declutter.sobel_magnitude`; never below Otsu's threshold
        on the narrow photo (:func:`stimuli.declutter.auto_threshold`), which is also the
        answer for a photo without gradients or a wide photo without edges above any candidate.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (the threshold the paper set by hand).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> from scipy.ndimage import gaussian_filter
    >>> bg = rng.random((64, 96)).astype(np.float32)
    >>> wide = 0.5 * bg; wide[16:48, 32:64] = 1.0
    >>> narrow = 0.5 * gaussian_filter(bg, 3); narrow[16:48, 32:64] = 1.0
    >>> t = retention_threshold(wide, narrow)
    >>> edges = sobel_magnitude(narrow) > t
    >>> bool(edges[16, 40:56].all()), bool(edges[:10].any())
    (True, False)
    """
    return retention_curve(wide, narrow).best_threshold()
