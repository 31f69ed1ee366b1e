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

The likelihood is binomial over the distinct stimulus levels, or, with ``overdispersion=True``,
beta-binomial: each level's P is itself drawn from a Beta distribution with mean P and
``Var = eta ** 2 * P * (1 - P)``, so the level's count has variance
``n P (1 - P) (1 + (n - 1) eta ** 2)`` (Schuett, Harmeling, Macke & Wichmann 2016, psignifit 4).
The scale ``eta`` in [0, 1) is a fourth free parameter with a Beta(1, 10) prior (psignifit 4's
default, as we read it; ours to adopt). Pooling subjects and objects whose thresholds differ makes
binomial-only intervals too narrow; eta absorbs that extra variance. Maximum-likelihood estimates
are always binomial (as Psychtoolbox's fit in the paper).

This module also aggregates trials into counts per level and warns (:class:`FitWarning`) about
data that are legal but suspicious for a fit.
"""

from __future__ import annotations

import warnings
from typing import Any, Literal

import numpy as np
from scipy import special

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

Sigmoid = Literal["weibull", "loglogistic", "lognormal", "gumbel", "logistic", "normal"]

#: Shape and axis of each sigmoid (see the module docstring).
SIGMOIDS: dict[str, tuple[str, str]] = {
    "weibull": ("gumbel", "log"),
    "loglogistic": ("logistic", "log"),
    "lognormal": ("normal", "log"),
    "gumbel": ("gumbel", "linear"),
    "logistic": ("logistic", "linear"),
    "normal": ("normal", "linear"),
}
#: Upper bound of the overdispersion scale eta (ours: eta -> 1 makes every level all-or-none).
ETA_MAX: float = 0.99
#: Concentration 1/eta^2 - 1 is capped here: beyond it the beta-binomial equals the binomial to
#: < 1e-4 in log-likelihood for levels of up to ~1,000 trials (n^2 / (2 v)), and gammaln stays
#: exact to ~1e-7.
_V_MAX: float = 1e9


_EPS = 1e-12


class FitWarning(UserWarning):
    """Legal but suspicious data for a psychometric fit (all correct, too few trials, ...)."""


def _check_sigmoid(sigmoid: str) -> None:
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"sigmoid must be one of {', '.join(SIGMOIDS)}, got {sigmoid!r}")


def is_log_axis(sigmoid: str) -> bool:
    """Return True when ``sigmoid`` works on log stimulus values (levels must be > 0)."""
    _check_sigmoid(sigmoid)
    return SIGMOIDS[sigmoid][1] == "log"


def _shape_cdf(z: np.ndarray, shape: str) -> np.ndarray:
    if shape == "gumbel":
        with np.errstate(over="ignore"):
            return -np.expm1(-np.exp(z))
    if shape == "logistic":
        return special.expit(z)
    return special.ndtr(z)


def _shape_ppf(f: np.ndarray, shape: str) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        if shape == "gumbel":
            return np.log(-np.log1p(-f))
        if shape == "logistic":
            return special.logit(f)
        return special.ndtri(f)


def _check_guess(guess: float) -> None:
    if not (0.0 <= guess < 1.0):
        raise ValueError(f"guess must be in [0, 1), got {guess!r}")


def _core(x: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            z = beta * (np.log(np.maximum(x, 1e-300)) - np.log(alpha))
    else:
        z = beta * (x - alpha)
    return _shape_cdf(z, shape)


def _core_inverse(f: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    shape, axis = SIGMOIDS[sigmoid]
    z = _shape_ppf(f, shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if axis == "log":
            return alpha * np.exp(z / beta)
        return alpha + z / beta


def psychometric(
    x: Any,
    alpha: float,
    beta: float,
    lapse: float,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
) -> np.ndarray:
    """Return the probability correct at stimulus levels ``x``.

    Parameters
    ----------
    x : array_like
        Stimulus levels (pixels for the Weibull: > 0; any unit for the logistic).
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
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    x = np.asarray(x, dtype=float)
    return guess + (1.0 - guess - lapse) * _core(x, alpha, beta, sigmoid)


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
    _check_sigmoid(sigmoid)
    if not (0.0 < pc < 1.0):
        raise ValueError(f"pc must be in (0, 1), got {pc!r}")
    alpha, beta, lapse = np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(lapse, float)
    )
    f = (pc - guess) / (1.0 - guess - lapse)
    out = _core_inverse(np.clip(f, 1e-15, 1 - 1e-15), alpha, beta, sigmoid)
    low = 0.0 if is_log_axis(sigmoid) else -np.inf
    out = np.where(f >= 1.0, np.inf, np.where(f <= 0.0, low, out))
    return out


def aggregate(x: Any, correct: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the distinct levels, the number correct and the number of trials at each.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial.
    correct : array_like of shape (n_trials,)
        1 (correct/recognised) or 0 per trial.

    Returns
    -------
    levels, k, n : ndarray of shape (n_levels,)
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
    levels, inv = np.unique(x, return_inverse=True)
    n = np.bincount(inv).astype(float)
    k = np.bincount(inv, weights=c).astype(float)
    return levels, k, n


def _axis(x: np.ndarray, sigmoid: str) -> np.ndarray:
    return np.log10(x) if is_log_axis(sigmoid) else x


def _params(theta: np.ndarray, sigmoid: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    loc, lb, lapse = theta[..., 0], theta[..., 1], theta[..., 2]
    alpha = 10.0**loc if is_log_axis(sigmoid) else loc
    return alpha, np.exp(lb), lapse


def _p_matrix(theta: np.ndarray, x: np.ndarray, guess: float, sigmoid: str) -> np.ndarray:
    """P(correct) of shape (n_theta, n_levels)."""
    alpha, beta, lapse = _params(theta, sigmoid)
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        z = beta[:, None] * (np.log(x)[None, :] - np.log(alpha)[:, None])
    else:
        z = beta[:, None] * (x[None, :] - alpha[:, None])
    p = guess + (1.0 - guess - lapse[:, None]) * _shape_cdf(z, shape)
    return np.clip(p, _EPS, 1.0 - _EPS)


def _log_likelihood(
    theta: np.ndarray, x: np.ndarray, k: np.ndarray, n: np.ndarray, guess: float, sigmoid: str
) -> np.ndarray:
    """Log-likelihood (without the binomial coefficients) for theta of shape (..., 3 or 4).

    Three columns: binomial. Four: beta-binomial with overdispersion scale ``theta[..., 3]``.
    """
    theta = np.atleast_2d(theta)
    p = _p_matrix(theta, x, guess, sigmoid)
    if theta.shape[-1] < 4:
        return _binomial_ll(k, n, p).sum(axis=1)
    eta = np.clip(theta[:, 3], 0.0, ETA_MAX)
    return _beta_binomial_ll(k, n, p, eta[:, None]).sum(axis=1)


def _binomial_ll(k: np.ndarray, n: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Binomial log-likelihood of k correct of n at P(correct) p, per level (no coefficient)."""
    return k * np.log(p) + (n - k) * np.log1p(-p)


def _beta_binomial_ll(k: np.ndarray, n: np.ndarray, p: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Beta-binomial log-likelihood per level: mean p, overdispersion scale eta (broadcast)."""
    with np.errstate(divide="ignore"):
        v = np.minimum(1.0 / np.maximum(eta, 1e-300) ** 2 - 1.0, _V_MAX)
    a, b = p * v, (1.0 - p) * v
    g = special.gammaln
    # log B(k + a, n - k + b) - log B(a, b), minus the binomial coefficient (a constant).
    return g(k + a) - g(a) + g(n - k + b) - g(b) - g(n + v) + g(v)


def _data_warnings(label: str, k: np.ndarray, n: np.ndarray) -> None:
    total, correct = n.sum(), k.sum()
    if correct == 0 or correct == total:
        what = "none" if correct == 0 else "all"
        side = "above the highest" if correct == 0 else "below the lowest"
        warnings.warn(
            f"{label or 'fit'}: {what} of {int(total)} trials correct; the threshold is not "
            f"located by the data (censored: {side} level tested) and its interval reflects "
            "the prior",
            FitWarning,
            stacklevel=3,
        )
    elif np.mean(n < 5) > 0.5:
        warnings.warn(
            f"{label or 'fit'}: fewer than 5 trials at most levels ({int(total)} trials over "
            f"{len(n)} levels); the fit leans on the prior",
            FitWarning,
            stacklevel=3,
        )
