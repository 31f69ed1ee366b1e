"""Each printed interval names its target; the pooled-curve interval recovers its target."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
from scipy import optimize

from analysis.pooled_curve import pooled_curve_threshold
from analysis.weibull import aggregate, default_prior, fit_mle, threshold_at

LEVELS = np.array([96.0, 486, 950, 3290, 6370, 17876, 40344, 160884])


def _pooled_curve(alpha: np.ndarray, beta: float, lapse: float):
    """The mean curve of cells with Weibull scales ``alpha``, and its 50 % point (brentq)."""

    def p(x):
        return (1 - lapse) * np.mean(-np.expm1(-((np.asarray(x)[..., None] / alpha) ** beta)), -1)

    return p, 10 ** optimize.brentq(lambda t: p(10**t) - 0.5, 0, 8, xtol=1e-12)


def _trials(p, n: int, rng=None):
    """Per-trial arrays with ``n`` trials per level: expected counts, or binomial draws."""
    k = np.rint(n * p(LEVELS)) if rng is None else rng.binomial(n, p(LEVELS))
    x = np.repeat(LEVELS, n)
    y = np.concatenate([np.r_[np.ones(int(kk)), np.zeros(n - int(kk))] for kk in k])
    return x, y


#: 120 subject x object cells, scales spread as the coverage benchmark's heterogeneous setting.
_rng = np.random.default_rng(7)
CELLS = (
    10_500
    * np.outer(
        10 ** (0.15 * _rng.standard_normal(6)), 10 ** (0.2 * _rng.standard_normal(20))
    ).ravel()
)


def test_pooled_curve_point_is_where_these_cells_recognise_half_the_time():
    # Near-noise-free data from 120 differing cells: the fitted Weibull misses the pooled curve's
    # 50 % point by several percent; the pooled-curve model recovers it (independent: brentq).
    p, truth = _pooled_curve(CELLS, 1.3, 0.05)
    x, y = _trials(p, 20_000)
    lv, k, n = aggregate(x, y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = fit_mle(lv, k, n, prior=default_prior(lv))
    weibull = float(threshold_at(0.5, m.alpha, m.beta, m.lapse))
    assert weibull / truth > 1.03
    r = pooled_curve_threshold(x, y)
    assert r["threshold"] == pytest.approx(truth, rel=0.005)
    lo, hi = r["ci95"]
    assert lo < truth < hi and hi / lo < 1.1


def test_pooled_curve_interval_is_a_likelihood_ratio_interval():
    # The profile interval's ends are where the likelihood ratio against the best fit is 3.84:
    # checked with a second implementation of the curve (Aranda-Ordaz written as
    # 1 - exp(-log(1 + lam e^z) / lam), the location found by brentq for each threshold),
    # maximised over slope, lapse and asymmetry by Powell's method from several starts.
    rng = np.random.default_rng(3)
    p, _ = _pooled_curve(8000 * 10 ** (0.2 * rng.standard_normal(30)), 1.2, 0.03)
    x, y = _trials(p, 120, rng)
    r = pooled_curve_threshold(x, y)
    lv, k, n = aggregate(x, y)

    def curve(d, s, lapse, lam):
        z = np.minimum(s * np.asarray(d, float), 700.0)
        core = (
            1 - np.exp(-np.log1p(lam * np.exp(z)) / lam) if lam > 1e-6 else 1 - np.exp(-np.exp(z))
        )
        return (1 - lapse) * core

    def ll(t, s, lapse, lam):
        a = optimize.brentq(lambda a: curve(t - a, s, lapse, lam) - 0.5, t - 20, t + 20)
        q = np.clip(curve(np.log10(lv) - a, s, lapse, lam), 1e-12, 1 - 1e-12)
        return float(np.sum(k * np.log(q) + (n - k) * np.log1p(-q)))

    def prof(t):
        best = -math.inf
        for s0, lam0 in ((r["slope"], r["asymmetry"]), (2.5, 0.0), (2.5, 1.0), (5.0, 3.0)):
            f = optimize.minimize(
                lambda v: -ll(t, math.exp(v[0]), v[1], v[2]),
                [math.log(s0), r["lapse"], lam0],
                method="Powell",
                bounds=[(-3, 5), (0, 0.2), (0, 5)],
                options={"xtol": 1e-6, "ftol": 1e-10},
            )
            best = max(best, -f.fun)
        return best

    top = prof(math.log10(r["threshold"]))
    for end in r["ci95"]:
        assert 2 * (top - prof(math.log10(end))) == pytest.approx(3.841, abs=0.05)


def test_pooled_curve_interval_covers_its_target_in_most_studies():
    # A small-rep version of benchmarks/validate_weibull_coverage.py (pooled-curve interval,
    # 'these subjects and objects'): 12 studies of differing cells with binomial noise. A
    # calibrated 95 % interval misses 3 or more of 12 with probability 0.02 (binomial).
    rng = np.random.default_rng(2015)
    hits = 0
    for _ in range(12):
        cells = (
            10_500
            * np.outer(
                10 ** (0.15 * rng.standard_normal(6)), 10 ** (0.2 * rng.standard_normal(20))
            ).ravel()
        )
        p, truth = _pooled_curve(cells, 1.3, 0.06)
        x, y = _trials(p, 120, rng)
        r = pooled_curve_threshold(x, y)
        hits += r is not None and r["ci95"][0] <= truth <= r["ci95"][1]
    assert hits >= 10


def test_every_printed_interval_names_its_target(small_result):
    from analysis.pipeline import AnalysisResult
    from analysis.report import (
        QUESTION_FITTED,
        QUESTION_ODDS_RATIO,
        QUESTION_POPULATION,
        QUESTION_SAMPLE,
        THRESHOLD_INTERVALS_NOTE,
        render_markdown,
    )

    text = render_markdown(small_result, figures=False)
    measured = [c for c, f in small_result.thresholds.items() if f.threshold(0.5).measured]
    assert measured and all(c in small_result.pooled_curve for c in measured)
    assert "95 % CrI" in text and f"for {QUESTION_FITTED};" in text
    assert f"; pooled curve {small_result.pooled_curve[measured[0]]['threshold']:,.0f} px" in text
    assert f"px for {QUESTION_SAMPLE}; asymmetric curve" in text
    assert f"for {QUESTION_POPULATION}" in text
    assert f"for {QUESTION_ODDS_RATIO})" in text
    from analysis.report import OR_INTERVALS_NOTE

    assert THRESHOLD_INTERVALS_NOTE in text and OR_INTERVALS_NOTE in text
    # the notes state measured coverages, no unfilled placeholders
    for note in (THRESHOLD_INTERVALS_NOTE, OR_INTERVALS_NOTE):
        assert not re.search(r"\b[A-Z]{2,}_[A-Z_]+\b", note)
        assert re.search(r"0\.9[3-7]\d", note)
    # carried through results.json and the saved result
    again = AnalysisResult.from_dict(small_result.to_dict())
    assert again.pooled_curve == small_result.pooled_curve
    assert small_result.results_json()["thresholds"][measured[0]]["pooled_curve"]["ci95"]


def test_console_names_every_interval_target(small_result, tmp_path, capsys):
    from analysis.cli import _print_summary
    from analysis.report import (
        QUESTION_FITTED,
        QUESTION_ODDS_RATIO,
        QUESTION_POPULATION,
        QUESTION_SAMPLE,
    )

    _print_summary(small_result, tmp_path)
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("50% threshold   cluttered"))
    for target in (QUESTION_FITTED, QUESTION_SAMPLE, QUESTION_POPULATION):
        assert f"for {target}" in line
    assert out.count(f"for {QUESTION_ODDS_RATIO}") == 2
