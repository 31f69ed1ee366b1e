"""Checks of the Cox model's proportional-hazards assumption, and its alternative when it fails.

:func:`schoenfeld_test` is the Grambsch & Therneau (1994) test: under proportional hazards the
scaled Schoenfeld residuals of the condition indicator do not trend with time; the statistic is
the squared covariance of the residuals with the rank of the event time, chi-squared with 1 df
(the rank transform of R's ``cox.zph(transform = "rank")`` and lifelines'
``proportional_hazard_test``). When it fails (p < 0.05) :func:`split_hazard_ratios` gives the
time-varying alternative: one hazard ratio before and one after the median event time (a step
function of time, fitted by splitting each trial into two episodes with delayed entry), stratified
by subject like the main model.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

__all__ = ["PH_ALPHA", "schoenfeld_test", "split_hazard_ratios", "proportional_hazards_check"]

#: Level of the proportional-hazards test below which the time-varying alternative is reported.
PH_ALPHA: float = 0.05
_Z95 = 1.959963984540054


def _arrays(time_s, recognized, x, strata):
    t = np.asarray(time_s, float).ravel()
    e = np.asarray(recognized).astype(bool).ravel()
    x = np.asarray(x, float).ravel()
    s = None if strata is None else np.asarray(strata, dtype=object).ravel().astype(str)
    return t, e, x, s


def schoenfeld_test(time_s: Any, recognized: Any, x: Any, strata: Any = None) -> dict[str, Any]:
    """Return the Grambsch-Therneau test of proportional hazards for one 0/1 covariate.

    Parameters
    ----------
    time_s : array_like of shape (n,)
        Time each trial ended.
    recognized : array_like of bool, shape (n,)
        Event (True) or censored.
    x : array_like of shape (n,)
        The covariate (condition indicator).
    strata : array_like of shape (n,), optional
        Stratum per trial (subject): each has its own baseline hazard and risk sets.

    Returns
    -------
    dict
        ``statistic`` (chi-squared, 1 df), ``p``, ``n_events``, ``beta`` (the Cox estimate),
        ``residuals`` (Schoenfeld, one per event, in the order of ``event_times``),
        ``event_times``; ``p`` None when the model cannot be fitted.
    """
    from scipy import stats
    from statsmodels.duration.hazard_regression import PHReg

    t, e, xv, s = _arrays(time_s, recognized, x, strata)
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        try:
            res = PHReg(t, xv[:, None], status=e.astype(int), strata=s).fit()
            beta, var = float(res.params[0]), float(res.cov_params()[0, 0])
            resid = np.asarray(res.schoenfeld_residuals, float)[:, 0]
        except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):
            return {"statistic": None, "p": None, "n_events": int(e.sum())}
    ev = e & np.isfinite(resid)
    r, te = resid[ev], t[ev]
    d = int(ev.sum())
    if d < 3 or not (math.isfinite(var) and var > 0):
        return {"statistic": None, "p": None, "n_events": d}
    g = stats.rankdata(te)
    g = g - g.mean()
    stat = d * var * float(g @ r) ** 2 / float(g @ g)
    return {
        "statistic": stat,
        "p": float(stats.chi2.sf(stat, 1)),
        "n_events": d,
        "beta": beta,
        "residuals": r.tolist(),
        "event_times": te.tolist(),
    }


def split_hazard_ratios(
    time_s: Any, recognized: Any, x: Any, strata: Any = None, *, split_s: float | None = None
) -> dict[str, Any]:
    """Return hazard ratios before and after ``split_s`` (default: the median event time).

    Each trial becomes an episode ``[0, min(t, split)]`` and, if it lasted longer, one
    ``(split, t]`` with delayed entry; the covariate is ``x`` times "early" and ``x`` times
    "late", so each period has its own hazard ratio (Cox, stratified as given; Wald intervals).

    Returns
    -------
    dict
        ``split_s``, ``early`` and ``late``: ``{"hazard_ratio", "ci95"}`` (None when not
        estimable).
    """
    from statsmodels.duration.hazard_regression import PHReg

    t, e, xv, s = _arrays(time_s, recognized, x, strata)
    if split_s is None:
        split_s = float(np.median(t[e])) if e.any() else float(np.median(t))
    late = t > split_s
    t2 = np.r_[np.minimum(t, split_s), t[late]]
    e2 = np.r_[e & ~late, e[late]]
    entry = np.r_[np.zeros(t.size), np.full(int(late.sum()), split_s)]
    x_early = np.r_[xv, np.zeros(int(late.sum()))]
    x_late = np.r_[np.zeros(t.size), xv[late]]
    s2 = None if s is None else np.r_[s, s[late]]
    out: dict[str, Any] = {"split_s": split_s}
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            res = PHReg(
                t2,
                np.column_stack([x_early, x_late]),
                status=e2.astype(int),
                entry=entry,
                strata=s2,
            ).fit()
        b, se = np.asarray(res.params, float), np.asarray(res.bse, float)
    except (np.linalg.LinAlgError, ValueError, ZeroDivisionError):
        b, se = np.full(2, np.nan), np.full(2, np.nan)
    for i, name in enumerate(("early", "late")):
        ok = math.isfinite(b[i]) and math.isfinite(se[i]) and se[i] > 0 and abs(b[i]) < 20
        out[name] = {
            "hazard_ratio": math.exp(b[i]) if ok else None,
            "ci95": [math.exp(b[i] - _Z95 * se[i]), math.exp(b[i] + _Z95 * se[i])]
            if ok
            else [None, None],
        }
    return out


def proportional_hazards_check(
    time_s: Any, recognized: Any, condition: Any, subject: Any, *, treated: str, reference: str
) -> dict[str, Any]:
    """Return the Schoenfeld test of the condition's hazard ratio, and an alternative if it fails.

    The split alternative is given when the test fails (``alternative``, else None); the test is
    stratified by subject when there are several.

    Returns
    -------
    dict
        ``test`` (:func:`schoenfeld_test`, without the residuals), ``holds`` (p >= 0.05, or
        None when untested), ``alternative`` and ``method`` (in words).
    """
    cond = np.asarray(condition, dtype=object).ravel()
    subj = np.asarray(subject, dtype=object).ravel()
    keep = (cond == treated) | (cond == reference)
    t = np.asarray(time_s, float).ravel()[keep]
    e = np.asarray(recognized).astype(bool).ravel()[keep]
    x = (cond[keep] == treated).astype(float)
    strata = subj[keep] if len(set(subj[keep].tolist())) > 1 else None
    test = schoenfeld_test(t, e, x, strata)
    test = {k: v for k, v in test.items() if k not in ("residuals", "event_times")}
    holds = None if test["p"] is None else bool(test["p"] >= PH_ALPHA)
    alt = split_hazard_ratios(t, e, x, strata) if holds is False else None
    return {
        "method": (
            "Grambsch-Therneau test on the Schoenfeld residuals of the condition (rank of "
            "event time; chi-squared, 1 df)"
            + (", stratified by subject" if strata is not None else "")
        ),
        "test": test,
        "holds": holds,
        "alternative": alt,
    }
