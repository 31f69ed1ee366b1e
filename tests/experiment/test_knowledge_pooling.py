"""A kind's similarity pooled over its exemplars: the best match, or the summed similarity."""

from __future__ import annotations

import math

import numpy as np
import pytest

from experiment.observers.calibration import CalibratedParams
from experiment.observers.exemplar import Knowledge


def _knowledge(rows: np.ndarray, cats: list[int]) -> Knowledge:
    names = tuple(f"kind{i}" for i in range(max(cats) + 1))
    return Knowledge(names, rows, np.asarray(cats), "", "", (), {})


def test_summed_similarity_equals_the_generalised_context_model_written_out() -> None:
    """tau * log(mean(exp(r / tau))) per kind, computed here term by term; tau 0 is the max."""
    g = np.random.default_rng(4)
    rows = g.normal(size=(7, 5))
    cats = [0, 1, 0, 2, 1, 0, 2]
    k = _knowledge(rows, cats)
    f = g.normal(size=5)
    r = rows @ f
    for tau in (0.02, 0.3, 5.0):
        want = [tau * math.log(sum(math.exp(r[i] / tau) for i in range(7) if cats[i] == c) /
                               cats.count(c)) for c in range(3)]  # fmt: skip
        assert np.allclose(k.similarities(f, tau=tau), want, rtol=0, atol=1e-9)
    best = [max(r[i] for i in range(7) if cats[i] == c) for c in range(3)]
    assert np.array_equal(k.similarities(f), best)
    # between the best match and the mean, nearer the best the lower tau is
    mean = [np.mean([r[i] for i in range(7) if cats[i] == c]) for c in range(3)]
    lo, hi = k.similarities(f, tau=0.02), k.similarities(f, tau=5.0)
    assert np.all(lo <= np.asarray(best) + 1e-12) and np.all(hi >= np.asarray(mean) - 1e-12)
    assert np.all(np.abs(lo - best) <= np.abs(hi - best))


def test_calibrated_params_refuse_a_negative_pooling_temperature() -> None:
    with pytest.raises(ValueError, match="exemplar_tau must be >= 0, got -0.1"):
        CalibratedParams(knowledge="k", exemplar_tau=-0.1)
