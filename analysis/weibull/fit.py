"""Fit a psychometric function to trials or counts: ML estimate, then a converged posterior."""

from __future__ import annotations

import logging
import warnings
from typing import Any

import numpy as np

from analysis.weibull.batch import FitJob, fit_batch, fit_of_chain
from analysis.weibull.kernel import Sigmoid, check_guess, check_sigmoid, data_warnings, is_log_axis
from analysis.weibull.mle import fit_mle
from analysis.weibull.model import aggregate
from analysis.weibull.posterior import MAX_STEPS, N_WALKERS
from analysis.weibull.priors import PsychometricPrior, default_prior
from analysis.weibull.summary import WeibullFit

__all__ = ["fit_weibull", "fit_counts", "group_fit_jobs"]

logger = logging.getLogger(__name__)


def fit_weibull(x: Any, correct: Any, **options: Any) -> WeibullFit:
    """Fit a psychometric function to trials: MLE, then a posterior sampled until converged.

    Like :func:`fit_counts` (same options, result, errors and warnings), for one row per trial:
    the trials are counted per level (:func:`aggregate`) and fitted.

    Parameters
    ----------
    x : array_like of shape (n_trials,)
        Stimulus level per trial (pixels for the Jung 2015 data; > 0 for log-axis sigmoids).
    correct : array_like of shape (n_trials,)
        1 = correct/recognised, 0 = not, per trial.
    **options
        ``guess``, ``sigmoid``, ``prior``, ``label``, ``overdispersion``, ``n_walkers``,
        ``max_steps``, ``rng``: as for :func:`fit_counts`.

    References
    ----------
    Jung et al. 2015, Sec. 3.2.2 (Weibull fits not forced to 100 %); Wichmann & Hill 2001.
    """
    pixels, k, n = aggregate(x, correct)
    return fit_counts(pixels, k, n, **options)


def fit_counts(
    pixels: Any,
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
    """Fit a psychometric function to aggregated counts: MLE, then a converged posterior.

    The posterior is sampled by the batch sampler (:func:`analysis.weibull.batch.fit_batch`, the
    one that every fit runs; emcee's differential-evolution move, vectorised) until the chain
    is 50 autocorrelation times long, with the constants of :mod:`analysis.weibull.posterior`.

    Parameters
    ----------
    pixels : array_like of shape (n_levels,)
        Stimulus values: pixels per object for the paper's data, any unit on a linear axis
        (repeated values are merged).
    k, n : array_like of shape (n_levels,)
        Number correct and number of trials at each level (0 <= k <= n, n > 0).
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
        Walkers of the fit's ensemble (even, >= 8).
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
        Bad counts or arguments (mismatched lengths, non-positive pixels for a log axis, bad
        guess rate).

    Warns
    -----
    FitWarning
        All or no trials correct, or fewer than 5 trials at most levels.
    """
    check_sigmoid(sigmoid)
    check_guess(guess)
    lv = np.asarray(pixels, float).ravel()
    kk = np.asarray(k, float).ravel()
    nn = np.asarray(n, float).ravel()
    if not (lv.shape == kk.shape == nn.shape) or lv.size == 0:
        raise ValueError(
            f"pixels, k and n must be non-empty and of equal length, got {lv.size}, {kk.size}, "
            f"{nn.size}"
        )
    if not (np.all(np.isfinite(lv)) and np.all(np.isfinite(kk)) and np.all(np.isfinite(nn))):
        raise ValueError("pixels, k and n must be finite, got NaN or inf")
    if np.any(nn <= 0) or np.any(kk < 0) or np.any(kk > nn):
        raise ValueError("counts must satisfy 0 <= k <= n and n > 0 at every level")
    pixels, inv = np.unique(lv, return_inverse=True)
    k = np.bincount(inv, weights=kk).astype(float)
    n = np.bincount(inv, weights=nn).astype(float)
    if is_log_axis(sigmoid) and pixels[0] <= 0:
        raise ValueError(f"x must be > 0 for the {sigmoid} (log axis), got {float(pixels[0])!r}")
    data_warnings(label, k, n)
    rng = np.random.default_rng(rng)
    prior = prior or default_prior(pixels, guess=guess, sigmoid=sigmoid)
    mle = fit_mle(pixels, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    job = FitJob(label, pixels, k, n, float(guess), prior, mle, bool(overdispersion))
    walkers = max(n_walkers + n_walkers % 2, 8)
    (fit,) = fit_batch([job], sigmoid=sigmoid, n_walkers=walkers, max_steps=max_steps, rng=rng)
    _log_unconverged(fit)
    return fit


def _log_unconverged(fit: WeibullFit) -> None:
    if not fit.converged:
        logger.warning(
            "%s: chain not converged after %d steps (tau_max %.0f)",
            fit.label or "fit",
            fit.n_steps,
            fit.tau_max,
        )


def _finish(
    label, sigmoid, guess, pixels, k, n, mle, prior, progress, overdispersion=False
) -> WeibullFit:
    """Return the fit of the last :class:`SamplerProgress` of :func:`sample_posterior`."""
    job = FitJob(label, pixels, k, n, float(guess), prior, mle, bool(overdispersion))
    fit = fit_of_chain(
        job,
        sigmoid,
        progress.sampler.get_chain(),
        tau_max=progress.tau_max,
        n_steps=progress.n_steps,
        converged=progress.converged,
        n_walkers=progress.sampler.nwalkers,
    )
    _log_unconverged(fit)
    return fit


def group_fit_jobs(
    trials: Any,
    groups: list[tuple[str | None, str]],
    *,
    guess: float,
    prior: PsychometricPrior | None,
    lapse_prior: tuple[float, float],
    overdispersion: bool = False,
) -> tuple[list[FitJob], list[tuple[str | None, str]], list[str]]:
    """Prepare one batch-sampler job per (subject, condition) group of tidy trials.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials with ``subject``, ``condition``, ``pixels`` and ``recognized``.
    groups : list of (subject or None, condition)
        The fits wanted; ``None``: all subjects pooled.
    guess : float
        The guess rate of every fit.
    prior : PsychometricPrior or None
        One prior for every fit; None: :func:`default_prior` of each group's pixels.
    lapse_prior : (float, float)
        The default prior's Beta lapse parameters.
    overdispersion : bool
        Beta-binomial for the pooled fits (per-subject fits stay binomial).

    Returns
    -------
    jobs : list of FitJob
        The groups with trials, in order (label ``condition`` or ``subject S, condition``).
    keys : list of (subject or None, condition)
        The group of each job.
    notes : list of str
        A line per group without trials, and each warning the data or the ML fit gave.
    """
    jobs: list[FitJob] = []
    keys: list[tuple[str | None, str]] = []
    notes: list[str] = []
    for subject, cond in groups:
        m = trials["condition"] == cond
        if subject is not None:
            m &= trials["subject"] == subject
        sel = trials[m]
        label = cond if subject is None else f"subject {subject}, {cond}"
        if len(sel) == 0:
            notes.append(f"{label}: no trials, not fitted")
            continue
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            pixels, k, n = aggregate(sel["pixels"].to_numpy(), sel["recognized"].to_numpy())
            data_warnings(label, k, n)
            p = prior or default_prior(
                pixels, guess=guess, lapse_a=lapse_prior[0], lapse_b=lapse_prior[1]
            )
            mle = fit_mle(pixels, k, n, guess=guess, prior=p)
        notes += [" ".join(str(w.message).split()) for w in caught]
        od = overdispersion and subject is None
        jobs.append(FitJob(label, pixels, k, n, guess, p, mle, od))
        keys.append((subject, cond))
    return jobs, keys, notes
