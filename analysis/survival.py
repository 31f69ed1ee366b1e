"""Censored time to recognition in active search: Kaplan-Meier, Cox hazard ratio, mixed model.

A trial that ends in a pass or a time-out did not recognise the target *by the time it ended*;
leaving it out (or averaging only the recognised trials) makes a condition in which subjects
often give up look fast. Here such a trial is **right-censored at the time it ended** (``rt_s``):

* per condition, the Kaplan-Meier survival curve of "not yet recognised", its median with a
  95 % interval (``None``, "not reached", while the curve stays at or above one half) and the
  recognition rate with a Wilson 95 % interval;
* between conditions, the hazard ratio of recognition from a Cox proportional-hazards model
  stratified by subject (each subject has their own baseline hazard, so the comparison is within
  subjects), with its 95 % Wald interval and Wald test;
* a mixed-effects logistic model of recognition (subject random intercept, statsmodels
  ``BinomialBayesMixedGLM`` fitted by variational Bayes), reported "not estimable" when the data
  cannot identify it (one subject, one condition, every or no trial recognised in a condition);
* secondary measures (planes visited, depth keys, zoom use) as means with t intervals over
  subject means (over trials when there is one subject).

The estimators are statsmodels' (``statsmodels.duration.SurvfuncRight`` and ``PHReg``); this module
only arranges the data and the results. It reads the per-trial table of
:func:`analysis.active.active_trials` and imports neither ``stimuli`` nor ``experiment``.

References
----------
Kaplan & Meier (1958), J. Am. Stat. Assoc. 53:457; Cox (1972), J. R. Stat. Soc. B 34:187;
Wilson (1927), J. Am. Stat. Assoc. 22:209. Jung et al. (2015), Sec. 5 (the active system whose
search these trials log).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import MISSING, asdict, dataclass, field, fields
from typing import Any

import numpy as np
import pandas as pd

__all__ = [
    "CENSORING",
    "REFERENCE_CONDITION",
    "SECONDARY_MEASURES",
    "KaplanMeierSummary",
    "HazardRatio",
    "RecognitionModel",
    "SurvivalAnalysis",
    "kaplan_meier",
    "cox_hazard_ratio",
    "recognition_model",
    "mean_ci95",
    "analyze_survival",
    "MIXED_FE_PRIOR_SD",
    "MIXED_VC_PRIOR_SD",
]

#: What the analysis censors, in words (report and ``results.json``).
CENSORING: str = (
    "passes and time-outs are right-censored at the time the trial ended (rt_s); a recognised "
    "trial is an event at its answer time"
)
#: The comparison's reference condition when present (ours): the conventional camera view, so a
#: hazard ratio above 1 means the other condition (the confocal de-cluttered view) is recognised
#: sooner.
REFERENCE_CONDITION: str = "cluttered"
#: Secondary measures given intervals: name in ``results.json`` -> column of the trial table.
SECONDARY_MEASURES: dict[str, str] = {
    "planes_visited_mean": "planes_visited",
    "depth_keys_mean": "depth_keys",
    "zoom_use_rate": "zoomed",
}
_Z95 = 1.959963984540054


def _fnum(v: Any) -> float | None:
    if v is None:
        return None
    f = float(v)
    return f if math.isfinite(f) else None


def _pair(v: Sequence[Any] | None) -> tuple[float | None, float | None]:
    if v is None:
        return (None, None)
    return (_fnum(v[0]), _fnum(v[1]))


def _floats(v: Sequence[Any]) -> tuple[float, ...]:
    return tuple(float(x) for x in v)


#: How a result's ``from_dict`` reads a field, by the field's annotation.
_READ_FIELD = {
    "str": str,
    "int": int,
    "float": float,
    "float | None": _fnum,
    "tuple[float | None, float | None]": _pair,
    "tuple[float, float]": _floats,
    "tuple[float, ...]": _floats,
}


def _to_dict(result: Any, **keys: str) -> dict[str, Any]:
    """Return a result's fields as a JSON-ready dict, tuples as lists; ``keys`` renames fields."""
    return {
        keys.get(k, k): list(v) if isinstance(v, tuple) else v for k, v in asdict(result).items()
    }


def _from_dict(cls: type, d: dict[str, Any], **keys: str) -> Any:
    """Return ``cls`` read back from its ``to_dict`` form (``keys`` as for :func:`_to_dict`).

    Each field is converted by its annotation (:data:`_READ_FIELD`); a field with a default may
    be missing from ``d``.
    """
    values = {}
    for f in fields(cls):
        key = keys.get(f.name, f.name)
        if key in d or f.default is MISSING:
            values[f.name] = _READ_FIELD[f.type](d[key])
    return cls(**values)


@dataclass(frozen=True)
class KaplanMeierSummary:
    """Kaplan-Meier estimate of "not yet recognised" for one group of trials.

    Attributes
    ----------
    label : str
        The condition (or subject and condition) these trials are.
    n_trials, n_recognized, n_censored : int
    median_s : float or None
        Kaplan-Meier median time to recognition, seconds (statsmodels: the first event time at
        which the curve is below one half); None: not reached.
    median_ci95_s : (float or None, float or None)
        95 % interval of the median (statsmodels ``quantile_ci``, complementary log-log); an end
        that is None is not reached (unbounded above) or not estimable.
    recognition_rate : float
        Share of trials recognised (by their end; not a Kaplan-Meier estimate).
    recognition_rate_ci95 : (float, float)
        Wilson 95 % interval of the rate.
    time_s : tuple of float
        Event (recognition) times of the curve's steps, ascending, seconds.
    survival : tuple of float
        Share not yet recognised just after each of ``time_s``.
    survival_ci95_low, survival_ci95_high : tuple of float
        Pointwise 95 % interval (Greenwood variance, log-log transform) at each of ``time_s``.
    censored_s : tuple of float
        End times of the censored trials (passes, time-outs), ascending, seconds.
    longest_s : float
        Longest trial, seconds (0 without trials).
    """

    label: str
    n_trials: int
    n_recognized: int
    n_censored: int
    median_s: float | None
    median_ci95_s: tuple[float | None, float | None]
    recognition_rate: float
    recognition_rate_ci95: tuple[float, float]
    time_s: tuple[float, ...] = ()
    survival: tuple[float, ...] = ()
    survival_ci95_low: tuple[float, ...] = ()
    survival_ci95_high: tuple[float, ...] = ()
    censored_s: tuple[float, ...] = ()
    longest_s: float = 0.0

    def survival_at(self, t_s: Any) -> np.ndarray:
        """Return the curve's value at times ``t_s`` (seconds; right-continuous step)."""
        t = np.asarray(t_s, float)
        idx = np.searchsorted(np.asarray(self.time_s, float), t, side="right")
        return np.concatenate([[1.0], np.asarray(self.survival, float)])[idx]

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict: every field, tuples as lists."""
        return _to_dict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> KaplanMeierSummary:
        """Inverse of :meth:`to_dict`."""
        return _from_dict(cls, d)


def _check_times(time_s: Any, recognized: Any) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(time_s, dtype=float).ravel()
    e = np.asarray(recognized).ravel()
    if t.shape != e.shape:
        raise ValueError(
            f"time_s and recognized must have the same length, got {t.size} and {e.size}"
        )
    if t.size == 0:
        raise ValueError("time_s must hold at least one trial, got none")
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError(f"time_s must be finite and >= 0 seconds, got {t[~(t >= 0)][:3]!r}")
    return t, e.astype(bool)


def kaplan_meier(time_s: Any, recognized: Any, *, label: str = "") -> KaplanMeierSummary:
    """Return the Kaplan-Meier summary of right-censored times to recognition.

    Parameters
    ----------
    time_s : array_like of shape (n_trials,)
        Time each trial ended (the answer, pass or time-out), seconds, finite and >= 0.
    recognized : array_like of bool, shape (n_trials,)
        True: recognised at ``time_s`` (an event); False: censored at ``time_s``.
    label : str
        Name of the group (kept in the result).

    Returns
    -------
    KaplanMeierSummary

    Raises
    ------
    ValueError
        Lengths differ, no trials, or a time that is negative or not finite.

    Examples
    --------
    >>> km = kaplan_meier([1.0, 2.0, 3.0, 4.0, 5.0], [True, False, True, True, False])
    >>> km.median_s, [round(s, 3) for s in km.survival]
    (4.0, [0.8, 0.533, 0.267])
    """
    from statsmodels.duration.survfunc import SurvfuncRight
    from statsmodels.stats.proportion import proportion_confint

    t, e = _check_times(time_s, recognized)
    n, k = int(t.size), int(e.sum())
    lo_r, hi_r = proportion_confint(k, n, alpha=0.05, method="wilson")
    rate_ci = (float(lo_r), float(hi_r))
    censored = tuple(float(v) for v in np.sort(t[~e]))
    base = dict(
        label=label,
        n_trials=n,
        n_recognized=k,
        n_censored=n - k,
        recognition_rate=k / n,
        recognition_rate_ci95=rate_ci,
        censored_s=censored,
        longest_s=float(t.max()),
    )
    if k == 0:
        return KaplanMeierSummary(median_s=None, median_ci95_s=(None, None), **base)
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        # statsmodels warns on log(0) at curve ends; those ends are handled below
        warnings.simplefilter("ignore", RuntimeWarning)
        sf = SurvfuncRight(t, e.astype(int))
        median = _fnum(sf.quantile(0.5))
        ci = _pair(sf.quantile_ci(0.5, alpha=0.05, method="cloglog"))
        s = np.asarray(sf.surv_prob, float)
        se = np.asarray(sf.surv_prob_se, float)
        # pointwise log-log interval, the transform statsmodels' quantile_ci uses
        inner = (s > 0) & (s < 1) & (se > 0)
        w = np.where(inner, _Z95 * se / (s * np.abs(np.log(np.where(inner, s, 0.5)))), 0.0)
        lo = np.where(inner, s ** np.exp(w), s)
        hi = np.where(inner, s ** np.exp(-w), s)
    if median is None:
        ci = (ci[0], None)
    return KaplanMeierSummary(
        median_s=median,
        median_ci95_s=ci,
        time_s=tuple(float(v) for v in sf.surv_times),
        survival=tuple(float(v) for v in s),
        survival_ci95_low=tuple(float(v) for v in lo),
        survival_ci95_high=tuple(float(v) for v in hi),
        **base,
    )


@dataclass(frozen=True)
class HazardRatio:
    """Hazard ratio of recognition between two conditions (Cox model).

    Attributes
    ----------
    condition, reference : str
        The hazard ratio is ``condition`` over ``reference``: above 1, ``condition`` is
        recognised sooner (or more often before the trials end).
    hazard_ratio : float or None
        None: not estimable (see ``note``).
    ci95 : (float or None, float or None)
        95 % Wald interval.
    p : float or None
        Two-sided Wald test of hazard ratio 1.
    method : str
        Model, strata and test, in words.
    n_trials, n_recognized, n_subjects : int
    note : str
        Why it is not estimable, or empty.
    """

    condition: str
    reference: str
    hazard_ratio: float | None
    ci95: tuple[float | None, float | None]
    p: float | None
    method: str
    n_trials: int
    n_recognized: int
    n_subjects: int
    note: str = ""

    @property
    def estimable(self) -> bool:
        """Return whether a hazard ratio was estimated."""
        return self.hazard_ratio is not None

    def to_dict(self) -> dict[str, Any]:
        """Return the ``comparison`` entry of ``results.json`` (ci95 as ``hazard_ratio_ci95``)."""
        return _to_dict(self, ci95="hazard_ratio_ci95")

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> HazardRatio:
        """Inverse of :meth:`to_dict`."""
        return _from_dict(cls, d, ci95="hazard_ratio_ci95")


def cox_hazard_ratio(
    time_s: Any,
    recognized: Any,
    condition: Any,
    subject: Any,
    *,
    treated: str,
    reference: str,
) -> HazardRatio:
    """Return the hazard ratio of recognition, ``treated`` over ``reference``, from a Cox model.

    The model is statsmodels ``PHReg`` (Breslow ties) with one indicator for ``treated``, on the
    trials of these two conditions, stratified by subject when there are two or more subjects
    (each subject has their own baseline hazard, so subjects' speed differences do not count as
    condition effects). The interval and test are Wald's.

    Parameters
    ----------
    time_s : array_like of shape (n_trials,)
        Time each trial ended, seconds.
    recognized : array_like of bool, shape (n_trials,)
        Event (True) or censored (False).
    condition, subject : array_like of shape (n_trials,)
        Labels per trial.
    treated, reference : str
        The two conditions compared.

    Returns
    -------
    HazardRatio
        With ``hazard_ratio`` None and a ``note`` when the data cannot identify it (no
        recognitions in a condition, no subject with both conditions, a fit that fails).

    Raises
    ------
    ValueError
        Lengths differ, or a time that is negative or not finite.
    """
    from statsmodels.duration.hazard_regression import PHReg

    t, e = _check_times(time_s, recognized)
    cond = np.asarray(condition, dtype=object).ravel()
    subj = np.asarray(subject, dtype=object).ravel()
    if not (cond.size == subj.size == t.size):
        raise ValueError(
            f"condition and subject must have one label per trial ({t.size}), got "
            f"{cond.size} and {subj.size}"
        )
    keep = (cond == treated) | (cond == reference)
    t, e, cond, subj = t[keep], e[keep], cond[keep], subj[keep]
    n_subj = len(set(subj.tolist()))
    strat = n_subj > 1
    method = (
        "Cox proportional hazards (statsmodels PHReg, Breslow ties)"
        + (", stratified by subject" if strat else ", one subject")
        + "; 95 % Wald interval and Wald test"
    )

    def out(hr=None, ci=(None, None), p=None, note=""):
        return HazardRatio(
            treated, reference, hr, ci, p, method, int(t.size), int(e.sum()), n_subj, note
        )

    for c in (treated, reference):
        if not np.any(cond == c):
            return out(note=f"no trials in condition {c!r}")
        if not np.any(e[cond == c]):
            return out(note=f"no recognitions in condition {c!r}: the hazard ratio is 0 or inf")
    x = (cond == treated).astype(float)[:, None]
    if strat:
        both = [s for s in set(subj.tolist()) if len(set(cond[subj == s].tolist())) == 2]
        if not both:
            return out(note="no subject searched in both conditions (strata carry no contrast)")
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        try:
            model = PHReg(t, x, status=e.astype(int), strata=subj if strat else None)
            res = model.fit()
            beta, se = float(res.params[0]), float(res.bse[0])
            p = float(res.pvalues[0])
        except (np.linalg.LinAlgError, ValueError, ZeroDivisionError) as exc:
            return out(note=f"Cox model not estimable ({exc})")
    if not (math.isfinite(beta) and math.isfinite(se) and se > 0 and abs(beta) < 20):
        return out(note="Cox model not estimable: no finite maximum of the likelihood (separation)")
    return out(math.exp(beta), (math.exp(beta - _Z95 * se), math.exp(beta + _Z95 * se)), p)


@dataclass(frozen=True)
class RecognitionModel:
    """Mixed-effects logistic model of recognition: condition (fixed), subject (random intercept).

    Attributes
    ----------
    method : str
        Model and fitting method, in words.
    condition, reference : str
        The odds ratio is ``condition`` over ``reference``.
    odds_ratio : float or None
        Posterior mean on the log-odds scale, exponentiated; None: not estimable.
    ci95 : (float or None, float or None)
        95 % interval (posterior mean +- 1.96 posterior SD, exponentiated).
    subject_sd : float or None
        Posterior mean of the subjects' random-intercept SD, log-odds.
    note : str
        Why it is not estimable, or empty.
    """

    method: str
    condition: str
    reference: str
    odds_ratio: float | None
    ci95: tuple[float | None, float | None]
    subject_sd: float | None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Return the ``recognition_model`` entry of ``results.json``."""
        return {
            "method": self.method,
            "condition": self.condition,
            "reference": self.reference,
            "estimable": self.odds_ratio is not None,
            "odds_ratio": self.odds_ratio,
            "odds_ratio_ci95": list(self.ci95),
            "subject_sd": self.subject_sd,
            "note": self.note,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RecognitionModel:
        """Inverse of :meth:`to_dict`."""
        return _from_dict(cls, d, ci95="odds_ratio_ci95")


#: The mixed model's priors (statsmodels' defaults, passed explicitly so they are the ones
#: stated): SD of the normal prior of each fixed effect (log-odds) and of each log random-effect
#: SD. A N(0, 2^2) prior on the log odds ratio shrinks a large odds ratio towards 1.
MIXED_FE_PRIOR_SD: float = 2.0
MIXED_VC_PRIOR_SD: float = 1.0

_MODEL_METHOD = (
    "mixed-effects logistic regression of recognition: condition fixed, subject random "
    "intercept (statsmodels BinomialBayesMixedGLM, variational Bayes; priors: fixed effects "
    f"N(0, {MIXED_FE_PRIOR_SD:g}^2) on the log-odds scale, log subject SD "
    f"N(0, {MIXED_VC_PRIOR_SD:g}^2), which shrink a large odds ratio towards 1)"
)


def recognition_model(
    recognized: Any, condition: Any, subject: Any, *, treated: str, reference: str
) -> RecognitionModel:
    """Fit the mixed-effects logistic model of recognition, or say why it is not estimable.

    Parameters
    ----------
    recognized : array_like of bool, shape (n_trials,)
    condition, subject : array_like of shape (n_trials,)
        Labels per trial (trials of other conditions are left out).
    treated, reference : str
        The two conditions compared.

    Returns
    -------
    RecognitionModel
        ``odds_ratio`` None with a ``note`` for one subject, a missing condition, or a
        condition in which every trial or no trial was recognised (complete separation).
    """
    y = np.asarray(recognized).astype(float).ravel()
    cond = np.asarray(condition, dtype=object).ravel()
    subj = np.asarray(subject, dtype=object).ravel()
    keep = (cond == treated) | (cond == reference)
    y, cond, subj = y[keep], cond[keep], subj[keep]

    def out(orr=None, ci=(None, None), sd=None, note=""):
        return RecognitionModel(_MODEL_METHOD, treated, reference, orr, ci, sd, note)

    if len(set(subj.tolist())) < 2:
        return out(note="not estimable: one subject (a subject random effect needs two or more)")
    for c in (treated, reference):
        yc = y[cond == c]
        if yc.size == 0:
            return out(note=f"not estimable: no trials in condition {c!r}")
        if yc.min() == yc.max():
            what = "every" if yc[0] else "no"
            return out(
                note=f"not estimable: {what} trial in condition {c!r} was recognised "
                "(complete separation)"
            )
    from statsmodels.genmod.bayes_mixed_glm import BinomialBayesMixedGLM

    df = pd.DataFrame({"y": y, "x": (cond == treated).astype(float), "subject": subj.astype(str)})
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        try:
            m = BinomialBayesMixedGLM.from_formula(
                "y ~ x",
                {"subject": "0 + C(subject)"},
                df,
                vcp_p=MIXED_VC_PRIOR_SD,
                fe_p=MIXED_FE_PRIOR_SD,
            )
            r = m.fit_vb()
        except (np.linalg.LinAlgError, ValueError) as exc:
            return out(note=f"not estimable: the fit failed ({exc})")
    b, sd = float(r.fe_mean[1]), float(r.fe_sd[1])
    if not (math.isfinite(b) and math.isfinite(sd)):
        return out(note="not estimable: no finite estimate")
    return out(
        math.exp(b),
        (math.exp(b - _Z95 * sd), math.exp(b + _Z95 * sd)),
        float(math.exp(r.vcp_mean[0])),
    )


def mean_ci95(values: Any, subject: Any) -> tuple[float, tuple[float | None, float | None], str]:
    """Return a mean with a t 95 % interval over subject means (over trials with one subject).

    Parameters
    ----------
    values : array_like of shape (n_trials,)
        Numbers per trial (booleans count as 0 / 1).
    subject : array_like of shape (n_trials,)
        Subject per trial.

    Returns
    -------
    mean : float
        Mean over trials.
    ci95 : (float or None, float or None)
        None ends when there is a single unit.
    unit : str
        ``'subjects'`` or ``'trials'``: what the interval's t distribution counts.
    """
    from scipy import stats

    v = np.asarray(values, dtype=float).ravel()
    s = np.asarray(subject, dtype=object).ravel()
    mean = float(v.mean())
    groups = pd.Series(v).groupby(s.astype(str)).mean().to_numpy()
    units, unit = (groups, "subjects") if groups.size >= 2 else (v, "trials")
    if units.size < 2:
        return mean, (None, None), unit
    m = float(units.mean())
    half = float(stats.t.ppf(0.975, units.size - 1) * units.std(ddof=1) / math.sqrt(units.size))
    return mean, (m - half, m + half), unit


@dataclass(frozen=True)
class SurvivalAnalysis:
    """Censored time to recognition and its companions, per condition, subject and comparison.

    Attributes
    ----------
    conditions : dict of str to KaplanMeierSummary
    comparisons : tuple of HazardRatio
        Each non-reference condition against ``reference`` (empty with one condition).
    recognition_model : RecognitionModel or None
        None with one condition.
    subjects : dict of str to dict of str to KaplanMeierSummary
        Subject -> condition -> Kaplan-Meier summary of that subject's trials.
    subject_means : dict of str to dict of str to dict of str to float
        Subject -> condition -> ``planes_visited_mean`` and ``zoom_use_rate``.
    secondary : dict of str to dict of str to (float or None, float or None)
        Condition -> measure of :data:`SECONDARY_MEASURES` -> 95 % interval of its mean.
    secondary_interval : str
        How the secondary intervals were computed, in words.
    reference : str
        The comparisons' reference condition.
    """

    conditions: dict[str, KaplanMeierSummary]
    comparisons: tuple[HazardRatio, ...]
    recognition_model: RecognitionModel | None
    subjects: dict[str, dict[str, KaplanMeierSummary]]
    subject_means: dict[str, dict[str, dict[str, float]]] = field(default_factory=dict)
    secondary: dict[str, dict[str, tuple[float | None, float | None]]] = field(default_factory=dict)
    secondary_interval: str = ""
    reference: str = ""

    @property
    def comparison(self) -> HazardRatio | None:
        """Return the first comparison (the only one with two conditions), or None."""
        return self.comparisons[0] if self.comparisons else None

    def condition_entry(self, condition: str) -> dict[str, Any]:
        """Return the survival keys of ``results.json``'s ``conditions.<condition>``."""
        km = self.conditions[condition]
        d = {
            "time_to_recognition_km_median_s": km.median_s,
            "time_to_recognition_km_median_ci95_s": list(km.median_ci95_s),
            "n_censored": km.n_censored,
            "recognition_rate_ci95": list(km.recognition_rate_ci95),
        }
        for name, ci in self.secondary.get(condition, {}).items():
            d[f"{name}_ci95"] = list(ci)
        d["km_curve"] = km.to_dict()
        return d

    def to_dict(self) -> dict[str, Any]:
        """Return the survival keys of ``results.json``'s ``active_search`` entry."""
        comp = self.comparison
        subjects = {
            s: {
                c: {
                    "trials": km.n_trials,
                    "recognized": km.n_recognized,
                    "censored": km.n_censored,
                    "km_median_s": km.median_s,
                    "longest_censored_s": max(km.censored_s) if km.censored_s else None,
                    **self.subject_means.get(s, {}).get(c, {}),
                }
                for c, km in by_c.items()
            }
            for s, by_c in self.subjects.items()
        }
        return {
            "censoring": CENSORING,
            "conditions": {c: self.condition_entry(c) for c in self.conditions},
            "comparison": comp.to_dict() if comp is not None else None,
            "comparisons": [h.to_dict() for h in self.comparisons],
            "recognition_model": (
                self.recognition_model.to_dict() if self.recognition_model is not None else None
            ),
            "subjects": subjects,
            "subject_curves": {
                s: {c: km.to_dict() for c, km in by_c.items()} for s, by_c in self.subjects.items()
            },
            "secondary_interval": self.secondary_interval,
            "reference_condition": self.reference,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SurvivalAnalysis:
        """Inverse of :meth:`to_dict` (also reads a whole ``active_search`` entry)."""
        conds = {c: KaplanMeierSummary.from_dict(v["km_curve"]) for c, v in d["conditions"].items()}
        secondary = {
            c: {m: _pair(v[f"{m}_ci95"]) for m in SECONDARY_MEASURES if f"{m}_ci95" in v}
            for c, v in d["conditions"].items()
        }
        means_keys = ("planes_visited_mean", "zoom_use_rate")
        return cls(
            conditions=conds,
            comparisons=tuple(HazardRatio.from_dict(h) for h in d.get("comparisons", ())),
            recognition_model=(
                RecognitionModel.from_dict(d["recognition_model"])
                if d.get("recognition_model")
                else None
            ),
            subjects={
                s: {c: KaplanMeierSummary.from_dict(v) for c, v in by_c.items()}
                for s, by_c in d.get("subject_curves", {}).items()
            },
            subject_means={
                s: {c: {k: v[k] for k in means_keys if k in v} for c, v in by_c.items()}
                for s, by_c in d.get("subjects", {}).items()
            },
            secondary=secondary,
            secondary_interval=str(d.get("secondary_interval", "")),
            reference=str(d.get("reference_condition", "")),
        )


def analyze_survival(trials: pd.DataFrame) -> SurvivalAnalysis:
    """Return the censored analysis of a per-trial active-search table.

    Parameters
    ----------
    trials : DataFrame
        Rows of :func:`analysis.active.active_trials`; uses ``subject``, ``condition``,
        ``rt_s`` (time the trial ended, seconds), ``recognized`` and the columns of
        :data:`SECONDARY_MEASURES`.

    Returns
    -------
    SurvivalAnalysis
        The reference condition is :data:`REFERENCE_CONDITION` when present, else the first
        in sort order.

    Raises
    ------
    ValueError
        No trials, or a column missing.
    """
    need = {"subject", "condition", "rt_s", "recognized", *SECONDARY_MEASURES.values()}
    missing = sorted(need - set(trials.columns))
    if missing:
        raise ValueError(f"trials lacks column(s) {', '.join(missing)}")
    if trials.empty:
        raise ValueError("trials must hold at least one trial, got none")
    df = trials.assign(
        condition=trials["condition"].astype(str),
        subject=trials["subject"].astype(str),
        recognized=trials["recognized"].astype(bool),
        rt_s=trials["rt_s"].astype(float),
    )
    conds = sorted(df["condition"].unique())
    reference = REFERENCE_CONDITION if REFERENCE_CONDITION in conds else conds[0]
    km = {
        c: kaplan_meier(g["rt_s"], g["recognized"], label=c)
        for c, g in df.groupby("condition", sort=True)
    }
    subjects: dict[str, dict[str, KaplanMeierSummary]] = {}
    means: dict[str, dict[str, dict[str, float]]] = {}
    for (s, c), g in df.groupby(["subject", "condition"], sort=True):
        subjects.setdefault(s, {})[c] = kaplan_meier(g["rt_s"], g["recognized"], label=f"{s} {c}")
        means.setdefault(s, {})[c] = {
            "planes_visited_mean": float(g["planes_visited"].mean()),
            "zoom_use_rate": float(g["zoomed"].astype(bool).mean()),
        }
    secondary: dict[str, dict[str, tuple[float | None, float | None]]] = {}
    units = set()
    for c, g in df.groupby("condition", sort=True):
        for name, col in SECONDARY_MEASURES.items():
            if name == "zoom_use_rate":  # a share: Wilson, within [0, 1]
                from analysis.shares import share_ci95

                _, ci, _ = share_ci95(g[col].astype(float), g["subject"])
                secondary.setdefault(c, {})[name] = ci
                continue
            _, ci, unit = mean_ci95(g[col].astype(float), g["subject"])
            secondary.setdefault(c, {})[name] = ci
            units.add(unit)
    interval = (
        "mean with a t 95 % interval over subject means (n - 1 degrees of freedom, n subjects)"
        if units == {"subjects"}
        else "mean with a t 95 % interval over trials (one subject: trials treated as independent)"
        if units == {"trials"}
        else "mean with a t 95 % interval over subject means, over trials where one subject"
    ) + (
        "; zoom use, a share, has a Wilson 95 % interval (with several subjects on the "
        "effective number of trials, from the spread of subject shares), within 0-100 %"
    )
    others = [c for c in conds if c != reference]
    comparisons = tuple(
        cox_hazard_ratio(
            df["rt_s"],
            df["recognized"],
            df["condition"],
            df["subject"],
            treated=c,
            reference=reference,
        )
        for c in others
    )
    model = (
        recognition_model(
            df["recognized"], df["condition"], df["subject"], treated=others[0], reference=reference
        )
        if others
        else None
    )
    return SurvivalAnalysis(
        conditions=km,
        comparisons=comparisons,
        recognition_model=model,
        subjects=subjects,
        subject_means=means,
        secondary=secondary,
        secondary_interval=interval,
        reference=reference,
    )
