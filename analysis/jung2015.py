"""Numbers reported by Jung, Aloni, Yitzhaky & Peli (2015) and their Eq. 1.

"Active confocal imaging for visual prostheses", Vision Research 111, 182-196. Each constant cites
its section (house style H9). The analysis reproduces these from logged trials; tests and the
report compare against them. ``analysis`` must not import ``stimuli`` (house style H1), so the
design constants shared with ``stimuli.jung2015`` are repeated here, and a test checks they agree.
"""

from __future__ import annotations

__all__ = [
    "PIXEL_COUNTS",
    "N_SUBJECTS",
    "N_OBJECTS",
    "CONDITIONS",
    "N_TRIALS",
    "N_RECOGNIZED",
    "THRESHOLD_P50_PX",
    "OR_BACKGROUND",
    "OR_BACKGROUND_CI95",
    "OR_LOG10_PIXELS",
    "OR_LOG10_PIXELS_CI95",
    "CLASSIFICATION_PCT",
    "N_SIGNIFICANT_OBJECTS",
    "EQ1_EXAMPLES",
    "eq1",
]

#: Pixel counts of the eight resolution levels, highest first. Source: Sec. 3.1.
PIXEL_COUNTS: tuple[int, ...] = (160_884, 40_344, 17_876, 6_370, 3_290, 950, 486, 96)
#: Subjects. Source: Sec. 3.1 (6 normally sighted subjects).
N_SUBJECTS: int = 6
#: Objects. Source: Sec. 3.1 (20 household/office objects).
N_OBJECTS: int = 20
#: Background conditions, reference first. Source: Sec. 3.2.2.
CONDITIONS: tuple[str, str] = ("cluttered", "decluttered")
#: Trials in total. Source: Sec. 3.2.2 (6 x 20 x 8 x 2 = 1,920).
N_TRIALS: int = 1920
#: Recognised trials. Source: Sec. 3.2.2 (892 recognised, 46.5 %).
N_RECOGNIZED: int = 892
#: 50 % recognition thresholds of the pooled Weibull fits, pixels. Source: Sec. 3.2.2, Fig. 8.
THRESHOLD_P50_PX: dict[str, float] = {"cluttered": 8695.0, "decluttered": 3532.0}
#: Odds ratio de-cluttered vs cluttered. Source: Sec. 3.2.2.
OR_BACKGROUND: float = 5.6
#: Its 95 % CI. Source: Sec. 3.2.2.
OR_BACKGROUND_CI95: tuple[float, float] = (3.9, 8.1)
#: Odds ratio per log10 pixels. Source: Sec. 3.2.2.
OR_LOG10_PIXELS: float = 74.5
#: Its 95 % CI. Source: Sec. 3.2.2.
OR_LOG10_PIXELS_CI95: tuple[float, float] = (48.9, 113.5)
#: Classification table of the logistic model at 0.5, percent correct. Source: Sec. 3.2.2.
CLASSIFICATION_PCT: dict[str, float] = {"recognized": 90.3, "not_recognized": 91.0}
#: Significant object dummies out of 19. Source: Sec. 3.2.2 / Fig. S3.
N_SIGNIFICANT_OBJECTS: int = 14
#: Eq. 1 examples: (reference rate, odds ratio, predicted rate). Source: Sec. 3.2.2. The paper's
#: 84.9 % and 15.1 % come from its unrounded odds ratio; OR = 5.6 exactly gives 84.85 % and
#: 15.15 %.
EQ1_EXAMPLES: tuple[tuple[float, float, float], ...] = (
    (0.5, 5.6, 0.849),
    (0.5, 1 / 5.6, 0.151),
)


def eq1(p_ref: float, odds_ratio: float) -> float:
    """Return the recognition rate predicted by Eq. 1: ``OR*O' / (1 + OR*O')``, ``O' = p'/(1-p')``.

    Parameters
    ----------
    p_ref : float
        Reference recognition rate p' in (0, 1).
    odds_ratio : float
        Odds ratio (> 0).

    Returns
    -------
    float

    References
    ----------
    Jung et al. 2015, Eq. 1 (Sec. 3.2.2).

    Examples
    --------
    >>> round(eq1(0.5, 5.6), 4)
    0.8485
    """
    from analysis.logistic import predict_from_odds_ratio

    return predict_from_odds_ratio(p_ref, odds_ratio)
