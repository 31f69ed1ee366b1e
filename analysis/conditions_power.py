"""Power of a method comparison: subjects needed to tell two of k methods apart, Holm-corrected.

A study compares ``k`` conditions (the reference and ``k - 1`` methods) at the same levels. The
question planned for is one pair: the reference against a method with odds ratio ``OR`` (or a
50 % threshold ratio, converted through the paper's slope: ``OR = 74.5 ** log10(ratio)``, so
the paper's ratio 2.46 gives about 5.4, near its odds ratio 5.6). The other ``k - 2`` methods
are simulated equal to the reference (they only add comparisons). Each simulated study
(:func:`analysis.conditions_sim.simulate_condition_trials`) is fitted by
:func:`analysis.conditions.fit_condition_logistic`; its power is the share of studies in which
the pair's contrast has a Holm-adjusted p below ``alpha`` over all ``k (k - 1) / 2`` pairwise
contrasts -- the multiplicity correction the report applies.

Documented effect sizes: the paper's background odds ratio 5.6 (Jung et al. 2015); the odds
ratios of Kartha et al. (2020) from their proportions correct with stereo distance filtering,
about 11 (86 % vs 35 %) and 2.3 (81 % vs 65 %) (:data:`analysis.conditions_sim.KARTHA_ORS`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from analysis.conditions import fit_condition_logistic
from analysis.conditions_sim import simulate_condition_trials
from analysis.power_report import needed

__all__ = [
    "PAPER_SLOPE_OR",
    "ratio_to_odds_ratio",
    "MethodPowerPoint",
    "method_power",
    "echo_method_power",
]

#: The paper's odds ratio per log10 pixels (Jung et al. 2015, Sec. 3.2.2), which converts a
#: threshold ratio into an odds ratio.
PAPER_SLOPE_OR: float = 74.5


def ratio_to_odds_ratio(ratio: float) -> float:
    """Return the odds ratio that moves the 50 % threshold by ``ratio`` under the paper's slope.

    Examples
    --------
    >>> round(ratio_to_odds_ratio(2.46), 2)
    5.39
    """
    return math.exp(math.log(PAPER_SLOPE_OR) * math.log10(ratio))


@dataclass(frozen=True)
class MethodPowerPoint:
    """Power at one design point.

    Parameters
    ----------
    odds_ratio : float
        The planned pair's odds ratio.
    n_conditions, n_subjects : int
    power : float
    ci95 : (float, float)
        Wilson 95 % interval of the power (Monte Carlo error).
    n_sims : int
        Studies simulated (fits that failed count as not significant).
    """

    odds_ratio: float
    n_conditions: int
    n_subjects: int
    power: float
    ci95: tuple[float, float]
    n_sims: int


def _wilson(k: int, n: int) -> tuple[float, float]:
    z = 1.959963984540054
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, c - h), min(1.0, c + h)


def method_power(
    odds_ratios: Sequence[float],
    subjects: Sequence[int],
    *,
    n_conditions: int = 4,
    n_objects: int = 20,
    n_sims: int = 200,
    alpha: float = 0.05,
    seed: int | None = None,
) -> Iterator[MethodPowerPoint | int]:
    """Simulate the power of a k-condition comparison, yielding progress then each point.

    Parameters
    ----------
    odds_ratios : sequence of float > 0
        Odds ratios of the planned pair (method over reference).
    subjects : sequence of int >= 1
    n_conditions : int >= 2
    n_objects : int >= 2
    n_sims : int >= 1
    alpha : float in (0, 1)
    seed : int or None

    Yields
    ------
    int or MethodPowerPoint
        The number of studies simulated so far (after each), and each point when it is done.
    """
    if n_conditions < 2:
        raise ValueError(f"n_conditions must be >= 2, got {n_conditions!r}")
    names = ["reference", "method", *(f"other{i}" for i in range(1, n_conditions - 1))]
    root = np.random.SeedSequence(seed)
    done = 0
    for o in odds_ratios:
        for n in subjects:
            hits = 0
            for ss in root.spawn(n_sims):
                ors = dict.fromkeys(names, 1.0)
                ors["method"] = float(o)
                df = simulate_condition_trials(
                    ors, n_subjects=n, n_objects=n_objects, rng=np.random.default_rng(ss)
                )
                fit = fit_condition_logistic(df, names, "reference")
                pair = next((c for c in fit.contrasts if c["pair"] == ["reference", "method"]), {})
                p = pair.get("p_adjusted")
                hits += int(p is not None and p < alpha)
                done += 1
                yield done
            yield MethodPowerPoint(
                float(o), n_conditions, int(n), hits / n_sims, _wilson(hits, n_sims), n_sims
            )


def echo_method_power(
    effect: str,
    sizes: Sequence[float],
    subjects: Sequence[int],
    n_conditions: int,
    n_objects: int,
    n_sims: int,
    alpha: float,
    seed: int | None,
    target: float,
    *,
    run,
    echo,
    seed_text: str | None = None,
) -> list[MethodPowerPoint]:
    """Run :func:`method_power` for ``confocal analyze power --conditions K`` and print the table.

    Parameters
    ----------
    effect : {'odds_ratio', 'threshold_ratio'}
        How ``sizes`` are given (a threshold ratio is converted by :func:`ratio_to_odds_ratio`).
    sizes, subjects, n_conditions, n_objects, n_sims, alpha, seed, target
        As the command's options.
    run : callable(generator, label, total) -> list
        Drains the generator under a progress bar, returning the points.
    echo : callable(str)
        Prints one line.
    seed_text : str, optional
        How the seed is printed (default ``'seed N'``); a drawn seed says how to reproduce it.

    Returns
    -------
    list of MethodPowerPoint
    """
    ors = [ratio_to_odds_ratio(v) if effect == "threshold_ratio" else float(v) for v in sizes]
    total = len(ors) * len(subjects) * n_sims
    gen = method_power(
        ors,
        subjects,
        n_conditions=n_conditions,
        n_objects=n_objects,
        n_sims=n_sims,
        alpha=alpha,
        seed=seed,
    )
    points = run(gen, "simulating a method comparison", total)
    echo(
        f"method comparison of {n_conditions} conditions: reference vs one method, Holm over "
        f"{n_conditions * (n_conditions - 1) // 2} pairs, alpha = {alpha:g}, {n_objects} objects, "
        f"8 levels; {n_sims} SIMULATED studies per row, {seed_text or f'seed {seed}'}"
    )
    echo(f"{'size':>6} {'OR':>6} {'subjects':>8}  power   (95% CI)")
    for size, o in zip(sizes, ors, strict=True):
        row = [p for p in points if p.odds_ratio == o]
        for p in row:
            lo, hi = p.ci95
            echo(f"{size:>6g} {o:>6.3g} {p.n_subjects:>8}  {p.power:.2f}   ({lo:.2f}-{hi:.2f})")
        need = needed(row, target)
        echo(
            f"size {size:g}: "
            + (
                f"subjects needed for power {target:g}: {need.n_subjects} (every larger number "
                f"simulated also reached {target:g})"
                if need is not None
                else f"no simulated number of subjects reached power {target:g} (and kept it)"
            )
        )
    return points
