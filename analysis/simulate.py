"""Simulated trial tables from stated models, in the paper's design (for tests and power).

Two generative models:

* :class:`WeibullObserver` per condition: P(recognised) = g + (1 - g - l)(1 - exp(-(x/a)^b)),
  optionally with a per-subject multiplicative spread of ``a``;
* :class:`LogisticObserver`: the paper's logistic model with random subject and object intercepts
  and a lapse rate.

The design defaults to Jung et al. 2015 (6 subjects x 20 objects x 8 levels x 2 conditions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import special

from analysis.jung2015 import CONDITIONS, N_OBJECTS, N_SUBJECTS, PIXEL_COUNTS
from analysis.weibull import psychometric

__all__ = [
    "WeibullObserver",
    "LogisticObserver",
    "design",
    "simulate_weibull_trials",
    "simulate_logistic_trials",
]


@dataclass(frozen=True)
class WeibullObserver:
    """Weibull observer for one condition.

    Parameters
    ----------
    alpha_px : float
        Weibull scale, pixels (> 0).
    beta : float
        Weibull shape (> 0).
    lapse : float
        Lapse rate in [0, 1 - guess).
    guess : float
        Guess rate in [0, 1).
    """

    alpha_px: float
    beta: float
    lapse: float = 0.0
    guess: float = 0.0

    def __post_init__(self) -> None:
        if not self.alpha_px > 0:
            raise ValueError(f"alpha_px must be > 0, got {self.alpha_px!r}")
        if not self.beta > 0:
            raise ValueError(f"beta must be > 0, got {self.beta!r}")
        if not (0 <= self.guess < 1 and 0 <= self.lapse < 1 - self.guess):
            raise ValueError(
                f"need 0 <= guess < 1 and 0 <= lapse < 1 - guess, got {(self.guess, self.lapse)!r}"
            )


@dataclass(frozen=True)
class LogisticObserver:
    """The paper's logistic model as a generator, with random intercepts and lapses.

    logit P = intercept + log(background_or) * decluttered + log(log10_pixels_or) * log10(px)
    + u_subject + v_object; then P -> (1 - lapse) * P.

    Parameters
    ----------
    background_or : float
        Odds ratio de-cluttered vs cluttered.
    log10_pixels_or : float
        Odds ratio per log10 pixels.
    intercept : float
        Log odds at 1 pixel, cluttered, average subject and object.
    subject_sd, object_sd : float
        SDs of the random intercepts, log-odds units.
    lapse : float
        Lapse rate in [0, 1).

    Notes
    -----
    Defaults follow the paper's estimates (OR 5.6 and 74.5, Sec. 3.2.2), with the intercept set so
    that the cluttered 50 % point is 8,695 px; the random-effect SDs and lapse are ours.
    """

    background_or: float = 5.6
    log10_pixels_or: float = 74.5
    intercept: float = -float(np.log(74.5) * np.log10(8695.0))
    subject_sd: float = 0.5
    object_sd: float = 1.0
    lapse: float = 0.0

    @classmethod
    def from_x50(
        cls,
        x50_cluttered_px: float,
        *,
        background_or: float = 5.6,
        log10_pixels_or: float = 74.5,
        subject_sd: float = 0.5,
        object_sd: float = 1.0,
        lapse: float = 0.0,
    ) -> LogisticObserver:
        """Return the observer whose cluttered 50 % point (no lapse) is ``x50_cluttered_px``.

        Parameters
        ----------
        x50_cluttered_px : float
            Cluttered 50 % point for an average subject and object, pixels (> 0).
        background_or, log10_pixels_or, subject_sd, object_sd, lapse : float
            As in the class.

        Returns
        -------
        LogisticObserver
            With ``intercept = -log(log10_pixels_or) * log10(x50_cluttered_px)``.

        Examples
        --------
        >>> obs = LogisticObserver.from_x50(8695.0)
        >>> round(float(obs.p_recognized(8695.0, False)), 6)
        0.5
        """
        return cls(
            background_or=background_or,
            log10_pixels_or=log10_pixels_or,
            intercept=-float(np.log(log10_pixels_or) * np.log10(x50_cluttered_px)),
            subject_sd=subject_sd,
            object_sd=object_sd,
            lapse=lapse,
        )

    def p_recognized(
        self,
        pixels: np.ndarray | float,
        decluttered: np.ndarray | bool,
        subject_effect: np.ndarray | float = 0.0,
        object_effect: np.ndarray | float = 0.0,
    ) -> np.ndarray:
        """Return P(recognised) of trials, lapse included (the one formula of the model).

        Parameters
        ----------
        pixels : array_like of float
            Pixels of each stimulus (> 0).
        decluttered : array_like of bool
            Whether each stimulus is de-cluttered (else cluttered).
        subject_effect, object_effect : array_like of float
            The trials' random intercepts u and v, log-odds units.

        Returns
        -------
        numpy.ndarray
            ``(1 - lapse) * expit(eta)``, broadcast over the arguments.
        """
        eta = (
            self.intercept
            + np.log(self.background_or) * np.asarray(decluttered)
            + np.log(self.log10_pixels_or) * np.log10(np.asarray(pixels, dtype=float))
            + subject_effect
            + object_effect
        )
        return (1 - self.lapse) * special.expit(eta)


def design(
    *,
    n_subjects: int = N_SUBJECTS,
    n_objects: int = N_OBJECTS,
    pixels: tuple[float, ...] = PIXEL_COUNTS,
    conditions: tuple[str, ...] = CONDITIONS,
) -> pd.DataFrame:
    """Return the full factorial design (one row per trial, no outcome).

    Parameters
    ----------
    n_subjects, n_objects : int
        Numbers of subjects (``s1``...) and objects (``1``...).
    pixels : tuple of float
        Pixel counts of the levels.
    conditions : tuple of str
        Conditions.

    Returns
    -------
    pandas.DataFrame
        Columns ``subject, object, condition, pixels, level``.
    """
    if n_subjects < 1 or n_objects < 1:
        raise ValueError(f"n_subjects and n_objects must be >= 1, got {(n_subjects, n_objects)!r}")
    px = sorted(float(p) for p in pixels)
    rows = [
        (f"s{s + 1}", str(o + 1), c, p, i + 1)
        for s in range(n_subjects)
        for c in conditions
        for i, p in enumerate(px)
        for o in range(n_objects)
    ]
    return pd.DataFrame(rows, columns=["subject", "object", "condition", "pixels", "level"])


def simulate_weibull_trials(
    observers: dict[str, WeibullObserver],
    *,
    n_subjects: int = N_SUBJECTS,
    n_objects: int = N_OBJECTS,
    pixels: tuple[float, ...] = PIXEL_COUNTS,
    subject_log10_sd: float = 0.0,
    object_log10_sd: float = 0.0,
    subject_lapse_spread: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> pd.DataFrame:
    """Simulate a trial table from one Weibull observer per condition.

    Heterogeneous observers, as a real study has: ``log10(alpha)`` shifted per subject and per
    object (normal, the same shift in both conditions), and each subject's lapse rate drawn
    uniformly within ``lapse +- subject_lapse_spread`` (clipped at 0).

    Parameters
    ----------
    observers : dict of str to WeibullObserver
        Condition name -> observer.
    n_subjects, n_objects : int
        Design size.
    pixels : tuple of float
        Pixel counts of the levels.
    subject_log10_sd : float
        SD of a per-subject shift of ``log10(alpha)`` (0: all subjects identical).
    object_log10_sd : float
        SD of a per-object shift of ``log10(alpha)`` (0: all objects equally hard).
    subject_lapse_spread : float
        Half-width of the uniform spread of each subject's lapse rate around the observer's.
    rng : numpy.random.Generator or int or None

    Returns
    -------
    pandas.DataFrame
        Tidy trials (``subject, object, condition, pixels, level, recognized``).
    """
    rng = np.random.default_rng(rng)
    d = design(
        n_subjects=n_subjects, n_objects=n_objects, pixels=pixels, conditions=tuple(observers)
    )
    subjects = d["subject"].unique()
    shift = dict(
        zip(subjects, 10 ** (subject_log10_sd * rng.standard_normal(len(subjects))), strict=False)
    )
    # Drawn only when asked for, so that the default stream (and old seeds) stay as they were.
    objects = d["object"].unique()
    oshift = (
        dict(zip(objects, 10 ** (object_log10_sd * rng.standard_normal(len(objects))), strict=True))
        if object_log10_sd > 0
        else dict.fromkeys(objects, 1.0)
    )
    lapse_u = (
        dict(zip(subjects, rng.uniform(-1, 1, len(subjects)), strict=True))
        if subject_lapse_spread > 0
        else dict.fromkeys(subjects, 0.0)
    )
    p = np.empty(len(d))
    for cond, obs in observers.items():
        m = (d["condition"] == cond).to_numpy()
        a = (
            obs.alpha_px
            * d.loc[m, "subject"].map(shift).to_numpy()
            * d.loc[m, "object"].map(oshift).to_numpy()
        )
        lapse = np.clip(
            obs.lapse + subject_lapse_spread * d.loc[m, "subject"].map(lapse_u).to_numpy(),
            0.0,
            1 - obs.guess - 1e-9,
        )
        p[m] = psychometric(d.loc[m, "pixels"].to_numpy(), a, obs.beta, 0.0, guess=obs.guess)
        p[m] = obs.guess + (1 - obs.guess - lapse) * (p[m] - obs.guess) / (1 - obs.guess)
    d["recognized"] = (rng.random(len(d)) < p).astype(int)
    return d


def simulate_logistic_trials(
    observer: LogisticObserver | None = None,
    *,
    n_subjects: int = N_SUBJECTS,
    n_objects: int = N_OBJECTS,
    pixels: tuple[float, ...] = PIXEL_COUNTS,
    rng: np.random.Generator | int | None = None,
) -> pd.DataFrame:
    """Simulate a trial table from the logistic model with random subject and object effects.

    Parameters
    ----------
    observer : LogisticObserver, optional
        Model parameters; the paper-like defaults when omitted.
    n_subjects, n_objects : int
        Design size.
    pixels : tuple of float
        Pixel counts of the levels.
    rng : numpy.random.Generator or int or None

    Returns
    -------
    pandas.DataFrame
        Tidy trials (``subject, object, condition, pixels, level, recognized``).
    """
    obs = observer or LogisticObserver()
    rng = np.random.default_rng(rng)
    d = design(n_subjects=n_subjects, n_objects=n_objects, pixels=pixels)
    u = dict(
        zip(d["subject"].unique(), obs.subject_sd * rng.standard_normal(n_subjects), strict=False)
    )
    v = dict(
        zip(d["object"].unique(), obs.object_sd * rng.standard_normal(n_objects), strict=False)
    )
    p = obs.p_recognized(
        d["pixels"].to_numpy(),
        (d["condition"] == "decluttered").to_numpy(),
        d["subject"].map(u).to_numpy(),
        d["object"].map(v).to_numpy(),
    )
    d["recognized"] = (rng.random(len(d)) < p).astype(int)
    return d
