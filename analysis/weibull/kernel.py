"""Internal: the numerical pieces the psychometric modules share (not re-exported).

This module is the one place where the modules of :mod:`analysis.weibull` share code that is not
their public API. It sits below all of them (it imports none) and holds:

* the sigmoid table (:data:`SIGMOIDS`), the bound of the overdispersion scale (:data:`ETA_MAX`),
  the numerical floors (:data:`EPS`, :data:`V_MAX`) and :class:`FitWarning` (all re-exported by
  :mod:`analysis.weibull.model`, where the model is described);
* the curve's parts: the three shapes and their inverses, the sigmoid on its axis, the
  parameter vector ``theta = (loc, log beta, lapse[, eta])`` and its P(correct) matrix;
* the binomial and beta-binomial log-likelihoods and the log Beta density of the priors;
* the data checks behind the thresholds' status (separation, decreasing data) and the
  warnings about legal but suspicious data;
* :func:`json_float` (JSON has no inf or NaN).

Other packages use the public names of :mod:`analysis.weibull`; the analysis modules that work
on the likelihood itself (the cluster-robust interval, the power simulation) may use these.
Names here may change with the package's internals, without notice.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Literal

import numpy as np
from scipy import special

__all__ = [
    "Sigmoid",
    "SIGMOIDS",
    "ETA_MAX",
    "V_MAX",
    "EPS",
    "FitWarning",
    "check_sigmoid",
    "check_guess",
    "is_log_axis",
    "shape_cdf",
    "shape_ppf",
    "sigmoid_cdf",
    "sigmoid_ppf",
    "to_axis",
    "axis_value",
    "theta_params",
    "theta_of_mle",
    "p_matrix",
    "log_likelihood",
    "binomial_ll",
    "beta_binomial_ll",
    "log_beta_density",
    "data_warnings",
    "separated",
    "decreasing",
    "json_float",
]

Sigmoid = Literal["weibull", "loglogistic", "lognormal", "gumbel", "logistic", "normal"]

#: Shape and axis of each sigmoid (see :mod:`analysis.weibull.model`).
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
V_MAX: float = 1e9
#: P(correct) is kept in [EPS, 1 - EPS] so that its logarithms stay finite.
EPS: float = 1e-12


class FitWarning(UserWarning):
    """Legal but suspicious data for a psychometric fit (all correct, too few trials, ...)."""


def check_sigmoid(sigmoid: str) -> None:
    """Raise ValueError unless ``sigmoid`` is a key of :data:`SIGMOIDS`."""
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"sigmoid must be one of {', '.join(SIGMOIDS)}, got {sigmoid!r}")


def is_log_axis(sigmoid: str) -> bool:
    """Return True when ``sigmoid`` works on log stimulus values (pixels must be > 0)."""
    check_sigmoid(sigmoid)
    return SIGMOIDS[sigmoid][1] == "log"


def shape_cdf(z: np.ndarray, shape: str) -> np.ndarray:
    """Return F(z) of a shape: ``'gumbel'``, ``'logistic'`` or ``'normal'``."""
    if shape == "gumbel":
        with np.errstate(over="ignore"):
            return -np.expm1(-np.exp(z))
    if shape == "logistic":
        return special.expit(z)
    return special.ndtr(z)


def shape_ppf(f: np.ndarray, shape: str) -> np.ndarray:
    """Return the inverse of :func:`shape_cdf`."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if shape == "gumbel":
            return np.log(-np.log1p(-f))
        if shape == "logistic":
            return special.logit(f)
        return special.ndtri(f)


def check_guess(guess: float) -> None:
    """Raise ValueError unless the guess rate is in [0, 1)."""
    if not (0.0 <= guess < 1.0):
        raise ValueError(f"guess must be in [0, 1), got {guess!r}")


def sigmoid_cdf(x: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    """Return ``F(beta * (s(x) - s(alpha)))``: the curve without guess and lapse rates."""
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            z = beta * (np.log(np.maximum(x, 1e-300)) - np.log(alpha))
    else:
        z = beta * (x - alpha)
    return shape_cdf(z, shape)


def sigmoid_ppf(f: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    """Return the stimulus value where :func:`sigmoid_cdf` equals ``f``."""
    shape, axis = SIGMOIDS[sigmoid]
    z = shape_ppf(f, shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if axis == "log":
            return alpha * np.exp(z / beta)
        return alpha + z / beta


def to_axis(x: np.ndarray, sigmoid: str) -> np.ndarray:
    """Return stimulus values on the sigmoid's axis of ``theta``'s loc: log10 or as they are."""
    return np.log10(x) if is_log_axis(sigmoid) else x


def axis_value(v: float, sigmoid: str) -> float:
    """Return one stimulus value on the loc axis (:func:`to_axis`); -inf for 0 on a log axis."""
    if is_log_axis(sigmoid):
        return math.log10(v) if v > 0 else -math.inf
    return v


def theta_params(theta: np.ndarray, sigmoid: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(alpha, beta, lapse)`` of parameter vectors ``(loc, log beta, lapse, ...)``."""
    loc, lb, lapse = theta[..., 0], theta[..., 1], theta[..., 2]
    alpha = 10.0**loc if is_log_axis(sigmoid) else loc
    return alpha, np.exp(lb), lapse


def theta_of_mle(mle: Any, sigmoid: str) -> np.ndarray:
    """Return the parameter vector ``(loc, log beta, lapse)`` of an ML estimate."""
    loc = math.log10(mle.alpha) if is_log_axis(sigmoid) else mle.alpha
    return np.array([loc, math.log(mle.beta), mle.lapse])


def p_matrix(theta: np.ndarray, x: np.ndarray, guess: float, sigmoid: str) -> np.ndarray:
    """P(correct) of shape (n_theta, n_pixels), kept in [EPS, 1 - EPS]."""
    alpha, beta, lapse = theta_params(theta, sigmoid)
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        z = beta[:, None] * (np.log(x)[None, :] - np.log(alpha)[:, None])
    else:
        z = beta[:, None] * (x[None, :] - alpha[:, None])
    p = guess + (1.0 - guess - lapse[:, None]) * shape_cdf(z, shape)
    return np.clip(p, EPS, 1.0 - EPS)


def log_likelihood(
    theta: np.ndarray, x: np.ndarray, k: np.ndarray, n: np.ndarray, guess: float, sigmoid: str
) -> np.ndarray:
    """Log-likelihood (without the binomial coefficients) for theta of shape (..., 3 or 4).

    Three columns: binomial. Four: beta-binomial with overdispersion scale ``theta[..., 3]``.
    """
    theta = np.atleast_2d(theta)
    p = p_matrix(theta, x, guess, sigmoid)
    if theta.shape[-1] < 4:
        return binomial_ll(k, n, p).sum(axis=1)
    eta = np.clip(theta[:, 3], 0.0, ETA_MAX)
    return beta_binomial_ll(k, n, p, eta[:, None]).sum(axis=1)


def binomial_ll(k: np.ndarray, n: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Binomial log-likelihood of k correct of n at P(correct) p, per level (no coefficient)."""
    return k * np.log(p) + (n - k) * np.log1p(-p)


def beta_binomial_ll(k: np.ndarray, n: np.ndarray, p: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Beta-binomial log-likelihood per level: mean p, overdispersion scale eta (broadcast)."""
    with np.errstate(divide="ignore"):
        v = np.minimum(1.0 / np.maximum(eta, 1e-300) ** 2 - 1.0, V_MAX)
    a, b = p * v, (1.0 - p) * v
    g = special.gammaln
    # log B(k + a, n - k + b) - log B(a, b), minus the binomial coefficient (a constant).
    return g(k + a) - g(a) + g(n - k + b) - g(b) - g(n + v) + g(v)


def log_beta_density(v: np.ndarray, a: Any, b: Any) -> np.ndarray:
    """Unnormalised log Beta(a, b) density, a and b broadcast with v (the box is the caller's)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lp = (a - 1.0) * np.log(np.where(v > 0, v, 1.0)) + (b - 1.0) * np.log1p(
            -np.clip(v, 0.0, 0.999999)
        )
        if np.any(np.asarray(a) < 1.0):
            lp = np.where((v > 0) | (np.asarray(a) >= 1.0), lp, np.inf)
    return lp


def data_warnings(label: str, k: np.ndarray, n: np.ndarray) -> None:
    """Warn (:class:`FitWarning`) when all or no trials are correct or most levels are thin."""
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


def separated(k: np.ndarray, n: np.ndarray) -> tuple[int, int] | None:
    """Return ``(i, j)`` when the data are a step: none correct at levels <= i, all from j.

    At most one level between the two (``j - i <= 2``) may be mixed (quasi-complete separation,
    as in logistic regression): no finite slope fits such data better than a vertical step.
    None when the data are not separated.
    """
    none = k == 0
    every = k == n
    m = len(k)
    for i in range(m - 1):
        if not none[: i + 1].all():
            break
        for j in (i + 1, i + 2):
            if j < m and every[j:].all() and (j == i + 1 or 0 < k[i + 1] < n[i + 1]):
                return i, j
    return None


def decreasing(pixels: np.ndarray, k: np.ndarray, n: np.ndarray, sigmoid: str) -> bool:
    """Logistic regression of correct on the axis: slope < 0 with z < -1.96 (lightly ridged)."""
    if len(pixels) < 2 or k.sum() in (0, n.sum()):
        return False
    u = to_axis(np.asarray(pixels, float), sigmoid)
    u = (u - u.mean()) / (u.std() or 1.0)
    X = np.column_stack([np.ones_like(u), u])
    b = np.zeros(2)
    ridge = np.diag([0.0, 1e-3])
    for _ in range(50):
        p = special.expit(X @ b)
        w = n * p * (1 - p)
        H = X.T @ (w[:, None] * X) + ridge
        g = X.T @ (k - n * p) - ridge @ b
        step = np.linalg.solve(H, g)
        b = b + step
        if np.max(np.abs(step)) < 1e-10:
            break
    p = special.expit(X @ b)
    H = X.T @ ((n * p * (1 - p))[:, None] * X) + ridge
    se = math.sqrt(max(np.linalg.inv(H)[1, 1], 1e-300))
    return bool(b[1] / se < -1.96)


def json_float(v: float) -> float | None:
    """JSON has no inf/NaN: those become None (null)."""
    v = float(v)
    return v if math.isfinite(v) else None
