"""Analysis of k image conditions: a comparison of de-clutter methods at the same resolutions.

The paper's study has two conditions and :mod:`analysis.pipeline` analyses it as the paper did.
A trial table that holds other conditions (de-clutter methods named by the stimulus set:
``sobel``, ``depth``, ``mask``, ``segment``, ``saliency``, ...) is analysed here instead:

- a Weibull psychometric function per condition (pooled, and per subject), fitted exactly as
  the paper's two (:mod:`analysis.weibull`, one MCMC batch);
- every pairwise threshold ratio ``threshold(a) / threshold(b)`` with its 95 % posterior
  interval (quantiles of the ratio of posterior draws of the two 50 % thresholds);
- a binary logistic regression of recognition on the condition (a factor against a reference
  condition, default ``cluttered``), log10 pixels and object dummies (the paper's model, with
  the background term replaced by the factor): an odds ratio per non-reference condition with
  its Wald 95 % interval, and every pairwise contrast with its Wald p-value adjusted by Holm's
  step-down method (familywise error 0.05 over all ``k (k - 1) / 2`` contrasts).

References
----------
Jung et al. (2015), Sec. 3.2.2 (the two-condition analysis this generalises).
Holm, S. (1979). A simple sequentially rejective multiple test procedure. Scandinavian Journal
of Statistics 6(2), 65-70.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd

from analysis.data import (
    CONDITIONS,
    METHOD_CONDITIONS,
    TrialTable,
    file_record,
    json_safe,
    object_order,
)
from analysis.errors import DataError

__all__ = [
    "DEFAULT_REFERENCE",
    "SEPARATION_LOG_OR",
    "has_other_conditions",
    "condition_order",
    "holm",
    "wald_odds_ratio",
    "ConditionsLogistic",
    "fit_condition_logistic",
    "threshold_ratios",
    "ConditionsResult",
    "ConditionsStep",
    "analyze_conditions",
]

#: The reference condition of the odds ratios unless ``--reference`` names another: the
#: paper's (background cluttered).
DEFAULT_REFERENCE: str = "cluttered"

#: |log odds ratio| above which a term is taken as separated (its ML estimate infinite): the
#: limit :mod:`analysis.logistic` uses.
SEPARATION_LOG_OR: float = 15.0


def has_other_conditions(trials: pd.DataFrame) -> bool:
    """Return whether a trial table holds a condition beyond the paper's two."""
    return bool((~trials["condition"].isin(CONDITIONS)).any())


def condition_order(trials: pd.DataFrame) -> tuple[str, ...]:
    """Return the conditions present in a fixed order.

    The order is the paper's two, the built-in methods (:data:`analysis.data.METHOD_CONDITIONS`),
    then any others by name (not by the order the trials came in, which a Latin square changes
    from subject to subject).
    """
    seen = set(trials["condition"].astype(str))
    known = [c for c in (*CONDITIONS, *METHOD_CONDITIONS) if c in seen]
    return tuple(known + sorted(seen - set(known)))


def holm(p: Sequence[float]) -> list[float]:
    """Return Holm's step-down adjusted p-values (same order as ``p``).

    Examples
    --------
    >>> [round(v, 3) for v in holm([0.01, 0.04, 0.03])]
    [0.03, 0.06, 0.06]
    """
    p = [float(v) for v in p]
    m = len(p)
    order = sorted(range(m), key=lambda i: p[i])
    out = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        out[i] = running
    return out


@dataclass(frozen=True)
class ConditionsLogistic:
    """The logistic model with condition as a factor.

    Parameters
    ----------
    reference : str
    odds_ratios : dict of str to dict
        Per non-reference condition: ``or``, ``ci95``, ``p``, ``separated``.
    per_log10_pixels : dict
        The odds ratio per log10 pixels (``or``, ``ci95``, ``p``).
    contrasts : list of dict
        Every pair ``[a, b]`` (condition order): ``or`` (odds of b over a), ``ci95``, ``p`` and
        ``p_adjusted`` (Holm).
    object_dummies : bool
        Whether the model holds object dummies (dropped, with a warning, when they separate).
    method : str
        ``'ml'`` or ``'none'`` (not estimable; ``warnings`` say why).
    warnings : tuple of str
    """

    reference: str
    odds_ratios: dict[str, dict[str, Any]]
    per_log10_pixels: dict[str, Any]
    contrasts: list[dict[str, Any]]
    object_dummies: bool
    method: str
    warnings: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """Return the ``logistic`` entry of ``results.json``."""
        return {
            "model": "recognized ~ condition + log10_pixels"
            + (" + object" if self.object_dummies else ""),
            "reference": self.reference,
            "odds_ratios": self.odds_ratios,
            "per_log10_pixels": self.per_log10_pixels,
            "contrasts": self.contrasts,
            "object_dummies": self.object_dummies,
            "method": self.method,
            "warnings": list(self.warnings),
        }


def _design(trials: pd.DataFrame, conds: Sequence[str], reference: str, objects: bool):
    others = [c for c in conds if c != reference]
    cols = {"intercept": np.ones(len(trials))}
    cond = trials["condition"].astype(str).to_numpy()
    for c in others:
        cols[f"condition:{c}"] = (cond == c).astype(float)
    cols["log10_pixels"] = np.log10(trials["pixels"].astype(float).to_numpy())
    if objects:
        obj = trials["object"].astype(str).to_numpy()
        for o in object_order(trials["object"])[1:]:
            cols[f"object:{o}"] = (obj == o).astype(float)
    return pd.DataFrame(cols), others


def _glm(x: pd.DataFrame, y: np.ndarray):
    import statsmodels.api as sm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sm.GLM(y, x, family=sm.families.Binomial()).fit()


def wald_odds_ratio(b: float, se: float) -> tuple[float, list[float | None], float]:
    """Return ``(odds ratio, 95 % Wald interval, p)`` of a log odds ratio ``b`` with SE ``se``.

    An estimate or SE that is not finite (or SE <= 0) gives no interval and a NaN p.
    """
    from scipy.stats import norm

    if not (math.isfinite(b) and math.isfinite(se) and se > 0):
        return math.exp(b) if math.isfinite(b) else math.nan, [None, None], math.nan
    lo, hi = b - 1.959963984540054 * se, b + 1.959963984540054 * se
    p = float(2 * norm.sf(abs(b) / se))
    return float(math.exp(b)), [float(math.exp(lo)), float(math.exp(hi))], p


def fit_condition_logistic(
    trials: pd.DataFrame, conditions: Sequence[str], reference: str = DEFAULT_REFERENCE
) -> ConditionsLogistic:
    """Fit ``recognized ~ condition + log10_pixels + object`` with ``reference`` as baseline.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials (:mod:`analysis.data`).
    conditions : sequence of str
        The conditions, in report order (``reference`` among them).
    reference : str

    Returns
    -------
    ConditionsLogistic
        Object dummies are dropped (with a warning) when they separate the data; a condition
        whose term still separates is marked ``separated`` and left out of the p-values'
        family with ``p`` None. All recognised or none: ``method = 'none'``.
    """
    conds = list(conditions)
    if reference not in conds:
        raise DataError(
            f"`reference` {reference!r}: no trials in that condition; expected one of "
            f"{', '.join(conds)}"
        )
    y = trials["recognized"].astype(int).to_numpy()
    notes: list[str] = []
    if y.min() == y.max():
        return ConditionsLogistic(
            reference, {}, {}, [], False, "none", (f"all {len(y)} trials have one outcome",)
        )
    res = None
    for objects in (True, False):
        x, others = _design(trials, conds, reference, objects)
        try:
            res = _glm(x, y)
        except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
            notes.append(f"logistic model with{'' if objects else 'out'} object dummies: {exc}")
            continue
        obj_sep = [
            t
            for t in x.columns
            if t.startswith("object:") and abs(float(res.params[t])) > SEPARATION_LOG_OR
        ]
        if objects and obj_sep:
            notes.append(
                f"object dummies separate the data ({len(obj_sep)} objects always or never "
                "recognised): the model is fitted without them"
            )
            continue
        break
    if res is None:
        return ConditionsLogistic(reference, {}, {}, [], False, "none", tuple(notes))
    params, cov = res.params, res.cov_params()
    beta = {c: 0.0 if c == reference else float(params[f"condition:{c}"]) for c in conds}
    sep = {c for c in others if abs(beta[c]) > SEPARATION_LOG_OR}
    for c in sorted(sep):
        notes.append(f"condition {c!r} separates the data (recognised always or never)")

    def var(c: str) -> float:
        return 0.0 if c == reference else float(cov.loc[f"condition:{c}", f"condition:{c}"])

    def covar(a: str, b: str) -> float:
        if reference in (a, b):
            return 0.0
        return float(cov.loc[f"condition:{a}", f"condition:{b}"])

    ors: dict[str, dict[str, Any]] = {}
    for c in others:
        o, ci, p = wald_odds_ratio(beta[c], math.sqrt(max(var(c), 0.0)))
        ors[c] = {"or": o, "ci95": ci, "p": None if c in sep else p, "separated": c in sep}
    se_px = math.sqrt(max(float(cov.loc["log10_pixels", "log10_pixels"]), 0.0))
    o, ci, p = wald_odds_ratio(float(params["log10_pixels"]), se_px)
    per_px = {"or": o, "ci95": ci, "p": p}
    contrasts: list[dict[str, Any]] = []
    for a, b in combinations(conds, 2):
        d = beta[b] - beta[a]
        se = math.sqrt(max(var(a) + var(b) - 2 * covar(a, b), 0.0))
        o, ci, p = wald_odds_ratio(d, se)
        bad = bool({a, b} & sep)
        contrasts.append(
            {"pair": [a, b], "or": o, "ci95": ci, "p": None if bad else p, "separated": bad}
        )
    family = [i for i, c in enumerate(contrasts) if c["p"] is not None and math.isfinite(c["p"])]
    adj = holm([contrasts[i]["p"] for i in family])
    for c in contrasts:
        c["p_adjusted"] = None
    for i, a in zip(family, adj, strict=True):
        contrasts[i]["p_adjusted"] = a
    return ConditionsLogistic(
        reference,
        ors,
        per_px,
        contrasts,
        any(t.startswith("object:") for t in params.index),
        "ml",
        tuple(notes),
    )


def _threshold_draws(fit, pc: float = 0.5) -> np.ndarray:
    from analysis.weibull.model import threshold_at

    a, b, lapse = fit.parameter_samples()
    return np.asarray(threshold_at(pc, a, b, lapse, guess=fit.guess, sigmoid=fit.sigmoid), float)


def threshold_ratios(
    fits: dict[str, Any], conditions: Sequence[str], *, n_draws: int = 4000, seed: int = 0
) -> list[dict[str, Any]]:
    """Return every pairwise 50 % threshold ratio ``threshold(a) / threshold(b)``.

    The two posteriors are independent, so ``n_draws`` draws of each (with replacement,
    seeded) are divided pairwise; the ratio's posterior median and its 2.5 % and 97.5 %
    quantiles are reported. A pair where either threshold is not ``measured`` (censored or
    not identified) has ``ratio`` None and says why.

    Parameters
    ----------
    fits : dict of str to WeibullFit
    conditions : sequence of str
    n_draws : int
    seed : int

    Returns
    -------
    list of dict
        ``pair``, ``ratio``, ``ratio_ci95``, ``note``.
    """
    rng = np.random.default_rng(seed)
    draws: dict[str, np.ndarray] = {}
    status: dict[str, str] = {}
    for c in conditions:
        f = fits.get(c)
        if f is None:
            status[c] = "not fitted"
            continue
        status[c] = f.threshold(0.5).status
        t = _threshold_draws(f)
        draws[c] = t[rng.integers(0, len(t), n_draws)]
    out = []
    for a, b in combinations(conditions, 2):
        bad = [c for c in (a, b) if status[c] != "measured"]
        if bad:
            out.append(
                {
                    "pair": [a, b],
                    "ratio": None,
                    "ratio_ci95": [None, None],
                    "note": "; ".join(f"{c} threshold {status[c]}" for c in bad),
                }
            )
            continue
        r = draws[a] / draws[b]
        q = np.quantile(r, [0.025, 0.5, 0.975])
        out.append({"pair": [a, b], "ratio": float(q[1]), "ratio_ci95": [float(q[0]), float(q[2])]})
    return out


@dataclass(frozen=True)
class ConditionsResult:
    """Everything the k-condition report shows (:func:`analyze_conditions`).

    Parameters
    ----------
    options : AnalysisOptions
    reference : str
    conditions : tuple of str
    sources : tuple of str
    n_training_excluded, n_trials, n_recognized : int
    thresholds : dict of str to WeibullFit
        Pooled fit per condition.
    subject_thresholds : dict of str to dict of str to WeibullFit
    logistic : ConditionsLogistic
    logistic_mixed : ConditionsMixed or None
        The mixed model (random subject and object intercepts), when asked for (``--mixed``)
        and estimable.
    comparisons : list of dict
        Every pair: ``pair``, ``ratio``, ``ratio_ci95`` (thresholds) with the logistic
        contrast's ``odds_ratio``, ``odds_ratio_ci95``, ``p`` and ``p_adjusted`` (Holm).
    warnings : tuple of str
    simulated_sessions : tuple of str
    """

    options: Any
    reference: str
    conditions: tuple[str, ...]
    sources: tuple[str, ...]
    n_training_excluded: int
    n_trials: int
    n_recognized: int
    thresholds: dict[str, Any]
    subject_thresholds: dict[str, dict[str, Any]]
    logistic: ConditionsLogistic
    comparisons: list[dict[str, Any]]
    warnings: tuple[str, ...] = field(default_factory=tuple)
    simulated_sessions: tuple[str, ...] = ()
    logistic_mixed: Any = None

    #: Tells the report and the command line which result this is.
    kind = "conditions"

    def results_json(self) -> dict[str, Any]:
        """Return ``results.json`` (strict JSON; file names and sha256, never host paths)."""
        pc = self.options.pc
        mixed = {} if self.logistic_mixed is None else {"logistic_mixed": self.logistic_mixed}
        return json_safe(
            {
                "analysis": "conditions",
                "conditions": list(self.conditions),
                "reference": self.reference,
                "n_trials": self.n_trials,
                "n_recognized": self.n_recognized,
                "pc": pc,
                "guess": self.options.guess,
                "seed": self.options.seed,
                "sources": [file_record(s) for s in self.sources],
                "simulated_sessions": list(self.simulated_sessions),
                "n_training_excluded": self.n_training_excluded,
                "thresholds": {c: f.summary(pc) for c, f in self.thresholds.items()},
                "subject_thresholds": {
                    s: {c: f.summary(pc) for c, f in fits.items()}
                    for s, fits in self.subject_thresholds.items()
                },
                "comparisons": self.comparisons,
                "logistic": self.logistic.to_dict(),
                **{k: v.to_dict() for k, v in mixed.items()},
                "warnings": list(self.warnings),
            }
        )


@dataclass(frozen=True)
class ConditionsStep:
    """Progress of :func:`analyze_conditions` (the fields of the pipeline's ``AnalysisStep``).

    ``done`` of ``total`` steps, ``label`` the one just finished, ``result`` on the last.
    """

    done: int
    total: int
    label: str
    result: ConditionsResult | None = None


def _merge(ratios: list[dict], logistic: ConditionsLogistic) -> list[dict[str, Any]]:
    by_pair = {tuple(c["pair"]): c for c in logistic.contrasts}
    out = []
    for r in ratios:
        c = by_pair.get(tuple(r["pair"]), {})
        out.append(
            {
                **r,
                "odds_ratio": c.get("or"),
                "odds_ratio_ci95": c.get("ci95", [None, None]),
                "p": c.get("p"),
                "p_adjusted": c.get("p_adjusted"),
            }
        )
    return out


def analyze_conditions(
    table: TrialTable,
    options: Any,
    *,
    reference: str = DEFAULT_REFERENCE,
    mixed_model: Callable[..., Any] | None = None,
) -> Iterator[ConditionsStep]:
    """Analyse a trial table of k conditions, yielding progress steps as the pipeline does.

    Parameters
    ----------
    table : TrialTable
    options : analysis.pipeline.AnalysisOptions
        ``pc``, ``guess``, ``seed``, ``by_subject``, ``prior`` and ``lapse_prior`` are used.
    reference : str
        The logistic model's reference condition.
    mixed_model : callable or None
        Also fit this mixed model, ``f(trials, conditions, reference)``
        (:func:`analysis.conditions_mixed.fit_condition_mixed` for ``--mixed``); a
        :class:`DataError` it raises becomes a warning.

    Yields
    ------
    ConditionsStep
        The last one carries the :class:`ConditionsResult`.

    Raises
    ------
    DataError
        No trials, or ``reference`` not among the conditions.
    """
    from analysis.weibull.batch import sample_batch
    from analysis.weibull.fit import group_fit_jobs

    opts = options
    trials = table.trials
    if len(trials) == 0:
        raise DataError(f"no trials in {', '.join(table.sources)}")
    conds = condition_order(trials)
    if reference not in conds:
        raise DataError(
            f"`reference` {reference!r}: no trials in that condition; the data hold "
            f"{', '.join(conds)}"
        )
    subjects = object_order(trials["subject"]) if opts.by_subject else []
    jobs = [(None, c) for c in conds] + [(s, c) for s in subjects for c in conds]
    total = len(jobs) + 1 + int(mixed_model is not None)
    notes: list[str] = []
    fit_jobs, keys, fit_notes = group_fit_jobs(
        trials, jobs, guess=opts.guess, prior=opts.prior, lapse_prior=opts.lapse_prior
    )
    notes += fit_notes
    seeds = np.random.SeedSequence(opts.seed).spawn(2)
    fits = []
    for prog in sample_batch(fit_jobs, sigmoid="weibull", rng=np.random.default_rng(seeds[0])):
        if prog.fits is None:
            yield ConditionsStep(prog.n_done, total, f"sampling ({prog.n_steps} steps)")
        else:
            fits = prog.fits
    pooled: dict[str, Any] = {}
    per_subject: dict[str, dict[str, Any]] = {}
    for (subject, cond), fit in zip(keys, fits, strict=True):
        notes += fit.diagnostics(opts.pc)
        if subject is None:
            pooled[cond] = fit
        else:
            per_subject.setdefault(subject, {})[cond] = fit
    yield ConditionsStep(len(jobs), total, "psychometric fits")
    logistic = fit_condition_logistic(trials, conds, reference)
    notes += [f"logistic model: {w}" for w in logistic.warnings]
    mixed = None
    if mixed_model is not None:
        try:
            mixed = mixed_model(trials, conds, reference)
        except DataError as exc:
            notes.append(f"mixed model not fitted: {' '.join(str(exc).split())}")
        yield ConditionsStep(len(jobs) + 1, total, "mixed model")
    ratio_seed = int(seeds[1].generate_state(1)[0])
    comparisons = _merge(threshold_ratios(pooled, conds, seed=ratio_seed), logistic)
    result = ConditionsResult(
        options=opts,
        reference=reference,
        conditions=conds,
        sources=table.sources,
        n_training_excluded=table.n_training_excluded,
        n_trials=int(len(trials)),
        n_recognized=int(trials["recognized"].sum()),
        thresholds=pooled,
        subject_thresholds=per_subject,
        logistic=logistic,
        comparisons=comparisons,
        warnings=tuple(dict.fromkeys(notes)),
        simulated_sessions=table.simulated_sessions,
        logistic_mixed=mixed,
    )
    yield ConditionsStep(total, total, "done", result)
