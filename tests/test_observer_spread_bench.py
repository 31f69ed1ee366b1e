"""The observer benchmarks' fast regression recovers the odds ratios it was given."""

from __future__ import annotations

import math

from benchmarks.design_observer import odds_ratios
from benchmarks.validate_observer_paper import paper_logistic_study


def test_paper_odds_observer_and_fast_regression_recover_the_paper() -> None:
    """A large study of the paper-odds observer gives back 5.6 and 74.5 (recovery)."""
    objects = [f"obj{i:02d}" for i in range(1, 21)]
    pixels = [96.0, 486.0, 950.0, 3290.0, 6370.0, 17876.0, 40344.0, 160884.0]
    rows = paper_logistic_study(objects, pixels, n_subjects=60, object_sd=1.0, rng=3)
    q = odds_ratios(rows)
    # 19,200 trials: standard errors about 0.07 (log background) and 0.06 (log slope)
    assert abs(math.log(q["or_background"] / 5.6)) < 0.2
    assert abs(math.log(q["or_per_log10_px"] / 74.5)) < 0.2
