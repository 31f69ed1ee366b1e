"""Psychometric functions: maximum likelihood and emcee posteriors, thresholds at any level.

The model (Jung et al. 2015, Sec. 3.2.2; Wichmann & Hill 2001) is

    P(x) = g + (1 - g - l) * F(beta * (s(x) - s(alpha)))

``g`` is the guess rate (0 for free recognition, 0.5 for 2AFC) and ``l`` the lapse rate, which is
free, so the curve is not forced to reach 1. ``s`` is the stimulus axis: ``ln x`` for the
log-axis sigmoids (``x > 0``, e.g. pixels) and ``x`` itself for the linear ones (any real ``x``,
e.g. a phase in degrees). ``F`` is one of three shapes:

==============  ======  ===========================  ==========================================
sigmoid         axis    F(z)                         note
==============  ======  ===========================  ==========================================
``weibull``     log     1 - exp(-exp(z))             ``1 - exp(-(x / alpha) ** beta)``
``loglogistic`` log     1 / (1 + exp(-z))
``lognormal``   log     Phi(z)
``gumbel``      linear  1 - exp(-exp(z))             psignifit's "gumbel" (log-Weibull)
``logistic``    linear  1 / (1 + exp(-z))
``normal``      linear  Phi(z)                       cumulative normal
==============  ======  ===========================  ==========================================

The likelihood is binomial over the distinct stimulus levels, or, with ``overdispersion=True``,
beta-binomial: each level's P is itself drawn from a Beta distribution with mean P and
``Var = eta ** 2 * P * (1 - P)``, so the level's count has variance
``n P (1 - P) (1 + (n - 1) eta ** 2)`` (Schuett, Harmeling, Macke & Wichmann 2016, psignifit 4).
The scale ``eta`` in [0, 1) is a fourth free parameter with a Beta(1, 10) prior (psignifit 4's
default, as we read it; ours to adopt). Pooling subjects and objects whose thresholds differ makes
binomial-only intervals too narrow; eta absorbs that extra variance. Maximum-likelihood estimates
are always binomial (as Psychtoolbox's fit in the paper).

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

Convergence follows emcee's advice: the chain is extended in chunks until it is at least
``50 * tau`` long, ``tau`` being the integrated autocorrelation time
(:func:`emcee.autocorr.integrated_time`) of the slowest parameter; otherwise the fit reports
``converged = False``.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, Literal

import emcee
import numpy as np
from scipy import optimize, special

__all__ = [
    "SIGMOIDS",
    "ETA_MAX",
    "is_log_axis",
    "PsychometricPrior",
    "MLEstimate",
    "Threshold",
    "WeibullFit",
    "SamplerProgress",
    "psychometric",
    "threshold_at",
    "aggregate",
    "default_prior",
    "fit_mle",
    "sample_posterior",
    "fit_weibull",
    "fit_counts",
    "STATUSES",
    "FitWarning",
]

logger = logging.getLogger(__name__)

Sigmoid = Literal["weibull", "loglogistic", "lognormal", "gumbel", "logistic", "normal"]

#: Shape and axis of each sigmoid (see the module docstring).
SIGMOIDS: dict[str, tuple[str, str]] = {
    "weibull": ("gumbel", "log"),
    "loglogistic": ("logistic", "log"),
    "lognormal": ("normal", "log"),
    "gumbel": ("gumbel", "linear"),
    "logistic": ("logistic", "linear"),
    "normal": ("normal", "linear"),
}
#: Upper bound of the overdispersion scale eta (ours: eta -> 1 makes every level all-or-none).
ETA_MAX: float = 0.99
#: Concentration 1/eta^2 - 1 is capped here: beyond it the beta-binomial equals the binomial to
#: < 1e-4 in log-likelihood for levels of up to ~1,000 trials (n^2 / (2 v)), and gammaln stays
#: exact to ~1e-7.
_V_MAX: float = 1e9

#: Chain length required for convergence, in autocorrelation times. Source: emcee documentation
#: ("Autocorrelation analysis & convergence": chains longer than ~50 tau), ours to adopt.
TAU_MULTIPLE: float = 50.0
#: Walkers per fit: ours. :func:`sample_posterior` (emcee) needs at least 2 x ndim; the batch
#: sampler used by :func:`fit_counts` needs an even number >= 8.
N_WALKERS: int = 16
#: Steps per chunk between convergence checks: ours.
CHUNK_STEPS: int = 250


def MOVES() -> list:  # noqa: N802 - a constant-like factory
    """Return emcee moves: differential evolution plus snooker (ours).

    On these posteriors they give an autocorrelation time of ~15-20 steps, against ~40-50 for
    emcee's default stretch move, so the 50 tau chain is 2-3 times shorter.
    """
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


#: Give up (converged = False) after this many steps: ours (about 200 tau for a typical fit).
MAX_STEPS: int = 20_000
#: Posterior samples kept in a fit (thinned), enough for 95 % intervals to +-0.5 % coverage.
KEEP_SAMPLES: int = 4_000
_EPS = 1e-12


class FitWarning(UserWarning):
    """Legal but suspicious data for a psychometric fit (all correct, too few trials, ...)."""


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
        lp = _log_beta_density(lapse, self.lapse_a, self.lapse_b)
        if theta.shape[-1] == 4:
            eta = theta[..., 3]
            inside &= (eta >= 0.0) & (eta <= ETA_MAX)
            lp = lp + _log_beta_density(eta, self.eta_a, self.eta_b)
        return np.where(inside, lp, -np.inf)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {
            "loc_range": list(self.loc_range),
            "log_beta_range": list(self.log_beta_range),
            "lapse_a": self.lapse_a,
            "lapse_b": self.lapse_b,
            "lapse_max": self.lapse_max,
            "eta_a": self.eta_a,
            "eta_b": self.eta_b,
        }

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


def _log_beta_density(v: np.ndarray, a: float, b: float) -> np.ndarray:
    """Unnormalised log Beta(a, b) density (0 outside handled by the caller's box)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lp = (a - 1.0) * np.log(np.where(v > 0, v, 1.0)) + (b - 1.0) * np.log1p(
            -np.clip(v, 0.0, 0.999999)
        )
        if a < 1.0:
            lp = np.where(v > 0, lp, np.inf)
    return lp


def _check_sigmoid(sigmoid: str) -> None:
    if sigmoid not in SIGMOIDS:
        raise ValueError(f"sigmoid must be one of {', '.join(SIGMOIDS)}, got {sigmoid!r}")


def is_log_axis(sigmoid: str) -> bool:
    """Return True when ``sigmoid`` works on log stimulus values (levels must be > 0)."""
    _check_sigmoid(sigmoid)
    return SIGMOIDS[sigmoid][1] == "log"


def _shape_cdf(z: np.ndarray, shape: str) -> np.ndarray:
    if shape == "gumbel":
        with np.errstate(over="ignore"):
            return -np.expm1(-np.exp(z))
    if shape == "logistic":
        return special.expit(z)
    return special.ndtr(z)


def _shape_ppf(f: np.ndarray, shape: str) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        if shape == "gumbel":
            return np.log(-np.log1p(-f))
        if shape == "logistic":
            return special.logit(f)
        return special.ndtri(f)


def _check_guess(guess: float) -> None:
    if not (0.0 <= guess < 1.0):
        raise ValueError(f"guess must be in [0, 1), got {guess!r}")


def _core(x: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            z = beta * (np.log(np.maximum(x, 1e-300)) - np.log(alpha))
    else:
        z = beta * (x - alpha)
    return _shape_cdf(z, shape)


def _core_inverse(f: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    shape, axis = SIGMOIDS[sigmoid]
    z = _shape_ppf(f, shape)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if axis == "log":
            return alpha * np.exp(z / beta)
        return alpha + z / beta


def psychometric(
    x: Any,
    alpha: float,
    beta: float,
    lapse: float,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
) -> np.ndarray:
    """Return the probability correct at stimulus levels ``x``.

    Parameters
    ----------
    x : array_like
        Stimulus levels (pixels for the Weibull: > 0; any unit for the logistic).
    alpha : float
        Scale (Weibull, x units, > 0) or midpoint (logistic, x units).
    beta : float
        Slope parameter, > 0 (dimensionless for the Weibull, 1/x units for the logistic).
    lapse : float
        Lapse rate in [0, 1 - guess).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}

    Returns
    -------
    ndarray
        P(correct), same shape as ``x``.

    Examples
    --------
    >>> float(psychometric(1.0, 1.0, 2.0, 0.0))  # 1 - exp(-1)
    0.6321205588285577
    """
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    x = np.asarray(x, dtype=float)
    return guess + (1.0 - guess - lapse) * _core(x, alpha, beta, sigmoid)


def threshold_at(
    pc: float,
    alpha: Any,
    beta: Any,
    lapse: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
) -> np.ndarray:
    """Return the stimulus level where the curve crosses proportion correct ``pc``.

    This is not ``alpha``: with a lapse rate the 50 % point lies to the right of the Weibull's
    own 63 % point. Where the curve never reaches ``pc`` (``pc >= 1 - lapse``) the result is
    ``+inf``; where it starts above it (``pc <= guess``) it is 0 (Weibull) or ``-inf``.

    Parameters
    ----------
    pc : float
        Proportion correct in (0, 1).
    alpha, beta, lapse : float or ndarray
        Parameters (broadcast together).
    guess : float
        Guess rate.
    sigmoid : {'weibull', 'logistic'}

    Returns
    -------
    ndarray
        Threshold(s) in stimulus units.

    Examples
    --------
    >>> round(float(threshold_at(0.5, 1000.0, 2.0, 0.0)), 3)  # 1000 * ln(2) ** 0.5
    832.555
    """
    _check_sigmoid(sigmoid)
    if not (0.0 < pc < 1.0):
        raise ValueError(f"pc must be in (0, 1), got {pc!r}")
    alpha, beta, lapse = np.broadcast_arrays(
        np.asarray(alpha, float), np.asarray(beta, float), np.asarray(lapse, float)
    )
    f = (pc - guess) / (1.0 - guess - lapse)
    out = _core_inverse(np.clip(f, 1e-15, 1 - 1e-15), alpha, beta, sigmoid)
    low = 0.0 if is_log_axis(sigmoid) else -np.inf
    out = np.where(f >= 1.0, np.inf, np.where(f <= 0.0, low, out))
    return out


def aggregate(x: Any, correct: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the distinct levels, the number correct and the number of trials at each.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial.
    correct : array_like of shape (n_trials,)
        1 (correct/recognised) or 0 per trial.

    Returns
    -------
    levels, k, n : ndarray of shape (n_levels,)
    """
    x = np.asarray(x, dtype=float).ravel()
    c = np.asarray(correct, dtype=float).ravel()
    if x.shape != c.shape:
        raise ValueError(f"x and correct must have the same length, got {x.size} and {c.size}")
    if x.size == 0:
        raise ValueError("x must contain at least one trial, got 0")
    if not np.all(np.isfinite(x)):
        raise ValueError("x must be finite, got NaN or inf")
    if not np.all((c == 0) | (c == 1)):
        raise ValueError("correct must be 0 or 1 for every trial")
    levels, inv = np.unique(x, return_inverse=True)
    n = np.bincount(inv).astype(float)
    k = np.bincount(inv, weights=c).astype(float)
    return levels, k, n


def _axis(x: np.ndarray, sigmoid: str) -> np.ndarray:
    return np.log10(x) if is_log_axis(sigmoid) else x


def default_prior(
    levels: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    lapse_a: float = 1.0,
    lapse_b: float = 10.0,
) -> PsychometricPrior:
    """Return the default prior for stimulus levels ``levels`` (see the module docstring).

    Parameters
    ----------
    levels : array_like
        Stimulus levels tested (> 0 for the Weibull).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}
    lapse_a, lapse_b : float
        Beta prior of the lapse rate (> 0).

    Returns
    -------
    PsychometricPrior
    """
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    lv = np.asarray(levels, dtype=float)
    if is_log_axis(sigmoid) and np.any(lv <= 0):
        raise ValueError(f"levels must be > 0 for the {sigmoid} (log axis), got a value <= 0")
    a = _axis(lv, sigmoid)
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


def _params(theta: np.ndarray, sigmoid: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    loc, lb, lapse = theta[..., 0], theta[..., 1], theta[..., 2]
    alpha = 10.0**loc if is_log_axis(sigmoid) else loc
    return alpha, np.exp(lb), lapse


def _p_matrix(theta: np.ndarray, x: np.ndarray, guess: float, sigmoid: str) -> np.ndarray:
    """P(correct) of shape (n_theta, n_levels)."""
    alpha, beta, lapse = _params(theta, sigmoid)
    shape, axis = SIGMOIDS[sigmoid]
    if axis == "log":
        z = beta[:, None] * (np.log(x)[None, :] - np.log(alpha)[:, None])
    else:
        z = beta[:, None] * (x[None, :] - alpha[:, None])
    p = guess + (1.0 - guess - lapse[:, None]) * _shape_cdf(z, shape)
    return np.clip(p, _EPS, 1.0 - _EPS)


def _log_likelihood(
    theta: np.ndarray, x: np.ndarray, k: np.ndarray, n: np.ndarray, guess: float, sigmoid: str
) -> np.ndarray:
    """Log-likelihood (without the binomial coefficients) for theta of shape (..., 3 or 4).

    Three columns: binomial. Four: beta-binomial with overdispersion scale ``theta[..., 3]``.
    """
    theta = np.atleast_2d(theta)
    p = _p_matrix(theta, x, guess, sigmoid)
    if theta.shape[-1] < 4:
        return (k * np.log(p) + (n - k) * np.log1p(-p)).sum(axis=1)
    eta = np.clip(theta[:, 3], 0.0, ETA_MAX)
    with np.errstate(divide="ignore"):
        v = np.minimum(1.0 / np.maximum(eta, 1e-300) ** 2 - 1.0, _V_MAX)[:, None]
    a, b = p * v, (1.0 - p) * v
    g = special.gammaln
    # log B(k + a, n - k + b) - log B(a, b), minus the binomial coefficient (a constant).
    ll = g(k + a) - g(a) + g(n - k + b) - g(b) - g(n + v) + g(v)
    return ll.sum(axis=1)


class _LogPosterior:
    """Vectorised log posterior over walkers (picklable, for emcee ``vectorize=True``)."""

    def __init__(self, x, k, n, guess, sigmoid, prior):
        self.x, self.k, self.n = x, k, n
        self.guess, self.sigmoid, self.prior = guess, sigmoid, prior

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        lp = self.prior.log_prob(theta)
        ok = np.isfinite(lp)
        out = np.full(theta.shape[0], -np.inf)
        if ok.any():
            out[ok] = lp[ok] + _log_likelihood(
                theta[ok], self.x, self.k, self.n, self.guess, self.sigmoid
            )
        return out


@dataclass(frozen=True)
class MLEstimate:
    """Maximum-likelihood parameters of a psychometric function.

    Parameters
    ----------
    alpha : float
        Scale (Weibull) or midpoint (logistic), x units.
    beta : float
        Slope parameter.
    lapse : float
        Lapse rate.
    log_likelihood : float
        Binomial log-likelihood at the maximum (without the binomial coefficients).
    """

    alpha: float
    beta: float
    lapse: float
    log_likelihood: float

    def to_dict(self) -> dict[str, float]:
        """Return a JSON-ready dict."""
        return {
            "alpha": self.alpha,
            "beta": self.beta,
            "lapse": self.lapse,
            "log_likelihood": self.log_likelihood,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MLEstimate:
        """Rebuild from :meth:`to_dict` output."""
        return cls(**{k: float(d[k]) for k in ("alpha", "beta", "lapse", "log_likelihood")})


def fit_mle(
    levels: Any,
    k: Any,
    n: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    prior: PsychometricPrior | None = None,
) -> MLEstimate:
    """Maximise the binomial likelihood within the prior's box (no prior density).

    Several L-BFGS-B starts across the box; the best is kept.

    Parameters
    ----------
    levels, k, n : array_like of shape (n_levels,)
        Distinct stimulus levels, number correct and number of trials (see :func:`aggregate`).
    guess : float
        Guess rate in [0, 1).
    sigmoid : {'weibull', 'logistic'}
    prior : PsychometricPrior, optional
        Only its box is used; :func:`default_prior` when omitted.

    Returns
    -------
    MLEstimate
    """
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    x = np.asarray(levels, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    prior = prior or default_prior(x, guess=guess, sigmoid=sigmoid)
    bounds = prior.bounds()

    def nll(theta: np.ndarray) -> float:
        return -float(_log_likelihood(theta[None, :], x, k, n, guess, sigmoid)[0])

    # Coarse vectorised grid over the whole box, then local polishing: robust
    # against the flat regions and local optima of lapse-rate models, and cheap.
    (l0, l1), (b0, b1), (_, lmax) = bounds
    g = np.stack(
        np.meshgrid(
            np.linspace(l0, l1, 61),
            np.linspace(b0, b1, 25),
            np.linspace(0.0, lmax, 11),
            indexing="ij",
        ),
        axis=-1,
    ).reshape(-1, 3)
    ll = _log_likelihood(g, x, k, n, guess, sigmoid)
    # The likelihood can be multimodal in the slope (a local maximum with lapse 0 and a ridge
    # towards steep curves with a lapse, as in the MPDiR staircase), so polish the best grid point
    # of each of several slopes and keep the best result.
    per_slope = ll.reshape(61, 25, 11).transpose(1, 0, 2).reshape(25, -1)
    best_in_row = per_slope.max(axis=1)
    starts = []
    for j in np.argsort(best_in_row)[::-1][:4]:
        i_loc, i_lapse = np.unravel_index(int(np.argmax(per_slope[j])), (61, 11))
        starts.append(g.reshape(61, 25, 11, 3)[i_loc, j, i_lapse])
    best = None
    for start in starts:
        # SLSQP: bounded, and much cheaper per call than L-BFGS-B here; Nelder-Mead as fallback.
        r = optimize.minimize(nll, start, method="SLSQP", bounds=bounds, options={"ftol": 1e-10})
        if not r.success or not np.isfinite(r.fun):
            r = optimize.minimize(nll, start, method="Nelder-Mead", bounds=bounds)
        if not np.isfinite(r.fun) or r.fun > nll(start):
            r = optimize.OptimizeResult(x=start, fun=nll(start))
        if best is None or r.fun < best.fun:
            best = r
    alpha, beta, lapse = _params(best.x[None, :], sigmoid)
    return MLEstimate(float(alpha[0]), float(beta[0]), float(lapse[0]), float(-best.fun))


@dataclass(frozen=True)
class SamplerProgress:
    """State of a running posterior sampler, yielded after each chunk of steps.

    Parameters
    ----------
    n_steps : int
        Steps taken so far (per walker).
    tau_max : float
        Largest integrated autocorrelation time over the parameters, steps.
    converged : bool
        True when ``n_steps >= 50 * tau_max``.
    sampler : emcee.EnsembleSampler
        The sampler itself (chain access).
    """

    n_steps: int
    tau_max: float
    converged: bool
    sampler: Any = field(repr=False, compare=False)


def _theta_of_mle(mle: MLEstimate, sigmoid: str) -> np.ndarray:
    loc = math.log10(mle.alpha) if is_log_axis(sigmoid) else mle.alpha
    return np.array([loc, math.log(mle.beta), mle.lapse])


def sample_posterior(
    levels: Any,
    k: Any,
    n: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    prior: PsychometricPrior | None = None,
    start: MLEstimate | None = None,
    overdispersion: bool = False,
    n_walkers: int = N_WALKERS,
    chunk_steps: int = CHUNK_STEPS,
    max_steps: int = MAX_STEPS,
    rng: np.random.Generator | int | None = None,
) -> Iterator[SamplerProgress]:
    """Sample the posterior with emcee, yielding after each chunk of steps (house style H5).

    The generator stops by itself once the chain is ``50 * tau`` long or ``max_steps`` is
    reached; the caller may stop earlier (a time limit) and use the last yielded state.

    Parameters
    ----------
    levels, k, n : array_like of shape (n_levels,)
        Distinct levels, number correct, number of trials.
    guess : float
        Guess rate in [0, 1).
    sigmoid : str
        One of :data:`SIGMOIDS`.
    prior : PsychometricPrior, optional
        :func:`default_prior` when omitted.
    start : MLEstimate, optional
        Centre of the initial walker ball; :func:`fit_mle` when omitted.
    overdispersion : bool
        Sample the beta-binomial model (a fourth parameter, eta) instead of the binomial one.
    n_walkers : int
        Number of walkers (>= 2 x the number of parameters).
    chunk_steps : int
        Steps between convergence checks.
    max_steps : int
        Upper limit on steps per walker.
    rng : numpy.random.Generator or int or None
        Randomness for the initial ball and the sampler's moves.

    Yields
    ------
    SamplerProgress
    """
    ndim = 4 if overdispersion else 3
    if n_walkers < 2 * ndim:
        raise ValueError(
            f"n_walkers must be >= {2 * ndim} (2 x {ndim} parameters), got {n_walkers!r}"
        )
    rng = np.random.default_rng(rng)
    x = np.asarray(levels, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    prior = prior or default_prior(x, guess=guess, sigmoid=sigmoid)
    start = start or fit_mle(x, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    logp = _LogPosterior(x, k, n, guess, sigmoid, prior)

    centre = _theta_of_mle(start, sigmoid)
    if overdispersion:
        centre = np.append(centre, 0.02)
    box = np.array(prior.bounds(ndim))
    lo, hi = box[:, 0], box[:, 1]
    width = hi - lo
    p0 = centre + 1e-3 * width * rng.standard_normal((n_walkers, ndim))
    if overdispersion:
        p0[:, 3] = rng.uniform(0.001, 0.05, n_walkers)
    # Reflect into the box (an MLE on the lapse bound 0 is common) and keep off the edges.
    p0 = np.clip(np.abs(p0 - lo) + lo, lo + 1e-6 * width, hi - 1e-6 * width)

    sampler = emcee.EnsembleSampler(n_walkers, ndim, logp, vectorize=True, moves=MOVES())
    sampler._random = np.random.RandomState(int(rng.integers(2**31)))  # noqa: SLF001 - H18 seed
    state = p0
    steps = 0
    while True:
        todo = min(chunk_steps, max_steps - steps)
        state = sampler.run_mcmc(state, todo, progress=False)
        steps += todo
        chain = sampler.get_chain()
        tau = emcee.autocorr.integrated_time(chain, c=5, tol=0, quiet=True)
        tau_max = float(np.max(tau)) if np.all(np.isfinite(tau)) else math.inf
        converged = steps >= TAU_MULTIPLE * tau_max
        yield SamplerProgress(steps, tau_max, converged, sampler)
        if converged or steps >= max_steps:
            return


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


@dataclass(frozen=True)
class WeibullFit:
    """A fitted psychometric function: data, MLE, posterior samples and convergence.

    (Named for the paper's Weibull; any sigmoid of :data:`SIGMOIDS` is fitted the same way.)

    Parameters
    ----------
    label : str
        What was fitted (a condition, ``"<subject>/<condition>"``, ...).
    sigmoid : str
        One of :data:`SIGMOIDS`.
    guess : float
        Guess rate (fixed).
    levels, k, n : tuple of float
        Distinct stimulus levels (x units), number correct and number of trials at each.
    mle : MLEstimate
        Maximum-likelihood parameters (binomial likelihood).
    samples : ndarray of shape (n_samples, 4)
        Thinned posterior samples of (loc, log_beta, lapse, eta) (see the module docstring).
    converged : bool
        Whether the chain reached ``50 * tau_max`` steps.
    tau_max : float
        Largest integrated autocorrelation time, steps.
    n_steps : int
        Steps per walker.
    n_walkers : int
        Number of walkers.
    prior : PsychometricPrior
        The prior used.
    overdispersion : bool
        Whether the posterior is of the beta-binomial model.
    """

    label: str
    sigmoid: str
    guess: float
    levels: tuple[float, ...]
    k: tuple[float, ...]
    n: tuple[float, ...]
    mle: MLEstimate
    samples: np.ndarray = field(repr=False, compare=False)
    converged: bool
    tau_max: float
    n_steps: int
    n_walkers: int
    prior: PsychometricPrior
    overdispersion: bool = False

    @property
    def n_trials(self) -> int:
        """Number of trials fitted."""
        return int(sum(self.n))

    @property
    def n_correct(self) -> int:
        """Number of correct (recognised) trials."""
        return int(sum(self.k))

    def parameter_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return posterior samples of (alpha, beta, lapse) in natural units."""
        return _params(self.samples, self.sigmoid)

    @property
    def alpha(self) -> float:
        """Posterior median of alpha, x units."""
        return float(np.median(self.parameter_samples()[0]))

    @property
    def beta(self) -> float:
        """Posterior median of beta."""
        return float(np.median(self.parameter_samples()[1]))

    @property
    def lapse(self) -> float:
        """Posterior median of the lapse rate."""
        return float(np.median(self.parameter_samples()[2]))

    @property
    def eta(self) -> float:
        """Posterior median of the overdispersion scale (0 without overdispersion)."""
        return float(np.median(self.samples[:, 3])) if self.samples.shape[1] > 3 else 0.0

    @property
    def eta_ci95(self) -> tuple[float, float]:
        """Central 95 % credible interval of the overdispersion scale."""
        if self.samples.shape[1] < 4:
            return (0.0, 0.0)
        q = np.quantile(self.samples[:, 3], [0.025, 0.975])
        return float(q[0]), float(q[1])

    def decreasing(self) -> bool:
        """Return True when proportion correct falls significantly with level (z < -1.96).

        Tested by a two-parameter binomial logistic regression of correct on the stimulus axis.
        """
        return _decreasing(
            np.asarray(self.levels), np.asarray(self.k), np.asarray(self.n), self.sigmoid
        )

    def threshold(self, pc: float = 0.5) -> Threshold:
        """Return the threshold at proportion correct ``pc`` with its status (see Threshold)."""
        a, b, lapse = self.parameter_samples()
        t = threshold_at(pc, a, b, lapse, guess=self.guess, sigmoid=self.sigmoid)
        # 'inverted_cdf' does not interpolate, so +inf samples (curve never reaches pc) are safe.
        q = np.quantile(t, [0.025, 0.5, 0.975], method="inverted_cdf")
        m = self.mle
        t_mle = float(
            threshold_at(pc, m.alpha, m.beta, m.lapse, guess=self.guess, sigmoid=self.sigmoid)
        )
        lo, hi = min(self.levels), max(self.levels)
        status, reason = self._status(pc, float(q[1]), (float(q[0]), float(q[2])), t_mle)
        return Threshold(
            float(pc), float(q[1]), (float(q[0]), float(q[2])), t_mle, status, lo, hi, reason
        )

    def _status(
        self, pc: float, med: float, ci: tuple[float, float], t_mle: float
    ) -> tuple[str, str]:
        k, n = np.asarray(self.k), np.asarray(self.n)
        lo, hi = min(self.levels), max(self.levels)
        if k.sum() == n.sum():
            return "censored_below", "every trial correct"
        if k.sum() == 0:
            return "censored_above", "no trial correct"
        if len(self.levels) < 2:
            rate = k.sum() / n.sum()
            if rate > pc:
                return "censored_below", "one level tested, above pc there"
            if rate < pc:
                return "censored_above", "one level tested, below pc there"
            return "unidentified", "one level tested"
        if self.decreasing():
            return "unidentified", "proportion correct decreases with level"
        if not (med <= hi):  # also inf / NaN
            return "censored_above", "posterior median above the highest level tested"
        if med < lo:
            return "censored_below", "posterior median below the lowest level tested"
        a_lo, a_hi = (_axis_value(c, self.sigmoid) for c in ci)
        prior_width = self.prior.loc_range[1] - self.prior.loc_range[0]
        if not math.isfinite(a_hi - a_lo) or (a_hi - a_lo) > 0.8 * prior_width:
            return "unidentified", "95 % interval spans most of the prior range"
        return "measured", ""

    def diagnostics(self, pc: float = 0.5) -> list[str]:
        """Return one-line warnings about this fit (unconverged chain, binding prior bound, ...).

        Parameters
        ----------
        pc : float
            Proportion correct of the threshold checked for ML/posterior disagreement.

        Returns
        -------
        list of str
        """
        name = self.label or "fit"
        out: list[str] = []
        if not self.converged:
            out.append(
                f"{name}: MCMC not converged after {self.n_steps} steps "
                f"(tau_max {self.tau_max:.0f}; needs {TAU_MULTIPLE:.0f} tau)"
            )
        box = self.prior.bounds(4)
        names = ("threshold location", "slope", "lapse rate", "overdispersion")
        theta_ml = _theta_of_mle(self.mle, self.sigmoid)
        for j in range(3):
            lo, hi = box[j]
            w = hi - lo
            if j == 2 and lo == 0.0:
                at_hi = theta_ml[j] >= hi - 1e-3 * w
                frac = float(np.mean(self.samples[:, j] > hi - 0.02 * w))
                if at_hi or frac > 0.10:
                    out.append(
                        f"{name}: the {names[j]} presses on its prior upper bound {hi:.3g} "
                        f"(ML {theta_ml[j]:.3g}; {100 * frac:.0f} % of the posterior within 2 % "
                        "of it); the fit is constrained by the prior, not the data"
                    )
                continue
            for side, bound in (("lower", lo), ("upper", hi)):
                at = abs(theta_ml[j] - bound) <= 1e-3 * w
                near = (
                    self.samples[:, j] < lo + 0.02 * w
                    if side == "lower"
                    else (self.samples[:, j] > hi - 0.02 * w)
                )
                frac = float(np.mean(near))
                if at or frac > 0.10:
                    val = math.exp(theta_ml[j]) if j == 1 else theta_ml[j]
                    bval = math.exp(bound) if j == 1 else bound
                    out.append(
                        f"{name}: the {names[j]} presses on its prior {side} bound "
                        f"{bval:.4g} (ML {val:.4g}; {100 * frac:.0f} % of the posterior within "
                        "2 % of it); the estimate is set by the prior box, not the data"
                    )
        if self.samples.shape[1] > 3:
            frac = float(np.mean(self.samples[:, 3] > ETA_MAX - 0.02))
            if frac > 0.10:
                out.append(f"{name}: the overdispersion scale presses on its upper bound")
        if len(self.levels) >= 2 and self.decreasing():
            out.append(
                f"{name}: proportion correct decreases with level; an increasing psychometric "
                "function does not describe these data and its thresholds are not reported"
            )
        t = self.threshold(pc)
        if t.status == "measured" and not (t.ci95[0] <= t.mle <= t.ci95[1]):
            out.append(
                f"{name}: the ML threshold ({t.mle:.4g}) lies outside the 95 % credible interval "
                f"({t.ci95[0]:.4g}-{t.ci95[1]:.4g}); the data barely constrain it"
            )
        elif t.status == "measured" and is_log_axis(self.sigmoid) and t.mle > 0:
            ratio = t.median / t.mle
            if ratio > 1.25 or ratio < 0.8:
                out.append(
                    f"{name}: posterior median ({t.median:.4g}) and ML threshold ({t.mle:.4g}) "
                    f"differ by {100 * abs(ratio - 1):.0f} %; the data barely constrain it"
                )
        if 0 < len(self.levels) < 3:
            out.append(
                f"{name}: only {len(self.levels)} level(s) tested; the slope is not "
                "identified by the data"
            )
        return out

    def goodness_of_fit(
        self, *, n_draws: int = 2000, rng: np.random.Generator | int | None = 0
    ) -> dict[str, float]:
        """Return the deviance at the ML fit and a posterior-predictive p-value.

        The deviance is twice the log-likelihood ratio of the saturated model to the binomial ML
        fit. The posterior-predictive p-value is the fraction of posterior draws for which
        data simulated from the draw (beta-binomial when the fit has overdispersion) have a
        deviance at least as large as the observed data's (Gelman, Meng & Stern 1996); values
        near 0 mean the model misses the data.

        Parameters
        ----------
        n_draws : int
            Posterior draws used.
        rng : numpy.random.Generator or int or None
            Randomness of the simulated data.

        Returns
        -------
        dict
            ``deviance``, ``deviance_df`` (levels - 3), ``ppp``.
        """
        rng = np.random.default_rng(rng)
        x, k, n = (np.asarray(v, float) for v in (self.levels, self.k, self.n))
        m = self.mle
        p_ml = psychometric(x, m.alpha, m.beta, m.lapse, guess=self.guess, sigmoid=self.sigmoid)
        dev = float(_deviance(k, n, np.clip(p_ml, _EPS, 1 - _EPS)))
        idx = np.linspace(0, len(self.samples) - 1, min(n_draws, len(self.samples))).astype(int)
        th = self.samples[idx]
        p = _p_matrix(th[:, :3], x, self.guess, self.sigmoid)
        p_draw = p
        if th.shape[1] > 3 and self.overdispersion:
            v = np.minimum(1.0 / np.maximum(th[:, 3], 1e-6) ** 2 - 1.0, _V_MAX)[:, None]
            p_draw = rng.beta(np.maximum(p * v, 1e-9), np.maximum((1 - p) * v, 1e-9))
        k_rep = rng.binomial(n.astype(int)[None, :], np.clip(p_draw, 0.0, 1.0))
        d_obs = _deviance(k[None, :], n[None, :], p)
        d_rep = _deviance(k_rep, n[None, :], p)
        return {
            "deviance": dev,
            "deviance_df": int(len(x) - 3),
            "ppp": float(np.mean(d_rep >= d_obs)),
        }

    def curve_band(
        self, x: Any, *, level: float = 0.95, max_samples: int = 1000
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the pointwise posterior median and ``level`` band of P(correct) at ``x``."""
        a, b, lapse = self.parameter_samples()
        idx = np.linspace(0, len(a) - 1, min(max_samples, len(a))).astype(int)
        x = np.asarray(x, float)
        p = self.guess + (1 - self.guess - lapse[idx, None]) * _core(
            x[None, :], a[idx, None], b[idx, None], self.sigmoid
        )
        lo, med, hi = np.quantile(p, [(1 - level) / 2, 0.5, (1 + level) / 2], axis=0)
        return med, lo, hi

    def summary(self, pc: float = 0.5) -> dict[str, Any]:
        """Return the results.json entry.

        ``p50_pixels``, ``ci95`` and ``mle_p50_pixels`` (the 50 % threshold's posterior median,
        interval and ML value) are set only when its ``status`` is ``measured`` (None
        otherwise); ``threshold_50`` keeps every number with its status. When ``pc`` differs
        from 0.5, ``threshold``, ``threshold_ci95``, ``mle_threshold`` and ``threshold_pc`` do
        the same at ``pc``.
        """
        t50 = self.threshold(0.5)
        ok = t50.measured
        d: dict[str, Any] = {
            "status": t50.status,
            "p50_pixels": _json_float(t50.median) if ok else None,
            "ci95": [_json_float(t50.ci95[0]), _json_float(t50.ci95[1])] if ok else [None, None],
            "mle_p50_pixels": _json_float(t50.mle) if ok else None,
            "threshold_50": t50.to_dict(),
            "alpha": self.alpha,
            "beta": self.beta,
            "lapse": self.lapse,
            "overdispersion": bool(self.overdispersion),
            "eta": self.eta,
            "eta_ci95": list(self.eta_ci95),
            "converged": bool(self.converged),
            "tau_max": _json_float(self.tau_max),
            "n_trials": self.n_trials,
            "n_recognized": self.n_correct,
            "mle": self.mle.to_dict(),
            "goodness_of_fit": self.goodness_of_fit(),
            "warnings": self.diagnostics(pc),
        }
        if pc != 0.5:
            t = self.threshold(pc)
            ok = t.measured
            d.update(
                pc=pc,
                threshold=_json_float(t.median) if ok else None,
                threshold_ci95=[_json_float(t.ci95[0]), _json_float(t.ci95[1])]
                if ok
                else [None, None],
                mle_threshold=_json_float(t.mle) if ok else None,
                threshold_pc=t.to_dict(),
            )
        return d

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (samples included, as lists)."""
        return {
            "label": self.label,
            "sigmoid": self.sigmoid,
            "guess": self.guess,
            "levels": list(self.levels),
            "k": list(self.k),
            "n": list(self.n),
            "mle": self.mle.to_dict(),
            "samples": self.samples.tolist(),
            "converged": self.converged,
            "tau_max": _json_float(self.tau_max),
            "n_steps": self.n_steps,
            "n_walkers": self.n_walkers,
            "prior": self.prior.to_dict(),
            "overdispersion": self.overdispersion,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> WeibullFit:
        """Rebuild from :meth:`to_dict` output."""
        samples = np.asarray(d["samples"], dtype=float)
        samples = samples.reshape(-1, samples.shape[-1] if samples.ndim == 2 else 4)
        if samples.shape[1] == 3:
            samples = np.column_stack([samples, np.zeros(len(samples))])
        return cls(
            label=str(d["label"]),
            sigmoid=str(d["sigmoid"]),
            guess=float(d["guess"]),
            levels=tuple(float(v) for v in d["levels"]),
            k=tuple(float(v) for v in d["k"]),
            n=tuple(float(v) for v in d["n"]),
            mle=MLEstimate.from_dict(d["mle"]),
            samples=samples,
            converged=bool(d["converged"]),
            tau_max=float(d["tau_max"]) if d["tau_max"] is not None else math.inf,
            n_steps=int(d["n_steps"]),
            n_walkers=int(d["n_walkers"]),
            prior=PsychometricPrior.from_dict(d["prior"]),
            overdispersion=bool(d.get("overdispersion", False)),
        )


def _deviance(k: np.ndarray, n: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Binomial deviance of counts k of n against probabilities p (summed over the last axis)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = np.where(k > 0, k * np.log(k / (n * p)), 0.0)
        t2 = np.where(n - k > 0, (n - k) * np.log((n - k) / (n * (1 - p))), 0.0)
    return 2.0 * np.sum(t1 + t2, axis=-1)


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


def _data_warnings(label: str, k: np.ndarray, n: np.ndarray) -> None:
    total, correct = n.sum(), k.sum()
    if correct == 0 or correct == total:
        what = "none" if correct == 0 else "all"
        side = "above the highest" if correct == 0 else "below the lowest"
        warnings.warn(
            f"{label or 'fit'}: {what} of {int(total)} trials correct; the threshold is not "
            f"located by the data (censored: {side} level tested) and its interval reflects "
            "the prior",
            FitWarning,
            stacklevel=3,
        )
    elif np.mean(n < 5) > 0.5:
        warnings.warn(
            f"{label or 'fit'}: fewer than 5 trials at most levels ({int(total)} trials over "
            f"{len(n)} levels); the fit leans on the prior",
            FitWarning,
            stacklevel=3,
        )


def fit_weibull(
    x: Any,
    correct: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    prior: PsychometricPrior | None = None,
    label: str = "",
    overdispersion: bool = False,
    n_walkers: int = N_WALKERS,
    max_steps: int = MAX_STEPS,
    rng: np.random.Generator | int | None = None,
) -> WeibullFit:
    """Fit a psychometric function to trials: MLE, then an emcee posterior until converged.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial (pixels for the Jung 2015 data; > 0 for log-axis sigmoids).
    correct : array_like of shape (n_trials,)
        1 = correct/recognised, 0 = not, per trial.
    guess : float
        Guess rate in [0, 1) (0 for free recognition, 0.5 for 2AFC).
    sigmoid : str
        One of :data:`SIGMOIDS`.
    prior : PsychometricPrior, optional
        :func:`default_prior` when omitted.
    label : str
        Name of the fitted data, used in warnings and reports.
    overdispersion : bool
        Beta-binomial posterior (free scale eta) instead of binomial.
    n_walkers : int
        emcee walkers.
    max_steps : int
        Steps per walker after which the fit gives up (``converged = False``).
    rng : numpy.random.Generator or int or None
        Randomness of the sampler.

    Returns
    -------
    WeibullFit

    Raises
    ------
    ValueError
        Bad arguments (mismatched lengths, non-positive x for a log axis, bad guess rate).

    Warns
    -----
    FitWarning
        All or no trials correct, or fewer than 5 trials at most levels.

    References
    ----------
    Jung et al. 2015, Sec. 3.2.2 (Weibull fits not forced to 100 %); Wichmann & Hill 2001.
    """
    levels, k, n = aggregate(x, correct)
    return fit_counts(
        levels,
        k,
        n,
        guess=guess,
        sigmoid=sigmoid,
        prior=prior,
        label=label,
        overdispersion=overdispersion,
        n_walkers=n_walkers,
        max_steps=max_steps,
        rng=rng,
    )


def fit_counts(
    levels: Any,
    k: Any,
    n: Any,
    *,
    guess: float = 0.0,
    sigmoid: Sigmoid = "weibull",
    prior: PsychometricPrior | None = None,
    label: str = "",
    overdispersion: bool = False,
    n_walkers: int = N_WALKERS,
    max_steps: int = MAX_STEPS,
    rng: np.random.Generator | int | None = None,
) -> WeibullFit:
    """Fit a psychometric function to aggregated counts (see :func:`fit_weibull`).

    Parameters
    ----------
    levels : array_like of shape (n_levels,)
        Stimulus levels (repeated levels are merged).
    k, n : array_like of shape (n_levels,)
        Number correct and number of trials at each level (0 <= k <= n, n > 0).
    guess, sigmoid, prior, label, overdispersion, n_walkers, max_steps, rng
        As for :func:`fit_weibull`.

    Returns
    -------
    WeibullFit

    Raises
    ------
    ValueError
        Bad counts or arguments.
    """
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    lv = np.asarray(levels, float).ravel()
    kk = np.asarray(k, float).ravel()
    nn = np.asarray(n, float).ravel()
    if not (lv.shape == kk.shape == nn.shape) or lv.size == 0:
        raise ValueError(
            f"levels, k and n must be non-empty and of equal length, got {lv.size}, {kk.size}, "
            f"{nn.size}"
        )
    if not (np.all(np.isfinite(lv)) and np.all(np.isfinite(kk)) and np.all(np.isfinite(nn))):
        raise ValueError("levels, k and n must be finite, got NaN or inf")
    if np.any(nn <= 0) or np.any(kk < 0) or np.any(kk > nn):
        raise ValueError("counts must satisfy 0 <= k <= n and n > 0 at every level")
    levels, inv = np.unique(lv, return_inverse=True)
    k = np.bincount(inv, weights=kk).astype(float)
    n = np.bincount(inv, weights=nn).astype(float)
    if is_log_axis(sigmoid) and levels[0] <= 0:
        raise ValueError(f"x must be > 0 for the {sigmoid} (log axis), got {float(levels[0])!r}")
    _data_warnings(label, k, n)
    rng = np.random.default_rng(rng)
    prior = prior or default_prior(levels, guess=guess, sigmoid=sigmoid)
    mle = fit_mle(levels, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    from analysis.sampler import FitJob, fit_batch

    job = FitJob(label, levels, k, n, float(guess), prior, mle, bool(overdispersion))
    walkers = max(n_walkers + n_walkers % 2, 8)
    (fit,) = fit_batch([job], sigmoid=sigmoid, n_walkers=walkers, max_steps=max_steps, rng=rng)
    if not fit.converged:
        logger.warning(
            "%s: chain not converged after %d steps (tau_max %.0f)",
            label or "fit",
            fit.n_steps,
            fit.tau_max,
        )
    return fit


def _finish(
    label, sigmoid, guess, levels, k, n, mle, prior, progress, overdispersion=False
) -> WeibullFit:
    tau = progress.tau_max if math.isfinite(progress.tau_max) else progress.n_steps / 10
    burn = min(int(3 * tau), progress.n_steps // 2)
    flat = progress.sampler.get_chain(discard=burn, flat=True)
    if len(flat) > KEEP_SAMPLES:
        flat = flat[np.linspace(0, len(flat) - 1, KEEP_SAMPLES).astype(int)]
    if flat.shape[1] == 3:
        flat = np.column_stack([flat, np.zeros(len(flat))])
    if not progress.converged:
        logger.warning(
            "%s: chain not converged after %d steps (tau_max %.0f)",
            label or "fit",
            progress.n_steps,
            progress.tau_max,
        )
    return WeibullFit(
        label=label,
        sigmoid=sigmoid,
        guess=float(guess),
        levels=tuple(float(v) for v in levels),
        k=tuple(float(v) for v in k),
        n=tuple(float(v) for v in n),
        mle=mle,
        samples=np.ascontiguousarray(flat),
        converged=bool(progress.converged),
        tau_max=float(progress.tau_max),
        n_steps=int(progress.n_steps),
        n_walkers=progress.sampler.nwalkers,
        prior=prior,
        overdispersion=bool(overdispersion),
    )
