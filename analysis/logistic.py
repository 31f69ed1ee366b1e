"""Binary logistic regression of recognition (Jung et al. 2015, Sec. 3.2.2 and Fig. S3).

Model (statsmodels formula)::

    recognized ~ background + C(object, Treatment(<first object>)) + log10_pixels [+ C(subject)]

``background`` is 1 for de-cluttered and 0 for cluttered (reference: cluttered, as in the paper),
so its odds ratio is how much more likely a de-cluttered image is recognised. ML odds ratios come
with 95 % Wald intervals and Wald p-values (as the paper's SPSS output) and 95 % profile-likelihood
intervals (:func:`profile_interval`). The default interval of the background and log10-pixels odds
ratios (:data:`DEFAULT_INTERVAL`, :meth:`LogisticFit.intervals`) is the profile penalised
likelihood around Firth's estimate (Heinze & Schemper 2002): in simulated studies of the paper's
design the ML log odds ratios are biased away from 0 by about 3 % and the ML intervals cover
0.925-0.95, Firth's profile intervals 0.95-0.96 (benchmarks/validate_or_coverage.py). A mixed-model
variant with random subject and object intercepts is fitted by Laplace-approximate maximum
likelihood (:func:`laplace_glmm`).
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from analysis.data import object_order
from analysis.errors import DataError
from analysis.firth import binomial_rows, firth_logit, profile_interval

__all__ = [
    "OddsRatioTable",
    "LogisticFit",
    "design_frame",
    "fit_logistic",
    "check_model_data",
    "firth_logit",
    "profile_interval",
    "SEPARATION_LOG_OR",
    "DEFAULT_INTERVAL",
    "DEFAULT_ESTIMATOR_TEXT",
    "ODDS_RATIO_QUESTION",
    "predict_from_odds_ratio",
]

logger = logging.getLogger(__name__)

_COLUMNS = ("term", "odds_ratio", "ci95_low", "ci95_high", "p_value")

#: The default 95 % odds-ratio interval: profile penalised likelihood around Firth's estimate
#: (Heinze & Schemper 2002). In simulated studies of the paper's design the ML log odds ratios
#: are biased away from 0 (per log10 pixels by a few percent, a sizeable fraction of a standard
#: error), so the ML Wald and profile intervals cover less than 95 %; Firth's estimate removes
#: that bias (benchmarks/validate_or_coverage.py).
DEFAULT_INTERVAL: str = "firth_profile"
#: The default estimate and interval in one phrase, printed beside each reported odds ratio on
#: the console and in the report.
DEFAULT_ESTIMATOR_TEXT: str = "Firth's estimate, profile penalised-likelihood 95 % CI"
#: Terms whose odds ratios the report states (their Firth profile intervals are computed also
#: when ML exists; object dummies keep their ML profile intervals, for Fig. S3).
_REPORTED_TERMS: tuple[str, ...] = ("background", "log10_pixels")
#: The question the fixed-effects odds ratios answer: subjects and objects are in the model as
#: they were tested (objects as dummies, subjects pooled), not drawn from a population.
ODDS_RATIO_QUESTION: str = "these subjects and objects"


@dataclass(frozen=True)
class OddsRatioTable:
    """Odds ratios of a logistic model, one row per term (intercept excluded).

    Parameters
    ----------
    rows : tuple of tuple
        ``(term, odds_ratio, ci95_low, ci95_high, p_value)`` per term. Terms are ``background``,
        ``log10_pixels``, ``object:<id>`` and ``subject:<id>``.
    """

    rows: tuple[tuple[str, float, float, float, float], ...]

    def to_frame(self) -> pd.DataFrame:
        """Return a DataFrame with columns term, odds_ratio, ci95_low, ci95_high, p_value."""
        return pd.DataFrame(list(self.rows), columns=list(_COLUMNS))

    def __getitem__(self, term: str) -> dict[str, Any]:
        for r in self.rows:
            if r[0] == term:
                return {"or": r[1], "ci95": [r[2], r[3]], "p": r[4]}
        raise KeyError(term)

    def terms(self) -> list[str]:
        """Return the term names in order."""
        return [r[0] for r in self.rows]

    def to_dict(self) -> dict[str, Any]:
        """Return ``{term: {"or", "ci95", "p"}}`` (the results.json layout)."""
        return {r[0]: self[r[0]] for r in self.rows}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> OddsRatioTable:
        """Rebuild from :meth:`to_dict` output."""
        return cls(
            tuple(
                (str(t), float(v["or"]), float(v["ci95"][0]), float(v["ci95"][1]), float(v["p"]))
                for t, v in d.items()
            )
        )


@dataclass(frozen=True)
class LogisticFit:
    """A fitted binary logistic regression of recognition.

    Parameters
    ----------
    odds_ratios : OddsRatioTable
        Odds ratios with 95 % Wald CIs and p-values.
    params : dict of str to float
        Coefficients (log odds), including ``Intercept``.
    bse : dict of str to float
        Standard errors of the coefficients.
    reference_object : str
        The object whose dummy is left out.
    subject_factor : bool
        Whether subject dummies were in the model.
    n_trials : int
        Trials fitted.
    log_likelihood : float
        Log-likelihood at the maximum.
    recognized_correct_pct, not_recognized_correct_pct : float
        Classification table: percentage of recognised (not recognised) trials whose predicted
        probability is >= (<) ``cutoff``.
    cutoff : float
        Classification cutoff.
    warnings : tuple of str
        What the fit noticed (separation, dropped terms, ...).
    method : {'ml', 'firth', 'none'}
        ``ml``: maximum likelihood (the paper's); ``firth``: Firth's penalised likelihood
        (Heinze & Schemper 2002), used when ML does not exist (separated data) or fails;
        ``none``: nothing could be estimated (see ``warnings``), the table is empty.
    separated : tuple of str
        Terms whose ML estimate is infinite (or the ML fit failed on), reported from Firth's fit.
    profile_ci95 : dict of str to (float, float)
        95 % profile-likelihood interval of each term's odds ratio (:func:`profile_interval`;
        ``inf`` where the profile never reaches the cutoff, as for a separated term).
    firth_params : dict of str to float
        Firth's penalised estimates (log odds), whatever ``method`` is: they remove the
        first-order small-sample bias of the ML log odds ratios (Firth 1993).
    firth_profile_ci95 : dict of str to (float, float)
        95 % profile penalised-likelihood interval of each term's odds ratio around Firth's
        estimate (Heinze & Schemper 2002): the :data:`DEFAULT_INTERVAL`.
    """

    odds_ratios: OddsRatioTable
    params: dict[str, float]
    bse: dict[str, float]
    reference_object: str
    subject_factor: bool
    n_trials: int
    log_likelihood: float
    recognized_correct_pct: float
    not_recognized_correct_pct: float
    cutoff: float = 0.5
    warnings: tuple[str, ...] = field(default_factory=tuple)
    method: str = "ml"
    separated: tuple[str, ...] = field(default_factory=tuple)
    profile_ci95: dict[str, tuple[float, float]] = field(default_factory=dict)
    firth_params: dict[str, float] = field(default_factory=dict)
    firth_profile_ci95: dict[str, tuple[float, float]] = field(default_factory=dict)

    def has(self, term: str) -> bool:
        """Return True when ``term`` was estimated."""
        return term in self.odds_ratios.terms()

    def classification(self) -> dict[str, float]:
        """Return the results.json ``classification`` entry."""
        return {
            "recognized_correct_pct": self.recognized_correct_pct,
            "not_recognized_correct_pct": self.not_recognized_correct_pct,
            "cutoff": self.cutoff,
        }

    def n_significant_objects(self, alpha: float = 0.05) -> int:
        """Return how many object dummies have p < ``alpha``."""
        return sum(1 for r in self.odds_ratios.rows if r[0].startswith("object:") and r[4] < alpha)

    def intervals(self, term: str) -> dict[str, Any]:
        """Return the odds ratio of ``term`` with each of its 95 % intervals, by name.

        ``{"interval": name of the default, "estimator": the default in words, "or": the
        default's estimate, "ci95": the default interval, "question": the question it answers,
        "ml_or": the ML odds ratio (the paper's), "wald", "profile", "firth_or",
        "firth_profile"}``; what the fit does not have is left out, an unbounded interval end is
        None (JSON). One rule for every reported term (:data:`DEFAULT_INTERVAL`): Firth's
        estimate with its profile penalised-likelihood interval. Where that profile could not be
        computed the default interval is ``[None, None]`` with a ``note`` saying so, never a
        Wald interval in its place (Wald ends of a separated term can be orders of magnitude too
        close to the estimate).
        """
        o = self.odds_ratios[term]
        out: dict[str, Any] = {}
        if self.method == "ml":
            out["ml_or"] = o["or"]
            out["wald"] = list(o["ci95"])
            if term in self.profile_ci95:
                out["profile"] = [_finite(v) for v in self.profile_ci95[term]]
        if term in self.firth_params:
            out["firth_or"] = math.exp(self.firth_params[term])
        if term in self.firth_profile_ci95 and term in self.firth_params:
            out["firth_profile"] = [_finite(v) for v in self.firth_profile_ci95[term]]
            name, est, ci = DEFAULT_INTERVAL, out["firth_or"], out["firth_profile"]
            note = ""
        else:
            name, ci = "none", [None, None]
            est = out.get("firth_or", o["or"])
            note = (
                "the profile interval could not be computed here; no interval is given (a "
                "Wald interval can be far narrower than these data support)"
            )
        res = {
            "interval": name,
            "estimator": DEFAULT_ESTIMATOR_TEXT if "firth_or" in out else "ML",
            "or": est,
            "ci95": ci,
            "question": ODDS_RATIO_QUESTION,
            **out,
        }
        if note:
            res["note"] = note
        return res

    def reported_intervals(self) -> dict[str, dict[str, Any]]:
        """Return :meth:`intervals` of the odds ratios the report states (results.json)."""
        return {t: self.intervals(t) for t in _REPORTED_TERMS if self.has(t)}

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict (``odds_ratios`` and ``classification`` as in results.json)."""
        return {
            "odds_ratios": self.odds_ratios.to_dict(),
            "classification": self.classification(),
            "params": dict(self.params),
            "bse": dict(self.bse),
            "reference_object": self.reference_object,
            "subject_factor": self.subject_factor,
            "n_trials": self.n_trials,
            "log_likelihood": self.log_likelihood,
            "warnings": list(self.warnings),
            "method": self.method,
            "separated": list(self.separated),
            "profile_ci95": {
                t: [_finite(v[0]), _finite(v[1])] for t, v in self.profile_ci95.items()
            },
            "firth_params": dict(self.firth_params),
            "firth_profile_ci95": {
                t: [_finite(v[0]), _finite(v[1])] for t, v in self.firth_profile_ci95.items()
            },
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LogisticFit:
        """Rebuild from :meth:`to_dict` output."""
        c = d["classification"]
        return cls(
            odds_ratios=OddsRatioTable.from_dict(d["odds_ratios"]),
            params={k: float(v) for k, v in d["params"].items()},
            bse={k: float(v) for k, v in d["bse"].items()},
            reference_object=str(d["reference_object"]),
            subject_factor=bool(d["subject_factor"]),
            n_trials=int(d["n_trials"]),
            log_likelihood=float(d["log_likelihood"]),
            recognized_correct_pct=float(c["recognized_correct_pct"]),
            not_recognized_correct_pct=float(c["not_recognized_correct_pct"]),
            cutoff=float(c["cutoff"]),
            warnings=tuple(d.get("warnings", ())),
            method=str(d.get("method", "ml")),
            separated=tuple(d.get("separated", ())),
            profile_ci95=_intervals_from_json(d.get("profile_ci95", {})),
            firth_params={k: float(v) for k, v in d.get("firth_params", {}).items()},
            firth_profile_ci95=_intervals_from_json(d.get("firth_profile_ci95", {})),
        )


def _intervals_from_json(d: dict[str, Any]) -> dict[str, tuple[float, float]]:
    """Odds-ratio intervals from JSON, where an unbounded end is None."""
    return {
        t: (0.0 if v[0] is None else float(v[0]), math.inf if v[1] is None else float(v[1]))
        for t, v in d.items()
    }


def _finite(v: float) -> float | None:
    """JSON has no inf: an unbounded interval end becomes None (null)."""
    return float(v) if math.isfinite(v) and v > 0 else None


def design_frame(trials: pd.DataFrame) -> pd.DataFrame:
    """Return the model's data: ``recognized, background, log10_pixels, object, subject``.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials (:mod:`analysis.data`).

    Returns
    -------
    pandas.DataFrame
    """
    return pd.DataFrame(
        {
            "recognized": trials["recognized"].astype(int).to_numpy(),
            "background": (trials["condition"] == "decluttered").astype(int).to_numpy(),
            "log10_pixels": np.log10(trials["pixels"].astype(float).to_numpy()),
            "object": trials["object"].astype(str).to_numpy(),
            "subject": trials["subject"].astype(str).to_numpy(),
        }
    )


def _term_name(name: str) -> str:
    if name.startswith("C(object"):
        return "object:" + name.split("[T.", 1)[1].rstrip("]")
    if name.startswith("C(subject"):
        return "subject:" + name.split("[T.", 1)[1].rstrip("]")
    return name


def check_model_data(d: pd.DataFrame) -> None:
    """Raise DataError (one line) when trials cannot identify the logistic model."""
    if d["recognized"].nunique() < 2:
        what = "recognised" if d["recognized"].iloc[0] == 1 else "not recognised"
        raise DataError(
            f"all {len(d)} trials are {what}: the logistic model (and any threshold) is not "
            "identified by these data"
        )
    for c, name in ((0, "cluttered"), (1, "decluttered")):
        if not (d["background"] == c).any():
            raise DataError(f"no trials in condition '{name}': both conditions are needed")


#: |log odds ratio| above which an ML estimate is taken as infinite (separation): ours,
#: OR > 3e6 is far beyond any effect these designs can measure.
SEPARATION_LOG_OR: float = 15.0


def _empty_fit(d: pd.DataFrame, ref: str, why: str, cutoff: float) -> LogisticFit:
    logger.warning("logistic model: %s", why)
    return LogisticFit(
        odds_ratios=OddsRatioTable(()),
        params={},
        bse={},
        reference_object=ref,
        subject_factor=False,
        n_trials=int(len(d)),
        log_likelihood=math.nan,
        recognized_correct_pct=math.nan,
        not_recognized_correct_pct=math.nan,
        cutoff=float(cutoff),
        warnings=(why,),
        method="none",
    )


def fit_logistic(
    trials: pd.DataFrame, *, subject_factor: bool = False, cutoff: float = 0.5
) -> LogisticFit:
    """Fit the paper's binary logistic regression; Firth's penalised fit when ML does not exist.

    Terms the data cannot inform are left out with a note: ``background`` with one condition,
    ``log10_pixels`` with one level, object dummies with one object or too few trials (fewer than
    10 per parameter, ours). When every trial has the same outcome nothing is estimated
    (``method == 'none'``). Separated data (e.g. every de-cluttered trial recognised) have no
    finite ML estimate; they are refitted with Firth's penalised likelihood and the separated terms
    are listed in ``separated``.

    Parameters
    ----------
    trials : pandas.DataFrame
        Tidy trials.
    subject_factor : bool
        Add subject dummies (reference: the first subject in sorted order).
    cutoff : float
        Classification-table cutoff on the predicted probability, in (0, 1).

    Returns
    -------
    LogisticFit

    References
    ----------
    Jung et al. 2015, Sec. 3.2.2: OR background 5.6 (3.9-8.1), OR log10 pixels 74.5
    (48.9-113.5), classification 90.3 % / 91.0 %. Firth 1993; Heinze & Schemper 2002.
    """
    import statsmodels.formula.api as smf
    from scipy import stats
    from statsmodels.tools.sm_exceptions import ConvergenceWarning, PerfectSeparationWarning

    if not (0.0 < cutoff < 1.0):
        raise ValueError(f"cutoff must be in (0, 1), got {cutoff!r}")
    d = design_frame(trials)
    objects = object_order(d["object"])
    ref = objects[0]
    if d["recognized"].nunique() < 2:
        what = "recognised" if d["recognized"].iloc[0] == 1 else "not recognised"
        return _empty_fit(
            d, ref, f"all {len(d)} trials are {what}: no odds ratio can be estimated", cutoff
        )
    notes: list[str] = []
    terms = []
    if d["background"].nunique() == 2:
        terms.append("background")
    else:
        notes.append("one background condition only: no background odds ratio")
    use_objects = len(objects) > 1
    if use_objects and len(d) < 10 * (len(objects) + 3):
        use_objects = False
        notes.append(
            f"{len(d)} trials are too few for {len(objects) - 1} object dummies (fewer than 10 "
            "per parameter): objects left out of the model"
        )
    if use_objects:
        terms.append("C(object)")
    if d["log10_pixels"].nunique() > 1:
        terms.append("log10_pixels")
    else:
        notes.append("one resolution level only: no odds ratio per log10 pixels")
    if subject_factor and d["subject"].nunique() > 1:
        terms.append("C(subject)")
    if not terms:
        return _empty_fit(d, ref, "; ".join(notes) + ": no term left to estimate", cutoff)
    # Categorical in natural order so that dummies come out as objects 2, 3, ..., 10 (not 10, 2).
    d["object"] = pd.Categorical(d["object"], categories=objects)
    d["subject"] = pd.Categorical(d["subject"], categories=object_order(d["subject"]))
    formula = "recognized ~ " + " + ".join(terms)
    model = smf.logit(formula, data=d)
    names = list(model.exog_names)
    X = model.exog
    if np.linalg.matrix_rank(X) < X.shape[1]:
        return _empty_fit(
            d, ref, "; ".join([*notes, "the design matrix is rank-deficient"]), cutoff
        )
    method, separated = "ml", []
    params = bse = None
    llf = math.nan
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = model.fit(method="newton", tol=1e-12, maxiter=200, disp=False)
        params, bse, llf = np.asarray(res.params), np.asarray(res.bse), float(res.llf)
        sep_warned = False
        ml_notes = []  # kept only if the ML fit stands (a Firth refit makes them moot)
        for w in caught:
            if issubclass(w.category, PerfectSeparationWarning):
                sep_warned = True
            elif issubclass(w.category, (ConvergenceWarning, RuntimeWarning)):
                ml_notes.append(" ".join(str(w.message).split()))
        separated = [
            _term_name(nm)
            for nm, b, se in zip(names, params, bse, strict=True)
            if nm != "Intercept" and (abs(b) > SEPARATION_LOG_OR or not np.isfinite(se))
        ]
        if sep_warned or separated or not np.all(np.isfinite(bse)):
            method = "firth"
        else:
            notes.extend(ml_notes)
    except Exception as exc:  # noqa: BLE001 - statsmodels raises several types on separation
        method = "firth"
        notes.append(f"ML fit failed ({type(exc).__name__}): Firth's penalised fit used instead")
    if method == "firth":
        y = d["recognized"].to_numpy(float)
        try:
            params, bse, llf = firth_logit(y, X)
        except np.linalg.LinAlgError:
            return _empty_fit(
                d, ref, "; ".join([*notes, "neither ML nor Firth's fit exists"]), cutoff
            )
        if not separated:
            separated = [_term_name(nm) for nm in names if nm != "Intercept"]
            notes.append(
                "ML estimates do not exist (the data are separated, or nearly); Firth's "
                "estimates for all terms"
            )
        else:
            notes.append(
                "separated in these data (ML odds ratio infinite): "
                + ", ".join(separated)
                + "; all odds ratios are from Firth's penalised likelihood"
            )
    rows = []
    for name, b, se in zip(names, params, bse, strict=True):
        if name == "Intercept":
            continue
        z = b / se if se > 0 else math.inf
        with np.errstate(over="ignore"):
            rows.append(
                (
                    _term_name(name),
                    float(np.exp(b)),
                    float(np.exp(b - 1.959963984540054 * se)),
                    float(np.exp(b + 1.959963984540054 * se)),
                    float(2 * stats.norm.sf(abs(z))),
                )
            )
    y_all = d["recognized"].to_numpy(float)
    failed: list[str] = []
    profile = _profiles(y_all, X, names, params, bse, penalized=method == "firth", failed=failed)
    if method == "firth":
        f_params, f_profile = params, profile
    else:
        try:
            f_params, f_bse, _ = firth_logit(y_all, X)
            f_profile = _profiles(
                y_all,
                X,
                names,
                f_params,
                f_bse,
                penalized=True,
                only=_REPORTED_TERMS,
                failed=failed,
            )
        except np.linalg.LinAlgError:
            f_params, f_profile = None, {}
            notes.append("Firth's penalised fit failed: ML intervals only")
    for term in dict.fromkeys(failed):
        if term in _REPORTED_TERMS:
            notes.append(
                f"the profile interval of the {term} odds ratio could not be computed; no "
                "interval is reported for it (a Wald interval can be far narrower than the data "
                "support)"
            )
    notes = list(dict.fromkeys(notes))
    for n in notes:
        logger.warning("logistic model: %s", n)
    eta = X @ params
    p = 1.0 / (1.0 + np.exp(-np.clip(eta, -700, 700)))
    y = d["recognized"].to_numpy()
    rec_ok = float(100.0 * np.mean(p[y == 1] >= cutoff))
    not_ok = float(100.0 * np.mean(p[y == 0] < cutoff))
    return LogisticFit(
        odds_ratios=OddsRatioTable(tuple(rows)),
        params={_term_name(k): float(v) for k, v in zip(names, params, strict=True)},
        bse={_term_name(k): float(v) for k, v in zip(names, bse, strict=True)},
        reference_object=ref,
        subject_factor="C(subject)" in formula,
        n_trials=int(len(d)),
        log_likelihood=float(llf),
        recognized_correct_pct=rec_ok,
        not_recognized_correct_pct=not_ok,
        cutoff=float(cutoff),
        warnings=tuple(notes),
        method=method,
        separated=tuple(separated),
        profile_ci95=profile,
        firth_params={}
        if f_params is None
        else {_term_name(k): float(v) for k, v in zip(names, f_params, strict=True)},
        firth_profile_ci95=f_profile,
    )


def _profiles(
    y: np.ndarray,
    X: np.ndarray,
    names: list[str],
    params: np.ndarray,
    bse: np.ndarray,
    *,
    penalized: bool,
    only: tuple[str, ...] | None = None,
    failed: list[str] | None = None,
) -> dict[str, tuple[float, float]]:
    """Return the 95 % profile (penalised if ``penalized``) interval of each term's odds ratio.

    Subject dummies are skipped (never reported), and with ``only`` every term not in it; a term
    whose profile fails is left out and its name appended to ``failed``.
    """
    out: dict[str, tuple[float, float]] = {}
    # merged once, not once per profile (the same rows, so the same numbers)
    y, X, n = binomial_rows(np.asarray(y, float), np.asarray(X, float), None)
    for j, name in enumerate(names):
        if name == "Intercept" or name.startswith("C(subject"):
            continue
        if only is not None and name not in only:
            continue
        try:
            lo_b, hi_b = profile_interval(
                y, X, j, params=params, bse=bse, penalized=penalized, weights=n
            )
        except (np.linalg.LinAlgError, ValueError, ArithmeticError):
            if failed is not None:
                failed.append(_term_name(name))
            continue
        with np.errstate(over="ignore"):
            out[_term_name(name)] = (float(np.exp(lo_b)), float(np.exp(hi_b)))
    return out


def predict_from_odds_ratio(p_ref: float, odds_ratio: float) -> float:
    """Return the recognition rate predicted from a reference rate and an odds ratio (Eq. 1).

    ``p = OR * O' / (1 + OR * O')`` with ``O' = p' / (1 - p')``.

    Parameters
    ----------
    p_ref : float
        Reference recognition rate p', in (0, 1).
    odds_ratio : float
        Odds ratio, > 0 (use ``1 / OR`` for the reverse direction).

    Returns
    -------
    float
        Predicted recognition rate p.

    References
    ----------
    Jung et al. 2015, Eq. 1: OR 5.6 and p' = 50 % give 84.9 %; the reverse gives 15.1 %.

    Examples
    --------
    >>> round(predict_from_odds_ratio(0.5, 5.6), 3)
    0.848
    """
    if not (0.0 < p_ref < 1.0):
        raise ValueError(f"p_ref must be in (0, 1), got {p_ref!r}")
    if not (odds_ratio > 0):
        raise ValueError(f"odds_ratio must be > 0, got {odds_ratio!r}")
    o = odds_ratio * p_ref / (1.0 - p_ref)
    return o / (1.0 + o)
