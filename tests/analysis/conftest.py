"""Fixtures for the analysis tests: small simulated trial tables and one shared analysis."""

from __future__ import annotations

import warnings

import pytest

from analysis.simulate import WeibullObserver, simulate_weibull_trials

#: Simulated observers (ours), near the paper's Fig. 8 curves.
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}


@pytest.fixture(scope="session")
def small_trials():
    """Two subjects x 20 objects x 8 levels x 2 conditions (640 trials), fixed seed."""
    return simulate_weibull_trials(TRUTH, n_subjects=2, subject_log10_sd=0.1, rng=7)


@pytest.fixture(scope="session")
def small_csv(tmp_path_factory, small_trials):
    """``small_trials`` written as a CSV file."""
    p = tmp_path_factory.mktemp("trials") / "small.csv"
    small_trials.to_csv(p, index=False)
    return p


@pytest.fixture(scope="session")
def small_result(small_csv):
    """The full analysis of ``small_csv`` (pooled + per-subject fits, logistic model)."""
    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        steps = list(analyze(read_trials([small_csv]), AnalysisOptions(seed=3)))
    return steps[-1].result
