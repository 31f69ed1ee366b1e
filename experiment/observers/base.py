"""What every simulated observer shares: construction, answer text, response time, description.

Also the parameters of how an observer answers, whatever its model (:class:`AnswerParams`: lapses,
uses, shape descriptions, pace), and the one-line check of a parameter's limits (``"> 0"``,
``">= 0"``, ``"in [0, 0.5)"``) that the observers' parameter classes use instead of one
``if``/``raise`` per field.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from experiment.interfaces import Answer
from experiment.session.stimset import StimulusSet

__all__ = ["AnswerParams", "SimulatedObserver", "check_limits", "response_time_s"]


def _within(value: Any, rule: str) -> bool:
    if not isinstance(value, numbers.Real) or math.isnan(value):
        return False
    if rule.startswith("in "):
        low, high = (float(x) for x in rule[4:-1].split(","))
        above = value >= low if rule[3] == "[" else value > low
        below = value <= high if rule[-1] == "]" else value < high
        return above and below
    op, bound = rule.split()
    if op not in (">", ">="):
        raise ValueError(f"rule must be '> x', '>= x' or 'in [a, b)', got {rule!r}")
    return value >= float(bound) if op == ">=" else value > float(bound)


def check_limits(params: Any, limits: dict[str, str]) -> None:
    """Refuse a parameter outside its limits, in the order of ``limits``.

    Parameters
    ----------
    params : dataclass instance
        The parameters (read with ``getattr``).
    limits : dict of field name -> rule
        ``"> x"``, ``">= x"`` or an interval ``"in [a, b)"`` (``[``/``]`` closed, ``(``/``)``
        open). A value that is not a number, or NaN, is outside every rule.

    Raises
    ------
    ValueError
        ``<field> must be <rule>, got <value>``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> check_limits(SimpleNamespace(lapse=0.5), {"lapse": "in [0, 0.5)"})
    Traceback (most recent call last):
    ...
    ValueError: lapse must be in [0, 0.5), got 0.5
    """
    for name, rule in limits.items():
        value = getattr(params, name)
        if not _within(value, rule):
            raise ValueError(f"{name} must be {rule}, got {value!r}")


@dataclass(frozen=True)
class AnswerParams:
    """How a simulated observer answers, whatever its model; the observers' parameters extend it.

    Parameters
    ----------
    lapse : float in [0, 0.5)
        Probability of passing (failing) a trial regardless of the image. Ours.
    p_use : float in [0, 1]
        Share of recognised answers given as a use instead of a name. Ours.
    p_shape : float in [0, 1]
        Share of unrecognised answers that describe the shape (else pass). Ours.
    median_rt_s : float > 0
        Median response time, seconds. Ours.
    """

    lapse: float = 0.0
    p_use: float = 0.15
    p_shape: float = 0.3
    median_rt_s: float = 4.0

    def __post_init__(self) -> None:
        check_limits(self, {"lapse": "in [0, 0.5)"})


def response_time_s(rng: np.random.Generator, median_s: float, limit_s: float = 600.0) -> float:
    """Draw a response time, seconds: log-normal around ``median_s`` (SD 0.5 in log units; ours).

    Parameters
    ----------
    rng : numpy.random.Generator
    median_s : float > 0
        Median response time, seconds.
    limit_s : float
        Longest time returned, seconds.
    """
    return float(min(limit_s, median_s * math.exp(rng.normal(0.0, 0.5))))


class SimulatedObserver:
    """Base of the simulated observers (each a :class:`~experiment.interfaces.Responder`).

    Subclasses set ``name``, ``model`` (one line for the log) and ``params_class``, and may
    add ``_prepare()`` (work after construction) and ``_provenance()`` (what the description
    says about where the observer's knowledge came from).

    Parameters
    ----------
    stimset : StimulusSet
        The test stimulus set (object names and uses for the answer text).
    subject : str
        Subject code; the rater name is ``sim:<name>``.
    rng : numpy.random.Generator, int or None
        Trial-level randomness.
    params : the subclass's ``params_class``, optional
        Its defaults when None.
    """

    name = "simulated"
    model = ""
    params_class: type = object

    def __init__(
        self,
        stimset: StimulusSet,
        subject: str,
        *,
        rng: np.random.Generator | int | None = None,
        params: Any = None,
    ) -> None:
        self.stimset = stimset
        self.subject = subject
        self.params = params if params is not None else self.params_class()
        self.rng = np.random.default_rng(rng)
        self.rater = f"sim:{self.name}"
        self._prepare()

    def _prepare(self) -> None:
        """Do what the observer needs before its first trial (nothing by default)."""

    def _provenance(self) -> dict[str, Any]:
        """Return what :meth:`describe` adds after the parameters (where knowledge came from)."""
        return {}

    def describe(self) -> dict[str, Any]:
        """Return the observer's name, parameters and where its knowledge came from (JSON)."""
        return {
            "observer": self.name,
            "simulated": True,
            "model": self.model,
            "params": asdict(self.params),
            **self._provenance(),
        }

    def _answer(
        self,
        trial: Any,
        rt_s: float,
        *,
        recognized: bool,
        wrong: str | None = None,
        p_use: float = 0.0,
        p_shape: float = 0.0,
        shape_text: str = "something round",
    ) -> Answer:
        """Return the answer text and score.

        A name or use when recognised, else ``wrong`` (a wrong name) when given, else a shape
        description (``p_shape``) or a pass.
        """
        if recognized:
            obj = self.stimset.objects[trial.object]
            if obj.uses and self.rng.random() < p_use:
                return Answer(f"you use it for {obj.uses[0]}", "use", self.rater, rt_s)
            return Answer(obj.name, "named", self.rater, rt_s)
        if wrong is not None:
            return Answer(wrong, "wrong", self.rater, rt_s)
        if self.rng.random() < p_shape:
            return Answer(shape_text, "shape", self.rater, rt_s)
        return Answer("", "pass", self.rater, max(rt_s, float(trial.pass_allowed_after_s)))
