"""The psychometric model: sigmoids, the curve and its thresholds, counts and likelihood.

The model (Jung et al. 2015, Sec. 3.2.2; Wichmann & Hill 2001) is

    P(x) = g + (1 - g - l) * F(beta * (s(x) - s(alpha)))

``g`` is the guess rate (0 for free recognition, 0.5 for 2AFC) and ``l`` the lapse rate, which is
free, so the curve is not forced to reach 1. ``s`` is the stimulus axis: ``ln x`` for the
log-axis sigmoids (``x > 0``, e.g. pixels) and ``x`` itself for the linear ones (any real ``x``,
e.g. a phase in degrees). ``F`` is one of three shapes:

==============  ======  ===========================  ==========================================
sigmoid         axis    F(z)                         note
==============  ======  ===========================  ==========================================
``weibull``     log     1 - exp(-exp(z))             ``1 - exp(-(x / alpha) ** beta)``
``loglogistic`` log     1 / (1 + exp(-z))
``lognormal``   log     Phi(z)
``gumbel``      linear  1 - exp(-exp(z))             psignifit's "gumbel" (log-Weibull)
``logistic``    linear  1 / (1 + exp(-z))
``normal``      linear  Phi(z)                       cumulative normal
==============  ======  ===========================  ==========================================

The likelihood is binomial over the distinct stimulus values, or, with ``overdispersion=True``,
beta-binomial: each level's P is itself drawn from a Beta distribution with mean P and
``Var = eta ** 2 * P * (1 - P)``, so the level's count has variance
``n P (1 - P) (1 + (n - 1) eta ** 2)`` (Schuett, Harmeling, Macke & Wichmann 2016, psignifit 4).
The scale ``eta`` in [0, 1) is a fourth free parameter with a Beta(1, 10) prior (psignifit 4's
default, as we read it; ours to adopt). Pooling subjects and objects whose thresholds differ makes
binomial-only intervals too narrow; eta absorbs that extra variance. Maximum-likelihood estimates
are always binomial (as Psychtoolbox's fit in the paper).

This module also aggregates trials into counts per stimulus value (:func:`aggregate`). The
sigmoid table, :class:`FitWarning` and the likelihood live in :mod:`analysis.weibull.kernel`
and are re-exported here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from analysis.weibull.kernel import (
    ETA_MAX,
    SIGMOIDS,
    FitWarning,
    Sigmoid,
    check_guess,
    check_sigmoid,
    is_log_axis,
    sigmoid_cdf,
    sigmoid_ppf,
)

__all__ = [
    "SIGMOIDS",
    "ETA_MAX",
    "Sigmoid",
    "FitWarning",
    "is_log_axis",
    "psychometric",
    "threshold_at",
    "aggregate",
]


def psychometric(
    x: Any,
    alpha: float,
    beta: float,
    lapse: float,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
) -> np.ndarray:
    """Return the probability correct at stimulus values ``x``.

    Parameters
    ----------
    x : array_like
        Stimulus values (pixels for the paper's Weibull: > 0; any unit for the logistic).
    alpha : float
        Scale (Weibull, x units, > 0) or midpoint (logistic, x units).
    beta : float
        Slope parameter, > 0 (dimensionless for the Weibull, 1/x units for the logistic).
    lapse : float
        Lapse rate in [0, 1 - guess).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}

    Returns
    -------
    ndarray
        P(correct), same shape as ``x``.

    Examples
    --------
    >>> float(psychometric(1.0, 1.0, 2.0, 0.0))  # 1 - exp(-1)
    0.6321205588285577
    """
    check_sigmoid(sigmoid)
    check_guess(guess)
    x = np.asarray(x, dtype=float)
    return guess + (1.0 - guess - lapse) * sigmoid_cdf(x, alpha, beta, sigmoid)


def threshold_at(
    pc: float,
    alpha: Any,
    beta: Any,
    lapse: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
) -> np.ndarray:
    """Return the stimulus level where the curve crosses proportion correct ``pc``.

    This is not ``alpha``: with a lapse rate the 50 % point lies to the right of the Weibull's
    own 63 % point. Where the curve never reaches ``pc`` (``pc >= 1 - lapse``) the result is
    ``+inf``; where it starts above it (``pc <= guess``) it is 0 (Weibull) or ``-inf``.

    Parameters
    ----------
    pc : float
        Proportion correct in (0, 1).
    alpha, beta, lapse : float or ndarray
        Parameters (broadcast together).
    guess : float
        Guess rate.
    sigmoid : {'weibull', 'logistic'}

    Returns
    -------
    ndarray
        Threshold(s) in stimulus units.

    Examples
    --------
    >>> round(float(threshold_at(0.5, 1000.0, 2.0, 0.0)), 3)  # 1000 * ln(2) ** 0.5
    832.555
    """
    check_sigmoid(sigmoid)
    if not (0.0 < pc < 1.0):
        raise ValueError(f"pc must be in (0, 1), got {pc!r}")
    alpha, beta, lapse = np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(lapse, float)
    )
    f = (pc - guess) / (1.0 - guess - lapse)
    out = sigmoid_ppf(np.clip(f, 1e-15, 1 - 1e-15), alpha, beta, sigmoid)
    low = 0.0 if is_log_axis(sigmoid) else -np.inf
    out = np.where(f >= 1.0, np.inf, np.where(f <= 0.0, low, out))
    return out


def aggregate(x: Any, correct: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the distinct stimulus values, the number correct and the number of trials at each.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus value per trial (pixels for the paper's data).
    correct : array_like of shape (n_trials,)
        1 (correct/recognised) or 0 per trial.

    Returns
    -------
    pixels, k, n : ndarray of shape (n_levels,)
        The distinct values, increasing; number correct and number of trials at each.
    """
    x = np.asarray(x, dtype=float).ravel()
    c = np.asarray(correct, dtype=float).ravel()
    if x.shape != c.shape:
        raise ValueError(f"x and correct must have the same length, got {x.size} and {c.size}")
    if x.size == 0:
        raise ValueError("x must contain at least one trial, got 0")
    if not np.all(np.isfinite(x)):
        raise ValueError("x must be finite, got NaN or inf")
    if not np.all((c == 0) | (c == 1)):
        raise ValueError("correct must be 0 or 1 for every trial")
    pixels, inv = np.unique(x, return_inverse=True)
    n = np.bincount(inv).astype(float)
    k = np.bincount(inv, weights=c).astype(float)
    return pixels, k, n
