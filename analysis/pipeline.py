"""The full analysis of a trial table: pooled and per-subject posteriors, logistic model, Eq. 1.

:func:`analyze` is a generator (house style H5): it yields an :class:`AnalysisStep` after each
fit, so the command line can draw a progress bar; the last step carries the
:class:`AnalysisResult`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from analysis.blas import on_one_blas_thread
from analysis.data import CONDITIONS, TrialTable, file_record, json_safe, object_order
from analysis.errors import DataError
from analysis.logistic import LogisticFit, fit_logistic, predict_from_odds_ratio
from analysis.mixed import MixedFit, fit_mixed
from analysis.pooled_curve import pooled_curve_by_condition
from analysis.weibull import PsychometricPrior, WeibullFit
from analysis.weibull.batch import sample_batch
from analysis.weibull.fit import group_fit_jobs

__all__ = ["AnalysisOptions", "AnalysisStep", "AnalysisResult", "analyze", "first_recognized"]


@dataclass(frozen=True)
class AnalysisOptions:
    """What to compute.

    Parameters
    ----------
    pc : float
        Proportion correct of the reported threshold, in (0, 1) (the 50 % threshold is always
        reported too).
    by_subject : bool
        Fit each subject's psychometric functions as well as the pooled ones.
    guess : float
        Guess rate of the psychometric function in [0, 1) (0: free recognition).
    seed : int or None
        Seed of all MCMC runs (one child stream per fit).
    subject_factor : bool
        Add subject dummies to the logistic model.
    mixed : bool
        Also fit the mixed model with random subject and object intercepts.
    prior : PsychometricPrior or None
        Prior of every psychometric fit; the data-dependent default when None.
    lapse_prior : (float, float)
        Beta(a, b) prior of the lapse rate for the default prior (ignored with ``prior``).
    overdispersion : bool
        Beta-binomial posteriors (free scale, psignifit 4 style) for the pooled fits; per-subject
        fits stay binomial. Off by default: the binomial credible interval covers its target,
        the 50 % point of the Weibull fitted to the pooled responses, in 0.93-0.97 of simulated
        studies (benchmarks/validate_weibull_coverage.py); the subjects and objects tested have
        their own interval (``pooled_curve``), and so has the population (``population_ci``).
    """

    pc: float = 0.5
    by_subject: bool = True
    guess: float = 0.0
    seed: int | None = None
    subject_factor: bool = False
    mixed: bool = False
    prior: PsychometricPrior | None = None
    lapse_prior: tuple[float, float] = (1.0, 10.0)
    overdispersion: bool = False

    def __post_init__(self) -> None:
        if len(self.lapse_prior) != 2 or min(self.lapse_prior) <= 0:
            raise ValueError(f"lapse_prior must be two numbers > 0, got {self.lapse_prior!r}")
        if not (0.0 < self.pc < 1.0):
            raise ValueError(f"pc must be in (0, 1), got {self.pc!r}")
        if not (0.0 <= self.guess < 1.0):
            raise ValueError(f"guess must be in [0, 1), got {self.guess!r}")
        if self.pc <= self.guess:
            raise ValueError(f"pc must be above the guess rate {self.guess!r}, got {self.pc!r}")


@dataclass(frozen=True)
class AnalysisResult:
    """Everything the report shows.

    Parameters
    ----------
    options : AnalysisOptions
    sources : tuple of str
        Trial files pooled.
    n_training_excluded : int
        Training rows left out.
    n_trials, n_recognized : int
        Trials analysed and how many were recognised.
    thresholds : dict of str to WeibullFit
        Pooled fit per condition.
    subject_thresholds : dict of str to dict of str to WeibullFit
        Per-subject fits per condition (empty without ``by_subject``).
    logistic : LogisticFit
    mixed : MixedFit or None
    first_recognized : dict
        ``{subject: {object: {condition: pixels or None}}}``: lowest level recognised.
    warnings : tuple of str
        Warnings raised by the fits (also logged).
    population_ci : dict of str to dict
        Per pooled condition, ``{"pc": [low, high] or None}``: 95 % population intervals of the
        ML threshold, two-way cluster-robust over subjects and objects
        (:func:`analysis.cluster.cluster_threshold_ci`), at 50 % and at ``pc``.
    simulated_sessions : tuple of str
        Sessions answered by a simulated observer (from :attr:`TrialTable.simulated_sessions`).
    pooled_curve : dict of str to dict
        Per pooled condition, the 50 % point of the pooled curve of the subjects and objects
        tested and its 95 % interval (:func:`analysis.pooled_curve.pooled_curve_threshold`).
    """

    options: AnalysisOptions
    sources: tuple[str, ...]
    n_training_excluded: int
    n_trials: int
    n_recognized: int
    thresholds: dict[str, WeibullFit]
    subject_thresholds: dict[str, dict[str, WeibullFit]]
    logistic: LogisticFit
    mixed: MixedFit | None
    first_recognized: dict[str, dict[str, dict[str, float | None]]]
    warnings: tuple[str, ...] = field(default_factory=tuple)
    population_ci: dict[str, dict[str, Any]] = field(default_factory=dict)
    simulated_sessions: tuple[str, ...] = ()
    pooled_curve: dict[str, dict[str, Any]] = field(default_factory=dict)

    def predictions(self) -> dict[str, Any] | None:
        """Return Eq. 1 applied with the reported background odds ratio (None when not estimated).

        The reported odds ratio is the one the console and the report print
        (:meth:`analysis.logistic.LogisticFit.intervals`: Firth's estimate).
        """
        if not self.logistic.has("background"):
            return None
        odds = self.logistic.intervals("background")["or"]
        ref = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]
        return {
            "background_or": odds,
            "decluttered_if_cluttered_50pct": predict_from_odds_ratio(0.5, odds),
            "cluttered_if_decluttered_50pct": predict_from_odds_ratio(0.5, 1.0 / odds),
            "decluttered_given_cluttered": [
                {"cluttered": p, "decluttered": predict_from_odds_ratio(p, odds)} for p in ref
            ],
        }

    def results_json(self) -> dict[str, Any]:
        """Return ``results.json``: ``sources`` are file names and sha256, never host paths."""
        pc = self.options.pc
        out: dict[str, Any] = {
            "n_trials": self.n_trials,
            "n_recognized": self.n_recognized,
            "pc": pc,
            "guess": self.options.guess,
            "seed": self.options.seed,
            "overdispersion": self.options.overdispersion,
            "prior": {c: f.prior.to_dict() for c, f in self.thresholds.items()},
            "sources": [file_record(s) for s in self.sources],
            "simulated_sessions": list(self.simulated_sessions),
            "n_training_excluded": self.n_training_excluded,
            "thresholds": {
                c: {
                    **f.summary(pc),
                    "population_ci95": self.population_ci.get(c, {}),
                    "pooled_curve": self.pooled_curve.get(c),
                }
                for c, f in self.thresholds.items()
            },
            "subject_thresholds": {
                s: {c: f.summary(pc) for c, f in fits.items()}
                for s, fits in self.subject_thresholds.items()
            },
            "logistic": {
                "odds_ratios": self.logistic.odds_ratios.to_dict(),
                "classification": self.logistic.classification(),
                "reference_object": self.logistic.reference_object,
                "subject_factor": self.logistic.subject_factor,
                "n_significant_objects": self.logistic.n_significant_objects(),
                "method": self.logistic.method,
                "separated": list(self.logistic.separated),
                "profile_ci95": self.logistic.to_dict()["profile_ci95"],
                "intervals": self.logistic.reported_intervals(),
                "warnings": list(self.logistic.warnings),
            },
            "predictions": self.predictions(),
            "first_recognized_pixels": self.first_recognized,
            "warnings": list(self.warnings),
        }
        if self.mixed is not None:
            out["logistic"]["mixed"] = self.mixed.to_dict()
        return json_safe(out)

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict from which :meth:`from_dict` rebuilds the result."""
        o = self.options
        return {
            "options": {
                "pc": o.pc,
                "by_subject": o.by_subject,
                "guess": o.guess,
                "seed": o.seed,
                "subject_factor": o.subject_factor,
                "mixed": o.mixed,
                "prior": o.prior.to_dict() if o.prior else None,
                "lapse_prior": list(o.lapse_prior),
                "overdispersion": o.overdispersion,
            },
            "sources": list(self.sources),
            "n_training_excluded": self.n_training_excluded,
            "n_trials": self.n_trials,
            "n_recognized": self.n_recognized,
            "thresholds": {c: f.to_dict() for c, f in self.thresholds.items()},
            "subject_thresholds": {
                s: {c: f.to_dict() for c, f in fits.items()}
                for s, fits in self.subject_thresholds.items()
            },
            "logistic": self.logistic.to_dict(),
            "mixed": self.mixed.to_dict() if self.mixed else None,
            "first_recognized": self.first_recognized,
            "warnings": list(self.warnings),
            "population_ci": self.population_ci,
            "simulated_sessions": list(self.simulated_sessions),
            "pooled_curve": self.pooled_curve,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> AnalysisResult:
        """Rebuild from :meth:`to_dict` output."""
        o = dict(d["options"])
        o["prior"] = PsychometricPrior.from_dict(o["prior"]) if o.get("prior") else None
        o["lapse_prior"] = tuple(o.get("lapse_prior", (1.0, 10.0)))
        return cls(
            options=AnalysisOptions(**o),
            sources=tuple(d["sources"]),
            n_training_excluded=int(d["n_training_excluded"]),
            n_trials=int(d["n_trials"]),
            n_recognized=int(d["n_recognized"]),
            thresholds={c: WeibullFit.from_dict(f) for c, f in d["thresholds"].items()},
            subject_thresholds={
                s: {c: WeibullFit.from_dict(f) for c, f in fits.items()}
                for s, fits in d["subject_thresholds"].items()
            },
            logistic=LogisticFit.from_dict(d["logistic"]),
            mixed=MixedFit.from_dict(d["mixed"]) if d.get("mixed") else None,
            first_recognized=d["first_recognized"],
            warnings=tuple(d.get("warnings", ())),
            population_ci=d.get("population_ci", {}),
            simulated_sessions=tuple(d.get("simulated_sessions", ())),
            pooled_curve=d.get("pooled_curve", {}),
        )


@dataclass(frozen=True)
class AnalysisStep:
    """Progress of :func:`analyze`: ``done`` of ``total`` steps, ``label`` the one just finished.

    ``result`` is set on the last step only.
    """

    done: int
    total: int
    label: str
    result: AnalysisResult | None = None


def first_recognized(trials: pd.DataFrame) -> dict[str, dict[str, dict[str, float | None]]]:
    """Return the lowest pixel count at which each subject recognised each object, per condition.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials (``subject, object, condition, pixels, recognized`` used).

    Returns
    -------
    dict
        ``{subject: {object: {condition: pixels or None}}}`` (None: never recognised).
    """
    out: dict[str, dict[str, dict[str, float | None]]] = {}
    objects = object_order(trials["object"])
    rec = trials[trials["recognized"] == 1]
    lowest = rec.groupby(
        [rec["subject"].astype(str), rec["object"].astype(str), rec["condition"].astype(str)]
    )["pixels"].min()
    low = {k: float(v) for k, v in lowest.items()}
    for s in object_order(trials["subject"]):
        out[s] = {o: {c: low.get((str(s), str(o), c)) for c in CONDITIONS} for o in objects}
    return out


def _population(
    trials: pd.DataFrame, pooled: dict[str, WeibullFit], opts: AnalysisOptions
) -> dict[str, dict[str, Any]]:
    """Two-way cluster-robust population intervals of each measured pooled ML threshold."""
    from analysis.cluster import cluster_threshold_ci

    out: dict[str, dict[str, Any]] = {}
    for cond, fit in pooled.items():
        sel = trials[trials["condition"] == cond]
        out[cond] = {}
        for pc in dict.fromkeys((0.5, opts.pc)):
            if not fit.threshold(pc).measured:
                continue
            ci = cluster_threshold_ci(
                sel["pixels"],
                sel["recognized"],
                [sel["subject"], sel["object"]],
                fit.mle,
                pc=pc,
                guess=opts.guess,
            )
            if ci is not None:
                out[cond][f"{pc:g}"] = [ci[0], ci[1]]
    return out


@on_one_blas_thread
def analyze(
    table: TrialTable, options: AnalysisOptions | None = None, *, reference: str = "cluttered"
) -> Iterator[AnalysisStep]:
    """Run the full analysis, yielding after each fit.

    Parameters
    ----------
    table : TrialTable
        Pooled trials (:func:`analysis.data.read_trials`).
    options : AnalysisOptions, optional
        Defaults when omitted.
    reference : str
        Data with conditions beyond the paper's two (a comparison of de-clutter methods) are
        analysed by :func:`analysis.conditions.analyze_conditions` instead, with this
        reference condition; the paper's two conditions as the paper did.

    Yields
    ------
    AnalysisStep
        The last one has ``result`` set.

    Degenerate data (one condition, all recognised, separated, a handful of trials) give a
    complete result that says what could not be estimated (``warnings``, threshold statuses,
    the logistic model's ``method``); nothing is raised for them.

    References
    ----------
    Jung et al. 2015, Sec. 3.2.2 (pooled Weibull fits, Fig. 8; per-subject thresholds, Fig. 9;
    logistic regression and Eq. 1).
    """
    opts = options or AnalysisOptions()
    trials = table.trials
    if len(trials) == 0:
        raise DataError(f"no trials in {', '.join(table.sources)}")
    from analysis.conditions import analyze_conditions, has_other_conditions

    if has_other_conditions(trials):
        mixed_model = None
        if opts.mixed:
            from analysis.conditions_mixed import fit_condition_mixed as mixed_model
        yield from analyze_conditions(table, opts, reference=reference, mixed_model=mixed_model)
        return
    present = [c for c in CONDITIONS if (trials["condition"] == c).any()]
    notes: list[str] = [
        f"no trials in condition '{c}': it is not fitted" for c in CONDITIONS if c not in present
    ]
    subjects = object_order(trials["subject"]) if opts.by_subject else []
    jobs: list[tuple[str | None, str]] = [(None, c) for c in present]
    jobs += [(s, c) for s in subjects for c in present]
    total = len(jobs) + 1 + int(opts.mixed)
    seeds = np.random.SeedSequence(opts.seed).spawn(1)
    pooled: dict[str, WeibullFit] = {}
    per_subject: dict[str, dict[str, WeibullFit]] = {}
    done = 0
    fit_jobs, keys, fit_notes = group_fit_jobs(
        trials,
        jobs,
        guess=opts.guess,
        prior=opts.prior,
        lapse_prior=opts.lapse_prior,
        overdispersion=opts.overdispersion,
    )
    notes += fit_notes
    # One batch for all posteriors: one vectorised step moves every fit's walkers.
    fits: list[WeibullFit] = []
    if fit_jobs:
        for prog in sample_batch(fit_jobs, sigmoid="weibull", rng=np.random.default_rng(seeds[0])):
            if prog.fits is None:
                yield AnalysisStep(prog.n_done, total, f"sampling ({prog.n_steps} steps)")
            else:
                fits = prog.fits
    for (subject, cond), fit in zip(keys, fits, strict=True):
        notes += fit.diagnostics(opts.pc)
        if subject is None:
            pooled[cond] = fit
        else:
            per_subject.setdefault(subject, {})[cond] = fit
    done = len(jobs)
    yield AnalysisStep(done, total, "psychometric fits")
    logistic = fit_logistic(trials, subject_factor=opts.subject_factor)
    notes += [f"logistic model: {w}" for w in logistic.warnings]
    done += 1
    yield AnalysisStep(done, total, "logistic regression")
    mixed = None
    if opts.mixed:
        try:
            mixed = fit_mixed(trials)
        except (DataError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            notes.append(f"mixed model not fitted: {' '.join(str(exc).split())}")
        done += 1
        yield AnalysisStep(done, total, "mixed model")
    result = AnalysisResult(
        options=opts,
        sources=table.sources,
        n_training_excluded=table.n_training_excluded,
        n_trials=int(len(trials)),
        n_recognized=int(trials["recognized"].sum()),
        thresholds=pooled,
        subject_thresholds=per_subject,
        logistic=logistic,
        mixed=mixed,
        first_recognized=first_recognized(trials),
        population_ci=_population(trials, pooled, opts),
        pooled_curve=pooled_curve_by_condition(trials, opts.guess),
        warnings=tuple(dict.fromkeys(notes)),
        simulated_sessions=table.simulated_sessions,
    )
    yield AnalysisStep(done, total, "done", result)
