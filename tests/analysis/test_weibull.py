"""Psychometric fits: analytic values, an independent MLE, convergence, warnings, recovery."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize, stats

from analysis.jung2015 import PIXEL_COUNTS
from analysis.weibull import (
    FitWarning,
    PsychometricPrior,
    WeibullFit,
    aggregate,
    default_prior,
    fit_counts,
    fit_mle,
    fit_weibull,
    psychometric,
    sample_posterior,
    threshold_at,
)

from .conftest import TRUTH

PX = np.array(sorted(PIXEL_COUNTS), dtype=float)


def independent_mle(x, k, n, *, guess, sigmoid, lapse_max, log_beta_bounds=(None, None)):
    """Second method: hand-written binomial likelihood in (alpha, beta, lapse) with Nelder-Mead.

    Different parametrisation (log alpha in natural log, log beta), a different optimizer
    (bounded Nelder-Mead, xatol/fatol 1e-10) and starts on a grid over the levels; returns the
    best (alpha, beta, lapse). The parameter space is the same as ours: lapse in
    [0, lapse_max] and, where given, log(beta) within ``log_beta_bounds``.
    """
    x, k, n = (np.asarray(v, float) for v in (x, k, n))

    def p_of(th):
        a, b, lapse = th
        if sigmoid == "weibull":
            f = 1 - np.exp(-np.exp(math.exp(b) * (np.log(x) - a)))
        else:
            f = 1 / (1 + np.exp(-math.exp(b) * (x - a)))
        return np.clip(guess + (1 - guess - lapse) * f, 1e-12, 1 - 1e-12)

    def nll(th):
        p = p_of(th)
        return -float(np.sum(k * np.log(p) + (n - k) * np.log(1 - p)))

    if sigmoid == "weibull":
        a_starts = np.log(np.geomspace(x.min(), x.max(), 7)[1:-1])
        b_starts = (0.5, 1.5, 4.0)
    else:
        span = x.max() - x.min()
        a_starts = np.linspace(x.min(), x.max(), 7)[1:-1]
        b_starts = (1 / span, 5 / span, 20 / span)
    best = None
    for a_start in a_starts:
        for b0 in b_starts:
            lb0 = math.log(b0)
            if log_beta_bounds[0] is not None:
                lb0 = min(max(lb0, log_beta_bounds[0]), log_beta_bounds[1])
            r = optimize.minimize(
                nll,
                [a_start, lb0, lapse_max / 4],
                method="Nelder-Mead",
                bounds=[(None, None), tuple(log_beta_bounds), (0, lapse_max)],
                options={"xatol": 1e-10, "fatol": 1e-10, "maxiter": 20000, "maxfev": 20000},
            )
            if best is None or r.fun < best.fun:
                best = r
    a, b, lapse = best.x
    return (math.exp(a) if sigmoid == "weibull" else a), math.exp(b), lapse


@pytest.mark.parametrize("sigmoid", ["weibull", "logistic"])
@pytest.mark.parametrize("guess", [0.0, 0.5])
@pytest.mark.parametrize("pc", [0.55, 0.7, 0.9])
def test_threshold_inverts_the_curve(sigmoid, guess, pc):
    t = threshold_at(
        pc, 1000.0, 1.7 if sigmoid == "weibull" else 0.004, 0.03, guess=guess, sigmoid=sigmoid
    )
    p = psychometric(
        t, 1000.0, 1.7 if sigmoid == "weibull" else 0.004, 0.03, guess=guess, sigmoid=sigmoid
    )
    assert float(p) == pytest.approx(pc, abs=1e-12)


def test_analytic_values():
    # P(alpha) = 1 - 1/e for the Weibull; x50 = alpha * ln(2) ** (1/beta) without lapse.
    assert float(psychometric(500.0, 500.0, 3.0, 0.0)) == pytest.approx(1 - math.exp(-1))
    assert float(threshold_at(0.5, 500.0, 3.0, 0.0)) == pytest.approx(500 * math.log(2) ** (1 / 3))
    # With a lapse the 50 % point moves right of the lapse-free one.
    assert threshold_at(0.5, 500.0, 3.0, 0.1) > threshold_at(0.5, 500.0, 3.0, 0.0)
    # A curve that never reaches pc has an infinite threshold; below the guess rate, 0.
    assert threshold_at(0.95, 500.0, 3.0, 0.1) == np.inf
    assert threshold_at(0.4, 500.0, 3.0, 0.0, guess=0.5) == 0.0


def test_bad_arguments():
    with pytest.raises(ValueError, match="sigmoid must be one of weibull, .*normal, got 'probit'"):
        psychometric(1.0, 1.0, 1.0, 0.0, sigmoid="probit")
    with pytest.raises(ValueError, match=r"guess must be in \[0, 1\), got 1.0"):
        psychometric(1.0, 1.0, 1.0, 0.0, guess=1.0)
    with pytest.raises(ValueError, match=r"pc must be in \(0, 1\), got 1.5"):
        threshold_at(1.5, 1.0, 1.0, 0.0)
    with pytest.raises(ValueError, match="x and correct must have the same length, got 2 and 1"):
        aggregate([1, 2], [1])
    with pytest.raises(ValueError, match="correct must be 0 or 1"):
        aggregate([1, 2], [1, 3])
    with pytest.raises(ValueError, match=r"x must be > 0 for the weibull \(log axis\), got -1.0"):
        fit_weibull([-1.0, 2.0], [0, 1])
    with pytest.raises(ValueError, match=r"loc_range must be finite with low < high, got \(2, 1\)"):
        PsychometricPrior(loc_range=(2, 1), log_beta_range=(0, 1))
    with pytest.raises(ValueError, match=r"n_walkers must be >= 6 \(2 x 3 parameters\), got 4"):
        next(sample_posterior(PX, PX * 0 + 5, PX * 0 + 10, n_walkers=4))
    with pytest.raises(ValueError, match=r"n_walkers must be >= 8 \(2 x 4 parameters\), got 6"):
        next(sample_posterior(PX, PX * 0 + 5, PX * 0 + 10, n_walkers=6, overdispersion=True))
    with pytest.raises(ValueError, match="counts must satisfy 0 <= k <= n and n > 0"):
        fit_counts([1.0, 2.0], [3, 1], [2, 2])
    with pytest.raises(ValueError, match="pixels, k and n must be non-empty and of equal length"):
        fit_counts([1.0, 2.0], [1], [2, 2])
    with pytest.raises(ValueError, match="pixels, k and n must be finite"):
        fit_counts([1.0, np.nan], [1, 1], [2, 2])


@pytest.mark.parametrize("case", ["cluttered", "decluttered"])
def test_mle_agrees_with_independent_fit(case):
    rng = np.random.default_rng(11)
    o = TRUTH[case]
    x = np.repeat(PX, 60)
    y = rng.random(x.size) < psychometric(x, o.alpha_px, o.beta, o.lapse)
    lv, k, n = aggregate(x, y)
    m = fit_mle(lv, k, n)
    a, b, lapse = independent_mle(lv, k, n, guess=0.0, sigmoid="weibull", lapse_max=0.5)
    # Both stop at a log-likelihood tolerance of ~1e-6 or better, which moves the 50 % point by
    # well under 0.5 %.
    assert float(threshold_at(0.5, m.alpha, m.beta, m.lapse)) == pytest.approx(
        float(threshold_at(0.5, a, b, lapse)), rel=5e-3
    )


def test_mle_recovers_noise_free_data():
    # Expected counts (k = n * p) with many trials: the MLE is the generating curve.
    n = np.full(PX.size, 1e6)
    k = n * psychometric(PX, 8000.0, 1.2, 0.05)
    m = fit_mle(PX, k, n)
    assert (m.alpha, m.beta, m.lapse) == pytest.approx((8000.0, 1.2, 0.05), rel=1e-3)


@pytest.fixture(scope="module")
def one_fit():
    rng = np.random.default_rng(5)
    o = TRUTH["decluttered"]
    x = np.repeat(PX, 120)
    y = (rng.random(x.size) < psychometric(x, o.alpha_px, o.beta, o.lapse)).astype(int)
    return fit_weibull(x, y, rng=2, label="decluttered")


def test_posterior_converges_and_brackets_mle(one_fit):
    assert one_fit.converged
    assert one_fit.n_steps >= 50 * one_fit.tau_max
    t = one_fit.threshold(0.5)
    assert t.ci95[0] < t.median < t.ci95[1]
    assert t.ci95[0] < t.mle < t.ci95[1]
    assert one_fit.n_trials == 960
    t75 = one_fit.threshold(0.75)
    assert t75.median > t.median


def test_same_seed_same_fit(one_fit):
    rng = np.random.default_rng(5)
    o = TRUTH["decluttered"]
    x = np.repeat(PX, 120)
    y = (rng.random(x.size) < psychometric(x, o.alpha_px, o.beta, o.lapse)).astype(int)
    again = fit_weibull(x, y, rng=2, label="decluttered")
    np.testing.assert_array_equal(again.samples, one_fit.samples)


def test_roundtrip(one_fit):
    d = json.loads(json.dumps(one_fit.to_dict()))
    back = WeibullFit.from_dict(d)
    assert back == one_fit  # dataclass equality (samples excluded from ==)
    np.testing.assert_array_equal(back.samples, one_fit.samples)
    assert back.threshold(0.5) == one_fit.threshold(0.5)
    assert back.summary() == one_fit.summary()


def test_not_converged_is_reported():
    x = np.repeat(PX, 10)
    y = (np.random.default_rng(1).random(x.size) < psychometric(x, 5000, 1, 0.05)).astype(int)
    fit = fit_weibull(x, y, rng=1, max_steps=60)
    assert not fit.converged and fit.n_steps == 60
    assert fit.summary()["converged"] is False


def test_generator_lets_the_caller_stop():
    lv, k, n = PX, np.array([0, 1, 3, 8, 12, 17, 19, 19.0]), np.full(8, 20.0)
    steps = []
    for prog in sample_posterior(lv, k, n, chunk_steps=50, max_steps=10_000, rng=0):
        steps.append(prog.n_steps)
        if len(steps) == 2:
            break
    assert steps == [50, 100]


def test_all_recognised_warns_and_interval_is_wide():
    x = np.repeat(PX, 20)
    with pytest.warns(FitWarning, match=r"all of 160 trials correct; the threshold is not"):
        fit = fit_weibull(x, np.ones(x.size), rng=0, label="cluttered")
    lo, hi = fit.threshold(0.5).ci95
    # Only bounded by the prior: the interval spans more than a decade.
    assert hi / lo > 10


def test_few_trials_warns():
    with pytest.warns(FitWarning, match="fewer than 5 trials at most levels"):
        fit_weibull(PX, [0, 0, 1, 0, 1, 1, 1, 1], rng=0)


def test_wide_lapse_prior_warns():
    with pytest.warns(FitWarning, match=r"the lapse prior puts \d+ % of its mass above .* 0.2"):
        PsychometricPrior(loc_range=(0, 1), log_beta_range=(0, 1), lapse_a=1, lapse_b=1)
    assert default_prior(PX).lapse_mass_above(0.2) < 0.15


def test_default_prior_bounds():
    p = default_prior(PX)
    assert p.loc_range[0] < math.log10(96) and p.loc_range[1] > math.log10(160884)
    assert default_prior(PX, guess=0.5).lapse_max == 0.25
    with pytest.raises(ValueError, match=r"pixels must be > 0 for the weibull \(log axis\)"):
        default_prior([0.0, 1.0])


@pytest.mark.slow
def pass_mark(p_bad: float = 0.85, p_good: float = 0.95) -> tuple[int, int]:
    """Return (intervals, hits needed): the fewest intervals n, and a mark c, such that a method
    with coverage ``p_bad`` passes (Binomial(n, p_bad) >= c) at most 10 % of the time while a
    calibrated one (``p_good``) passes at least 99 % of the time."""
    for n in range(20, 400, 2):
        c = int(stats.binom.isf(0.10, n, p_bad)) + 1
        while stats.binom.sf(c - 1, n, p_bad) > 0.10:
            c += 1
        if stats.binom.sf(c - 1, n, p_good) >= 0.99:
            return n, c
    raise AssertionError("no replicate count found")


def test_pass_mark_fails_an_85_percent_method():
    n, c = pass_mark()
    assert stats.binom.sf(c - 1, n, 0.85) <= 0.10  # an 85 % method fails >= 90 % of the time
    assert stats.binom.sf(c - 1, n, 0.95) >= 0.99  # a calibrated one passes >= 99 % of the time
    assert (n, c) == (108, 97)  # the search above, written out so a change is noticed


@pytest.mark.slow
def test_parameter_recovery_coverage():
    """Ideal observers, paper design; n intervals from :func:`pass_mark` (54 studies x 2).

    Fitted as the study command fits pooled data (beta-binomial posteriors, batch sampler).
    The full run with heterogeneous observers is ``benchmarks/validate_weibull_coverage.py``.
    """
    from analysis.simulate import simulate_weibull_trials
    from analysis.weibull.batch import FitJob, fit_batch

    n, c_min = pass_mark()
    jobs, truth = [], []
    for child in np.random.SeedSequence(123).spawn(n // 2):
        d = simulate_weibull_trials(TRUTH, rng=np.random.default_rng(child))
        for c, o in TRUTH.items():
            sel = d[d["condition"] == c]
            lv, k, nn = aggregate(sel["pixels"], sel["recognized"])
            prior = default_prior(lv)
            jobs.append(FitJob(c, lv, k, nn, 0.0, prior, fit_mle(lv, k, nn, prior=prior), True))
            truth.append(float(threshold_at(0.5, o.alpha_px, o.beta, o.lapse)))
    fits = fit_batch(jobs, rng=5)
    hits = sum(
        f.threshold(0.5).ci95[0] <= t <= f.threshold(0.5).ci95[1]
        for f, t in zip(fits, truth, strict=True)
    )
    print(f"coverage {hits}/{n}; pass mark {c_min}")
    assert all(f.converged for f in fits)
    assert hits >= c_min
