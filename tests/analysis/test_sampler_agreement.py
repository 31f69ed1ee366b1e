"""The fits' sampler against emcee: the same posterior, sampled by the batch sampler that every fit
runs (analysis.weibull.batch) and by emcee itself (analysis.weibull.sample_posterior), must have
the same quantiles within Monte Carlo error."""

from __future__ import annotations

import numpy as np

from analysis.weibull import default_prior, fit_counts, fit_mle, sample_posterior
from analysis.weibull.fit import _finish

#: Quantiles compared: the body of each marginal (the tails' MC error is too wide to test much).
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)
#: Allowed difference in combined MC standard errors (about 20 comparisons: 4 SE keeps a false
#: alarm below 1e-3 overall while a sampler that misses the posterior's spread still fails).
N_SE = 4.0


def _quantile_se(samples: np.ndarray, q: float, n_eff: float) -> float:
    """MC standard error of a sample quantile: sqrt(q(1-q)/n_eff) / density at the quantile,
    the density estimated from the spacing of neighbouring quantiles."""
    lo, hi = np.quantile(samples, [max(q - 0.05, 0.0), min(q + 0.05, 1.0)])
    density = (min(q + 0.05, 1.0) - max(q - 0.05, 0.0)) / max(hi - lo, 1e-12)
    return float(np.sqrt(q * (1 - q) / n_eff) / density)


def _marginals(fit) -> dict[str, np.ndarray]:
    a, b, lapse = fit.parameter_samples()
    return {"log10_alpha": np.log10(a), "log_beta": np.log(b), "lapse": lapse}


def test_batch_sampler_and_emcee_give_the_same_posterior() -> None:
    """Quantiles of log10 alpha, log beta and the lapse rate agree within N_SE combined MC errors
    (effective sample size = walkers x steps / tau of the slower parameter, per sampler)."""
    lv = np.geomspace(100, 10000, 6)
    k, n = np.array([1.0, 4, 12, 21, 27, 28]), np.array([30.0] * 6)
    batch = fit_counts(lv, k, n, rng=1)
    prior = default_prior(lv)
    mle = fit_mle(lv, k, n, prior=prior)
    last = None
    for last in sample_posterior(lv, k, n, prior=prior, start=mle, rng=2):  # noqa: B007
        pass
    ref = _finish("", "weibull", 0.0, lv, k, n, mle, prior, last)
    assert batch.converged and ref.converged
    n_eff = {
        id(f): f.n_walkers * f.n_steps / f.tau_max for f in (batch, ref)
    }  # chains are >= 50 tau long, so n_eff >= 50 x walkers
    far = []
    for name, ours in _marginals(batch).items():
        theirs = _marginals(ref)[name]
        for q in QUANTILES:
            se = np.hypot(
                _quantile_se(ours, q, n_eff[id(batch)]), _quantile_se(theirs, q, n_eff[id(ref)])
            )
            diff = float(np.quantile(ours, q) - np.quantile(theirs, q))
            if abs(diff) > N_SE * se:
                far.append(f"{name} q{q}: batch - emcee = {diff:.4g}, {N_SE} SE = {N_SE * se:.4g}")
    assert not far, far


def test_quantile_error_detects_a_wrong_spread() -> None:
    """The check can fail: a sample twice as wide as the reference is told apart at the quartiles
    with these sample sizes."""
    rng = np.random.default_rng(0)
    ref, wide = rng.normal(0, 1, 4000), rng.normal(0, 2, 4000)
    se = np.hypot(_quantile_se(ref, 0.25, 800), _quantile_se(wide, 0.25, 800))
    assert abs(np.quantile(wide, 0.25) - np.quantile(ref, 0.25)) > N_SE * se
