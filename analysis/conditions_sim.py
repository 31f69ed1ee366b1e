"""Simulated studies of k conditions: a logistic observer with known odds ratios per condition.

The generating model is the analysis model of :mod:`analysis.conditions`:
``logit P(recognised) = intercept + log(OR_condition) + slope * log10(pixels) + object effect``,
with object effects drawn once per study from a normal distribution. Used by the recovery
benchmark (``benchmarks/bench_methods_recovery.py``), the power analysis of a method comparison
and the tests.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from analysis.jung2015 import PIXEL_COUNTS

__all__ = ["KARTHA_ORS", "PAPER_OR", "simulate_condition_trials"]

#: Odds ratios of Kartha et al. (2020) from their proportions correct with and without stereo
#: distance filtering: 86 % vs 35 % (about 11) and 81 % vs 65 % (about 2.3).
KARTHA_ORS: tuple[float, float] = (11.4, 2.3)

#: The paper's background odds ratio (Jung et al. 2015, Sec. 3.2.2: 5.6, 95 % CI 3.9-8.1).
PAPER_OR: float = 5.6

#: Slope of the generating model per log10 pixel: the paper's odds ratio per log10 pixels
#: (Jung et al. 2015, Sec. 3.2.2: 74.5).
_SLOPE = math.log(74.5)
#: Intercept of the generating model: the reference condition's 50 % point at the paper's
#: cluttered threshold, 8,695 px (Sec. 3.2.2).
_INTERCEPT = -_SLOPE * math.log10(8695.0)


def simulate_condition_trials(
    odds_ratios: Mapping[str, float],
    *,
    n_subjects: int = 6,
    n_objects: int = 20,
    pixels: Sequence[float] = PIXEL_COUNTS,
    intercept: float = _INTERCEPT,
    slope: float = _SLOPE,
    object_sd: float = 0.5,
    subject_sd: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> pd.DataFrame:
    """Return one simulated study's tidy trials: every subject x object x condition x level.

    Parameters
    ----------
    odds_ratios : mapping of str to float > 0
        Condition -> its odds ratio against the reference (the reference's is 1).
    n_subjects, n_objects : int >= 1
    pixels : sequence of float
        The levels' pixel counts (default the paper's eight).
    intercept, slope : float
        Log odds at 1 pixel, and per log10 pixel.
    object_sd : float >= 0
        SD of the objects' log-odds effects.
    subject_sd : float >= 0
        SD of the subjects' log-odds effects (random intercepts; none by default).
    rng : numpy Generator, int or None

    Returns
    -------
    pandas.DataFrame
        Columns ``subject, object, condition, pixels, recognized`` (labelled simulated:
        ``simulated = 1``, ``observer = 'logistic-k'``).
    """
    rng = np.random.default_rng(rng)
    conds = list(odds_ratios)
    px = np.asarray(pixels, float)
    obj_eff = rng.normal(0.0, object_sd, n_objects)
    s, o, c, p = np.meshgrid(
        np.arange(n_subjects), np.arange(n_objects), np.arange(len(conds)), px, indexing="ij"
    )
    s, o, c, p = s.ravel(), o.ravel(), c.ravel(), p.ravel()
    log_or = np.log(np.asarray([odds_ratios[k] for k in conds], float))
    eta = intercept + log_or[c] + slope * np.log10(p) + obj_eff[o]
    if subject_sd > 0:
        eta = eta + rng.normal(0.0, subject_sd, n_subjects)[s]
    y = (rng.random(len(eta)) < 1.0 / (1.0 + np.exp(-eta))).astype(int)
    return pd.DataFrame(
        {
            "subject": [f"S{i + 1:02d}" for i in s],
            "object": [f"{i + 1}" for i in o],
            "condition": [conds[i] for i in c],
            "pixels": p,
            "recognized": y,
            "simulated": 1,
            "observer": "logistic-k",
        }
    )
