"""The trial plan of an active-search session: targets x conditions x repetitions.

The ``[task]`` table that describes the task is part of the protocol
(:class:`experiment.protocol.task.ActiveSearchSpec`); this module turns it into the session's
trials.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

# ActiveSearchSpec is also imported from here by the active session.
from experiment.protocol.task import ActiveSearchSpec

__all__ = ["ActiveSearchSpec", "ActiveTrial", "plan_trials"]


@dataclass(frozen=True)
class ActiveTrial:
    """One planned active-search trial.

    Parameters
    ----------
    index : int
        Position in the session's plan, 0-based.
    target : str
        The object to find and name (the cue shown at onset).
    condition : {'decluttered', 'cluttered'}
    repetition : int
        0-based repetition.
    """

    index: int
    target: str
    condition: str
    repetition: int = 0

    def to_dict(self) -> dict[str, Any]:
        """Return the trial as plain data (the ``plan`` event's payload rows)."""
        return {
            "index": self.index,
            "target": self.target,
            "condition": self.condition,
            "repetition": self.repetition,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ActiveTrial:
        """Inverse of :meth:`to_dict`."""
        return cls(
            int(data["index"]),
            str(data["target"]),
            str(data["condition"]),
            int(data.get("repetition", 0)),
        )


def plan_trials(task: ActiveSearchSpec, rng: np.random.Generator | int | None) -> list[ActiveTrial]:
    """Return the session's trials: targets x conditions x repetitions, shuffled per repetition.

    Parameters
    ----------
    task : ActiveSearchSpec
    rng : numpy Generator, int or None
        Draws the order when ``task.trial_order == 'random'``.
    """
    rng = np.random.default_rng(rng)
    out: list[ActiveTrial] = []
    for rep in range(task.repetitions):
        pairs = [(t, c) for c in task.conditions for t in task.targets]
        if task.trial_order == "random":
            pairs = [pairs[i] for i in rng.permutation(len(pairs))]
        for t, c in pairs:
            out.append(ActiveTrial(len(out), t, c, rep))
    return out
