"""Logistic regression: agreement with an independent fit, classification table, Eq. 1."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize, special, stats

from analysis.jung2015 import EQ1_EXAMPLES, eq1
from analysis.logistic import (
    LogisticFit,
    OddsRatioTable,
    firth_logit,
    fit_logistic,
    predict_from_odds_ratio,
)
from analysis.mixed import MixedFit, fit_mixed, laplace_glmm
from analysis.simulate import LogisticObserver, simulate_logistic_trials
from tests.analysis.conftest import hand_design_matrix


@pytest.fixture(scope="module")
def trials():
    return simulate_logistic_trials(LogisticObserver(lapse=0.03), rng=2015)


@pytest.fixture(scope="module")
def fit(trials):
    return fit_logistic(trials)


def independent_fit(trials):
    """Hand-built design matrix; log-likelihood maximised with scipy (trust-exact, gtol 1e-12).

    Columns: intercept, de-cluttered indicator, one indicator per object other than object "1",
    log10(pixels). Returns (coefficients by term name, Wald standard errors, predictions).
    """
    X, y = hand_design_matrix(trials)

    def nll(b):
        eta = X @ b
        return float(np.sum(np.logaddexp(0, eta) - y * eta))

    def grad(b):
        return X.T @ (special.expit(X @ b) - y)

    def hess(b):
        p = special.expit(X @ b)
        return (X * (p * (1 - p))[:, None]).T @ X

    r = optimize.minimize(
        nll,
        np.zeros(X.shape[1]),
        jac=grad,
        hess=hess,
        method="trust-exact",
        options={"gtol": 1e-12},
    )
    se = np.sqrt(np.diag(np.linalg.inv(hess(r.x))))
    others = sorted(set(trials["object"].astype(int)) - {1})
    names = ["Intercept", "background"] + [f"object:{o}" for o in others] + ["log10_pixels"]
    return (
        dict(zip(names, r.x, strict=True)),
        dict(zip(names, se, strict=True)),
        special.expit(X @ r.x),
    )


def test_odds_ratios_match_independent_fit(trials, fit):
    coef, se, _ = independent_fit(trials)
    table = fit.odds_ratios
    assert table.terms()[:2] == ["object:2", "object:3"] and len(table.terms()) == 21
    for term in table.terms():
        assert table[term]["or"] == pytest.approx(math.exp(coef[term]), rel=1e-6), term
        lo, hi = table[term]["ci95"]
        z = stats.norm.ppf(0.975)
        assert lo == pytest.approx(math.exp(coef[term] - z * se[term]), rel=1e-6)
        assert hi == pytest.approx(math.exp(coef[term] + z * se[term]), rel=1e-6)
        p = 2 * stats.norm.sf(abs(coef[term]) / se[term])
        assert table[term]["p"] == pytest.approx(p, rel=1e-5, abs=1e-300)


def test_classification_table_matches_independent_predictions(trials, fit):
    _, _, p = independent_fit(trials)
    y = trials["recognized"].to_numpy()
    assert fit.recognized_correct_pct == pytest.approx(100 * np.mean(p[y == 1] >= 0.5))
    assert fit.not_recognized_correct_pct == pytest.approx(100 * np.mean(p[y == 0] < 0.5))


def test_recovers_the_simulated_odds_ratio(fit):
    # Data simulated with OR 5.6 (random effects and lapses attenuate it a little); a 95 % CI
    # should contain a value near it.
    lo, hi = fit.odds_ratios["background"]["ci95"]
    assert lo < 5.6 * 1.3 and hi > 5.6 / 1.3


def test_subject_factor(trials):
    f = fit_logistic(trials, subject_factor=True)
    subjects = [t for t in f.odds_ratios.terms() if t.startswith("subject:")]
    assert subjects == [f"subject:s{i}" for i in range(2, 7)]
    assert f.subject_factor


def test_mixed_model(trials):
    m = fit_mixed(trials)
    o = m.odds_ratios["background"]
    assert o["ci95"][0] < o["or"] < o["ci95"][1]
    assert o["or"] > 1 and m.subject_sd > 0 and m.object_sd > 0
    back = MixedFit.from_dict(json.loads(json.dumps(m.to_dict())))
    assert back == m


def test_mixed_intervals_agree_with_fixed_effects_model(trials, fit):
    """Widths within 15 % of the dummy-coded model's (second method: statsmodels GLM with subject
    and object dummies; background and log10 pixels vary within subjects and objects, so both
    models estimate the same conditional effects with nearly the same precision). This catches
    intervals ~10x too narrow, as the variational-Bayes fit used before gave."""
    import statsmodels.formula.api as smf

    from analysis.logistic import design_frame

    d = design_frame(trials)
    res = smf.logit("recognized ~ background + log10_pixels + C(object) + C(subject)", d).fit(
        disp=False, method="newton"
    )
    m = fit_mixed(trials)
    for term in ("background", "log10_pixels"):
        o = m.odds_ratios[term]
        ours = math.log(o["ci95"][1]) - math.log(o["ci95"][0])
        second = 2 * 1.959963984540054 * res.bse[term]
        assert ours == pytest.approx(second, rel=0.15), term
        assert math.log(o["or"]) == pytest.approx(res.params[term], abs=0.5 * res.bse[term] + 0.1)
    assert m.intervals and m.object_sd == pytest.approx(1.0, rel=0.5)  # simulated SD: 1.0


def test_laplace_loglik_matches_quadrature_one_factor():
    """One grouping factor: the marginal likelihood is a product of 1-D integrals, computed here
    by scipy.integrate.quad (second method). Laplace is accurate to ~1e-3 per cluster with tens
    of trials per cluster; the tolerance 0.05 in the total log-likelihood allows that."""
    from scipy import integrate

    rng = np.random.default_rng(4)
    g = np.repeat(np.arange(6), 40)
    x = rng.normal(size=g.size)
    u = rng.normal(0, 0.8, 6)
    y = (rng.random(g.size) < special.expit(-0.3 + 1.2 * x + u[g])).astype(float)
    X = np.column_stack([np.ones_like(x), x])
    beta, se, sd, ll = laplace_glmm(y, X, [g])
    total = 0.0
    for j in range(6):
        m = g == j
        eta = X[m] @ beta

        def f(v, eta=eta, yy=y[m]):
            return math.exp(
                float(np.sum(yy * (eta + v) - np.logaddexp(0, eta + v)))
                + stats.norm.logpdf(v, 0, sd[0])
            )

        total += math.log(integrate.quad(f, -10 * sd[0], 10 * sd[0], epsabs=0, epsrel=1e-10)[0])
    assert ll == pytest.approx(total, abs=0.05)
    assert np.all(se > 0)


def test_roundtrip(fit):
    d = json.loads(json.dumps(fit.to_dict()))
    assert LogisticFit.from_dict(d) == fit
    t = OddsRatioTable.from_dict(fit.odds_ratios.to_dict())
    assert t == fit.odds_ratios
    assert list(t.to_frame().columns) == ["term", "odds_ratio", "ci95_low", "ci95_high", "p_value"]


def test_all_recognised_gives_an_empty_table_not_an_error(trials):
    t = trials.copy()
    t["recognized"] = 1
    f = fit_logistic(t)
    assert f.method == "none" and f.odds_ratios.rows == ()
    assert "all 1920 trials are recognised" in f.warnings[0]


def test_one_condition_drops_the_background_term(trials):
    f = fit_logistic(trials[trials["condition"] == "cluttered"])
    assert not f.has("background") and f.has("log10_pixels")
    assert any("one background condition" in w for w in f.warnings)


def _penalised_nll(b, X, y):
    eta = X @ b
    p = special.expit(eta)
    info = X.T @ ((p * (1 - p))[:, None] * X)
    return -(float(np.sum(y * eta - np.logaddexp(0, eta))) + 0.5 * np.linalg.slogdet(info)[1])


def test_firth_matches_direct_maximisation_of_the_penalised_likelihood():
    """Second method: scipy BFGS on l(b) + 0.5 log det(X'WX), written out here (gtol 1e-10)."""
    rng = np.random.default_rng(5)
    x = rng.normal(size=40)
    X = np.column_stack([np.ones(40), x, (rng.random(40) < 0.5).astype(float)])
    y = (x > 0).astype(float)  # complete separation on x: no ML estimate
    ours, se, _ = firth_logit(y, X)
    r = optimize.minimize(
        _penalised_nll, np.zeros(3), args=(X, y), method="BFGS", options={"gtol": 1e-10}
    )
    assert np.all(np.isfinite(ours)) and np.all(se > 0)
    np.testing.assert_allclose(ours, r.x, rtol=1e-4, atol=1e-5)


def test_separated_condition_is_refitted_with_firth(trials):
    t = trials.copy()
    t.loc[t["condition"] == "cluttered", "recognized"] = 0
    t.loc[t["condition"] == "decluttered", "recognized"] = 1
    f = fit_logistic(t)
    assert f.method == "firth" and "background" in f.separated
    o = f.odds_ratios["background"]
    assert math.isfinite(o["or"]) and o["or"] > 100
    assert any("separated" in w for w in f.warnings)


def test_sixteen_trials_do_not_crash(trials):
    small = trials.sample(16, random_state=3)
    assert small["object"].nunique() > 1
    f = fit_logistic(small)
    assert f.method in ("ml", "firth", "none")
    assert any("too few" in w for w in f.warnings)


def test_eq1_paper_examples():
    # Eq. 1 with OR = 5.6 exactly gives 84.85 % and 15.15 %; the paper's 84.9 % and 15.1 % come
    # from its unrounded OR. Any OR that rounds to 5.6 (5.55-5.65) brackets the paper's values.
    for p_ref, odds, paper in EQ1_EXAMPLES:
        assert eq1(p_ref, odds) == pytest.approx(paper, abs=0.001)
    assert eq1(0.5, 5.55) < 0.849 < eq1(0.5, 5.65)
    assert eq1(0.5, 1 / 5.65) < 0.151 < eq1(0.5, 1 / 5.55)
    assert predict_from_odds_ratio(0.5, 5.6) == pytest.approx(5.6 / 6.6, rel=1e-15)


def test_eq1_bad_arguments():
    with pytest.raises(ValueError, match=r"p_ref must be in \(0, 1\), got 1.0"):
        predict_from_odds_ratio(1.0, 2.0)
    with pytest.raises(ValueError, match="odds_ratio must be > 0, got -1"):
        predict_from_odds_ratio(0.5, -1)
    with pytest.raises(ValueError, match=r"cutoff must be in \(0, 1\), got 0"):
        fit_logistic(simulate_logistic_trials(rng=1, n_subjects=1), cutoff=0)
