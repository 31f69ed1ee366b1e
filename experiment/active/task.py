"""The trial plan of an active-search session: scenes x targets x conditions x repetitions.

The ``[task]`` table that describes the task is part of the protocol
(:class:`experiment.protocol.task.ActiveSearchSpec`); this module turns it into the session's
trials. Each trial of a randomised scene carries its own object layout and texture seed, drawn
here from the session's seed and saved in the plan, so the trial can be rebuilt exactly. With
``counterbalance = "latin_square"`` the conditions run in blocks whose order is a row of a
balanced Latin square, chosen by the subject's index (saved in the plan too).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

# ActiveSearchSpec is also imported from here by the active session.
from experiment.protocol.task import ActiveSearchSpec
from experiment.trials import balanced_latin_square

__all__ = [
    "ActiveSearchSpec",
    "ActiveTrial",
    "balanced_latin_square",
    "condition_order",
    "plan_trials",
]


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
    scene : str
        The scene searched (an entry of ``task.scene``; "" in plans written before scenes were
        listed per trial: the task's only scene).
    layout : dict or None
        Where a randomised scene's objects stand (``{name: {x_frac, depth_m}}``), else None.
    scene_seed : int or None
        Texture seed of a randomised scene, else None (the scene's fixed textures).
    """

    index: int
    target: str
    condition: str
    repetition: int = 0
    scene: str = ""
    layout: dict | None = None
    scene_seed: int | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return the trial as plain data (the ``plan`` event's payload rows)."""
        out: dict[str, Any] = {
            "index": self.index,
            "target": self.target,
            "condition": self.condition,
            "repetition": self.repetition,
            "scene": self.scene,
        }
        if self.layout is not None:
            out["layout"] = self.layout
            out["scene_seed"] = self.scene_seed
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ActiveTrial:
        """Inverse of :meth:`to_dict`."""
        seed = data.get("scene_seed")
        return cls(
            int(data["index"]),
            str(data["target"]),
            str(data["condition"]),
            int(data.get("repetition", 0)),
            str(data.get("scene", "")),
            data.get("layout"),
            None if seed is None else int(seed),
        )


def condition_order(task: ActiveSearchSpec, subject_index: int) -> tuple[str, ...]:
    """Return the order of the condition blocks for a subject (``latin_square`` only).

    Parameters
    ----------
    task : ActiveSearchSpec
    subject_index : int >= 0
        The subject's position in the study (row ``subject_index mod rows`` of the square).
    """
    if isinstance(subject_index, bool) or not isinstance(subject_index, int) or subject_index < 0:
        raise ValueError(f"subject_index must be an integer >= 0, got {subject_index!r}")
    rows = balanced_latin_square(len(task.conditions))
    return tuple(task.conditions[k] for k in rows[subject_index % len(rows)])


def plan_trials(
    task: ActiveSearchSpec,
    rng: np.random.Generator | int | None,
    *,
    scene_objects: dict[str, tuple[str, ...] | None] | None = None,
    subject_index: int = 0,
) -> list[ActiveTrial]:
    """Return the session's trials: scenes x targets x conditions x repetitions.

    Parameters
    ----------
    task : ActiveSearchSpec
    rng : numpy Generator, int or None
        Draws the order when ``task.trial_order == 'random'``, then each randomised scene
        trial's layout and texture seed.
    scene_objects : dict of scene -> tuple of str or None, optional
        The objects each scene holds (None: unknown, every target is searched there). Default:
        every target in every scene.
    subject_index : int >= 0
        Chooses the condition order under ``counterbalance = "latin_square"``.

    Returns
    -------
    list of ActiveTrial
        Under ``latin_square``, per repetition one block per condition, in the subject's
        order; otherwise all conditions interleaved. Shuffled within each repetition (or
        block) when ``trial_order == 'random'``.
    """
    from experiment.active.adapter import draw_layout

    rng = np.random.default_rng(rng)
    objects = scene_objects or {}
    units = [
        (s, t)
        for s in task.scenes
        for t in task.targets
        if objects.get(s) is None or t in objects[s]
    ]
    if task.counterbalance == "latin_square":
        blocks = [(c,) for c in condition_order(task, subject_index)]
    else:
        blocks = [tuple(task.conditions)]
    listed: list[tuple[str, str, str, int]] = []
    for rep in range(task.repetitions):
        for conds in blocks:
            group = [(s, t, c) for c in conds for s, t in units]
            if task.trial_order == "random":
                group = [group[i] for i in rng.permutation(len(group))]
            listed += [(s, t, c, rep) for s, t, c in group]
    out: list[ActiveTrial] = []
    for s, t, c, rep in listed:
        layout = draw_layout(s, rng)
        seed = None if layout is None else int(rng.integers(0, 2**31 - 1))
        out.append(ActiveTrial(len(out), t, c, rep, s, layout, seed))
    return out
