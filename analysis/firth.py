"""Firth's penalised logistic regression and profile-likelihood intervals of its coefficients.

Both work on a design matrix (0/1 outcomes, or proportions of binomial rows with ``weights``), so
:mod:`analysis.logistic`, :mod:`analysis.mixed` and the coverage benchmarks share them.
:func:`firth_logit` maximises Firth's penalised likelihood (finite under separation, first-order
bias of the ML estimate removed); :func:`profile_interval` inverts the (penalised) likelihood-ratio
test of one coefficient, as R's ``confint.glm`` and ``logistf`` do.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

__all__ = ["firth_logit", "profile_interval"]


def _halve_step(
    obj: Callable[[np.ndarray], float], b: np.ndarray, step: np.ndarray, cur: float, t_min: float
) -> tuple[float, float]:
    """Halve a Newton step from 1 until ``obj`` does not fall below ``cur`` or it is ``t_min``.

    Returns the step fraction ``t`` and ``obj`` at the last point tried.
    """
    t = 1.0
    while t > t_min:
        new = obj(b + t * step)
        if new >= cur - 1e-12:
            break
        t /= 2
    return t, new


def firth_logit(
    y: np.ndarray,
    X: np.ndarray,
    *,
    max_iter: int = 200,
    tol: float = 1e-9,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Fit a logistic regression by Firth's penalised likelihood.

    Maximises ``l(b) + 0.5 log det(X' W X)`` by Newton steps on the modified score
    ``X' (y - p + h (0.5 - p))`` with step halving; finite even under complete separation.

    Parameters
    ----------
    y : ndarray of shape (n,)
        0/1 outcomes.
    X : ndarray of shape (n, p)
        Design matrix (with the intercept column), full column rank.
    max_iter : int
        Newton iterations.
    tol : float
        Convergence tolerance on the largest coefficient change.
    weights : ndarray of shape (n,), optional
        Trials per row (binomial rows: ``y`` is then the proportion recognised); the fit equals
        the fit of the trials one by one.

    Returns
    -------
    params : ndarray of shape (p,)
    bse : ndarray of shape (p,)
        Standard errors from the inverse of ``X' W X`` at the estimate.
    log_likelihood : float
        Unpenalised log-likelihood at the estimate.

    Raises
    ------
    numpy.linalg.LinAlgError
        Rank-deficient design.

    References
    ----------
    Firth 1993, Biometrika 80:27; Heinze & Schemper 2002, Stat. Med. 21:2409.
    """
    from scipy import special

    y = np.asarray(y, float)
    X = np.asarray(X, float)
    n = np.ones(len(y)) if weights is None else np.asarray(weights, float)

    def pen_ll(b: np.ndarray) -> float:
        eta = X @ b
        p = special.expit(eta)
        w = n * p * (1 - p)
        sign, logdet = np.linalg.slogdet(X.T @ (w[:, None] * X))
        ll = float(np.sum(n * (y * eta - np.logaddexp(0, eta))))
        return ll + 0.5 * logdet if sign > 0 else -np.inf

    b = np.zeros(X.shape[1])
    cur = pen_ll(b)
    for _ in range(max_iter):
        p = special.expit(X @ b)
        w = n * p * (1 - p)
        info = X.T @ (w[:, None] * X)
        inv = np.linalg.inv(info)
        xw = X * np.sqrt(w)[:, None]
        h = np.einsum("ij,jk,ik->i", xw, inv, xw)
        step = inv @ (X.T @ (n * (y - p) + h * (0.5 - p)))
        t, _ = _halve_step(pen_ll, b, step, cur, 1e-6)
        b = b + t * step
        cur = pen_ll(b)
        if np.max(np.abs(t * step)) < tol:
            break
    p = special.expit(X @ b)
    w = n * p * (1 - p)
    cov = np.linalg.inv(X.T @ (w[:, None] * X))
    eta = X @ b
    return b, np.sqrt(np.diag(cov)), float(np.sum(n * (y * eta - np.logaddexp(0, eta))))


#: Chi-squared(1) 95 % quantile: a 95 % profile interval is where the deviance rises by this.
_CHI2_1_95: float = 3.841458820694124


def _constrained_ll(
    y: np.ndarray,
    X: np.ndarray,
    j: int,
    bj: float,
    start: np.ndarray,
    penalized: bool,
    n: np.ndarray | None = None,
) -> tuple[float, np.ndarray]:
    """Maximise the (Firth-penalised if ``penalized``) log-likelihood with ``b[j] = bj`` fixed.

    Newton steps on the other coefficients (for Firth's, on their modified score, the
    Heinze & Schemper 2002 profile), with step halving. Returns the maximum and the estimate.
    """
    from scipy import special

    free = np.arange(X.shape[1]) != j
    n = np.ones(len(y)) if n is None else n

    def obj(b: np.ndarray) -> float:
        eta = X @ b
        ll = float(np.sum(n * (y * eta - np.logaddexp(0, eta))))
        if penalized:
            w = n * special.expit(eta) * (1 - special.expit(eta))
            sign, logdet = np.linalg.slogdet(X.T @ (w[:, None] * X))
            ll = ll + 0.5 * logdet if sign > 0 else -math.inf
        return ll

    b = start.copy()
    b[j] = bj
    cur = obj(b)
    for _ in range(100):
        p = special.expit(X @ b)
        w = n * p * (1 - p)
        r = n * (y - p)
        if penalized:
            inv = np.linalg.inv(X.T @ (w[:, None] * X))
            xw = X * np.sqrt(w)[:, None]
            r = r + np.einsum("ij,jk,ik->i", xw, inv, xw) * (0.5 - p)
        Xf = X[:, free]
        step = np.zeros_like(b)
        step[free] = np.linalg.solve(Xf.T @ (w[:, None] * Xf), Xf.T @ r)
        t, new = _halve_step(obj, b, step, cur, 1e-8)
        b = b + t * step
        gain, cur = new - cur, new
        if np.max(np.abs(t * step)) < 1e-10 or abs(gain) < 1e-13:
            break
    return cur, b


def profile_interval(
    y: np.ndarray,
    X: np.ndarray,
    j: int,
    *,
    params: np.ndarray | None = None,
    bse: np.ndarray | None = None,
    penalized: bool = False,
    weights: np.ndarray | None = None,
) -> tuple[float, float]:
    """Return the 95 % profile-likelihood interval of coefficient ``j`` (log-odds units).

    The interval is every ``b_j`` whose profile deviance ``2 (l(b_hat) - max l(b | b_j))`` is at
    most the chi-squared(1) 95 % point 3.84; its ends are found by Brent's method on a bracket
    that widens until the deviance passes the cutoff. With ``penalized`` the (Firth-)penalised
    log-likelihood is profiled instead (Heinze & Schemper 2002), which is finite under
    separation. statsmodels has no profile interval for GLMs; R's ``confint.glm`` computes this one.

    Parameters
    ----------
    y : ndarray of shape (n,)
        0/1 outcomes.
    X : ndarray of shape (n, p)
        Design matrix with the intercept column, full column rank.
    j : int
        Column of the coefficient, in [0, p).
    params, bse : ndarray of shape (p,), optional
        The (penalised) estimate and its standard errors, when already known.
    penalized : bool
        Profile Firth's penalised log-likelihood.
    weights : ndarray of shape (n,), optional
        Trials per row (binomial rows: ``y`` is then the proportion recognised), as
        :func:`firth_logit`.

    Returns
    -------
    (float, float)
        Lower and upper end, log-odds units; ``-inf`` / ``inf`` when the profile deviance stays
        below the cutoff that far (a separated direction).

    Raises
    ------
    ValueError
        ``j`` outside the columns of ``X``.

    References
    ----------
    Venzon & Moolgavkar 1988, Appl. Stat. 37:87; Heinze & Schemper 2002, Stat. Med. 21:2409.
    """
    from scipy import optimize

    y = np.asarray(y, float)
    X = np.asarray(X, float)
    if not (0 <= j < X.shape[1]):
        raise ValueError(f"j must be a column of X in [0, {X.shape[1]}), got {j!r}")
    n = None if weights is None else np.asarray(weights, float)
    if params is None or bse is None:
        if penalized:
            params, bse, _ = firth_logit(y, X, weights=n)
        elif n is not None:
            import statsmodels.api as sm

            res = sm.GLM(y, X, family=sm.families.Binomial(), var_weights=n).fit(
                tol=1e-12, maxiter=200
            )
            params, bse = np.asarray(res.params), np.asarray(res.bse)
        else:
            import statsmodels.api as sm

            res = sm.Logit(y, X).fit(method="newton", tol=1e-12, maxiter=200, disp=False)
            params, bse = np.asarray(res.params), np.asarray(res.bse)
    params = np.asarray(params, float)
    l_max, _ = _constrained_ll(y, X, j, float(params[j]), params, penalized, n)
    se = float(bse[j]) if np.isfinite(bse[j]) and bse[j] > 0 else 1.0

    def excess(bj: float) -> float:
        return 2.0 * (l_max - _constrained_ll(y, X, j, bj, params, penalized, n)[0]) - _CHI2_1_95

    ends = []
    for sign in (-1.0, 1.0):
        inner, width = float(params[j]), 2.0 * se
        outer = inner + sign * width
        while excess(outer) < 0:
            inner, width = outer, 2.0 * width
            outer = inner + sign * width
            if abs(outer - params[j]) > 100.0 * max(se, 1.0) or abs(outer) > 50.0:
                outer = math.nan
                break
        if math.isnan(outer):
            ends.append(sign * math.inf)
            continue
        ends.append(optimize.brentq(excess, inner, outer, xtol=1e-8))
    return float(ends[0]), float(ends[1])
