"""The proportional-hazards check: Schoenfeld residuals against a hand computation, the test
against its closed form, and recovery of proportional and crossing hazards by simulation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from analysis.ph_check import proportional_hazards_check, schoenfeld_test, split_hazard_ratios


def _hand_schoenfeld(t, e, x, s, beta):
    """x_i minus the risk set's exp(beta x)-weighted mean of x, per event (within stratum)."""
    out = []
    for i in np.flatnonzero(e):
        risk = (t >= t[i]) & (s == s[i])
        w = np.exp(beta * x[risk])
        out.append((t[i], x[i] - np.sum(w * x[risk]) / np.sum(w)))
    return out


def _sim(rng, n, hr_early, hr_late, split=1.0, n_strata=3):
    """Exponential times (rate 1 reference) with a hazard ratio that steps at ``split``."""
    x = rng.integers(0, 2, n).astype(float)
    s = rng.integers(0, n_strata, n).astype(str)
    r1 = np.where(x == 1, hr_early, 1.0)
    r2 = np.where(x == 1, hr_late, 1.0)
    u = rng.exponential(size=n)
    t = np.where(u < r1 * split, u / r1, split + (u - r1 * split) / r2)
    c = np.minimum(rng.uniform(0.5, 4.0, n), 3.0)
    return np.minimum(t, c), t <= c, x, s


def test_residuals_and_statistic_equal_a_hand_computation():
    rng = np.random.default_rng(4)
    t, e, x, s = _sim(rng, 80, 2.0, 2.0)
    t = np.round(t, 6) + rng.uniform(0, 1e-7, t.size)  # no ties
    r = schoenfeld_test(t, e, x, s)
    hand = _hand_schoenfeld(t, e, x, s, r["beta"])
    by_time = dict(hand)
    np.testing.assert_allclose(r["residuals"], [by_time[ti] for ti in r["event_times"]], atol=1e-8)
    res = np.array(r["residuals"])
    g = stats.rankdata(r["event_times"])
    g = g - g.mean()
    from statsmodels.duration.hazard_regression import PHReg

    var = float(PHReg(t, x[:, None], status=e.astype(int), strata=s).fit().cov_params()[0, 0])
    stat = len(res) * var * (g @ res) ** 2 / (g @ g)
    assert r["statistic"] == pytest.approx(stat, rel=1e-9)
    assert r["p"] == pytest.approx(stats.chi2.sf(stat, 1), rel=1e-9)


def test_proportional_hazards_pass_and_crossing_hazards_fail():
    rng = np.random.default_rng(11)
    t, e, x, s = _sim(rng, 600, 2.0, 2.0)
    cond = np.where(x == 1, "decluttered", "cluttered")
    ok = proportional_hazards_check(t, e, cond, s, treated="decluttered", reference="cluttered")
    assert ok["holds"] is True and ok["alternative"] is None
    t, e, x, s = _sim(rng, 600, 4.0, 0.25, split=0.3)
    cond = np.where(x == 1, "decluttered", "cluttered")
    bad = proportional_hazards_check(t, e, cond, s, treated="decluttered", reference="cluttered")
    assert bad["holds"] is False and bad["test"]["p"] < 0.01
    alt = bad["alternative"]
    assert alt["early"]["hazard_ratio"] > 2 and alt["late"]["hazard_ratio"] < 1


def test_split_hazard_ratios_recover_the_generating_steps():
    rng = np.random.default_rng(5)
    t, e, x, s = _sim(rng, 4000, 3.0, 1.0, split=0.5)
    r = split_hazard_ratios(t, e, x, s, split_s=0.5)
    assert r["early"]["ci95"][0] < 3.0 < r["early"]["ci95"][1]
    assert r["late"]["ci95"][0] < 1.0 < r["late"]["ci95"][1]


def test_active_report_states_the_check_and_the_mixed_model_prior():
    """Through the active-search summary: the check is in results.json and the report, with the
    split alternative when the hazards cross; the mixed model names its priors."""
    import pandas as pd

    from analysis.active import render_active_markdown, summarize_active

    rng = np.random.default_rng(2)
    t, e, x, s = _sim(rng, 300, 4.0, 0.25, split=0.3)
    trials = pd.DataFrame(
        {
            "subject": s,
            "condition": np.where(x == 1, "decluttered", "cluttered"),
            "rt_s": t,
            "recognized": e,
            "planes_visited": 1,
            "depth_keys": 0,
            "zoomed": rng.integers(0, 2, t.size).astype(bool),
            "zooms": 0,
            "zoom_time_s": 0.0,
            "at_target_plane": None,
            "searcher": "sim:test",
            "session": "x",
        }
    )
    res = summarize_active(trials)
    ph = res.to_dict()["proportional_hazards"]["decluttered"]
    assert ph["holds"] is False and ph["alternative"]["early"]["hazard_ratio"] > 1
    md = "\n".join(render_active_markdown(res).splitlines())
    assert "**Proportional hazards**" in md and "FAILS" in md and "before" in md
    assert "N(0, 2^2) on the log-odds scale" in md
