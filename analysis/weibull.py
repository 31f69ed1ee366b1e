"""Psychometric functions: maximum likelihood and emcee posteriors, thresholds at any level.

The model (Jung et al. 2015, Sec. 3.2.2; Wichmann & Hill 2001) is

    P(x) = g + (1 - g - l) * F(x; alpha, beta)

with ``F = 1 - exp(-(x / alpha) ** beta)`` (Weibull, ``x > 0``, e.g. pixels) or
``F = 1 / (1 + exp(-beta * (x - alpha)))`` (logistic, any real ``x``, e.g. a phase in degrees).
``g`` is the guess rate (0 for free recognition, 0.5 for 2AFC) and ``l`` the lapse rate, which is
free, so the curve is not forced to reach 1. The likelihood is binomial over the distinct stimulus
levels.

Sampled parameters (the columns of ``WeibullFit.samples``):

* ``loc``: ``log10(alpha)`` for the Weibull, ``alpha`` for the logistic;
* ``log_beta``: natural log of the slope parameter ``beta``;
* ``lapse``: the lapse rate ``l``.

Default priors (ours, not the paper's; Psychtoolbox's fit in the paper is maximum likelihood):

* ``loc`` uniform on the stimulus range widened by one range on each side, so the threshold may
  lie outside the tested levels but not absurdly far;
* ``log_beta`` uniform on ``[log(0.5 / span), log(100 / span)]``, ``span`` being the stimulus
  range in the sigmoid's own unit (natural log units for the Weibull), i.e. from a curve rising
  over twice the tested range to one rising within 1 % of it;
* ``lapse`` Beta(1, 10) truncated to ``[0, min(0.5, (1 - g) / 2)]`` (as psignifit; mean 0.09).

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
    "FitWarning",
]

logger = logging.getLogger(__name__)

Sigmoid = Literal["weibull", "logistic"]

#: Chain length required for convergence, in autocorrelation times. Source: emcee documentation
#: ("Autocorrelation analysis & convergence": chains longer than ~50 tau), ours to adopt.
TAU_MULTIPLE: float = 50.0
#: Walkers per fit: ours, the fewest that mix well for 3 parameters with the stretch move
#: (emcee needs at least 2 x ndim); fewer walkers means fewer log-prob calls per step.
N_WALKERS: int = 12
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
    """

    loc_range: tuple[float, float]
    log_beta_range: tuple[float, float]
    lapse_a: float = 1.0
    lapse_b: float = 10.0
    lapse_max: float = 0.5

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

    def bounds(self) -> list[tuple[float, float]]:
        """Return the box of the three sampled parameters (loc, log_beta, lapse)."""
        return [tuple(self.loc_range), tuple(self.log_beta_range), (0.0, self.lapse_max)]

    def log_prob(self, theta: np.ndarray) -> np.ndarray:
        """Return the unnormalised log prior of ``theta`` (shape (..., 3)); -inf outside."""
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
        with np.errstate(divide="ignore", invalid="ignore"):
            lp = (self.lapse_a - 1.0) * np.log(np.where(lapse > 0, lapse, 1.0)) + (
                self.lapse_b - 1.0
            ) * np.log1p(-np.clip(lapse, 0.0, 0.999999))
            if self.lapse_a < 1.0:
                lp = np.where(lapse > 0, lp, np.inf)
        return np.where(inside, lp, -np.inf)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {
            "loc_range": list(self.loc_range),
            "log_beta_range": list(self.log_beta_range),
            "lapse_a": self.lapse_a,
            "lapse_b": self.lapse_b,
            "lapse_max": self.lapse_max,
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
        )


def _check_sigmoid(sigmoid: str) -> None:
    if sigmoid not in ("weibull", "logistic"):
        raise ValueError(f"sigmoid must be 'weibull' or 'logistic', got {sigmoid!r}")


def _check_guess(guess: float) -> None:
    if not (0.0 <= guess < 1.0):
        raise ValueError(f"guess must be in [0, 1), got {guess!r}")


def _core(x: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    if sigmoid == "weibull":
        with np.errstate(divide="ignore", over="ignore"):
            z = np.exp(beta * (np.log(np.maximum(x, 1e-300)) - np.log(alpha)))
        return -np.expm1(-z)
    return special.expit(beta * (x - alpha))


def _core_inverse(f: np.ndarray, alpha: Any, beta: Any, sigmoid: str) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        if sigmoid == "weibull":
            return alpha * (-np.log1p(-f)) ** (1.0 / beta)
        return alpha + special.logit(f) / beta


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
    low = 0.0 if sigmoid == "weibull" else -np.inf
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
    return np.log10(x) if sigmoid == "weibull" else x


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
    if sigmoid == "weibull" and np.any(lv <= 0):
        raise ValueError("levels must be > 0 for the Weibull, got a value <= 0")
    a = _axis(lv, sigmoid)
    lo, hi = float(a.min()), float(a.max())
    span = hi - lo
    if span <= 0:
        # One level only: the threshold is barely identified; a one-decade (or unit) box.
        span = 1.0
    span_natural = span * (math.log(10.0) if sigmoid == "weibull" else 1.0)
    return PsychometricPrior(
        loc_range=(lo - span, hi + span),
        log_beta_range=(math.log(0.5 / span_natural), math.log(100.0 / span_natural)),
        lapse_a=float(lapse_a),
        lapse_b=float(lapse_b),
        lapse_max=min(0.5, (1.0 - guess) / 2.0),
    )


def _params(theta: np.ndarray, sigmoid: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    loc, lb, lapse = theta[..., 0], theta[..., 1], theta[..., 2]
    alpha = 10.0**loc if sigmoid == "weibull" else loc
    return alpha, np.exp(lb), lapse


def _log_likelihood(
    theta: np.ndarray, x: np.ndarray, k: np.ndarray, n: np.ndarray, guess: float, sigmoid: str
) -> np.ndarray:
    """Binomial log-likelihood (without the constant) for theta of shape (..., 3)."""
    theta = np.atleast_2d(theta)
    alpha, beta, lapse = _params(theta, sigmoid)
    if sigmoid == "weibull":
        z = np.exp(beta[:, None] * (np.log(x)[None, :] - np.log(alpha)[:, None]))
        f = -np.expm1(-z)
    else:
        f = special.expit(beta[:, None] * (x[None, :] - alpha[:, None]))
    p = guess + (1.0 - guess - lapse[:, None]) * f
    p = np.clip(p, _EPS, 1.0 - _EPS)
    return (k * np.log(p) + (n - k) * np.log1p(-p)).sum(axis=1)


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
    loc = math.log10(mle.alpha) if sigmoid == "weibull" else mle.alpha
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
    sigmoid : {'weibull', 'logistic'}
    prior : PsychometricPrior, optional
        :func:`default_prior` when omitted.
    start : MLEstimate, optional
        Centre of the initial walker ball; :func:`fit_mle` when omitted.
    n_walkers : int
        Number of walkers (>= 6).
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
    if n_walkers < 6:
        raise ValueError(f"n_walkers must be >= 6 (2 x 3 parameters), got {n_walkers!r}")
    rng = np.random.default_rng(rng)
    x = np.asarray(levels, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    prior = prior or default_prior(x, guess=guess, sigmoid=sigmoid)
    start = start or fit_mle(x, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    logp = _LogPosterior(x, k, n, guess, sigmoid, prior)

    centre = _theta_of_mle(start, sigmoid)
    lo = np.array([b[0] for b in prior.bounds()])
    hi = np.array([b[1] for b in prior.bounds()])
    width = hi - lo
    p0 = centre + 1e-3 * width * rng.standard_normal((n_walkers, 3))
    # Reflect into the box (an MLE on the lapse bound 0 is common) and keep off the edges.
    p0 = np.clip(np.abs(p0 - lo) + lo, lo + 1e-6 * width, hi - 1e-6 * width)

    sampler = emcee.EnsembleSampler(n_walkers, 3, logp, vectorize=True, moves=MOVES())
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


@dataclass(frozen=True)
class Threshold:
    """A threshold: where the fitted curve crosses proportion correct ``pc``.

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
    """

    pc: float
    median: float
    ci95: tuple[float, float]
    mle: float


@dataclass(frozen=True)
class WeibullFit:
    """A fitted psychometric function: data, MLE, posterior samples and convergence.

    Parameters
    ----------
    label : str
        What was fitted (a condition, ``"<subject>/<condition>"``, ...).
    sigmoid : {'weibull', 'logistic'}
    guess : float
        Guess rate (fixed).
    levels, k, n : tuple of float
        Distinct stimulus levels (x units), number correct and number of trials at each.
    mle : MLEstimate
        Maximum-likelihood parameters.
    samples : ndarray of shape (n_samples, 3)
        Thinned posterior samples of (loc, log_beta, lapse) (see the module docstring).
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

    def threshold(self, pc: float = 0.5) -> Threshold:
        """Return the threshold at proportion correct ``pc`` (median, 95 % CrI, MLE)."""
        a, b, lapse = self.parameter_samples()
        t = threshold_at(pc, a, b, lapse, guess=self.guess, sigmoid=self.sigmoid)
        # 'inverted_cdf' does not interpolate, so +inf samples (curve never reaches pc) are safe.
        q = np.quantile(t, [0.025, 0.5, 0.975], method="inverted_cdf")
        m = self.mle
        t_mle = threshold_at(pc, m.alpha, m.beta, m.lapse, guess=self.guess, sigmoid=self.sigmoid)
        return Threshold(float(pc), float(q[1]), (float(q[0]), float(q[2])), float(t_mle))

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
        """Return the results.json entry (``p50_pixels``, ``ci95``, ``mle_p50_pixels``, ...).

        ``p50_pixels`` etc. are always at 50 %; when ``pc`` differs, ``threshold``,
        ``threshold_ci95`` and ``mle_threshold`` give the threshold at ``pc`` too.
        """
        t50 = self.threshold(0.5)
        d: dict[str, Any] = {
            "p50_pixels": _json_float(t50.median),
            "ci95": [_json_float(t50.ci95[0]), _json_float(t50.ci95[1])],
            "mle_p50_pixels": _json_float(t50.mle),
            "alpha": self.alpha,
            "beta": self.beta,
            "lapse": self.lapse,
            "converged": bool(self.converged),
            "tau_max": _json_float(self.tau_max),
            "n_trials": self.n_trials,
            "n_recognized": self.n_correct,
            "mle": self.mle.to_dict(),
        }
        if pc != 0.5:
            t = self.threshold(pc)
            d.update(
                pc=pc,
                threshold=_json_float(t.median),
                threshold_ci95=[_json_float(t.ci95[0]), _json_float(t.ci95[1])],
                mle_threshold=_json_float(t.mle),
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
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> WeibullFit:
        """Rebuild from :meth:`to_dict` output."""
        return cls(
            label=str(d["label"]),
            sigmoid=str(d["sigmoid"]),
            guess=float(d["guess"]),
            levels=tuple(float(v) for v in d["levels"]),
            k=tuple(float(v) for v in d["k"]),
            n=tuple(float(v) for v in d["n"]),
            mle=MLEstimate.from_dict(d["mle"]),
            samples=np.asarray(d["samples"], dtype=float).reshape(-1, 3),
            converged=bool(d["converged"]),
            tau_max=float(d["tau_max"]) if d["tau_max"] is not None else math.inf,
            n_steps=int(d["n_steps"]),
            n_walkers=int(d["n_walkers"]),
            prior=PsychometricPrior.from_dict(d["prior"]),
        )


def _json_float(v: float) -> float | None:
    """JSON has no inf/NaN: those become None (null)."""
    v = float(v)
    return v if math.isfinite(v) else None


def _data_warnings(label: str, k: np.ndarray, n: np.ndarray) -> None:
    total, correct = n.sum(), k.sum()
    if correct == 0 or correct == total:
        what = "none" if correct == 0 else "all"
        warnings.warn(
            f"{label or 'fit'}: {what} of {int(total)} trials correct; the threshold is not "
            "identified by the data and its interval reflects the prior",
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
    n_walkers: int = N_WALKERS,
    max_steps: int = MAX_STEPS,
    rng: np.random.Generator | int | None = None,
) -> WeibullFit:
    """Fit a psychometric function to trials: MLE, then an emcee posterior until converged.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial (pixels for the Jung 2015 data; > 0 for the Weibull).
    correct : array_like of shape (n_trials,)
        1 = correct/recognised, 0 = not, per trial.
    guess : float
        Guess rate in [0, 1) (0 for free recognition, 0.5 for 2AFC).
    sigmoid : {'weibull', 'logistic'}
    prior : PsychometricPrior, optional
        :func:`default_prior` when omitted.
    label : str
        Name of the fitted data, used in warnings and reports.
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
        Bad arguments (mismatched lengths, non-positive x for the Weibull, bad guess rate).

    Warns
    -----
    FitWarning
        All or no trials correct, or fewer than 5 trials at most levels.

    References
    ----------
    Jung et al. 2015, Sec. 3.2.2 (Weibull fits not forced to 100 %); Wichmann & Hill 2001.
    """
    _check_sigmoid(sigmoid)
    _check_guess(guess)
    levels, k, n = aggregate(x, correct)
    if sigmoid == "weibull" and levels[0] <= 0:
        raise ValueError(f"x must be > 0 for the Weibull, got {float(levels[0])!r}")
    _data_warnings(label, k, n)
    rng = np.random.default_rng(rng)
    prior = prior or default_prior(levels, guess=guess, sigmoid=sigmoid)
    mle = fit_mle(levels, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    last = None
    for progress in sample_posterior(
        levels,
        k,
        n,
        guess=guess,
        sigmoid=sigmoid,
        prior=prior,
        start=mle,
        n_walkers=n_walkers,
        max_steps=max_steps,
        rng=rng,
    ):
        last = progress
    assert last is not None
    return _finish(label, sigmoid, guess, levels, k, n, mle, prior, last)


def _finish(label, sigmoid, guess, levels, k, n, mle, prior, progress) -> WeibullFit:
    tau = progress.tau_max if math.isfinite(progress.tau_max) else progress.n_steps / 10
    burn = min(int(3 * tau), progress.n_steps // 2)
    flat = progress.sampler.get_chain(discard=burn, flat=True)
    if len(flat) > KEEP_SAMPLES:
        flat = flat[np.linspace(0, len(flat) - 1, KEEP_SAMPLES).astype(int)]
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
    )
