"""The threshold of the pooled curve of the subjects and objects tested, with its interval.

When subjects and objects differ, the pooled proportion correct at a level is the mean of their
curves, which is not a Weibull: it is shallower and more symmetric on the log axis. A Weibull
fitted to the pooled data then puts its 50 % point 5-7 % above the pooled curve's (measured in
benchmarks/validate_weibull_coverage.py), so the credible interval of that fit answers "where is
the Weibull fitted to these pooled responses?", not "where do these subjects and objects, taken
together, recognise half the time?".

This module answers the second question by modelling the variation: the pooled curve is a
Weibull whose scale varies log-normally across the subject x object cells,

``P(x) = g + (1 - g - l) * E_z[1 - exp(-(x / (alpha 10^(sigma z)))^beta)]``, ``z ~ N(0, 1)``,

(ours; the expectation by Gauss-Hermite quadrature, 24 nodes), fitted by binomial maximum
likelihood to the pooled counts, and the 95 % interval of its ``pc`` point is the profile
likelihood interval (likelihood-ratio 3.84, one degree of freedom). ``sigma = 0`` is the plain
Weibull. Given the subjects and objects tested, the pooled counts are sums of independent trials
with different probabilities, whose variance is at most the binomial one, so the binomial
likelihood is, if anything, conservative for this question.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy import optimize, special

from analysis.weibull import aggregate

__all__ = ["SIGMA_MAX", "pooled_curve_threshold", "pooled_curve_by_condition"]

#: Upper bound of the spread ``sigma`` of log10 scale across cells (ours: a factor of 10 per SD).
SIGMA_MAX: float = 1.0
_NODES, _WEIGHTS = np.polynomial.hermite_e.hermegauss(24)
_WEIGHTS = _WEIGHTS / _WEIGHTS.sum()
_LN10 = math.log(10.0)
_CHI2_95 = 3.841458820694124


def _core(d: np.ndarray, beta: float, sigma: float) -> np.ndarray:
    """Mean Weibull core at log10 distances ``d`` from log10 alpha, scale spread ``sigma``."""
    z = beta * _LN10 * (d[..., None] - sigma * _NODES)
    with np.errstate(over="ignore"):
        return -np.expm1(-np.exp(np.minimum(z, 700.0))) @ _WEIGHTS


def _offset(f: float, beta: float, sigma: float) -> float:
    """Return d with mean core(d) = f (log10 distance from alpha to the ``f`` point of the core)."""
    d = math.log(-math.log1p(-f)) / (beta * _LN10)  # sigma = 0
    if sigma == 0:
        return d
    lo, hi = d - 8 * sigma - 1, d + 8 * sigma + 1
    for _ in range(60):  # safeguarded Newton on a monotone function
        c = float(_core(np.array([d]), beta, sigma)[0]) - f
        if c > 0:
            hi = min(hi, d)
        else:
            lo = max(lo, d)
        h = 1e-6
        slope = (float(_core(np.array([d + h]), beta, sigma)[0]) - f - c) / h
        step = c / slope if slope > 0 else math.inf
        d_new = d - step
        if not (lo < d_new < hi):
            d_new = (lo + hi) / 2
        if abs(d_new - d) < 1e-11:
            return d_new
        d = d_new
    return d


def pooled_curve_threshold(
    x: Any, correct: Any, *, pc: float = 0.5, guess: float = 0.0
) -> dict[str, Any] | None:
    """Return the pooled curve's ``pc`` point and its 95 % profile-likelihood interval.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Pixels (stimulus level, > 0) per trial.
    correct : array_like of shape (n_trials,)
        1 / 0 per trial.
    pc : float
        Proportion correct of the threshold, above ``guess``.
    guess : float
        Guess rate in [0, 1).

    Returns
    -------
    dict or None
        ``threshold`` (pixels), ``ci95`` (low, high; ``None`` for an end the profile does not
        reach within one decade beyond the tested levels), ``sigma`` (fitted spread of log10
        scale), ``beta``, ``lapse``; None with fewer than three levels or when no ``pc`` point
        lies inside the tested range.
    """
    levels, k, n = aggregate(x, correct)
    if len(levels) < 3 or np.any(levels <= 0) or not (guess < pc < 1):
        return None
    try:
        with np.errstate(all="ignore"):
            return _fit(np.log10(levels), np.asarray(k, float), np.asarray(n, float), pc, guess)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return None


def _fit(u: np.ndarray, k: np.ndarray, n: np.ndarray, pc: float, guess: float) -> dict | None:
    """Return the ML fit and profile interval on log10 levels ``u`` (see the public function)."""
    span = max(float(u.max() - u.min()), 0.5)
    lapse_max = min(0.2, 0.99 * (1 - pc))
    nuis = [(math.log(0.3 / span), math.log(100.0 / span)), (0.0, lapse_max), (0.0, SIGMA_MAX)]

    def nll_p(p: np.ndarray) -> float:
        p = np.clip(p, 1e-12, 1 - 1e-12)
        return -float(np.sum(special.xlogy(k, p) + special.xlogy(n - k, 1 - p)))

    def nll_a(v: np.ndarray) -> float:  # v = (log10 alpha, log beta, lapse, sigma)
        return nll_p(guess + (1 - guess - v[2]) * _core(u - v[0], math.exp(v[1]), v[3]))

    def t_of(v: np.ndarray) -> float:
        f = (pc - guess) / (1 - guess - v[2])
        return float(v[0] + _offset(f, math.exp(v[1]), v[3]))

    best = None
    for b0 in (1.0, 4.0):
        for s0 in (0.0, 0.25, 0.5):
            start = [float(np.median(u)), math.log(b0 / span), 0.02, s0]
            r = optimize.minimize(
                nll_a,
                start,
                method="SLSQP",
                bounds=[(u.min() - span, u.max() + span), *nuis],
                options={"ftol": 1e-10, "maxiter": 200},
            )
            if best is None or r.fun < best.fun:
                best = r
    v_hat = np.asarray(best.x)
    ll_hat = float(best.fun)
    t_hat = t_of(v_hat)
    if not (u.min() <= t_hat <= u.max()):
        return None

    box = [(u.min() - span - 2 * SIGMA_MAX, u.max() + span + 2 * SIGMA_MAX), *nuis]

    def profile(t: float, start: np.ndarray) -> tuple[float, np.ndarray]:
        # Maximise with the curve constrained to pass through pc at t (it is monotone).
        def through(v: np.ndarray) -> float:
            core = _core(np.array([t - v[0]]), math.exp(v[1]), v[3])[0]
            return float(guess + (1 - guess - v[2]) * core - pc)

        v0 = np.array(start, float)
        v0[0] = t - (t_hat - v_hat[0])  # shift the curve to pass near t
        r = optimize.minimize(
            nll_a,
            v0,
            method="SLSQP",
            bounds=box,
            constraints=[{"type": "eq", "fun": through}],
            options={"ftol": 1e-10, "maxiter": 200},
        )
        if not r.success or abs(through(r.x)) > 1e-6:
            # Fall back on the exact parametrisation by the threshold.
            def nll_t(w: np.ndarray) -> float:
                v = np.array([0.0, *w])
                f = (pc - guess) / (1 - guess - w[1])
                v[0] = t - _offset(f, math.exp(w[0]), w[2])
                return nll_a(v)

            q = optimize.minimize(nll_t, v0[1:], method="SLSQP", bounds=nuis)
            x = np.array(
                [t - _offset((pc - guess) / (1 - guess - q.x[1]), math.exp(q.x[0]), q.x[2]), *q.x]
            )
            return float(q.fun), x
        return float(r.fun), np.asarray(r.x)

    ends: list[float | None] = []
    for sign in (-1.0, 1.0):
        limit = (u.min() - 1.0) if sign < 0 else (u.max() + 1.0)
        step, prev, start, end = 0.05, t_hat, v_hat, None
        while (t_hat + sign * step - limit) * sign <= 0:
            t = t_hat + sign * step
            val, w = profile(t, start)
            if 2 * (val - ll_hat) > _CHI2_95:
                # Safeguarded regula falsi on the deficit (smooth in t), robust to the small
                # noise of the inner maximisations.
                lo, hi = prev, t
                f_lo, f_hi = -_CHI2_95 if prev == t_hat else None, 2 * (val - ll_hat) - _CHI2_95
                if f_lo is None:
                    f_lo = 2 * (profile(prev, start)[0] - ll_hat) - _CHI2_95
                for _ in range(20):
                    if abs(hi - lo) < 2e-4:
                        break
                    frac = min(max(-f_lo / (f_hi - f_lo), 0.1), 0.9) if f_hi > f_lo else 0.5
                    mid = lo + (hi - lo) * frac
                    val, w = profile(mid, start)
                    f_mid = 2 * (val - ll_hat) - _CHI2_95
                    if abs(f_mid) < 2e-3:
                        lo = hi = mid
                        break
                    if f_mid > 0:
                        hi, f_hi = mid, f_mid
                    else:
                        lo, f_lo, start = mid, f_mid, w
                end = (lo + hi) / 2
                break
            prev, start, step = t, w, step * 1.6
        ends.append(None if end is None else float(10**end))
    return {
        "threshold": float(10**t_hat),
        "ci95": (ends[0], ends[1]),
        "sigma": float(v_hat[3]),
        "beta": math.exp(v_hat[1]),
        "lapse": float(v_hat[2]),
    }


def pooled_curve_by_condition(trials: Any, guess: float = 0.0) -> dict[str, dict[str, Any]]:
    """Return :func:`pooled_curve_threshold` at 50 % per condition of a trial table.

    Parameters
    ----------
    trials : pandas.DataFrame
        Columns ``condition``, ``pixels``, ``recognized``.
    guess : float
        Guess rate.

    Returns
    -------
    dict
        Condition -> ``{"threshold", "ci95": [low, high], "sigma", "beta", "lapse"}``; a
        condition whose pooled curve has no 50 % point inside the tested range (or that cannot be
        fitted) is left out.
    """
    out: dict[str, dict[str, Any]] = {}
    for cond, sel in trials.groupby(trials["condition"].astype(str), sort=True):
        if guess >= 0.5:
            continue
        r = pooled_curve_threshold(sel["pixels"], sel["recognized"], guess=guess)
        if r is not None:
            out[str(cond)] = {**r, "ci95": list(r["ci95"])}
    return out
