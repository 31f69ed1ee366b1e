"""Real psychophysics data: our MLE agrees with a second maximum-likelihood method within 2 %.

Second method: the hand-written likelihood with bounded Nelder-Mead of ``test_weibull``
(different parametrisation and optimizer) over the same parameter space (lapse and slope
bounds of the default prior: without a slope bound the staircase's MLE is a step function,
beta ~ 120). 2 % is the agreement the project requires of its fit; both methods maximise the
same likelihood.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from analysis.weibull import aggregate, default_prior, fit_mle, fit_weibull, threshold_at

from ..conftest import require_data
from .test_weibull import independent_mle

pytestmark = pytest.mark.data


def _both(x, y, *, guess, sigmoid, pc):
    lv, k, n = aggregate(x, y)
    prior = default_prior(lv, guess=guess, sigmoid=sigmoid)
    m = fit_mle(lv, k, n, guess=guess, sigmoid=sigmoid, prior=prior)
    a, b, lapse = independent_mle(
        lv,
        k,
        n,
        guess=guess,
        sigmoid=sigmoid,
        lapse_max=prior.lapse_max,
        log_beta_bounds=prior.log_beta_range,
    )
    ours = float(threshold_at(pc, m.alpha, m.beta, m.lapse, guess=guess, sigmoid=sigmoid))
    second = float(threshold_at(pc, a, b, lapse, guess=guess, sigmoid=sigmoid))
    return ours, second


def test_staircase_2afc(data_dir):
    d = pd.read_csv(require_data(data_dir, "psychophysics", "MPDiR_StairCase.csv"))
    ours, second = _both(d["Contrast"], d["Response"], guess=0.5, sigmoid="weibull", pc=0.75)
    print(f"MPDiR staircase 75% threshold: ours {ours:.5f}, second method {second:.5f}")
    assert ours == pytest.approx(second, rel=0.02)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_weibull(d["Contrast"], d["Response"], guess=0.5, rng=1)
    t = fit.threshold(0.75)
    assert fit.converged
    assert t.ci95[0] < ours < t.ci95[1]


@pytest.mark.parametrize("participant", ["aa", "bb", "cc"])
def test_qpdat_logistic(data_dir, participant):
    d = pd.read_csv(require_data(data_dir, "psychophysics", "qpdat.csv"))
    if participant not in set(d["participant"]):
        pytest.skip(f"participant {participant} not in qpdat.csv")
    sel = d[(d["participant"] == participant) & (d["cond"] == 1)]
    ours, second = _both(sel["phase"], sel["resp"], guess=0.0, sigmoid="logistic", pc=0.5)
    print(f"qpdat {participant} cond 1 50% point (deg): ours {ours:.3f}, second {second:.3f}")
    assert ours == pytest.approx(second, rel=0.02)
    assert np.isfinite(ours)
