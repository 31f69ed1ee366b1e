"""Priors of the sampled parameters: the box-and-Beta prior and its data-dependent default.

Sampled parameters (the columns of ``WeibullFit.samples``):

* ``loc``: ``log10(alpha)`` for the log-axis sigmoids, ``alpha`` for the linear ones;
* ``log_beta``: natural log of the slope parameter ``beta``;
* ``lapse``: the lapse rate ``l``;
* ``eta``: the overdispersion scale (all 0 without overdispersion).

Default priors (ours, not the paper's; Psychtoolbox's fit in the paper is maximum likelihood):

* ``loc`` uniform on the stimulus range widened by one range on each side, so the threshold may
  lie outside the tested levels but not absurdly far;
* ``log_beta`` uniform on ``[log(0.5 / span), log(100 / span)]``, ``span`` being the stimulus
  range in the sigmoid's own unit (natural log units for the Weibull), i.e. from a curve rising
  over twice the tested range to one rising within 1 % of it;
* ``lapse`` Beta(1, 10) truncated to ``[0, min(0.5, (1 - g) / 2)]`` (as psignifit; mean 0.09);
* ``eta`` Beta(1, 10) on ``[0, ETA_MAX]``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from analysis.weibull.kernel import (
    ETA_MAX,
    FitWarning,
    Sigmoid,
    check_guess,
    check_sigmoid,
    is_log_axis,
    log_beta_density,
    to_axis,
)

__all__ = ["PsychometricPrior", "default_prior"]


@dataclass(frozen=True)
class PsychometricPrior:
    """Box-and-Beta prior on the sampled parameters (see the module docstring).

    Parameters
    ----------
    loc_range : (float, float)
        Uniform range of ``loc`` (``log10(alpha)`` for the Weibull, ``alpha`` for the logistic).
    log_beta_range : (float, float)
        Uniform range of ``log(beta)``.
    lapse_a, lapse_b : float
        Beta distribution parameters of the lapse rate.
    lapse_max : float
        Upper bound of the lapse rate, in [0, 1 - guess).
    eta_a, eta_b : float
        Beta distribution parameters of the overdispersion scale eta (used only by fits with
        overdispersion), on ``[0, ETA_MAX]``.
    """

    loc_range: tuple[float, float]
    log_beta_range: tuple[float, float]
    lapse_a: float = 1.0
    lapse_b: float = 10.0
    lapse_max: float = 0.5
    eta_a: float = 1.0
    eta_b: float = 10.0

    def __post_init__(self) -> None:
        for name in ("loc_range", "log_beta_range"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"{name} must be finite with low < high, got {(lo, hi)!r}")
        if not (0.0 < self.lapse_max < 1.0):
            raise ValueError(f"lapse_max must be in (0, 1), got {self.lapse_max!r}")
        if self.lapse_a <= 0 or self.lapse_b <= 0:
            raise ValueError(
                f"lapse_a and lapse_b must be > 0, got {(self.lapse_a, self.lapse_b)!r}"
            )
        mass = self.lapse_mass_above(0.2)
        if mass > 0.2:
            warnings.warn(
                f"the lapse prior puts {100 * mass:.0f} % of its mass above a lapse rate of 0.2; "
                "lapses that large usually mean a wrong model (as psignifit warns)",
                FitWarning,
                stacklevel=3,
            )

    def lapse_mass_above(self, lapse: float) -> float:
        """Return the prior probability that the lapse rate exceeds ``lapse``."""
        from scipy import stats

        dist = stats.beta(self.lapse_a, self.lapse_b)
        total = dist.cdf(self.lapse_max)
        return float(max(0.0, total - dist.cdf(min(lapse, self.lapse_max))) / total)

    def bounds(self, n_params: int = 3) -> list[tuple[float, float]]:
        """Return the box of the sampled parameters (loc, log_beta, lapse[, eta])."""
        box = [tuple(self.loc_range), tuple(self.log_beta_range), (0.0, self.lapse_max)]
        return box + [(0.0, ETA_MAX)] if n_params == 4 else box

    def log_prob(self, theta: np.ndarray) -> np.ndarray:
        """Return the unnormalised log prior of ``theta`` (shape (..., 3) or (..., 4)).

        -inf outside the box; a fourth column is the overdispersion scale eta.
        """
        theta = np.asarray(theta, dtype=float)
        loc, lb, lapse = theta[..., 0], theta[..., 1], theta[..., 2]
        inside = (
            (loc >= self.loc_range[0])
            & (loc <= self.loc_range[1])
            & (lb >= self.log_beta_range[0])
            & (lb <= self.log_beta_range[1])
            & (lapse >= 0.0)
            & (lapse <= self.lapse_max)
        )
        lp = log_beta_density(lapse, self.lapse_a, self.lapse_b)
        if theta.shape[-1] == 4:
            eta = theta[..., 3]
            inside &= (eta >= 0.0) & (eta <= ETA_MAX)
            lp = lp + log_beta_density(eta, self.eta_a, self.eta_b)
        return np.where(inside, lp, -np.inf)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict: every field, ranges as lists."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PsychometricPrior:
        """Rebuild from :meth:`to_dict` output."""
        return cls(
            loc_range=tuple(d["loc_range"]),
            log_beta_range=tuple(d["log_beta_range"]),
            lapse_a=float(d["lapse_a"]),
            lapse_b=float(d["lapse_b"]),
            lapse_max=float(d["lapse_max"]),
            eta_a=float(d.get("eta_a", 1.0)),
            eta_b=float(d.get("eta_b", 10.0)),
        )


def default_prior(
    pixels: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    lapse_a: float = 1.0,
    lapse_b: float = 10.0,
) -> PsychometricPrior:
    """Return the default prior for the tested stimulus values ``pixels`` (module docstring).

    Parameters
    ----------
    pixels : array_like
        Stimulus values tested (pixels for the paper's data; > 0 for the Weibull).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}
    lapse_a, lapse_b : float
        Beta prior of the lapse rate (> 0).

    Returns
    -------
    PsychometricPrior
    """
    check_sigmoid(sigmoid)
    check_guess(guess)
    lv = np.asarray(pixels, dtype=float)
    if is_log_axis(sigmoid) and np.any(lv <= 0):
        raise ValueError(f"pixels must be > 0 for the {sigmoid} (log axis), got a value <= 0")
    a = to_axis(lv, sigmoid)
    lo, hi = float(a.min()), float(a.max())
    span = hi - lo
    if span <= 0:
        # One level only: the threshold is barely identified; a one-decade (or unit) box.
        span = 1.0
    span_natural = span * (math.log(10.0) if is_log_axis(sigmoid) else 1.0)
    return PsychometricPrior(
        loc_range=(lo - span, hi + span),
        log_beta_range=(math.log(0.5 / span_natural), math.log(100.0 / span_natural)),
        lapse_a=float(lapse_a),
        lapse_b=float(lapse_b),
        lapse_max=min(0.5, (1.0 - guess) / 2.0),
    )
