"""Thresholds the data do not identify get a bracket of tested levels and a reason, no interval.

Each case once gave a "measured" threshold with a falsely narrow interval: two levels only, a step
response, a 16-trial subject whose credible interval ran far below the lowest level, and a slope
or lapse rate held by its prior bound. Now each is ``unidentified`` with the reason in its status,
reported by the tested levels that bracket it, and the pooled fit gets no population interval.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from analysis.weibull import PsychometricPrior, default_prior, fit_counts
from analysis.weibull.threshold import bracket

from .conftest import TRUTH

#: The paper's eight levels, pixels (Jung et al. 2015, Sec. 3.1).
LEVELS = [96.0, 486.0, 950.0, 3290.0, 6370.0, 17876.0, 40344.0, 160884.0]
#: Counts of 120 trials per level near the paper's cluttered curve (ours, simulated).
GOOD_K = [0, 4, 5, 24, 52, 100, 112, 109]


def _fit(levels, k, n, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_counts(levels, k, n, rng=1, **kw)


def test_well_identified_data_stay_measured():
    t = _fit(LEVELS, GOOD_K, [120] * 8, overdispersion=True).threshold(0.5)
    assert t.status == "measured" and t.reason == ""
    assert LEVELS[3] < t.ci95[0] < t.median < t.ci95[1] < LEVELS[5]


def test_two_levels_are_bracketed_not_measured():
    t = _fit([3290.0, 17876.0], [24, 100], [120, 120], overdispersion=True).threshold(0.5)
    assert t.status == "unidentified"
    assert t.reason == "2 levels with data"
    assert t.bracket == (3290.0, 17876.0)
    text = t.text("{:,.0f}", unit="px")
    assert text.startswith("between 3,290 and 17,876 px (unidentified: 2 levels")
    assert "CrI" not in t.text()


def test_step_response_is_unidentified_with_its_step():
    k = [0, 0, 0, 0, 120, 120, 120, 120]  # recognised iff >= 6,370 px
    t = _fit(LEVELS, k, [120] * 8, overdispersion=True).threshold(0.5)
    assert t.status == "unidentified"
    assert t.reason.startswith("step response (none correct at 3,290 or below, all from 6,370)")
    assert t.bracket == (3290.0, 6370.0)


def test_quasi_separated_step_with_one_mixed_level_is_a_step():
    k = [0, 0, 0, 0, 1, 2, 3, 1]  # 16 trials: a single mixed level between none and all
    t = _fit(LEVELS, k, [2, 3, 2, 1, 2, 2, 3, 1]).threshold(0.5)
    assert t.status == "unidentified" and t.reason.startswith("step response")


def test_sixteen_trials_with_an_interval_far_below_the_lowest_level():
    t = _fit(LEVELS, [1, 0, 1, 1, 2, 1, 2, 2], [2] * 8).threshold(0.5)
    # The posterior's interval reaches far below anything tested: not a measurement.
    assert t.ci95[0] < LEVELS[0] / 50
    assert t.status == "unidentified"
    assert t.reason.startswith("95 % interval runs beyond the tested range (down to")
    assert t.bracket == (486.0, 6370.0)
    assert t.text("{:,.0f}", unit="px").startswith("between 486 and 6,370 px")


@pytest.mark.parametrize(
    ("bound", "reason"),
    [
        ({"log_beta_range": "upper 0.8"}, "slope on its prior upper bound (0.8)"),
        ({"lapse_max": 0.02}, "lapse rate on its prior upper bound (0.02)"),
    ],
)
def test_parameter_on_its_prior_bound_is_unidentified(bound, reason):
    p = default_prior(LEVELS)
    if "log_beta_range" in bound:
        prior = PsychometricPrior(p.loc_range, (p.log_beta_range[0], math.log(0.8)))
    else:
        prior = PsychometricPrior(p.loc_range, p.log_beta_range, lapse_max=bound["lapse_max"])
    t = _fit(LEVELS, GOOD_K, [120] * 8, prior=prior).threshold(0.5)
    assert t.status == "unidentified"
    assert t.reason == reason
    assert t.bracket == (6370.0, 17876.0)


def test_decreasing_data_give_no_bracket():
    t = _fit(LEVELS, GOOD_K[::-1], [120] * 8).threshold(0.5)
    assert t.status == "unidentified" and "decreases" in t.reason
    assert all(math.isnan(v) for v in t.bracket)
    assert t.text().startswith("not identified (")


def test_bracket_pools_a_noisy_level_and_gives_bounds():
    # 0.6 at the lowest level then 0.4: pooled to 0.5, so neither is below 50 %.
    lo, hi = bracket([1.0, 2.0, 3.0], [6, 4, 10], [10, 10, 10], 0.5)
    assert math.isnan(lo) and hi == 3.0
    lo, hi = bracket([1.0, 2.0], [9, 10], [10, 10], 0.5)
    assert math.isnan(lo) and hi == 1.0
    lo, hi = bracket([1.0, 2.0], [0, 1], [10, 10], 0.5)
    assert lo == 2.0 and math.isnan(hi)


@pytest.fixture(scope="module")
def sim():
    from analysis.simulate import simulate_weibull_trials

    return simulate_weibull_trials(TRUTH, n_subjects=2, subject_log10_sd=0.1, rng=11)


def _analyze(trials):
    from analysis.data import TrialTable
    from analysis.pipeline import AnalysisOptions, analyze

    table = TrialTable(trials=trials.reset_index(drop=True), sources=("sim.csv",))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return list(analyze(table, AnalysisOptions(seed=1, by_subject=False)))[-1].result


@pytest.mark.parametrize("case", ["two levels", "step"])
def test_pooled_unidentified_fit_prints_no_population_interval(sim, case):
    from analysis.report import render_markdown

    d = sim.copy()
    if case == "two levels":
        d = d[d["pixels"].isin([3290.0, 17876.0])]
        expect = "between 3,290 and 17,876 px (unidentified: 2 levels with data"
    else:
        d["recognized"] = (d["pixels"] >= 6370.0).astype(int)
        expect = "between 3,290 and 6,370 px (unidentified: step response"
    res = _analyze(d)
    assert res.population_ci == {c: {} for c in res.thresholds}
    text = render_markdown(res, figures=False)
    assert expect in text
    assert "95 % population interval" not in text  # the per-condition interval
    r = res.results_json()
    for c in res.thresholds:
        assert r["thresholds"][c]["p50_pixels"] is None
        assert r["thresholds"][c]["ci95"] == [None, None]
        assert r["thresholds"][c]["status"] != "measured"
    assert r["thresholds"]["cluttered"]["status"] == "unidentified"


def test_bracket_round_trips_through_json():
    t = _fit([3290.0, 17876.0], [24, 100], [120, 120]).threshold(0.5)
    assert t.to_dict()["bracket"] == [3290.0, 17876.0]
    assert np.isfinite(t.median)  # the number is kept for the record, not reported
