"""Giving up as a competing outcome: cumulative incidence of recognition and of giving up.

The censored analysis (:mod:`analysis.survival`) treats a pass like a time-out: the target was
not recognised by the time the trial ended, and might have been later. A subject who passes,
or answers wrongly, has stopped searching, though: that trial can no longer end in recognition.
Treated as a competing outcome, the Aalen-Johansen estimator gives the cumulative incidence of
each ending, ``F_k(t) = sum over t_j <= t of S(t_j-) d_kj / n_j`` (``S`` the Kaplan-Meier curve of
"no ending yet", ``d_kj`` endings of kind ``k`` at ``t_j``, ``n_j`` trials still running), with
only time-outs censored. Its recognition curve stays below ``1 - KM`` of the censored analysis,
which counts a pass as a trial that might still have recognised. statsmodels'
``CumIncidenceRight`` computes it; intervals are on the log(-log) scale, inside [0, 1].
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

__all__ = ["ENDING_CODES", "cumulative_incidence", "competing_by_condition"]

#: Status codes of each ``ended`` value: 1 recognised, 2 gave up (pass or wrong answer),
#: 0 censored (time-out).
ENDING_CODES: dict[str, int] = {"recognised": 1, "pass": 2, "wrong": 2, "timeout": 0}
_Z95 = 1.959963984540054


def _loglog_ci(f: float, se: float) -> list[float | None]:
    """95 % interval of a cumulative incidence on the log(-log) scale (inside [0, 1])."""
    if not (0.0 < f < 1.0) or not math.isfinite(se) or se <= 0:
        return [None, None]
    w = _Z95 * se / (f * abs(math.log(f)))
    return [f ** math.exp(w), f ** math.exp(-w)]


def cumulative_incidence(time_s: Any, ended: Any) -> dict[str, Any]:
    """Return the cumulative incidence of recognition and of giving up by the last time.

    Parameters
    ----------
    time_s : array_like of shape (n,)
        Time each trial ended.
    ended : array_like of str, shape (n,)
        How it ended (keys of :data:`ENDING_CODES`).

    Returns
    -------
    dict
        ``at_s`` (the last time), ``recognised`` and ``gave_up``: ``{"cif", "ci95"}``,
        ``n_trials``, ``n_gave_up``, ``n_timeout``.
    """
    from statsmodels.duration.survfunc import CumIncidenceRight

    t = np.asarray(time_s, float).ravel()
    codes = np.array([ENDING_CODES[str(e)] for e in np.asarray(ended, dtype=object).ravel()])
    out: dict[str, Any] = {
        "at_s": float(t.max()) if t.size else None,
        "n_trials": int(t.size),
        "n_gave_up": int(np.sum(codes == 2)),
        "n_timeout": int(np.sum(codes == 0)),
    }
    for name in ("recognised", "gave_up"):
        out[name] = {"cif": 0.0, "ci95": [None, None]}
    if not np.any(codes > 0):
        return out
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        ci = CumIncidenceRight(t, codes)
    for name, k in (("recognised", 1), ("gave_up", 2)):
        if k - 1 < len(ci.cinc):
            f = float(ci.cinc[k - 1][-1])
            se = float(ci.cinc_se[k - 1][-1])
            if not math.isfinite(se):  # the last step's variance is undefined (n = d)
                fin = np.flatnonzero(np.isfinite(ci.cinc_se[k - 1]))
                se = float(ci.cinc_se[k - 1][fin[-1]]) if fin.size else math.nan
            out[name] = {"cif": f, "ci95": _loglog_ci(f, se)}
    return out


def competing_by_condition(trials: Any) -> dict[str, dict[str, Any]]:
    """Return :func:`cumulative_incidence` per condition of an active-trials table.

    The table is :func:`analysis.active.active_trials`'s; it needs ``condition``, ``rt_s`` and
    ``ended``.
    """
    if "ended" not in trials.columns or trials["ended"].isna().any():
        return {}
    return {
        str(c): cumulative_incidence(g["rt_s"].astype(float), g["ended"].astype(str))
        for c, g in trials.groupby("condition", sort=True)
    }
