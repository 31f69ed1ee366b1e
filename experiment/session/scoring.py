"""Scoring free-text answers and rater agreement (Jung et al. 2015, Sec. 3.2).

The operator types what the subject said; :func:`suggest_score` proposes a score from the
object's name, synonyms and uses (``objects.csv``), tolerant of case, plurals and small typos;
the operator confirms or overrides. A second rater can re-score later; :func:`cohen_kappa`
reports agreement, with a 95 % interval from statsmodels (:func:`kappa_interval`).
"""

from __future__ import annotations

import difflib
import json
import math
import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from experiment.protocol import SCORES
from experiment.session.stimset import ObjectInfo

__all__ = [
    "SHAPE_WORDS",
    "check_rater",
    "check_score",
    "normalize",
    "suggest_score",
    "kappa",
    "KappaResult",
    "cohen_kappa",
    "kappa_interval",
    "kappa_interval_few_trials",
    "KAPPA_MIN_TRIALS",
]

#: Words that describe shape or features rather than identity or use; a response made only of
#: these (and filler) is scored ``shape``. Ours, not the paper's (the paper gives no word list).
SHAPE_WORDS: frozenset[str] = frozenset(
    """round circle circular square rectangle rectangular box boxy long thin tall short flat
    curved straight line lines edge edges shape triangle triangular oval cylinder cylindrical
    handle big small large tiny wide narrow tube stick ring hole corner top bottom side""".split()
)

#: Minimum difflib similarity for two words (or phrases) to count as the same. Ours: 0.8 lets
#: one typo through in a word of five or more letters ("scisors", "mugg") but not a different
#: short word ("cup" vs "cap" is 0.67).
MATCH_RATIO: float = 0.8

_FILLER = frozenset(
    "a an the it its is it's its's this that some kind of like looks maybe i think something "
    "thing for to used use you and or with which".split()
)


def check_score(score: object, name: str = "score") -> None:
    """Refuse a score that is not one of the protocol's scores (``named``, ``use``, ...).

    Raises
    ------
    ValueError
        Naming ``name`` (``score``, ``answer.score``), the scores allowed and the value given.
    """
    if score not in SCORES:
        raise ValueError(f"{name} must be one of {', '.join(SCORES)}, got {score!r}")


def check_rater(rater: object) -> None:
    """Refuse a rater that is not a non-empty string.

    Raises
    ------
    ValueError
        Naming ``rater`` and the value given.
    """
    if not isinstance(rater, str) or not rater.strip():
        raise ValueError(f"rater must be a non-empty string, got {rater!r}")


def _singular(word: str) -> str:
    if len(word) > 4 and word.endswith("ies"):
        return word[:-3] + "y"
    if len(word) > 4 and word.endswith(("ches", "shes", "sses", "xes")):
        return word[:-2]
    if len(word) > 3 and word.endswith("s") and not word.endswith("ss"):
        return word[:-1]
    return word


def normalize(text: str) -> str:
    """Return ``text`` lower-cased, punctuation removed, words singular, single-spaced.

    Idempotent: ``normalize(normalize(t)) == normalize(t)``.

    Examples
    --------
    >>> normalize("  Two MUGS, please! ")
    'two mug please'
    """
    words = re.findall(r"[a-z0-9]+", str(text).lower())
    out = [_singular(w) for w in words]
    # singular of a singular may shorten again ("glasses" -> "glass" is stable); iterate to a
    # fixed point so the function is idempotent
    while True:
        nxt = [_singular(w) for w in out]
        if nxt == out:
            break
        out = nxt
    return " ".join(out)


def _similar(a: str, b: str) -> bool:
    if a == b:
        return True
    # a typo changes a word's length by a letter or two; a different word ("coffee" for
    # "coffeecup") differs more, even when difflib's ratio is high
    if abs(len(a) - len(b)) > 2:
        return False
    return difflib.SequenceMatcher(None, a, b).ratio() >= MATCH_RATIO


def _mentions(response: str, phrase: str) -> bool:
    """Whether the normalised ``response`` contains ``phrase``, typos and spacing allowed.

    Runs of response words are joined without spaces and compared with the phrase joined the
    same way, so "tooth brush" matches "toothbrush" and "coffeecup" matches "coffee cup".
    """
    r_words = response.split()
    p_words = normalize(phrase).split()
    if not p_words or not r_words:
        return False
    target = "".join(p_words)
    for size in range(max(1, len(p_words) - 1), len(p_words) + 2):
        for i in range(len(r_words) - size + 1):
            if _similar("".join(r_words[i : i + size]), target):
                return True
    return False


def suggest_score(response: str, obj: ObjectInfo, others: Iterable[ObjectInfo] = ()) -> str:
    """Propose a score for a typed response to an image of ``obj``.

    Parameters
    ----------
    response : str
        The subject's words as typed ("" = pass).
    obj : ObjectInfo
        The object shown (name, synonyms, uses).
    others : iterable of ObjectInfo
        The other objects; naming one of them is ``wrong``.

    Returns
    -------
    {'named', 'use', 'shape', 'wrong', 'pass'}
        ``named`` if the name or a synonym is mentioned; else ``use`` if a use is; else
        ``wrong`` if another object is named; else ``shape`` if the words describe shape only;
        ``pass`` for an empty answer or "pass"/"don't know"; else ``wrong``.

    Examples
    --------
    >>> mug = ObjectInfo("o1", "mug", ("cup",), ("drinking coffee",), "main")
    >>> suggest_score("a Mugg", mug), suggest_score("for drinking coffee", mug)
    ('named', 'use')
    """
    r = normalize(response)
    if not r or r in {"pass", "don t know", "dont know", "no idea", "nothing", "i don t know"}:
        return "pass"
    for phrase in (obj.name, *obj.synonyms):
        if _mentions(r, phrase):
            return "named"
    for phrase in obj.uses:
        if _mentions(r, phrase):
            return "use"
    for other in others:
        if other.object == obj.object:
            continue
        if any(_mentions(r, p) for p in (other.name, *other.synonyms)):
            return "wrong"
    content = [w for w in r.split() if w not in _FILLER]
    if content and all(w in SHAPE_WORDS for w in content):
        return "shape"
    return "wrong"


@dataclass(frozen=True)
class KappaResult:
    """Agreement between two raters on the same trials.

    Parameters
    ----------
    rater_a, rater_b : str
    n : int
        Trials scored by both.
    observed : float
        Proportion of trials with the same score.
    expected : float
        Agreement expected by chance from the raters' marginal score frequencies.
    kappa : float
        Cohen's kappa, ``(observed - expected) / (1 - expected)`` (NaN when n = 0 or expected = 1).
    se : float
        Its asymptotic standard error (Fleiss, Cohen & Everitt 1969), NaN when undefined.
    ci95_low, ci95_high : float
        95 % Wald interval ``kappa -/+ 1.96 se``, clipped to [-1, 1] (NaN when undefined).
    """

    rater_a: str
    rater_b: str
    n: int
    observed: float
    expected: float
    kappa: float
    se: float = float("nan")
    ci95_low: float = float("nan")
    ci95_high: float = float("nan")

    def to_dict(self) -> dict:
        """Return the result as a dict."""
        return dict(self.__dict__)


def kappa(scores_a: Sequence[str], scores_b: Sequence[str]) -> tuple[float, float, float]:
    """Return ``(kappa, observed, expected)`` for two equally long lists of labels.

    References
    ----------
    Cohen, J. (1960). A coefficient of agreement for nominal scales. Educ. Psychol. Meas. 20, 37-46.

    Examples
    --------
    >>> round(kappa(["a", "a", "b", "b"], ["a", "b", "b", "b"])[0], 3)
    0.5
    """
    if len(scores_a) != len(scores_b):
        raise ValueError(
            f"scores_a and scores_b must have the same length, got {len(scores_a)} and "
            f"{len(scores_b)}"
        )
    n = len(scores_a)
    if n == 0:
        return float("nan"), float("nan"), float("nan")
    labels = sorted(set(scores_a) | set(scores_b))
    po = sum(a == b for a, b in zip(scores_a, scores_b, strict=True)) / n
    pe = sum((list(scores_a).count(k) / n) * (list(scores_b).count(k) / n) for k in labels)
    k = float("nan") if pe == 1.0 else (po - pe) / (1.0 - pe)
    return k, po, pe


def cohen_kappa(log, rater_a: str, rater_b: str, *, labels: str = "score") -> KappaResult:
    """Return Cohen's kappa between two raters' latest scores in a trial log.

    Parameters
    ----------
    log : experiment.log.TrialLog
    rater_a, rater_b : str
        Rater names as stored in ``scores.rater``.
    labels : {'score', 'recognized'}
        Compare the five scores, or only recognised vs not.

    Returns
    -------
    KappaResult
    """
    if labels not in ("score", "recognized"):
        raise ValueError(f"labels must be 'score' or 'recognized', got {labels!r}")
    a = log.latest_scores(rater_a)
    b = log.latest_scores(rater_b)
    common = sorted(set(a) & set(b))
    la = [a[k] for k in common]
    lb = [b[k] for k in common]
    if labels == "recognized":
        rec = {
            r[0]: json.loads(r[1])["scoring"]["recognized"]
            for r in log.execute("SELECT session_id, protocol_json FROM sessions")
        }
        la = [str(rec[k[0]][s]) for k, s in zip(common, la, strict=True)]
        lb = [str(rec[k[0]][s]) for k, s in zip(common, lb, strict=True)]
    k, po, pe = kappa(la, lb)
    se, lo, hi = float("nan"), float("nan"), float("nan")
    if la and not math.isnan(k):
        k, se, lo, hi = kappa_interval_few_trials(la, lb)
    return KappaResult(rater_a, rater_b, len(common), po, pe, k, se, lo, hi)


def kappa_interval(
    scores_a: Sequence[str], scores_b: Sequence[str]
) -> tuple[float, float, float, float]:
    """Return Cohen's kappa with its standard error and 95 % interval, from statsmodels.

    Returns
    -------
    (kappa, se, ci95_low, ci95_high) : floats
        ``statsmodels.stats.inter_rater.cohens_kappa`` on the raters' contingency table: the
        asymptotic standard error of Fleiss, Cohen & Everitt (1969) and a Wald interval, clipped
        to [-1, 1] (with few trials the unclipped interval can pass 1).

    References
    ----------
    Fleiss, J. L., Cohen, J., Everitt, B. S. (1969). Large sample standard errors of kappa and
    weighted kappa. Psychol. Bull. 72, 323-327.
    """
    import numpy as np
    from statsmodels.stats.inter_rater import cohens_kappa

    if len(scores_a) != len(scores_b) or not scores_a:
        raise ValueError(
            f"scores_a and scores_b must be equally long and non-empty, got {len(scores_a)} and "
            f"{len(scores_b)}"
        )
    labels = sorted(set(scores_a) | set(scores_b))
    index = {lab: i for i, lab in enumerate(labels)}
    table = np.zeros((len(labels), len(labels)))
    for a, b in zip(scores_a, scores_b, strict=True):
        table[index[a], index[b]] += 1
    with warnings.catch_warnings():
        # its z test against kappa = 0 divides by zero when one rater used one score only;
        # we report kappa and its interval, not that test
        warnings.simplefilter("ignore", RuntimeWarning)
        res = cohens_kappa(table)  # its default alpha, 0.025 per side: a 95 % interval
    k, se = float(res["kappa"]), float(res["std_kappa"])
    return k, se, max(-1.0, float(res["kappa_low"])), min(1.0, float(res["kappa_upp"]))


#: Fewest trials scored by both raters for which a 95 % interval of kappa is given (ours): below
#: it the interval is left out and reported as "too few trials", because the asymptotic standard
#: error behind the Wald interval then misstates the uncertainty (it is 0 at perfect agreement).
KAPPA_MIN_TRIALS: int = 20


def kappa_interval_few_trials(
    scores_a: Sequence[str], scores_b: Sequence[str]
) -> tuple[float, float, float, float]:
    """Return Cohen's kappa with a 95 % interval that stays honest on few trials.

    Below :data:`KAPPA_MIN_TRIALS` trials the standard error and interval are NaN ("too few
    trials"). From there on it is the Wald interval of :func:`kappa_interval`, widened where
    needed to contain the exact interval conditional on the raters' marginals: the
    Clopper-Pearson 95 % interval of the observed agreement ``po`` mapped to kappa with the
    chance agreement ``pe`` held at its observed value, ``(po - pe) / (1 - pe)``. So perfect
    agreement on 30 trials gives an interval reaching well below 1, never "1.000 to 1.000".

    Parameters
    ----------
    scores_a, scores_b : sequence of str
        Labels of the same trials by two raters (equally long, non-empty).

    Returns
    -------
    (kappa, se, ci95_low, ci95_high) : floats
        NaN for se and the interval below :data:`KAPPA_MIN_TRIALS` trials.

    Raises
    ------
    ValueError
        Unequal lengths or no trials.

    References
    ----------
    Clopper, C. J., Pearson, E. S. (1934). Biometrika 26, 404-413; Fleiss, Cohen & Everitt 1969.
    """
    from scipy import stats

    k, se, lo, hi = kappa_interval(scores_a, scores_b)
    n = len(scores_a)
    if n < KAPPA_MIN_TRIALS:
        return k, float("nan"), float("nan"), float("nan")
    _, po, pe = kappa(scores_a, scores_b)
    if pe < 1.0:
        agree = round(po * n)
        po_lo = stats.beta.ppf(0.025, agree, n - agree + 1) if agree > 0 else 0.0
        po_hi = stats.beta.ppf(0.975, agree + 1, n - agree) if agree < n else 1.0
        lo = float(min(lo, max(-1.0, (po_lo - pe) / (1.0 - pe))))
        hi = float(max(hi, min(1.0, (po_hi - pe) / (1.0 - pe))))
    return k, se, lo, hi
