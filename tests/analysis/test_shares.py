"""Shares keep their intervals in [0, 1]: Wilson against statsmodels, clustered by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats
from statsmodels.stats.proportion import proportion_confint

from analysis.shares import share_ci95, wilson_ci95


@pytest.mark.parametrize(("k", "n"), [(0, 5), (3, 9), (9, 9), (17, 40)])
def test_wilson_equals_statsmodels(k, n):
    assert wilson_ci95(k / n, n) == pytest.approx(
        proportion_confint(k, n, alpha=0.05, method="wilson"), abs=1e-12
    )


def test_one_subject_is_wilson_over_trials():
    v = [1, 0, 0, 1, 0, 0]
    p, ci, unit = share_ci95(v, ["s"] * 6)
    assert unit == "trials" and ci == pytest.approx(proportion_confint(2, 6, method="wilson"))


def test_clustered_share_stays_in_unit_interval_where_a_t_interval_did_not():
    """Three subjects who zoomed in 0 %, 0 % and 100 % of their trials: the t interval over
    subject shares was 33 % (-110-177 %); the Wilson interval on the effective trials is inside
    [0, 1] and equals the closed form computed here by hand."""
    v = np.r_[np.zeros(4), np.zeros(4), np.ones(4)]
    s = np.repeat(["a", "b", "c"], 4)
    p, (lo, hi), unit = share_ci95(v, s)
    shares = np.array([0.0, 0.0, 1.0])
    half_t = stats.t.ppf(0.975, 2) * shares.std(ddof=1) / math.sqrt(3)
    assert p - half_t < 0 and p + half_t > 1  # the old interval left [0, 1]
    assert 0.0 <= lo < p < hi <= 1.0 and unit == "subjects"
    n_eff = p * (1 - p) / (shares.var(ddof=1) / 3)
    z = stats.t.ppf(0.975, 2)
    c = (p + z * z / (2 * n_eff)) / (1 + z * z / n_eff)
    h = z / (1 + z * z / n_eff) * math.sqrt(p * (1 - p) / n_eff + z * z / (4 * n_eff**2))
    assert (lo, hi) == pytest.approx((max(0, c - h), min(1, c + h)))
