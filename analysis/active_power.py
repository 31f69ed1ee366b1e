"""Power of an active-search study: simulated times to recognition, censored, tested by Cox.

Each simulated study has ``n_subjects`` subjects who each search every target of every scene
once per condition (``n_scenes x n_targets x 2`` trials per subject, as the ``active_search``
protocol does). A trial's time to recognition is drawn from a Weibull proportional-hazards model,

    S(t) = exp(-(t / scale)^shape * frailty * HR^[condition is the treated one]),

with ``scale`` set so that the reference condition's median is ``median_time_s`` for a subject of
frailty 1, ``shape = 1`` giving exponential times, and a log-normal subject frailty (SD
``frailty_sd`` on the log-hazard scale) shared by all of a subject's trials. Times beyond
``time_limit_s`` are right-censored there (the trial ends as a time-out). The study is analysed as
a real one is (:func:`analysis.survival.cox_hazard_ratio`: Cox model stratified by subject, Wald
test), and power is the share of studies whose test rejects hazard ratio 1 at ``alpha``.

The studies run here, in local worker processes or on a Dask cluster, with the same seeding
scheme as :func:`analysis.power.power_grid`: one seed per study, spawned from the root seed by
its position in the grid, so the result does not depend on where or in which order it ran.

References
----------
Bender, Augustin & Blettner (2005), Stat. Med. 24:1713 (Weibull proportional-hazards times);
Cox (1972), J. R. Stat. Soc. B 34:187.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from analysis.power import (
    _PowerEstimate,
    chunk_tasks,
    collect_grid,
    execute_chunks,
    quiet_statsmodels,
)
from analysis.survival import cox_hazard_ratio

__all__ = [
    "ActiveDesign",
    "ActivePowerPoint",
    "simulate_active_study",
    "active_study_detects",
    "active_power_grid",
]

#: Studies per task sent to a worker (ours): a Cox fit takes milliseconds, so chunks are large.
CHUNK_SIMS: int = 25
_CONDITIONS = ("cluttered", "decluttered")


@dataclass(frozen=True)
class ActiveDesign:
    """Design and nuisance parameters of a simulated active-search study.

    Parameters
    ----------
    n_subjects : int
        Subjects, >= 1.
    n_scenes : int
        Scenes per subject, >= 1.
    n_targets : int
        Targets per scene, >= 1 (the shipped scene has 3).
    time_limit_s : float
        Trial time limit, seconds (> 0); later times are censored there.
    median_time_s : float
        Median time to recognition in the reference (cluttered) condition for a subject of
        frailty 1, seconds (> 0), before censoring.
    weibull_shape : float
        Weibull shape (> 0; 1: exponential times, > 1: hazard rising with time).
    frailty_sd : float
        SD of the subjects' log-normal frailty on the log-hazard scale (>= 0).
    """

    n_subjects: int
    n_scenes: int = 2
    n_targets: int = 3
    time_limit_s: float = 60.0
    median_time_s: float = 20.0
    weibull_shape: float = 1.0
    frailty_sd: float = 0.5

    def __post_init__(self) -> None:
        for name in ("n_subjects", "n_scenes", "n_targets"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
        for name in ("time_limit_s", "median_time_s", "weibull_shape"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        v = self.frailty_sd
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"frailty_sd must be a finite number >= 0, got {v!r}")


def simulate_active_study(
    design: ActiveDesign,
    hazard_ratio: float,
    *,
    rng: np.random.Generator | int | None = None,
) -> pd.DataFrame:
    """Simulate one active-search study's trials.

    Parameters
    ----------
    design : ActiveDesign
    hazard_ratio : float
        Hazard of recognition, de-cluttered over cluttered (> 0; 1: no effect).
    rng : Generator, int or None
        Random source.

    Returns
    -------
    DataFrame
        One row per trial: ``subject, scene, target, condition, rt_s, recognized`` (``rt_s``
        the time the trial ended, seconds; not recognised = censored at the time limit).

    Raises
    ------
    ValueError
        ``hazard_ratio`` not finite and > 0.
    """
    if not (math.isfinite(hazard_ratio) and hazard_ratio > 0):
        raise ValueError(f"hazard_ratio must be a finite number > 0, got {hazard_ratio!r}")
    rng = np.random.default_rng(rng)
    d = design
    per_subject = d.n_scenes * d.n_targets * len(_CONDITIONS)
    n = d.n_subjects * per_subject
    subj = np.repeat(np.arange(d.n_subjects), per_subject)
    cond = np.tile(np.repeat([0, 1], d.n_scenes * d.n_targets), d.n_subjects)
    scene = np.tile(np.repeat(np.arange(d.n_scenes), d.n_targets), 2 * d.n_subjects)
    target = np.tile(np.arange(d.n_targets), 2 * d.n_scenes * d.n_subjects)
    frailty = np.exp(rng.normal(0.0, d.frailty_sd, d.n_subjects))[subj]
    hazard = frailty * np.where(cond == 1, hazard_ratio, 1.0)
    # S(t) = exp(-(t/scale)^k * h): t = scale * (E / h)^(1/k), E ~ Exp(1); the median at h = 1
    # is scale * ln(2)^(1/k).
    scale = d.median_time_s / math.log(2.0) ** (1.0 / d.weibull_shape)
    t = scale * (rng.exponential(1.0, n) / hazard) ** (1.0 / d.weibull_shape)
    recognized = t <= d.time_limit_s
    return pd.DataFrame(
        {
            "subject": [f"S{i + 1:02d}" for i in subj],
            "scene": scene,
            "target": target,
            "condition": np.asarray(_CONDITIONS, dtype=object)[cond],
            "rt_s": np.minimum(t, d.time_limit_s),
            "recognized": recognized,
        }
    )


def active_study_detects(trials: pd.DataFrame, *, alpha: float = 0.05) -> bool:
    """Return whether the study's Cox test rejects hazard ratio 1 at ``alpha`` (two-sided).

    A study whose hazard ratio is not estimable (no recognitions in a condition) counts as
    not detecting.
    """
    h = cox_hazard_ratio(
        trials["rt_s"],
        trials["recognized"],
        trials["condition"],
        trials["subject"],
        treated=_CONDITIONS[1],
        reference=_CONDITIONS[0],
    )
    return h.p is not None and h.p < alpha


@dataclass(frozen=True)
class ActivePowerPoint(_PowerEstimate):
    """Power at one active-search design and hazard ratio.

    Parameters
    ----------
    hazard_ratio : float
    n_subjects, n_scenes, n_targets : int
    power : float
        Share of simulated studies whose test rejected hazard ratio 1.
    ci95 : (float, float)
        Clopper-Pearson 95 % interval of ``power``.
    n_sims : int
    """

    hazard_ratio: float
    n_subjects: int
    n_scenes: int
    n_targets: int
    power: float
    ci95: tuple[float, float]
    n_sims: int

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ActivePowerPoint:
        """Inverse of :meth:`to_dict`."""
        return cls(
            float(d["hazard_ratio"]),
            int(d["n_subjects"]),
            int(d["n_scenes"]),
            int(d["n_targets"]),
            float(d["power"]),
            (float(d["ci95"][0]), float(d["ci95"][1])),
            int(d["n_sims"]),
        )


def _run_chunk(
    design: ActiveDesign, hazard_ratio: float, alpha: float, seeds: list[np.random.SeedSequence]
) -> list[bool]:
    """Simulate and test one chunk of studies, each with its own seed (a picklable task)."""
    out = []
    with quiet_statsmodels():
        for ss in seeds:
            trials = simulate_active_study(design, hazard_ratio, rng=np.random.default_rng(ss))
            out.append(active_study_detects(trials, alpha=alpha))
    return out


def active_power_grid(
    hazard_ratios: Sequence[float],
    n_subjects: Sequence[int],
    *,
    n_scenes: Sequence[int] = (2,),
    n_sims: int = 200,
    alpha: float = 0.05,
    seed: int | None = None,
    processes: int | None = None,
    cluster: str | None = None,
    **design: Any,
) -> Iterator[ActivePowerPoint | int]:
    """Estimate the power of the hazard-ratio test over hazard ratios, subjects and scenes.

    Like :func:`analysis.power.power_grid` (seeds, workers and errors alike), for active search.

    Parameters
    ----------
    hazard_ratios : sequence of float
        Hazard ratios to simulate (finite, > 0).
    n_subjects, n_scenes : sequence of int
        Designs to try (each >= 1).
    n_sims, alpha, seed, processes, cluster
        As for :func:`analysis.power.power_grid` (any ``n_sims`` >= 1).
    **design
        ``n_targets``, ``time_limit_s``, ``median_time_s``, ``weibull_shape``, ``frailty_sd``:
        as :class:`ActiveDesign` (its defaults when omitted).

    Yields
    ------
    int or ActivePowerPoint
        The number of studies finished so far (progress), and each grid point when all its
        studies are in, in grid order (hazard ratio, then scenes, then subjects).
    """
    if not hazard_ratios or not all(math.isfinite(v) and v > 0 for v in hazard_ratios):
        raise ValueError(f"hazard ratios must be finite and > 0, got {list(hazard_ratios)!r}")
    if n_sims < 1:
        raise ValueError(f"n_sims must be >= 1, got {n_sims!r}")
    if not (0 < alpha < 1):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    for name, vals in (("subjects", n_subjects), ("scenes", n_scenes)):
        if not vals or min(vals) < 1:
            raise ValueError(f"numbers of {name} must be integers >= 1, got {list(vals)!r}")
    grid = [
        (float(hr), ActiveDesign(int(s), int(sc), **design))
        for hr in hazard_ratios
        for sc in n_scenes
        for s in n_subjects
    ]
    tasks = chunk_tasks([(d, hr, alpha) for hr, d in grid], n_sims, seed, CHUNK_SIMS)
    from statsmodels.stats.proportion import proportion_confint

    def point(gi: int, hits: int) -> ActivePowerPoint:
        hr, d = grid[gi]
        lo, hi = proportion_confint(hits, n_sims, alpha=0.05, method="beta")
        return ActivePowerPoint(
            hr,
            d.n_subjects,
            d.n_scenes,
            d.n_targets,
            hits / n_sims,
            (float(lo), float(hi)),
            n_sims,
        )

    results = execute_chunks(_run_chunk, tasks, processes, cluster)
    yield from collect_grid(results, len(grid), n_sims, point)
