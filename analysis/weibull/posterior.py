"""Posterior sampling with emcee, chunk by chunk, until the chain is 50 autocorrelation times long.

Convergence follows emcee's advice: the chain is extended in chunks until it is at least
``50 * tau`` long, ``tau`` being the integrated autocorrelation time
(:func:`emcee.autocorr.integrated_time`) of the slowest parameter; otherwise the fit reports
``converged = False``.

The fits do not run this sampler: :func:`analysis.weibull.fit_counts`, ``confocal analyze`` and
the pipeline sample with the batch sampler (:mod:`analysis.weibull.batch`), which runs emcee's
differential-evolution move on many posteriors at once. :func:`sample_posterior` is emcee itself,
kept as the reference: ``tests/analysis/test_sampler_agreement.py`` checks that both give the same
posterior quantiles within Monte Carlo error. The constants here (walkers, chunk and step
limits, samples kept) are shared by both.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import emcee
import numpy as np

from analysis.weibull.kernel import Sigmoid, log_likelihood, theta_of_mle
from analysis.weibull.mle import MLEstimate, fit_mle
from analysis.weibull.priors import PsychometricPrior, default_prior

__all__ = [
    "TAU_MULTIPLE",
    "N_WALKERS",
    "CHUNK_STEPS",
    "MAX_STEPS",
    "KEEP_SAMPLES",
    "MOVES",
    "SamplerProgress",
    "sample_posterior",
]


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
            out[ok] = lp[ok] + log_likelihood(
                theta[ok], self.x, self.k, self.n, self.guess, self.sigmoid
            )
        return out


@dataclass(frozen=True)
class SamplerProgress:
    """State of a running posterior sampler, yielded after each chunk of steps.

    ``n_steps`` steps per walker so far; ``tau_max`` the largest integrated autocorrelation time
    over the parameters, steps; ``converged`` once ``n_steps >= 50 * tau_max``; ``sampler`` the
    ``emcee.EnsembleSampler`` itself (chain access).
    """

    n_steps: int
    tau_max: float
    converged: bool
    sampler: Any = field(repr=False, compare=False)


def sample_posterior(
    pixels: Any,
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
    pixels, k, n : array_like of shape (n_levels,)
        Distinct stimulus values (pixels for the paper's data), number correct, number of
        trials.
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
    x = np.asarray(pixels, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    prior = prior or default_prior(x, guess=guess, sigmoid=sigmoid)
    start = start or fit_mle(x, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    logp = _LogPosterior(x, k, n, guess, sigmoid, prior)

    centre = theta_of_mle(start, sigmoid)
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
