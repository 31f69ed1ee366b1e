"""Many psychometric posteriors sampled at once: one vectorised ensemble sampler for all fits.

This is the sampler every fit runs (:func:`analysis.weibull.fit_counts`, ``confocal analyze fit``
and the pipeline); :func:`analysis.weibull.sample_posterior` (emcee itself) is the reference it
is checked against (``tests/analysis/test_sampler_agreement.py``: same posterior quantiles within
Monte Carlo error).

A study analysis needs a dozen or more small posteriors (per condition, per subject, per group).
Run one at a time through emcee, each step costs more in Python overhead than in arithmetic. Here
every fit keeps its own ensemble of walkers, and one step of all ensembles is one NumPy
evaluation of the log posterior over (fits x walkers x levels).

The move is emcee's differential-evolution move (``emcee.moves.DEMove``; ter Braak 2006): walkers
are split into two halves, and each walker of one half proposes
``x + gamma * (x_j - x_k) + 1e-5 * N(0, 1)`` with ``x_j, x_k`` two different walkers of the other
half *of the same fit*, ``gamma = 2.38 / sqrt(2 d)``; one proposal in ten uses ``gamma = 1`` to
jump between modes (ter Braak 2006). The proposal is symmetric, so it is accepted with
probability ``min(1, p(x') / p(x))``. Each fit stops once its chain is ``50 tau`` long
(:data:`analysis.weibull.posterior.TAU_MULTIPLE`, tau from
:func:`emcee.autocorr.integrated_time`), as :func:`analysis.weibull.sample_posterior` does.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import emcee
import numpy as np

from analysis.weibull.kernel import (
    EPS,
    ETA_MAX,
    SIGMOIDS,
    beta_binomial_ll,
    binomial_ll,
    check_guess,
    check_sigmoid,
    log_beta_density,
    shape_cdf,
    theta_of_mle,
)
from analysis.weibull.mle import MLEstimate
from analysis.weibull.posterior import CHUNK_STEPS, KEEP_SAMPLES, MAX_STEPS, TAU_MULTIPLE
from analysis.weibull.priors import PsychometricPrior
from analysis.weibull.summary import WeibullFit

__all__ = ["FitJob", "BatchProgress", "sample_batch", "fit_batch", "fit_of_chain", "BATCH_WALKERS"]

#: Walkers per fit (ours): 16 = 8 per half, so each half offers 56 difference vectors.
BATCH_WALKERS: int = 16


@dataclass(frozen=True)
class FitJob:
    """One posterior to sample: aggregated data, prior, ML start.

    Parameters
    ----------
    label : str
        Name used in warnings and reports.
    pixels, k, n : ndarray of shape (n_levels,)
        Distinct stimulus values (x units: pixels for the paper's data), number correct, number
        of trials (n > 0).
    guess : float
        Guess rate in [0, 1).
    prior : PsychometricPrior
    mle : MLEstimate
        Binomial ML estimate (centre of the starting ball).
    overdispersion : bool
        Beta-binomial posterior (fourth parameter eta).
    """

    label: str
    pixels: np.ndarray
    k: np.ndarray
    n: np.ndarray
    guess: float
    prior: PsychometricPrior
    mle: MLEstimate
    overdispersion: bool = False


@dataclass(frozen=True)
class BatchProgress:
    """State of :func:`sample_batch` after a chunk of steps: ``n_done`` of ``n_fits`` fits done.

    A fit is done when converged or out of steps; the others have taken ``n_steps`` steps.
    ``fits`` is set on the last yield only, in job order.
    """

    n_steps: int
    n_done: int
    n_fits: int
    fits: list[WeibullFit] | None = field(default=None, repr=False)


class _Batch:
    """Padded arrays of a set of jobs and their vectorised log posterior."""

    def __init__(self, jobs: Sequence[FitJob], sigmoid: str):
        self.sigmoid = sigmoid
        self.shape, axis = SIGMOIDS[sigmoid]
        self.log = axis == "log"
        n_lv = max(len(j.pixels) for j in jobs)
        f = len(jobs)
        self.x = np.ones((f, n_lv))
        self.k = np.zeros((f, n_lv))
        self.n = np.zeros((f, n_lv))
        for i, j in enumerate(jobs):
            m = len(j.pixels)
            # Padding repeats a real level with n = k = 0: it adds exactly 0 to the likelihood.
            self.x[i, :m], self.x[i, m:] = j.pixels, j.pixels[0]
            self.k[i, :m], self.n[i, :m] = j.k, j.n
        self.u = np.log(self.x) if self.log else self.x
        self.guess = np.array([j.guess for j in jobs])
        pr = [j.prior for j in jobs]
        self.lo = np.array([[p.loc_range[0], p.log_beta_range[0], 0.0, 0.0] for p in pr])
        self.hi = np.array(
            [[p.loc_range[1], p.log_beta_range[1], p.lapse_max, ETA_MAX] for p in pr]
        )
        self.lapse_ab = np.array([[p.lapse_a, p.lapse_b] for p in pr])
        self.eta_ab = np.array([[p.eta_a, p.eta_b] for p in pr])
        self.od = np.array([j.overdispersion for j in jobs])

    def log_prob(self, theta: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """Log posterior of theta (len(idx), W, 4) for the fits ``idx``."""
        lo, hi = self.lo[idx][:, None, :], self.hi[idx][:, None, :]
        inside = np.all((theta >= lo) & (theta <= hi), axis=-1)
        loc, lb, lapse, eta = (theta[..., i] for i in range(4))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            lp = _beta_lp(lapse, self.lapse_ab[idx])
            od = self.od[idx]
            if od.any():  # the scale's prior, for the beta-binomial fits only
                lp = lp + np.where(od[:, None], _beta_lp(eta, self.eta_ab[idx]), 0.0)
            s_alpha = loc * math.log(10.0) if self.log else loc
            z = np.exp(lb)[..., None] * (self.u[idx][:, None, :] - s_alpha[..., None])
            g = self.guess[idx][:, None, None]
            p = g + (1.0 - g - lapse[..., None]) * shape_cdf(z, self.shape)
            p = np.clip(p, EPS, 1.0 - EPS)
            k, n = self.k[idx][:, None, :], self.n[idx][:, None, :]
            ll = binomial_ll(k, n, p).sum(-1)
            if od.any():
                bb = beta_binomial_ll(k, n, p, eta[..., None]).sum(-1)
                ll = np.where(od[:, None], bb, ll)
        out = np.where(inside, lp + ll, -np.inf)
        return np.where(np.isnan(out), -np.inf, out)


def _beta_lp(v: np.ndarray, ab: np.ndarray) -> np.ndarray:
    """Log Beta density of v (fits, walkers), one (a, b) row of ``ab`` per fit."""
    return log_beta_density(v, ab[:, 0][:, None], ab[:, 1][:, None])


def sample_batch(
    jobs: Sequence[FitJob],
    *,
    sigmoid: str = "weibull",
    n_walkers: int = BATCH_WALKERS,
    chunk_steps: int = CHUNK_STEPS,
    max_steps: int = MAX_STEPS,
    rng: np.random.Generator | int | None = None,
) -> Iterator[BatchProgress]:
    """Sample every job's posterior together, yielding after each chunk (house style H5).

    Parameters
    ----------
    jobs : sequence of FitJob
        Posteriors to sample (at least one), all with the same sigmoid.
    sigmoid : str
        One of :data:`analysis.weibull.SIGMOIDS`.
    n_walkers : int
        Walkers per fit (even, >= 8).
    chunk_steps : int
        Steps between convergence checks.
    max_steps : int
        Steps after which a fit gives up (``converged = False``).
    rng : numpy.random.Generator or int or None
        All randomness of the batch.

    Yields
    ------
    BatchProgress
        The last one carries the fits, in job order.
    """
    check_sigmoid(sigmoid)
    if not jobs:
        raise ValueError("jobs must hold at least one FitJob, got none")
    if n_walkers < 8 or n_walkers % 2:
        raise ValueError(f"n_walkers must be even and >= 8, got {n_walkers!r}")
    for j in jobs:
        check_guess(j.guess)
    rng = np.random.default_rng(rng)
    batch = _Batch(jobs, sigmoid)
    nf, w, h = len(jobs), n_walkers, n_walkers // 2
    ndim = np.where(batch.od, 4, 3)
    dim_mask = np.ones((nf, 4))
    dim_mask[~batch.od, 3] = 0.0
    gamma0 = 2.38 / np.sqrt(2.0 * ndim)

    # Start: a small ball around the ML estimate, reflected into the box.
    centre = np.array([[*theta_of_mle(j.mle, sigmoid), 0.0] for j in jobs])
    width = batch.hi - batch.lo
    p0 = centre[:, None, :] + 1e-3 * width[:, None, :] * rng.standard_normal((nf, w, 4))
    p0[:, :, 3] = np.where(batch.od[:, None], rng.uniform(0.001, 0.05, (nf, w)), 0.0)
    lo, hi = batch.lo[:, None, :], batch.hi[:, None, :]
    p0 = np.clip(np.abs(p0 - lo) + lo, lo + 1e-6 * width[:, None, :], hi - 1e-6 * width[:, None, :])
    p0[:, :, 3] *= dim_mask[:, None, 3]
    state = p0
    all_idx = np.arange(nf)
    lp = batch.log_prob(state, all_idx)

    chains: list[list[np.ndarray]] = [[] for _ in range(nf)]
    steps = np.zeros(nf, int)
    tau = np.full(nf, math.inf)
    done = np.zeros(nf, bool)
    converged = np.zeros(nf, bool)
    total = 0
    while not done.all():
        act = np.flatnonzero(~done)
        s, l_act = state[act], lp[act]
        todo = int(min(chunk_steps, max_steps - steps[act].min()))
        buf = np.empty((todo, len(act), w, 4))
        for t in range(todo):
            for first in (True, False):
                a_sl, b_sl = (slice(0, h), slice(h, w)) if first else (slice(h, w), slice(0, h))
                xa, xb = s[:, a_sl], s[:, b_sl]
                j1 = rng.integers(h, size=(len(act), h))
                j2 = (j1 + 1 + rng.integers(h - 1, size=(len(act), h))) % h
                rows = np.arange(len(act))[:, None]
                diff = xb[rows, j1] - xb[rows, j2]
                gam = np.where(rng.random((len(act), h)) < 0.1, 1.0, gamma0[act][:, None])
                noise = 1e-5 * rng.standard_normal((len(act), h, 4))
                prop = xa + (gam[..., None] * diff + noise) * dim_mask[act][:, None, :]
                lp_new = batch.log_prob(prop, act)
                accept = np.log(rng.random((len(act), h))) < lp_new - l_act[:, a_sl]
                xa = np.where(accept[..., None], prop, xa)
                s[:, a_sl] = xa
                l_act[:, a_sl] = np.where(accept, lp_new, l_act[:, a_sl])
            buf[t] = s
        state[act], lp[act] = s, l_act
        total += todo
        for i_local, f in enumerate(act):
            chains[f].append(buf[:, i_local])
            steps[f] += todo
            chain = np.concatenate(chains[f])[..., : ndim[f]]
            tf = emcee.autocorr.integrated_time(chain, c=5, tol=0, quiet=True)
            tau[f] = float(np.max(tf)) if np.all(np.isfinite(tf)) else math.inf
            converged[f] = steps[f] >= TAU_MULTIPLE * tau[f]
            done[f] = converged[f] or steps[f] >= max_steps
        if not done.all():
            yield BatchProgress(total, int(done.sum()), nf)
    fits = [
        fit_of_chain(
            j,
            sigmoid,
            np.concatenate(chains[f]),
            tau_max=tau[f],
            n_steps=steps[f],
            converged=converged[f],
            n_walkers=w,
        )
        for f, j in enumerate(jobs)
    ]
    yield BatchProgress(total, nf, nf, fits)


def fit_of_chain(
    job: FitJob,
    sigmoid: str,
    chain: np.ndarray,
    *,
    tau_max: float,
    n_steps: int,
    converged: bool,
    n_walkers: int,
) -> WeibullFit:
    """Return the fit of ``job`` from its chain of shape (n_steps, n_walkers, 3 or 4).

    The first ``3 tau`` steps (at most half the chain; ``tau`` = steps / 10 when it is not
    finite) are burn-in; the rest is thinned evenly to at most :data:`KEEP_SAMPLES` samples,
    and a binomial chain gets an all-zero eta column.
    """
    tau = tau_max if math.isfinite(tau_max) else n_steps / 10
    burn = min(int(3 * tau), n_steps // 2)
    flat = chain[burn:].reshape(-1, chain.shape[-1])
    if len(flat) > KEEP_SAMPLES:
        flat = flat[np.linspace(0, len(flat) - 1, KEEP_SAMPLES).astype(int)]
    if flat.shape[1] == 3:
        flat = np.column_stack([flat, np.zeros(len(flat))])
    return WeibullFit(
        label=job.label,
        sigmoid=sigmoid,
        guess=float(job.guess),
        pixels=tuple(float(v) for v in job.pixels),
        k=tuple(float(v) for v in job.k),
        n=tuple(float(v) for v in job.n),
        mle=job.mle,
        samples=np.ascontiguousarray(flat),
        converged=bool(converged),
        tau_max=float(tau_max),
        n_steps=int(n_steps),
        n_walkers=n_walkers,
        prior=job.prior,
        overdispersion=bool(job.overdispersion),
    )


def fit_batch(
    jobs: Sequence[FitJob], *, sigmoid: str = "weibull", **kwargs: Any
) -> list[WeibullFit]:
    """Return the fits of :func:`sample_batch` (runs it to the end).

    Parameters
    ----------
    jobs : sequence of FitJob
    sigmoid : str
    **kwargs
        ``n_walkers``, ``chunk_steps``, ``max_steps``, ``rng`` of :func:`sample_batch`.

    Returns
    -------
    list of WeibullFit
    """
    last = None
    for prog in sample_batch(jobs, sigmoid=sigmoid, **kwargs):
        last = prog
    return last.fits
