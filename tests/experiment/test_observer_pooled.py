"""The ``logistic`` observer's thresholds as the paper measured them: a Weibull through the
trials of all subjects and objects pooled (experiment.observers.pooled)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import special

from analysis.jung2015 import PIXEL_COUNTS
from experiment.observers.pooled import pooled_curve, pooled_weibull_x50


def test_pooled_curve_equals_a_monte_carlo_average_of_logistic_curves() -> None:
    """The quadrature is checked against its definition by drawing the effects."""
    x = np.asarray(PIXEL_COUNTS, dtype=float)
    e = np.random.default_rng(0).normal(0.0, 1.2, 400_000)
    for declut in (False, True):
        eta = math.log(74.5) * (np.log10(x)[:, None] - math.log10(7000.0)) + e
        eta = eta + (math.log(5.6) if declut else 0.0)
        mc = special.expit(eta).mean(axis=1)
        q = pooled_curve(x, 7000.0, decluttered=declut, effect_sd=1.2)
        assert q == pytest.approx(mc, abs=3e-3)


def test_the_demo_logistic_observer_puts_the_pooled_weibull_at_the_papers_thresholds() -> None:
    """The demo's average object sits below 8,695 px (the pooled curve is flatter and its
    Weibull's 50 % point higher: the Weibull's shape alone puts it 12 % above a single
    logistic curve's); from there the pooled Weibull is at the paper's 8,695 px and,
    through the paper's background odds ratio alone, within 5 % of its de-cluttered 3,532 px."""
    from experiment.demos.study import _observer_params

    x50 = _observer_params("logistic", [], None)["x50_cluttered_px"]
    assert 6000 < x50 < 8695
    sd = math.hypot(0.3, 1.0)  # LogisticParams' subject and object SDs
    assert pooled_weibull_x50(x50, effect_sd=sd) == pytest.approx(8695.0, rel=1e-3)
    assert pooled_weibull_x50(x50, effect_sd=sd, decluttered=True) == pytest.approx(
        3532.0, rel=0.05
    )
