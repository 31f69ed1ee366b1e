"""Mixed logistic model of k image conditions (``confocal analyze --mixed`` on a comparison).

The k-condition counterpart of :mod:`analysis.mixed`: ``recognized ~ condition + log10_pixels``
with condition a factor (treatment coding against the reference condition) and random subject
and object intercepts, fitted by the same Laplace approximation
(:func:`analysis.mixed.laplace_glmm`). It gives an odds ratio per non-reference condition with
its Wald 95 % interval, and every pairwise contrast with its Wald p-value (from the fixed
effects' covariance) adjusted by Holm's step-down method, as the fixed-effects model of
:mod:`analysis.conditions` does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd

from analysis.conditions import DEFAULT_REFERENCE, holm, wald_odds_ratio
from analysis.errors import DataError
from analysis.mixed import check_mixed_terms, laplace_glmm, random_groups

__all__ = ["ConditionsMixed", "fit_condition_mixed"]


@dataclass(frozen=True)
class ConditionsMixed:
    """The mixed logistic model with condition as a factor.

    Parameters
    ----------
    reference : str
    odds_ratios : dict of str to dict
        Per non-reference condition: ``or``, ``ci95``, ``p`` (Wald).
    per_log10_pixels : dict
        The odds ratio per log10 pixels (``or``, ``ci95``, ``p``).
    contrasts : list of dict
        Every pair ``[a, b]`` (condition order): ``or`` (odds of b over a), ``ci95``, ``p`` and
        ``p_adjusted`` (Holm over all pairs).
    subject_sd, object_sd : float
        Standard deviations of the random intercepts, log-odds units (0 for a factor with one
        level, which is left out).
    method : str
    """

    reference: str
    odds_ratios: dict[str, dict[str, Any]]
    per_log10_pixels: dict[str, Any]
    contrasts: list[dict[str, Any]]
    subject_sd: float
    object_sd: float
    method: str = "Laplace-approximate maximum likelihood, as lme4's glmer"

    def to_dict(self) -> dict[str, Any]:
        """Return the ``logistic_mixed`` entry of ``results.json``."""
        return {
            "model": "recognized ~ condition + log10_pixels + (1 | subject) + (1 | object)",
            "reference": self.reference,
            "odds_ratios": self.odds_ratios,
            "per_log10_pixels": self.per_log10_pixels,
            "contrasts": self.contrasts,
            "subject_sd": self.subject_sd,
            "object_sd": self.object_sd,
            "method": self.method,
        }


def fit_condition_mixed(
    trials: pd.DataFrame, conditions: Sequence[str], reference: str = DEFAULT_REFERENCE
) -> ConditionsMixed:
    """Fit ``recognized ~ condition + log10_pixels`` with random subject and object intercepts.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials (:mod:`analysis.data`).
    conditions : sequence of str
        The conditions, in report order (``reference`` among them).
    reference : str

    Returns
    -------
    ConditionsMixed

    Raises
    ------
    DataError
        ``reference`` not among the conditions, all trials with one outcome, one subject and one
        object only, or a separated term (or one without a finite standard error): the same
        refusals as :func:`analysis.mixed.fit_mixed`.
    """
    conds = list(conditions)
    if reference not in conds:
        raise DataError(
            f"`reference` {reference!r}: no trials in that condition; expected one of "
            f"{', '.join(conds)}"
        )
    y = trials["recognized"].astype(int).to_numpy()
    if y.min() == y.max():
        what = "recognised" if y[0] == 1 else "not recognised"
        raise DataError(
            f"all {len(y)} trials are {what}: the logistic model (and any threshold) is not "
            "identified by these data"
        )
    others = [c for c in conds if c != reference]
    cond = trials["condition"].astype(str).to_numpy()
    X = np.column_stack(
        [np.ones(len(trials))]
        + [(cond == c).astype(float) for c in others]
        + [np.log10(trials["pixels"].astype(float).to_numpy())]
    )
    groups, used = random_groups(trials)
    beta, cov, sd, _ = laplace_glmm(y, X, groups, cov=True)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    px = len(others) + 1
    terms = [(i + 1, f"condition {c!r}") for i, c in enumerate(others)] + [(px, "log10_pixels")]
    check_mixed_terms(beta, se, terms, "the fixed-effects model")
    col = {c: i + 1 for i, c in enumerate(others)}

    def diff_se(a: str, b: str) -> float:
        ia, ib = col.get(a), col.get(b)
        v = sum(float(cov[i, i]) for i in (ia, ib) if i is not None)
        if ia is not None and ib is not None:
            v -= 2 * cov[ia, ib]
        return math.sqrt(max(v, 0.0))

    def coef(c: str) -> float:
        return 0.0 if c == reference else float(beta[col[c]])

    ors = {}
    for c in others:
        o, ci, p = wald_odds_ratio(coef(c), float(se[col[c]]))
        ors[c] = {"or": o, "ci95": ci, "p": p}
    o, ci, p = wald_odds_ratio(float(beta[px]), float(se[px]))
    per_px = {"or": o, "ci95": ci, "p": p}
    contrasts = []
    for a, b in combinations(conds, 2):
        o, ci, p = wald_odds_ratio(coef(b) - coef(a), diff_se(a, b))
        contrasts.append({"pair": [a, b], "or": o, "ci95": ci, "p": p})
    family = [i for i, c in enumerate(contrasts) if math.isfinite(c["p"])]
    adj = holm([contrasts[i]["p"] for i in family])
    for c in contrasts:
        c["p_adjusted"] = None
    for i, a in zip(family, adj, strict=True):
        contrasts[i]["p_adjusted"] = a
    sds = dict(zip(used, sd, strict=True))
    return ConditionsMixed(
        reference,
        ors,
        per_px,
        contrasts,
        float(sds.get("subject", 0.0)),
        float(sds.get("object", 0.0)),
    )
