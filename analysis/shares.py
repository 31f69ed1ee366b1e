"""Intervals of shares (proportions) that stay in [0, 1], also when trials cluster in subjects.

A t interval over subject shares is symmetric and can run below 0 or above 100 % (zoom use
"33 % (-21-88 %)"). :func:`share_ci95` gives the Wilson score interval instead; with several
subjects its number of trials is the effective one, ``p (1 - p) / SE^2`` with ``SE`` the standard
error of the mean over subject shares (the design effect of clustering, as Korn & Graubard 1998
do for survey proportions), and its quantile is t with subjects - 1 degrees of freedom.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["wilson_ci95", "share_ci95"]


def wilson_ci95(p: float, n: float, z: float = 1.959963984540054) -> tuple[float, float]:
    """Return the Wilson score interval of a share ``p`` of ``n`` trials (within [0, 1]).

    Parameters
    ----------
    p : float
        Observed share, in [0, 1].
    n : float
        Number of trials (> 0; may be an effective, non-integer number).
    z : float
        Normal (or t) quantile of the interval.

    Returns
    -------
    (float, float)

    Examples
    --------
    >>> [round(v, 4) for v in wilson_ci95(0.5, 10)]
    [0.2366, 0.7634]
    """
    if not n > 0:
        raise ValueError(f"n must be > 0, got {n!r}")
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z / (1 + z2 / n) * math.sqrt(max(p * (1 - p) / n + z2 / (4 * n * n), 0.0))
    return max(0.0, centre - half), min(1.0, centre + half)


def share_ci95(values: Any, subject: Any) -> tuple[float, tuple[float, float], str]:
    """Return a share over trials with its 95 % interval, clustered by subject.

    Parameters
    ----------
    values : array_like of shape (n_trials,)
        0 / 1 (or booleans) per trial.
    subject : array_like of shape (n_trials,)
        Subject per trial.

    Returns
    -------
    share : float
        Share over trials.
    ci95 : (float, float)
        Wilson interval (see the module docstring), within [0, 1].
    unit : str
        ``'subjects'`` (effective trials from the spread over subjects) or ``'trials'``.
    """
    from scipy import stats

    v = np.asarray(values, dtype=float).ravel()
    s = np.asarray(subject, dtype=object).ravel().astype(str)
    if v.size == 0:
        raise ValueError("values must hold at least one trial")
    p = float(v.mean())
    shares = pd.Series(v).groupby(s).mean().to_numpy()
    if shares.size < 2:
        return p, wilson_ci95(p, v.size), "trials"
    se2 = float(shares.var(ddof=1)) / shares.size
    n_eff = v.size if se2 <= 0 or p in (0.0, 1.0) else min(v.size, p * (1 - p) / se2)
    z = float(stats.t.ppf(0.975, shares.size - 1))
    return p, wilson_ci95(p, n_eff, z), "subjects"
