"""Thresholds with a status: measured, censored below or above the tested range, or unidentified."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import special

from analysis.weibull.model import _axis, is_log_axis

__all__ = ["STATUSES", "Threshold"]


#: Threshold statuses (see :class:`Threshold`).
STATUSES: tuple[str, ...] = ("measured", "censored_below", "censored_above", "unidentified")


@dataclass(frozen=True)
class Threshold:
    """A threshold: where the fitted curve crosses proportion correct ``pc``.

    Only a ``measured`` threshold is a number to report. ``censored_below`` means "below the
    lowest level tested" (e.g. everything was recognised), ``censored_above`` "above the highest
    level tested" (e.g. the curve never reaches ``pc`` there), and ``unidentified`` that the data
    do not locate it (the posterior is essentially the prior, one level only, or the data decrease
    with level). The numbers are kept for the record but are not measurements in those cases.

    Parameters
    ----------
    pc : float
        Proportion correct.
    median : float
        Posterior median, x units (``inf`` when more than half the posterior never reaches pc).
    ci95 : (float, float)
        Central 95 % credible interval, x units.
    mle : float
        Threshold of the maximum-likelihood curve, x units.
    status : {'measured', 'censored_below', 'censored_above', 'unidentified'}
    lowest, highest : float
        Lowest and highest level tested, x units.
    reason : str
        Why the status is not ``measured`` (empty when it is).
    """

    pc: float
    median: float
    ci95: tuple[float, float]
    mle: float
    status: str = "measured"
    lowest: float = math.nan
    highest: float = math.nan
    reason: str = ""

    @property
    def measured(self) -> bool:
        """True when the threshold is a measurement inside the tested range."""
        return self.status == "measured"

    def text(self, fmt: str = "{:,.4g}", unit: str = "") -> str:
        """Return the threshold as report text: a number with CrI and ML, or a censoring phrase."""
        u = f" {unit}" if unit else ""
        if self.status == "measured":
            return (
                f"{fmt.format(self.median)}{u} (95 % CrI {fmt.format(self.ci95[0])}-"
                f"{fmt.format(self.ci95[1])}; ML {fmt.format(self.mle)})"
            )
        if self.status == "censored_below":
            return f"< {fmt.format(self.lowest)}{u} (below the lowest level tested)"
        if self.status == "censored_above":
            return f"> {fmt.format(self.highest)}{u} (above the highest level tested)"
        return f"not identified ({self.reason})"

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (inf -> None)."""
        return {
            "pc": self.pc,
            "status": self.status,
            "median": _json_float(self.median),
            "ci95": [_json_float(self.ci95[0]), _json_float(self.ci95[1])],
            "mle": _json_float(self.mle),
            "lowest_tested": _json_float(self.lowest),
            "highest_tested": _json_float(self.highest),
            "reason": self.reason,
        }


def _axis_value(v: float, sigmoid: str) -> float:
    if is_log_axis(sigmoid):
        return math.log10(v) if v > 0 else -math.inf
    return v


def _decreasing(levels: np.ndarray, k: np.ndarray, n: np.ndarray, sigmoid: str) -> bool:
    """Logistic regression of correct on the axis: slope < 0 with z < -1.96 (lightly ridged)."""
    if len(levels) < 2 or k.sum() in (0, n.sum()):
        return False
    u = _axis(np.asarray(levels, float), sigmoid)
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


def _json_float(v: float) -> float | None:
    """JSON has no inf/NaN: those become None (null)."""
    v = float(v)
    return v if math.isfinite(v) else None
