"""Odds-ratio intervals: Firth's estimate and its profile penalised-likelihood interval checked
against closed forms and a brute-force second computation; binomial rows equal single trials."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import optimize, special, stats

from analysis.logistic import firth_logit, profile_interval
from tests.analysis.conftest import hand_design_matrix


def _penalised_ll(b, X, y):
    eta = X @ b
    p = special.expit(eta)
    info = X.T @ ((p * (1 - p))[:, None] * X)
    return float(np.sum(y * eta - np.logaddexp(0, eta))) + 0.5 * np.linalg.slogdet(info)[1]


def _profile_brute(X, y, j, bj):
    """Max of the penalised log-likelihood with b_j = bj: Nelder-Mead then BFGS (scipy)."""
    free = [i for i in range(X.shape[1]) if i != j]

    def nll(c):
        b = np.empty(X.shape[1])
        b[j], b[free] = bj, c
        return -_penalised_ll(b, X, y)

    r = optimize.minimize(
        nll,
        np.zeros(len(free)),
        method="Nelder-Mead",
        options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000},
    )
    r = optimize.minimize(nll, r.x, method="BFGS", options={"gtol": 1e-10})
    return -r.fun


def _table(a, b, c, d):
    """Trials of a 2x2 table: x = 1 has a successes, b failures; x = 0 has c and d."""
    x = np.repeat([1.0, 1.0, 0.0, 0.0], [a, b, c, d])
    y = np.repeat([1.0, 0.0, 1.0, 0.0], [a, b, c, d])
    return np.column_stack([np.ones(len(x)), x]), y


@pytest.mark.parametrize("cells", [(7, 3, 2, 8), (9, 0, 3, 6), (12, 5, 4, 11)])
def test_firth_of_a_2x2_table_is_the_log_odds_ratio_with_half_added(cells):
    """Closed form: in the saturated 2x2 model Firth's estimate adds 0.5 to each cell."""
    a, b, c, d = cells
    X, y = _table(*cells)
    est, _, _ = firth_logit(y, X)
    assert est[1] == pytest.approx(
        math.log((a + 0.5) * (d + 0.5) / ((b + 0.5) * (c + 0.5))), abs=1e-8
    )


@pytest.mark.parametrize("cells", [(7, 3, 2, 8), (9, 0, 3, 6)])
def test_firth_profile_interval_ends_are_where_a_brute_force_profile_crosses_the_cutoff(cells):
    """Second computation: profile by generic optimisers and a grid, crossing found by
    interpolation -- independent of the Newton profile and Brent root finder under test."""
    X, y = _table(*cells)
    est, se, _ = firth_logit(y, X)
    lo, hi = profile_interval(y, X, 1, penalized=True)
    l_max = _penalised_ll(est, X, y)
    cut = stats.chi2.ppf(0.95, 1)
    for end in (lo, hi):
        grid = np.linspace(end - 0.05, end + 0.05, 11)
        dev = np.array([2 * (l_max - _profile_brute(X, y, 1, g)) for g in grid]) - cut
        k = int(np.flatnonzero(np.diff(np.sign(dev)))[0])
        cross = grid[k] - dev[k] * (grid[k + 1] - grid[k]) / (dev[k + 1] - dev[k])
        assert end == pytest.approx(cross, abs=2e-4)
    # Separated table (9, 0, 3, 6): ML is infinite, yet Firth's interval is finite and
    # asymmetric around the estimate (longer towards the separated side).
    assert math.isfinite(lo) and math.isfinite(hi) and lo < est[1] < hi
    if cells[1] == 0:
        assert hi - est[1] > est[1] - lo


def test_ml_profile_interval_ends_have_deviance_3_84_by_brute_force():
    X, y = _table(12, 5, 4, 11)
    lo, hi = profile_interval(y, X, 1)
    a, b, c, d = 12, 5, 4, 11
    b_hat = math.log(a * d / (b * c))  # closed-form ML log odds ratio of a 2x2 table

    def ll(b1):  # profile over the intercept: ML intercept for x = 0 cells is logit(c / (c+d))
        b0 = optimize.minimize_scalar(
            lambda t: -np.sum(y * (t + b1 * X[:, 1]) - np.logaddexp(0, t + b1 * X[:, 1])),
            bracket=(-5, 5),
            tol=1e-12,
        ).x
        eta = b0 + b1 * X[:, 1]
        return float(np.sum(y * eta - np.logaddexp(0, eta)))

    for end in (lo, hi):
        assert 2 * (ll(b_hat) - ll(end)) == pytest.approx(stats.chi2.ppf(0.95, 1), abs=1e-6)


def test_binomial_rows_give_the_fit_and_intervals_of_single_trials():
    rng = np.random.default_rng(3)
    g = 30
    Xg = np.column_stack([np.ones(g), rng.normal(size=g), rng.integers(0, 2, g)])
    n = rng.integers(1, 6, g).astype(float)
    k = rng.binomial(n.astype(int), special.expit(Xg @ [0.3, 1.2, -0.7])).astype(float)
    X = np.repeat(Xg, n.astype(int), axis=0)
    y = np.concatenate(
        [np.r_[np.ones(int(ki)), np.zeros(int(ni - ki))] for ki, ni in zip(k, n, strict=True)]
    )
    np.testing.assert_allclose(
        firth_logit(k / n, Xg, weights=n)[0], firth_logit(y, X)[0], atol=1e-10
    )
    for pen in (False, True):
        np.testing.assert_allclose(
            profile_interval(k / n, Xg, 1, penalized=pen, weights=n),
            profile_interval(y, X, 1, penalized=pen),
            atol=1e-7,
        )


@pytest.fixture(scope="module")
def sim_fit():
    import warnings

    from analysis.logistic import fit_logistic
    from analysis.simulate import simulate_logistic_trials

    trials = simulate_logistic_trials(rng=7)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return trials, fit_logistic(trials)


def test_default_interval_is_firth_profile_beside_ml_wald_and_profile(sim_fit):
    """The default is recomputed from a hand-built design matrix, with ML and Wald beside it."""
    trials, fit = sim_fit
    X, y = hand_design_matrix(trials)
    est, _, _ = firth_logit(y, X)
    for term, j in (("background", 1), ("log10_pixels", X.shape[1] - 1)):
        iv = fit.intervals(term)
        assert iv["interval"] == "firth_profile"
        assert iv["question"] == "these subjects and objects"
        assert iv["or"] == pytest.approx(math.exp(est[j]), rel=1e-6)
        lo, hi = profile_interval(y, X, j, penalized=True)
        assert iv["ci95"] == pytest.approx([math.exp(lo), math.exp(hi)], rel=1e-6)
        assert iv["ml_or"] == fit.odds_ratios[term]["or"]
        assert iv["wald"] == fit.odds_ratios[term]["ci95"]
        assert "profile" in iv
        # Firth's estimate is pulled towards OR 1 from ML's
        assert abs(math.log(iv["or"])) < abs(math.log(iv["ml_or"]))


def test_firth_intervals_survive_the_round_trip(sim_fit):
    from analysis.logistic import LogisticFit

    _, fit = sim_fit
    back = LogisticFit.from_dict(fit.to_dict())
    assert back.reported_intervals() == fit.reported_intervals()
    assert set(back.reported_intervals()) == {"background", "log10_pixels"}


def test_report_and_results_json_give_the_default_interval_first_and_name_it(small_result):
    from analysis.report import OR_INTERVALS_NOTE, render_markdown

    iv = small_result.results_json()["logistic"]["intervals"]["background"]
    assert iv["interval"] == "firth_profile" and iv["ci95"] == iv["firth_profile"]
    text = render_markdown(small_result, figures=False)
    default = f"{iv['firth_profile'][0]:.3g}-{iv['firth_profile'][1]:.3g}"
    wald = f"{iv['wald'][0]:.3g}-{iv['wald'][1]:.3g} Wald"
    assert f"95 % CI {default} Firth profile penalised likelihood" in text
    assert text.index(default) < text.index(wald)
    assert OR_INTERVALS_NOTE in text


def test_separated_data_have_only_firth_intervals(sim_fit):
    """No ML estimate exists: the default is Firth's, and no ML Wald or profile is claimed."""
    import warnings

    from analysis.logistic import fit_logistic

    t = sim_fit[0].copy()
    t.loc[t["condition"] == "cluttered", "recognized"] = 0
    t.loc[t["condition"] == "decluttered", "recognized"] = 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = fit_logistic(t)
    iv = f.intervals("background")
    assert f.method == "firth" and iv["interval"] == "firth_profile"
    assert "wald" not in iv and "ml_or" not in iv
    assert iv["ci95"][0] > 1.0 and (iv["ci95"][1] is None or iv["ci95"][1] > iv["or"])


def _separated_design(n_objects: int = 3, repeats: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A condition that alone decides the outcome, beside object dummies and log10 pixels."""
    per_condition = 8 * n_objects * repeats
    condition = np.repeat([0.0, 1.0], per_condition)
    levels = np.log10(25.0 * 2.0 ** np.arange(8))
    log_px = np.tile(np.repeat(levels, n_objects * repeats), 2)
    obj = np.tile(np.repeat(np.arange(n_objects), repeats), 16)
    dummies = [(obj == k).astype(float) for k in range(1, n_objects)]
    X = np.column_stack([np.ones(len(condition)), *dummies, condition, log_px])
    return X, condition.copy()


def test_separated_profile_ends_have_deviance_3_84_where_the_surface_is_not_concave():
    """Near a separated direction the penalised profile surface is not concave, and an iteration
    that stops early reports a point below the profile's maximum, so an end too close. Second
    computation: BFGS (scipy) over the free coefficients from two starts, the best kept."""
    X, y = _separated_design()
    j = X.shape[1] - 2
    est, _, _ = firth_logit(y, X)
    lo, hi = profile_interval(y, X, j, penalized=True)
    free = np.arange(X.shape[1]) != j

    def brute_profile(bj: float) -> float:
        def nll(c):
            b = np.empty(X.shape[1])
            b[j], b[free] = bj, c
            return -_penalised_ll(b, X, y)

        starts = (est[free], np.zeros(int(free.sum())))
        return max(-optimize.minimize(nll, s, method="BFGS").fun for s in starts)

    l_max = _penalised_ll(est, X, y)
    for end in (lo, hi):
        assert 2 * (l_max - brute_profile(end)) == pytest.approx(stats.chi2.ppf(0.95, 1), abs=1e-3)
    assert 5.0 < lo < est[j] < 15.0 < hi < 20.0


def test_newton_step_is_minus_the_inverse_hessian_times_the_gradient_by_finite_differences():
    """The penalised Newton step uses the analytic gradient and Hessian of Firth's penalised
    log-likelihood; both are checked against central differences of the log-likelihood."""
    from analysis.firth import _ascent_step

    rng = np.random.default_rng(5)
    X = np.column_stack([np.ones(60), rng.normal(size=60), rng.integers(0, 2, 60)])
    y = (rng.random(60) < special.expit(X @ [0.2, 0.8, -0.5])).astype(float)
    b = np.array([0.1, 0.6, -0.3])
    eps = 1e-4
    eye = np.eye(3) * eps
    grad = np.array(
        [(_penalised_ll(b + e, X, y) - _penalised_ll(b - e, X, y)) / (2 * eps) for e in eye]
    )
    hess = np.array(
        [
            [
                (
                    _penalised_ll(b + ei + ej, X, y)
                    - _penalised_ll(b + ei - ej, X, y)
                    - _penalised_ll(b - ei + ej, X, y)
                    + _penalised_ll(b - ei - ej, X, y)
                )
                / (4 * eps * eps)
                for ej in eye
            ]
            for ei in eye
        ]
    )
    assert np.all(np.linalg.eigvalsh(hess) < 0)
    step = _ascent_step(y, X, np.ones(60), b, np.ones(3, bool), True)
    np.testing.assert_allclose(step, np.linalg.solve(-hess, grad), rtol=1e-4, atol=1e-7)
    # One coefficient held: the step is the Newton step of the other two, and 0 for it.
    held = np.array([True, False, True])
    step = _ascent_step(y, X, np.ones(60), b, held, True)
    sub = np.ix_(held, held)
    assert step[1] == 0.0
    np.testing.assert_allclose(step[held], np.linalg.solve(-hess[sub], grad[held]), rtol=1e-4)
