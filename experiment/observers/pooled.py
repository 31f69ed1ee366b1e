"""The ``logistic`` observer's 50 % point as the paper measured it: a Weibull through pooled data.

The paper's thresholds (8,695 / 3,532 px, Jung et al. 2015, Sec. 3.2.2) are Weibull fits to the
trials of all subjects and objects pooled; its logistic regression describes the average
subject and object. With subject and object effects (SD ``subject_sd``, ``object_sd`` in logit
units) the pooled curve is the average of many logistic curves: flatter than one, and a Weibull
(guess 0, lapse free) fitted to it has its 50 % point above the average object's. With the
``logistic`` observer's defaults (SD 0.3 and 1.0, OR 74.5 per log10 px) the pooled Weibull sits at
10,260 px when the average object's 50 % point is the paper's 8,695 px, so a demo that puts the
average object there gives the paper's model back but not the paper's thresholds.

:func:`pooled_weibull_x50` computes the pooled Weibull's 50 % point of a given average-object
point (the population curve by Gauss-Hermite quadrature over the summed effects, then the ML
Weibull the analysis fits, at the study's pixel levels); :func:`average_object_x50` inverts it,
so that the demo can ask for the paper's pooled thresholds.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["pooled_curve", "pooled_weibull_x50", "average_object_x50", "paper_pooled_params"]


def pooled_curve(
    pixels: np.ndarray,
    x50_px: float,
    *,
    decluttered: bool = False,
    or_background: float = 5.6,
    or_per_log10_px: float = 74.5,
    effect_sd: float = math.hypot(0.3, 1.0),
    nodes: int = 41,
) -> np.ndarray:
    """Return the population's P(recognised) at ``pixels``: the model averaged over effects.

    Parameters
    ----------
    pixels : ndarray
        Pixel counts (> 0).
    x50_px : float
        The average subject's and object's cluttered 50 % point, pixels.
    decluttered : bool
        De-cluttered condition (the odds multiplied by ``or_background``).
    or_background, or_per_log10_px : float
        The model's odds ratios.
    effect_sd : float
        SD of the summed subject and object effects, logit units.
    nodes : int
        Gauss-Hermite nodes.

    Returns
    -------
    ndarray
        E[expit(eta + e)], e ~ N(0, effect_sd^2).

    Examples
    --------
    >>> float(pooled_curve(np.array([8695.0]), 8695.0, effect_sd=1.2)[0])
    0.5
    """
    from scipy import special

    x, w = np.polynomial.hermite_e.hermegauss(int(nodes))
    slope = math.log(or_per_log10_px)
    eta = slope * (np.log10(np.asarray(pixels, dtype=float)) - math.log10(x50_px))
    eta = eta + (math.log(or_background) if decluttered else 0.0)
    p = special.expit(eta[..., None] + effect_sd * x) @ w / w.sum()
    return np.round(p, 15)


def pooled_weibull_x50(x50_px: float, *, pixels: tuple[float, ...] | None = None, **model) -> float:
    """Return the 50 % point of the ML Weibull (guess 0, lapse free) through the pooled curve.

    Parameters
    ----------
    x50_px : float
        The average subject's and object's cluttered 50 % point, pixels.
    pixels : tuple of float, optional
        The study's levels; the paper's eight when None.
    **model
        ``decluttered``, ``or_background``, ``or_per_log10_px``, ``effect_sd``
        (:func:`pooled_curve`).

    Returns
    -------
    float
    """
    from analysis.jung2015 import PIXEL_COUNTS
    from analysis.weibull import fit_mle, threshold_at

    x = np.asarray(sorted(pixels or PIXEL_COUNTS), dtype=float)
    n = np.full(len(x), 1000.0)  # expected proportions; n only scales the likelihood
    fit = fit_mle(x, pooled_curve(x, x50_px, **model) * n, n)
    return float(threshold_at(0.5, fit.alpha, fit.beta, fit.lapse))


def average_object_x50(
    pooled_x50_px: float, *, pixels: tuple[float, ...] | None = None, **model
) -> float:
    """Return the average-object 50 % point whose pooled Weibull 50 % point is ``pooled_x50_px``.

    Parameters
    ----------
    pooled_x50_px : float
        The wanted pooled (Weibull) cluttered 50 % point, pixels, e.g. the paper's 8,695.
    pixels, **model
        As :func:`pooled_weibull_x50` (cluttered: ``decluttered`` must not be given).

    Returns
    -------
    float

    Raises
    ------
    ValueError
        No average-object point between a tenth and ten times ``pooled_x50_px`` gives it.
    """
    from scipy import optimize

    def gap(log_x50: float) -> float:
        return math.log(pooled_weibull_x50(math.exp(log_x50), pixels=pixels, **model))

    target = math.log(pooled_x50_px)
    lo, hi = target - math.log(10.0), target + math.log(10.0)
    if not (gap(lo) - target) * (gap(hi) - target) < 0:
        raise ValueError(f"no average-object 50 % point gives a pooled one of {pooled_x50_px!r}")
    return math.exp(optimize.brentq(lambda v: gap(v) - target, lo, hi, xtol=1e-4))


def paper_pooled_params() -> dict[str, float]:
    """Return the ``logistic`` observer's ``x50_cluttered_px`` whose pooled Weibull is at 8,695 px.

    With :class:`~experiment.observers.LogisticParams`' odds ratios and effect SDs; the
    threshold is the paper's (Jung et al. 2015, Sec. 3.2.2).

    Returns
    -------
    dict
        ``{"x50_cluttered_px": ...}`` (pixels, to 0.1 px).
    """
    from experiment.observers import PAPER_X50_CLUTTERED_PX, LogisticParams

    p = LogisticParams()
    x50 = average_object_x50(
        PAPER_X50_CLUTTERED_PX,
        or_background=p.or_background,
        or_per_log10_px=p.or_per_log10_px,
        effect_sd=math.hypot(p.subject_sd, p.object_sd),
    )
    return {"x50_cluttered_px": round(x50, 1)}
