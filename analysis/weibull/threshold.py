"""Thresholds with a status: measured, censored below or above the tested range, or unidentified."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from analysis.weibull.kernel import json_float

__all__ = ["STATUSES", "Threshold", "bracket", "unmeasured_text"]


#: Threshold statuses (see :class:`Threshold`).
STATUSES: tuple[str, ...] = ("measured", "censored_below", "censored_above", "unidentified")


@dataclass(frozen=True)
class Threshold:
    """A threshold: where the fitted curve crosses proportion correct ``pc``.

    Only a ``measured`` threshold is a number to report. ``censored_below`` means "below the
    lowest level tested" (e.g. everything was recognised), ``censored_above`` "above the highest
    level tested" (e.g. the curve never reaches ``pc`` there), and ``unidentified`` that the data
    do not locate it: fewer than three levels carry data, the data are separated (a step
    response), the slope or the lapse rate sits on its prior bound, the 95 % interval runs
    beyond the tested levels or spans most of the prior, or the data decrease with level. The
    numbers are kept for the record but are not measurements in those cases; an unidentified
    threshold is reported by the tested levels that bracket it (:func:`bracket`) instead.

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
        Why the status is not ``measured`` (empty when it is), e.g. ``2 levels with data``.
    bracket : (float, float)
        The tested levels between which the observed proportion correct crosses ``pc``
        (:func:`bracket`), widened to contain the ML threshold, x units; NaN on a side with no
        such level, both NaN when the data give no bracket (e.g. proportion correct decreasing
        with level).
    midpoint : bool
        The threshold is psignifit's: where the curve is midway between the guess rate and
        1 - lapse (``pc`` is that midpoint on the ML curve).
    """

    pc: float
    median: float
    ci95: tuple[float, float]
    mle: float
    status: str = "measured"
    lowest: float = math.nan
    highest: float = math.nan
    reason: str = ""
    bracket: tuple[float, float] = (math.nan, math.nan)
    midpoint: bool = False

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
        tested = {"lowest_tested": self.lowest, "highest_tested": self.highest}  # nan, inf kept
        return unmeasured_text({**self.to_dict(), **tested}, fmt, unit)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (inf -> None)."""
        return {
            "pc": self.pc,
            "status": self.status,
            "median": json_float(self.median),
            "ci95": [json_float(self.ci95[0]), json_float(self.ci95[1])],
            "mle": json_float(self.mle),
            "lowest_tested": json_float(self.lowest),
            "highest_tested": json_float(self.highest),
            "reason": self.reason,
            "bracket": [json_float(self.bracket[0]), json_float(self.bracket[1])],
            "midpoint": self.midpoint,
        }


def unmeasured_text(
    t: dict[str, Any],
    fmt: str,
    unit: str = "",
    *,
    below: str = "below the lowest level tested",
    above: str = "above the highest level tested",
    with_reason: bool = False,
    unidentified_note: str = "",
) -> str:
    """Return a threshold that is not ``measured`` as report text.

    Parameters
    ----------
    t : dict
        A :meth:`Threshold.to_dict` entry (``status``, ``lowest_tested``, ``highest_tested``,
        ``bracket``, ``reason``).
    fmt : str
        Format of a level (``"{:,.0f}"``); a missing level (None) is ``n/a``.
    unit : str
        Unit after each level (``px``), or ''.
    below, above : str
        What a threshold censored below or above the tested range is called in parentheses.
    with_reason : bool
        Add ``: <reason>`` to ``below`` and ``above``.
    unidentified_note : str
        Text after the reason of an unidentified threshold with a bracket.

    Returns
    -------
    str
        ``"< 96 px (below ...)"``, ``"> 160,884 px (above ...)"``, ``"between 3,290 and 17,876 px
        (unidentified: ...)"`` (the tested levels that bracket it, or a bound) or
        ``"not identified (...)"``.
    """
    u = f" {unit}" if unit else ""
    why = f": {t['reason']}" if with_reason else ""
    if t["status"] == "censored_below":
        return f"< {_level_text(t['lowest_tested'], fmt)}{u} ({below}{why})"
    if t["status"] == "censored_above":
        return f"> {_level_text(t['highest_tested'], fmt)}{u} ({above}{why})"
    where = _bracket_text(t.get("bracket") or (None, None), fmt, u)
    if where:
        return f"{where} (unidentified: {t['reason']}{unidentified_note})"
    return f"not identified ({t['reason']})"


def _level_text(v: float | None, fmt: str) -> str:
    return "n/a" if v is None else fmt.format(v)


def _bracket_text(br: Any, fmt: str, u: str) -> str:
    """``"between A and B px"``, ``"< B px"``, ``"> A px"``, or '' without a bracket.

    ``br`` is a bracket pair; None (from JSON) counts as NaN.
    """
    lo, hi = (math.nan if v is None else float(v) for v in br)
    if math.isfinite(lo) and math.isfinite(hi):
        return f"between {fmt.format(lo)} and {fmt.format(hi)}{u}"
    if math.isfinite(hi):
        return f"< {fmt.format(hi)}{u}"
    if math.isfinite(lo):
        return f"> {fmt.format(lo)}{u}"
    return ""


def bracket(pixels: Any, k: Any, n: Any, pc: float) -> tuple[float, float]:
    """Return the tested levels that bracket where proportion correct crosses ``pc``.

    The observed proportions are made non-decreasing in level first (pool-adjacent-violators,
    weighted by trials), so one noisy level does not split the bracket. The bracket is the
    highest level whose pooled proportion is below ``pc`` and the lowest level whose pooled
    proportion is above it; levels at exactly ``pc`` lie inside. A side with no such level is
    NaN: ``(nan, B)`` means "below B", ``(A, nan)`` "above A".

    Parameters
    ----------
    pixels, k, n : array_like of shape (n_levels,)
        Distinct stimulus values in increasing order (x units), number correct, number of
        trials (> 0).
    pc : float
        Proportion correct, in (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper bracketing level, x units.

    Examples
    --------
    >>> bracket([3290.0, 17876.0], [24, 100], [120, 120], 0.5)
    (3290.0, 17876.0)
    >>> bracket([96.0, 486.0, 950.0], [0, 0, 3], [2, 2, 3], 0.5)
    (486.0, 950.0)
    """
    x = np.asarray(pixels, float)
    p = _pava(np.asarray(k, float) / np.asarray(n, float), np.asarray(n, float))
    below, above = x[p < pc], x[p > pc]
    lo = float(below.max()) if below.size else math.nan
    hi = float(above.min()) if above.size else math.nan
    return lo, hi


def _pava(y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least-squares non-decreasing fit of ``y`` (pool adjacent violators)."""
    vals: list[float] = []
    wts: list[float] = []
    sizes: list[int] = []
    for yi, wi in zip(y, w, strict=True):
        vals.append(float(yi))
        wts.append(float(wi))
        sizes.append(1)
        while len(vals) > 1 and vals[-2] > vals[-1]:
            wsum = wts[-2] + wts[-1]
            v = (vals[-2] * wts[-2] + vals[-1] * wts[-1]) / wsum
            s = sizes[-2] + sizes[-1]
            del vals[-1], wts[-1], sizes[-1]
            vals[-1], wts[-1], sizes[-1] = v, wsum, s
    return np.repeat(vals, sizes)
