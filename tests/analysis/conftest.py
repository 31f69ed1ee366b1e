"""Fixtures for the analysis tests: small simulated trial tables and one shared analysis."""

from __future__ import annotations

import warnings

import numpy as np
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


def active_session(log, subject="S01"):
    """Create an ``active_search`` session in trial log ``log``; return its id."""
    return log.create_session(
        subject=subject,
        protocol_name="active_search",
        protocol_sha256="p",
        protocol_json="{}",
        display_json="{}",
        stimset_path="synthetic:three_plane",
        stimset_manifest_sha256="s",
        seed="1",
        primary_rater="operator",
    )


def lab_and_pilot_csv(trials, folder, human_columns, sim_columns):
    """Write the first subject's trials to ``lab.csv`` and the rest to ``pilot.csv`` in ``folder``.

    Each file gets its columns set as given (``{column: value}``); returns both paths.
    """
    first = trials["subject"] == trials["subject"].iloc[0]
    a, b = folder / "lab.csv", folder / "pilot.csv"
    trials[first].assign(**human_columns).to_csv(a, index=False)
    trials[~first].assign(**sim_columns).to_csv(b, index=False)
    return a, b


def hand_design_matrix(trials):
    """Return the logistic model's design matrix and responses, built by hand (not by patsy).

    Columns: intercept, de-cluttered indicator, one indicator per object other than object "1",
    log10(pixels).
    """
    obj = trials["object"].astype(int).to_numpy()
    others = sorted(set(obj) - {1})
    X = np.column_stack(
        [np.ones(len(trials)), (trials["condition"] == "decluttered").to_numpy(float)]
        + [(obj == o).astype(float) for o in others]
        + [np.log10(trials["pixels"].to_numpy(float))]
    )
    return X, trials["recognized"].to_numpy(float)
