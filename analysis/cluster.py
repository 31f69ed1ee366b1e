"""Population intervals for pooled thresholds: two-way cluster-robust (subjects and objects).

A pooled psychometric fit describes the subjects and objects that were tested. When the question
is about the population they were drawn from, the threshold's uncertainty must include how much
it would change with other subjects and objects. This module gives that interval for the ML
threshold: the sandwich covariance of the binomial ML parameters with scores summed within
clusters, two-way (subjects and objects; Cameron, Gelbach & Miller 2011,
J. Bus. Econ. Stat. 29:238), each one-way term scaled by G / (G - 1), the threshold's variance by
the delta method on log10 (log-axis sigmoids) or x, and a t quantile with min(G) - 1 degrees of
freedom because there are few clusters (ours, the usual small-G correction).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import stats

from analysis.weibull import MLEstimate, is_log_axis, threshold_at
from analysis.weibull.kernel import p_matrix, theta_of_mle

__all__ = ["cluster_threshold_ci"]


def _loglik_pixels(theta: np.ndarray, pixels: np.ndarray, guess: float, sigmoid: str):
    p = p_matrix(theta[None, :], pixels, guess, sigmoid)[0]
    return np.log(p), np.log1p(-p)


def cluster_threshold_ci(
    x: Any,
    correct: Any,
    clusters: Sequence[Any],
    mle: MLEstimate,
    *,
    pc: float = 0.5,
    guess: float = 0.0,
    sigmoid: str = "weibull",
) -> tuple[float, float, float] | None:
    """Return a 95 % population interval of the ML threshold, cluster-robust over ``clusters``.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial.
    correct : array_like of shape (n_trials,)
        1 / 0 per trial.
    clusters : sequence of array_like of shape (n_trials,)
        One or two labelings of the trials (e.g. subject, object); labels with one value are
        ignored.
    mle : MLEstimate
        The binomial ML fit of these trials.
    pc : float
        Proportion correct of the threshold.
    guess : float
        Guess rate.
    sigmoid : str
        One of :data:`analysis.weibull.SIGMOIDS`.

    Returns
    -------
    (low, high, se) or None
        The interval in x units and the standard error on the axis (log10 x or x); None when
        it cannot be computed (fewer than two clusters, the threshold outside the curve, a
        singular information matrix).
    """
    x = np.asarray(x, float)
    y = np.asarray(correct, float)
    pixels, lev = np.unique(x, return_inverse=True)
    theta0 = theta_of_mle(mle, sigmoid)
    # A lapse rate on its bound 0 is not a free parameter locally: hold it there.
    free = [0, 1] if mle.lapse <= 1e-6 else [0, 1, 2]
    k = len(free)
    steps = np.array([1e-5, 1e-5, 1e-6])[free]

    def full(v: np.ndarray) -> np.ndarray:
        t = theta0.copy()
        t[free] = v
        return t

    v0 = theta0[free]
    # Per-level scores of a correct and of an incorrect trial (central differences).
    s1 = np.empty((len(pixels), k))
    s0 = np.empty((len(pixels), k))
    for j in range(k):
        e = np.zeros(k)
        e[j] = steps[j]
        a1, a0 = _loglik_pixels(full(v0 + e), pixels, guess, sigmoid)
        b1, b0 = _loglik_pixels(full(v0 - e), pixels, guess, sigmoid)
        s1[:, j] = (a1 - b1) / (2 * steps[j])
        s0[:, j] = (a0 - b0) / (2 * steps[j])
    scores = np.where(y[:, None] == 1, s1[lev], s0[lev])

    def total(v: np.ndarray) -> float:
        l1, l0 = _loglik_pixels(full(v), pixels, guess, sigmoid)
        return float(np.sum(np.where(y == 1, l1[lev], l0[lev])))

    hess = np.empty((k, k))
    h = 1e-4
    for i in range(k):
        for j in range(i, k):
            ei, ej = np.eye(k)[i] * h, np.eye(k)[j] * h
            hess[i, j] = hess[j, i] = (
                total(v0 + ei + ej)
                - total(v0 + ei - ej)
                - total(v0 - ei + ej)
                + total(v0 - ei - ej)
            ) / (4 * h * h)
    try:
        bread = np.linalg.inv(-hess)
    except np.linalg.LinAlgError:
        return None
    labels = [np.unique(np.asarray(c).astype(str), return_inverse=True) for c in clusters]
    labels = [(u, inv) for u, inv in labels if len(u) > 1]
    if not labels:
        return None

    def meat(codes: np.ndarray, g: int) -> np.ndarray:
        sums = np.stack([np.bincount(codes, scores[:, j], minlength=g) for j in range(k)], 1)
        return sums.T @ sums * g / (g - 1)

    m = sum(meat(inv, len(u)) for u, inv in labels)
    if len(labels) == 2:
        (u1, c1), (u2, c2) = labels
        both = c1 * len(u2) + c2
        g12 = len(np.unique(both))
        if g12 > 1:
            m = m - meat(np.unique(both, return_inverse=True)[1], g12)
    cov = bread @ m @ bread
    if not np.all(np.isfinite(cov)):
        return None
    w, vec = np.linalg.eigh((cov + cov.T) / 2)
    cov = (vec * np.clip(w, 0, None)) @ vec.T  # two-way subtraction can leave tiny negatives

    log = is_log_axis(sigmoid)

    def thr(v: np.ndarray) -> float:
        t = full(v)
        alpha = 10 ** t[0] if log else t[0]
        val = float(threshold_at(pc, alpha, math.exp(t[1]), t[2], guess=guess, sigmoid=sigmoid))
        return math.log10(val) if log and val > 0 else val

    t0 = thr(v0)
    if not math.isfinite(t0):
        return None
    grad = np.empty(k)
    for j in range(k):
        e = np.zeros(k)
        e[j] = steps[j] * 10
        grad[j] = (thr(v0 + e) - thr(v0 - e)) / (2 * e[j])
    se = float(math.sqrt(max(grad @ cov @ grad, 0.0)))
    if not math.isfinite(se):
        return None
    df = min(len(u) for u, _ in labels) - 1
    q = float(stats.t.ppf(0.975, df))
    lo, hi = t0 - q * se, t0 + q * se
    return (10**lo, 10**hi, se) if log else (lo, hi, se)
