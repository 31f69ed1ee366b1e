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


def _one_kind_study(**variant: float) -> list[tuple[str, str, str, float, int]]:
    """1,000 subjects; kind 0 at one level, kind 1 at another, in both conditions (standout 2.0),
    no internal noise, priming or lapses: only the variant varies the criterion."""
    import numpy as np

    from benchmarks.design_observer import simulate_study

    known = np.array([[2.0, 0.0, -1.0], [0.0, 2.0, -1.0]])
    cond = {"pixels": np.array([100.0, 1000.0]), "known": known,
            "correct": np.array([0, 1]), "objects": np.array(["a", "b"])}  # fmt: skip
    resp = {"cluttered": cond, "decluttered": cond}
    return simulate_study(resp, noise_sd=0.0, criterion=1.5, priming=0.0, lapse=0.0,
                          n_subjects=1000, rng=7, **variant)  # fmt: skip


def test_criterion_variants_of_the_fast_path_follow_their_closed_form() -> None:
    """Criterion noise (per trial), a criterion per subject and one per subject and kind: a
    match standing 0.5 above the criterion is named with probability Phi(0.5 / SD) whichever
    varies; a per-trial criterion makes a subject's trials independent, a per-subject one makes
    them identical, a per-kind one ties only the trials of one kind."""
    from collections import defaultdict

    import numpy as np
    from scipy.stats import norm

    expected = float(norm.cdf(0.5 / 0.5))  # 0.841
    assert {r[4] for r in _one_kind_study()} == {1}  # no variant: every trial named
    agree = {}
    for variant in ("criterion_jitter", "subject_sd", "kind_sd"):
        rows = _one_kind_study(**{variant: 0.5})
        rate = np.mean([r[4] for r in rows])
        assert abs(rate - expected) < 4 * math.sqrt(expected * (1 - expected) / 1000), variant
        by: dict[tuple[str, str], list[int]] = defaultdict(list)
        for subject, obj, _, _, ok in rows:
            by[(subject, obj)].append(ok)
        same_kind = np.mean([len(set(v)) == 1 for v in by.values()])
        subj: dict[str, list[int]] = defaultdict(list)
        for subject, _, _, _, ok in rows:
            subj[subject].append(ok)
        agree[variant] = (same_kind, np.mean([len(set(v)) == 1 for v in subj.values()]))
    assert agree["subject_sd"] == (1.0, 1.0)
    assert agree["kind_sd"][0] == 1.0 and agree["kind_sd"][1] < 0.9
    # independent trials: a kind's two trials (one level, two conditions) agree with
    # probability p^2 + (1 - p)^2 = 0.73 (SE 0.014)
    assert agree["criterion_jitter"][0] < 0.8
