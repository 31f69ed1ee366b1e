"""Mixed logistic model: random subject and object intercepts (``confocal analyze --mixed``).

A Laplace-approximate generalised linear mixed model of recognition with the same fixed effects
as :func:`analysis.logistic.fit_logistic` (the paper's binary logistic regression), and random
intercepts for subjects and objects, so odds ratios are conditional on a subject and an object.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from analysis.errors import DataError
from analysis.logistic import (
    SEPARATION_LOG_OR,
    OddsRatioTable,
    check_model_data,
    design_frame,
    firth_logit,
)

__all__ = ["MixedFit", "fit_mixed", "laplace_glmm", "random_groups", "check_mixed_terms"]


@dataclass(frozen=True)
class MixedFit:
    """Fixed effects of the mixed logistic model (random subject and object intercepts).

    Parameters
    ----------
    odds_ratios : OddsRatioTable
        Fixed-effect odds ratios (``background``, ``log10_pixels``); intervals are 95 % posterior
        intervals of the variational approximation, ``p`` the two-sided normal tail probability.
    subject_sd, object_sd : float
        Standard deviations of the random intercepts, log-odds units.
    method : str
        How it was fitted.
    intervals : bool
        Whether the intervals and p-values are trustworthy enough to print (only point estimates
        are reported otherwise).
    note : str
        Why intervals are not given, when they are not.
    """

    odds_ratios: OddsRatioTable
    subject_sd: float
    object_sd: float
    method: str = "Laplace"
    intervals: bool = False
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {
            "odds_ratios": self.odds_ratios.to_dict(),
            "subject_sd": self.subject_sd,
            "object_sd": self.object_sd,
            "method": self.method,
            "intervals": self.intervals,
            "note": self.note,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MixedFit:
        """Rebuild from :meth:`to_dict` output."""
        return cls(
            OddsRatioTable.from_dict(d["odds_ratios"]),
            float(d["subject_sd"]),
            float(d["object_sd"]),
            str(d.get("method", "Laplace")),
            bool(d.get("intervals", False)),
            str(d.get("note", "")),
        )


def laplace_glmm(
    y: np.ndarray, X: np.ndarray, groups: Sequence[np.ndarray], *, cov: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Fit a logistic GLMM with crossed random intercepts by the Laplace approximation.

    ``logit P = X b + sum_g u_g[group_g]``, ``u_g ~ N(0, sd_g^2)``. The marginal likelihood is
    approximated by Laplace's method around the conditional mode of the random effects (as lme4's
    ``glmer`` with ``nAGQ = 1``) and maximised over ``(b, log sd)``; standard errors come from the
    numerical Hessian of that approximate log-likelihood.

    Parameters
    ----------
    y : ndarray of shape (n,)
        0/1 outcomes.
    X : ndarray of shape (n, p)
        Fixed-effect design (with the intercept column).
    groups : sequence of ndarray of shape (n,)
        Integer codes 0..m_g-1 of each grouping factor (e.g. subject, object).
    cov : bool
        Return the fixed effects' covariance matrix in place of their standard errors (for
        Wald tests of contrasts between fixed effects).

    Returns
    -------
    beta : ndarray of shape (p,)
    se : ndarray of shape (p,), or of shape (p, p) with ``cov``
        Standard errors of ``beta`` (the square roots of the covariance's diagonal), or the
        covariance itself.
    sd : ndarray of shape (len(groups),)
        Random-intercept standard deviations, log-odds units.
    log_likelihood : float
        Laplace-approximate marginal log-likelihood at the maximum.

    References
    ----------
    Bates, Maechler, Bolker & Walker 2015 (lme4), Sec. 5; Breslow & Clayton 1993.
    """
    from scipy import optimize, special

    y = np.asarray(y, float)
    X = np.asarray(X, float)
    n, p = X.shape
    codes = [np.asarray(g, int) for g in groups]
    sizes = [int(g.max()) + 1 for g in codes]
    offs = np.concatenate([[0], np.cumsum(sizes)])
    q = int(offs[-1])
    col_group = np.concatenate([np.full(m, i) for i, m in enumerate(sizes)]).astype(int)
    cache = {"u": np.zeros(q)}

    def zu(u: np.ndarray) -> np.ndarray:
        return sum(u[offs[i] + c] for i, c in enumerate(codes))

    def zt(v: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [np.bincount(c, v, minlength=m) for c, m in zip(codes, sizes, strict=True)]
        )

    def ztwz(w: np.ndarray) -> np.ndarray:
        # Indicator columns: diagonal blocks are per-level sums of w, off-diagonal blocks the
        # sums over each pair of levels (no dense n x q matrix).
        H = np.zeros((q, q))
        for i, (ci, mi) in enumerate(zip(codes, sizes, strict=True)):
            sl_i = slice(offs[i], offs[i + 1])
            H[sl_i, sl_i] = np.diag(np.bincount(ci, w, minlength=mi))
            for j in range(i + 1, len(codes)):
                cj, mj = codes[j], sizes[j]
                blk = np.bincount(ci * mj + cj, w, minlength=mi * mj).reshape(mi, mj)
                H[sl_i, offs[j] : offs[j + 1]] = blk
                H[offs[j] : offs[j + 1], sl_i] = blk.T
        return H

    def neg_loglik(theta: np.ndarray) -> float:
        beta, log_sd = theta[:p], theta[p:]
        d = np.exp(2 * log_sd)[col_group]
        fixed = X @ beta
        u = cache["u"].copy()
        for _ in range(50):
            eta = fixed + zu(u)
            mu = special.expit(eta)
            grad = zt(y - mu) - u / d
            H = ztwz(mu * (1 - mu)) + np.diag(1 / d)
            step = np.linalg.solve(H, grad)
            u = u + step
            if np.max(np.abs(step)) < 1e-10:
                break
        cache["u"] = u
        eta = fixed + zu(u)
        mu = special.expit(eta)
        H = ztwz(mu * (1 - mu)) + np.diag(1 / d)
        ll = float(np.sum(y * eta - np.logaddexp(0, eta)))
        ll -= 0.5 * float(np.sum(u**2 / d)) + 0.5 * float(np.sum(np.log(d)))
        ll -= 0.5 * np.linalg.slogdet(H)[1]
        return -ll

    beta0 = firth_logit(y, X)[0]
    theta0 = np.concatenate([beta0, np.full(len(groups), math.log(0.5))])
    bounds = [(None, None)] * p + [(math.log(1e-3), math.log(20.0))] * len(groups)
    r = optimize.minimize(
        neg_loglik, theta0, method="L-BFGS-B", bounds=bounds, options={"ftol": 1e-13, "gtol": 1e-7}
    )
    theta = r.x
    hess = _num_hessian(neg_loglik, theta)
    try:
        vcov = np.linalg.inv(hess)
        if np.any(np.diag(vcov)[:p] <= 0):
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        # A variance on its boundary: condition on the SDs (fixed-effect block only).
        vcov = np.linalg.inv(hess[:p, :p])
    second = vcov[:p, :p] if cov else np.sqrt(np.diag(vcov)[:p])
    return theta[:p], second, np.exp(theta[p:]), float(-r.fun)


def _num_hessian(f, x: np.ndarray, h: float = 1e-4) -> np.ndarray:
    """Central-difference Hessian of a scalar function."""
    k = len(x)
    H = np.empty((k, k))
    for i in range(k):
        for j in range(i, k):
            ei, ej = np.eye(k)[i] * h, np.eye(k)[j] * h
            v = (f(x + ei + ej) - f(x + ei - ej) - f(x - ei + ej) + f(x - ei - ej)) / (4 * h * h)
            H[i, j] = H[j, i] = v
    return H


def random_groups(d: pd.DataFrame) -> tuple[list[np.ndarray], list[str]]:
    """Return the random-intercept grouping factors of the mixed model: subject and object.

    A factor with one level is left out.

    Parameters
    ----------
    d : pandas.DataFrame
        Trials with ``subject`` and ``object`` columns.

    Returns
    -------
    groups : list of ndarray
        Integer codes of each factor kept, for :func:`laplace_glmm`.
    names : list of str
        The names of the factors kept.

    Raises
    ------
    DataError
        One subject and one object only.
    """
    groups, used = [], []
    for nm in ("subject", "object"):
        codes = pd.Categorical(d[nm]).codes
        if codes.max() >= 1:
            groups.append(codes)
            used.append(nm)
    if not groups:
        raise DataError("one subject and one object only: there is no random effect to fit")
    return groups, used


def check_mixed_terms(
    beta: np.ndarray, se: np.ndarray, terms: Sequence[tuple[int, str]], see: str
) -> None:
    """Refuse a mixed fit whose fixed effects ran off (separation) or have no standard error.

    Parameters
    ----------
    beta, se : ndarray
        Fixed effects and their standard errors (:func:`laplace_glmm`).
    terms : sequence of (int, str)
        Index into ``beta`` and name of each term to check.
    see : str
        The fit the message points to instead (e.g. ``'the fixed-effects model'``).

    Raises
    ------
    DataError
        A term with |log odds ratio| above :data:`analysis.logistic.SEPARATION_LOG_OR`, or one
        without a finite positive standard error.
    """
    separated = [t for i, t in terms if not abs(beta[i]) <= SEPARATION_LOG_OR]
    if separated:  # the fit ran off along the separated term: no other term's SE means anything
        raise DataError(
            f"{', '.join(separated)} separated in these data (|log odds ratio| > "
            f"{SEPARATION_LOG_OR:g}): the mixed model's odds ratios are not estimable; see "
            f"{see}"
        )
    no_se = [t for i, t in terms if not (math.isfinite(se[i]) and se[i] > 0)]
    if no_se:
        raise DataError(
            f"{', '.join(no_se)}: no finite standard error in the mixed model (nearly separated "
            f"data): its odds ratios are not estimable; see {see}"
        )


def fit_mixed(trials: pd.DataFrame) -> MixedFit:
    """Fit ``recognized ~ background + log10_pixels`` with random subject and object intercepts.

    Laplace-approximate maximum likelihood (:func:`laplace_glmm`, as lme4's ``glmer``), Wald
    95 % intervals and p-values from the Hessian. (The variational-Bayes fit used before gave
    intervals about ten times too narrow.) A grouping factor with one level is left out.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials (:mod:`analysis.data`), as for :func:`analysis.logistic.fit_logistic`.

    Returns
    -------
    MixedFit

    Raises
    ------
    DataError
        All trials recognised or none, a condition without trials, or separated fixed effects.
    """
    from scipy import stats

    d = design_frame(trials)
    check_model_data(d)
    X = np.column_stack([np.ones(len(d)), d["background"], d["log10_pixels"]])
    groups, used = random_groups(d)
    beta, se, sd, _ = laplace_glmm(d["recognized"].to_numpy(), X, groups)
    terms = ((1, "background"), (2, "log10_pixels"))
    check_mixed_terms(beta, se, terms, "the Firth fit of the fixed-effects model")
    rows = []
    for i, term in ((1, "background"), (2, "log10_pixels")):
        z = beta[i] / se[i]
        rows.append(
            (
                term,
                math.exp(beta[i]),
                math.exp(beta[i] - 1.959963984540054 * se[i]),
                math.exp(beta[i] + 1.959963984540054 * se[i]),
                float(2 * stats.norm.sf(abs(z))),
            )
        )
    sds = dict(zip(used, sd, strict=True))
    return MixedFit(
        OddsRatioTable(tuple(rows)),
        float(sds.get("subject", 0.0)),
        float(sds.get("object", 0.0)),
        method="Laplace-approximate maximum likelihood, as lme4's glmer",
        intervals=True,
        note="",
    )
