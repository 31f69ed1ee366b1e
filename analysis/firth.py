"""Firth's penalised logistic regression and profile-likelihood intervals of its coefficients.

Both work on a design matrix (0/1 outcomes, or proportions of binomial rows with ``weights``), so
:mod:`analysis.logistic`, :mod:`analysis.mixed` and the coverage benchmarks share them.
:func:`firth_logit` maximises Firth's penalised likelihood (finite under separation, first-order
bias of the ML estimate removed); :func:`profile_interval` inverts the (penalised) likelihood-ratio
test of one coefficient, as R's ``confint.glm`` and ``logistf`` do.

Both maximise by Newton's method with the exact Hessian of the penalised log-likelihood
(:func:`_ascent_step`), and first merge equal rows of the design into binomial rows, which
changes no sum: a study's design of conditions, levels and objects has a few hundred distinct
rows however many trials it holds.
"""

from __future__ import annotations

import math

import numpy as np

from analysis.blas import one_blas_thread

__all__ = ["firth_logit", "profile_interval", "binomial_rows"]


#: Most values held at once (a block of rows of the row-wise Kronecker product of the hat
#: matrix's orthonormal factor with itself) while the penalised Hessian's cross term is summed.
_BLOCK_VALUES: int = 4_000_000


def binomial_rows(
    y: np.ndarray, X: np.ndarray, n: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge the rows of ``X`` that are equal into binomial rows; return ``(y, X, n)``.

    A merged row's ``n`` is the sum of the merged trials and its ``y`` their share recognised:
    the likelihood, Firth's penalty and their derivatives are sums over trials, so they are
    unchanged, and a design of few distinct rows (factors and levels) costs as many rows.
    Rows already merged are returned as they are, so merging once before several profiles
    (:func:`profile_interval` with ``weights``) changes no number.

    Parameters
    ----------
    y : ndarray of shape (n,)
        Outcomes (0/1, or shares recognised of binomial rows).
    X : ndarray of shape (n, p)
        Design matrix.
    n : ndarray of shape (n,) or None
        Trials per row (None: one each).

    Returns
    -------
    y, X, n : ndarray
        Share recognised, distinct rows (sorted) and trials per row.
    """
    w = np.ones(len(y)) if n is None else n
    if _strictly_sorted(X):  # merged already (np.unique's order): nothing to merge
        return y, X, w
    rows, inv = np.unique(X, axis=0, return_inverse=True)
    if len(rows) == len(X):
        return y, X, w
    inv = inv.ravel()
    trials = np.bincount(inv, weights=w, minlength=len(rows))
    recognised = np.bincount(inv, weights=w * y, minlength=len(rows))
    return recognised / trials, rows, trials


def _strictly_sorted(X: np.ndarray) -> bool:
    """Whether each row of ``X`` is lexicographically greater than the one before it.

    Such rows are all distinct, so merging equal rows would return them as they are; checking
    costs a comparison of neighbours instead of ``np.unique``'s sort.
    """
    if len(X) < 2:
        return True
    before, after = X[:-1], X[1:]
    differ = before != after
    if not differ.any(axis=1).all():
        return False
    first = differ.argmax(axis=1)  # the first column where neighbours differ
    rows = np.arange(len(before))
    return bool(np.all(before[rows, first] < after[rows, first]))


def _log_likelihood(y: np.ndarray, X: np.ndarray, n: np.ndarray, b: np.ndarray) -> float:
    """Binomial log-likelihood of ``b`` (``y`` the share recognised of ``n`` trials per row)."""
    eta = X @ b
    return float(np.sum(n * (y * eta - np.logaddexp(0, eta))))


def _objective(
    y: np.ndarray, X: np.ndarray, n: np.ndarray, b: np.ndarray, penalized: bool
) -> float:
    """Log-likelihood of ``b``, plus Firth's penalty ``0.5 log det(X' W X)`` if ``penalized``."""
    from scipy import special

    ll = _log_likelihood(y, X, n, b)
    if not penalized:
        return ll
    eta = X @ b
    w = n * special.expit(eta) * special.expit(-eta)  # exact far out, where 1 - p rounds to 0
    sign, logdet = np.linalg.slogdet(X.T @ (w[:, None] * X))
    return ll + 0.5 * logdet if sign > 0 else -math.inf


def _ascent_step(
    y: np.ndarray, X: np.ndarray, n: np.ndarray, b: np.ndarray, free: np.ndarray, penalized: bool
) -> np.ndarray:
    """Return a Newton step of the objective over the coefficients in ``free`` (others 0).

    Without the penalty the Hessian is ``-X' W X``. With it, the gradient is Firth's modified
    score ``X' (n (y - p) + h (0.5 - p))`` and the Hessian adds the penalty's,
    ``0.5 [X' diag((1 - 6p + 6p^2) h) X - X' ((s s') o H o H) X]``, with ``H`` the hat matrix
    of ``W^1/2 X``, ``h`` its diagonal and ``s = 1 - 2p`` (from ``d log det I = tr(I^-1 dI)``;
    written with ``H``, whose entries lie in [-1, 1], it does not overflow far out on a profile).
    Where the Hessian is not negative definite (the penalised surface is not concave near a
    separated direction), its eigenvalues are taken in absolute value, which keeps the step an
    ascent direction. Near the maximum Newton's step converges in a few iterations where Fisher
    scoring's (``(X' W X)^-1`` times the modified score, Heinze & Schemper 2002) takes about a
    hundred.

    Raises
    ------
    numpy.linalg.LinAlgError
        ``W^1/2 X`` is (numerically) rank-deficient here, or the step is not finite.
    """
    from scipy import linalg, special

    eta = X @ b
    p = special.expit(eta)
    w = n * p * special.expit(-eta)  # p (1 - p), exact far out where 1 - p rounds to 0
    hess = X.T @ (w[:, None] * X)
    resid = n * (y - p)
    if penalized:
        u, r = np.linalg.qr(X * np.sqrt(w)[:, None])
        diag = np.abs(np.diag(r))
        if not diag.min() > 1e-300 * diag.max():
            raise np.linalg.LinAlgError("singular information matrix")
        h = np.sum(u * u, axis=1)
        resid = resid + h * (0.5 - p)
        # X' ((s s') o H o H) X without the n x n matrix H: with H = U U', (H_ik)^2 is
        # sum_cd U_ic U_id U_kc U_kd, so the term is A A' with A = (s X)' (U (x) U), the
        # row-wise Kronecker product of U with itself (n x p^2, built a block of rows at a time).
        s = 1 - 2 * p
        k = u.shape[1]
        xs = X * s[:, None]
        a = np.zeros((X.shape[1], k * k))
        block = max(1, _BLOCK_VALUES // (k * k))
        for i in range(0, len(X), block):
            ub = u[i : i + block]
            a += xs[i : i + block].T @ (ub[:, :, None] * ub[:, None, :]).reshape(len(ub), k * k)
        cross = a @ a.T
        hess = hess - 0.5 * (X.T @ (((1 - 6 * p + 6 * p * p) * h)[:, None] * X) - cross)
    grad = X.T @ resid
    step = np.zeros_like(b)
    sub = np.ix_(free, free)
    try:
        step[free] = linalg.cho_solve(linalg.cho_factor(hess[sub]), grad[free])
    except linalg.LinAlgError:  # the penalised surface is not concave here
        if not penalized:
            raise
        e, v = np.linalg.eigh(hess[sub])
        e = np.maximum(np.abs(e), 1e-12 * np.max(np.abs(e)))
        step[free] = v @ ((v.T @ grad[free]) / e)
    if not np.all(np.isfinite(step)):
        raise np.linalg.LinAlgError("the Newton step is not finite")
    return step


def _maximise(
    y: np.ndarray,
    X: np.ndarray,
    n: np.ndarray,
    b: np.ndarray,
    free: np.ndarray,
    penalized: bool,
    *,
    max_iter: int,
    tol: float,
) -> tuple[float, np.ndarray]:
    """Maximise the objective over the coefficients in ``free`` from ``b``; return it and ``b``.

    Newton steps (:func:`_ascent_step`), each halved from 1 until the objective does not fall
    (down to 1e-8 of a step); stops when a step moves no coefficient by more than ``tol`` or
    gains less than 1e-13.
    """
    cur = _objective(y, X, n, b, penalized)
    for _ in range(max_iter):
        step = _ascent_step(y, X, n, b, free, penalized)
        t = 1.0
        while True:
            new = _objective(y, X, n, b + t * step, penalized)
            if new >= cur - 1e-12 or t <= 1e-8:
                break
            t /= 2
        b = b + t * step
        gain, cur = new - cur, new
        if np.max(np.abs(t * step)) < tol or abs(gain) < 1e-13:
            break
    return cur, b


def firth_logit(
    y: np.ndarray,
    X: np.ndarray,
    *,
    max_iter: int = 200,
    tol: float = 1e-9,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Fit a logistic regression by Firth's penalised likelihood.

    Maximises ``l(b) + 0.5 log det(X' W X)`` by Newton steps with step halving (Fisher scoring
    on the modified score ``X' (y - p + h (0.5 - p))`` where the penalised Hessian is not
    negative definite); finite even under complete separation.

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

    y, X, n = binomial_rows(
        np.asarray(y, float),
        np.asarray(X, float),
        None if weights is None else np.asarray(weights, float),
    )
    free = np.ones(X.shape[1], bool)
    with one_blas_thread():
        _, b = _maximise(y, X, n, np.zeros(X.shape[1]), free, True, max_iter=max_iter, tol=tol)
        p = special.expit(X @ b)
        cov = np.linalg.inv(X.T @ ((n * p * (1 - p))[:, None] * X))
    return b, np.sqrt(np.diag(cov)), _log_likelihood(y, X, n, b)


def _intercept_column(X: np.ndarray, j: int) -> int | None:
    """Return the column of ``X`` (other than ``j``) that is all ones, or None."""
    for c in range(X.shape[1]):
        if c != j and np.all(X[:, c] == 1.0):
            return c
    return None


#: Newton iterations of one point of a profile. A well-posed point takes about five; near a
#: separated direction the penalised surface is not concave and the climb can take a few hundred
#: (a cap of 100 can stop a point with its deviance 1.5 above the profile's true one).
PROFILE_MAX_ITER: int = 1000

#: Chi-squared(1) 95 % quantile: a 95 % profile interval is where the deviance rises by this.
_CHI2_1_95: float = 3.841458820694124


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
    y, X, n = binomial_rows(y, X, n)
    free = np.arange(X.shape[1]) != j

    # Each point starts from the estimate with b_j moved. Far out on the profile that can push
    # every row's p to 0 or 1, where the information matrix is singular and Newton's method
    # cannot start; the point is then climbed from the same start with the intercept shifted so
    # that the linear predictor keeps its mean.
    icpt = _intercept_column(X, j)
    centre = float(np.average(X[:, j], weights=n))

    # Brent's method evaluates points ever closer to each other, so a point is first climbed
    # from the maximum found at the previous one (b_j moved): a few Newton steps instead of ten.
    last: list[np.ndarray] = []

    def climb(b: np.ndarray) -> float:
        value, b = _maximise(y, X, n, b, free, penalized, max_iter=PROFILE_MAX_ITER, tol=1e-10)
        last[:] = [b]
        return value

    def profile(bj: float) -> float:
        if last:
            b = last[0].copy()
            b[j] = bj
            try:
                return climb(b)
            except np.linalg.LinAlgError:
                pass
        b = params.copy()
        b[j] = bj
        try:
            return climb(b)
        except np.linalg.LinAlgError:
            if icpt is None:
                raise
        b[icpt] -= (bj - params[j]) * centre
        return climb(b)

    with one_blas_thread():
        l_max = profile(float(params[j]))
        se = float(bse[j]) if np.isfinite(bse[j]) and bse[j] > 0 else 1.0

        def excess(bj: float) -> float:
            return 2.0 * (l_max - profile(bj)) - _CHI2_1_95

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
