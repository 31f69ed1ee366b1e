"""The active-search task of a protocol: ``[task] type = "active_search"`` (issue 14, point 5).

In an active-search trial the subject drives the confocal viewer (depth keys, jumps between the
detected planes, zoom) through a light-field scene to find a cued object and name it; the
operator scores the answer as in the static study (Jung et al. 2015, Sec. 3.2). A protocol file
with a ``[task]`` table needs no ``[[blocks]]``::

    [task]
    type = "active_search"
    scene = "synthetic:three_plane"     # or a light-field file/folder
    targets = ["pedestrian", "tree", "building"]
    conditions = ["decluttered", "cluttered"]
    grid_px = [28, 35]

Conditions mirror the static study's: ``decluttered`` shows the implant the de-cluttered edges
of the *confocal image at the current depth* (the active confocal system); ``cluttered`` shows
the edges of the all-in-focus centre view (a conventional camera), so depth keys change nothing
the implant shows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from experiment.protocol import ProtocolError, _choice, _need, _Spec

__all__ = [
    "TASK_TYPES",
    "ACTIVE_CONDITIONS",
    "ActiveSearchSpec",
    "ActiveTrial",
    "task_from_table",
    "plan_trials",
]

#: Task types a protocol's ``[task]`` table may name.
TASK_TYPES: tuple[str, ...] = ("active_search",)

#: Conditions of an active-search trial (see the module docstring).
ACTIVE_CONDITIONS: tuple[str, ...] = ("decluttered", "cluttered")

#: Implant grid of the paper's light-field simulation, (rows, cols) = 28x35 = 980 cells.
#: Source: Jung et al. 2015, Sec. 4.1 and Fig. 13.
JUNG2015_GRID_PX: tuple[int, int] = (28, 35)


@dataclass(frozen=True)
class ActiveSearchSpec(_Spec):
    """The ``[task]`` table of an active-search protocol.

    Parameters
    ----------
    type : {'active_search'}
    scene : str
        ``"synthetic:three_plane"`` (Fig. 10 scene) or a light-field file/folder path.
    targets : tuple of str
        Objects to find, one trial per target x condition x repetition.
    conditions : tuple of {'decluttered', 'cluttered'}
    grid_px : (rows, cols)
        Implant grid. Default: the paper's 28x35; with a ``[display] implant`` the implant's
        electrode grid (and the subject's screen draws its phosphenes at its field of view).
    zoom_allowed : bool
        Whether the zoom keys work.
    time_limit_s : float > 0
        A trial ends with a pass after this long, seconds. Default 60: the static study's
        pass after 1 min (Jung et al. 2015, Sec. 3.2).
    n_planes : int >= 3
        Planes of the depth scan that finds the object planes (paper Fig. 15: 200).
    depth_step_px : float > 0 or None
        Disparity change per depth key press, px per view step. None: the light field's own
        depth resolution (one pixel of shift at the outermost view).
    scene_shape_px : (rows, cols) or None
        View size of a synthetic scene (None: the paper's 308x385).
    scene_grid : (n_u, n_v)
        Views of a synthetic scene (ours: 7x7 with the adapter's 3 cm baseline blurs each
        plane's neighbours by several pixels; the paper's lens array had 10x10).
    repetitions : int >= 1
    trial_order : {'random', 'listed'}
    """

    type: str
    scene: str
    targets: tuple[str, ...]
    conditions: tuple[str, ...] = ACTIVE_CONDITIONS
    grid_px: tuple[int, int] = JUNG2015_GRID_PX
    zoom_allowed: bool = True
    time_limit_s: float = 60.0
    n_planes: int = 200
    depth_step_px: float | None = None
    scene_shape_px: tuple[int, int] | None = None
    scene_grid: tuple[int, int] = (7, 7)
    repetitions: int = 1
    trial_order: str = "random"

    def _check_type(self) -> None:
        _choice(self.type, TASK_TYPES, "task.type")

    def _check_scene(self) -> None:
        _need(self.scene, str, "task.scene")
        if not self.scene.strip():
            raise ProtocolError("task.scene must name a scene or a light-field path")

    def _check_targets(self) -> None:
        if not isinstance(self.targets, tuple) or not self.targets:
            raise ProtocolError(f"task.targets must be a non-empty list, got {self.targets!r}")
        for t in self.targets:
            _need(t, str, "task.targets[]")
        if len(set(self.targets)) != len(self.targets):
            raise ProtocolError(f"task.targets lists a target twice: {list(self.targets)}")

    def _check_conditions(self) -> None:
        if not isinstance(self.conditions, tuple) or not self.conditions:
            raise ProtocolError(
                f"task.conditions must be a non-empty list, got {self.conditions!r}"
            )
        for c in self.conditions:
            _choice(c, ACTIVE_CONDITIONS, "task.conditions[]")
        if len(set(self.conditions)) != len(self.conditions):
            raise ProtocolError(f"task.conditions lists a condition twice: {list(self.conditions)}")

    @staticmethod
    def _pair(value: Any, name: str, minimum: int) -> None:
        ok = (
            isinstance(value, tuple)
            and len(value) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) and v >= minimum for v in value)
        )
        if not ok:
            raise ProtocolError(f"{name} must be 2 integers >= {minimum}, got {value!r}")

    def _check_grid_px(self) -> None:
        self._pair(self.grid_px, "task.grid_px", 1)

    def _check_zoom_allowed(self) -> None:
        _need(self.zoom_allowed, bool, "task.zoom_allowed")

    def _check_time_limit_s(self) -> None:
        _need(self.time_limit_s, (int, float), "task.time_limit_s")
        if not (math.isfinite(self.time_limit_s) and self.time_limit_s > 0):
            raise ProtocolError(f"task.time_limit_s must be > 0, got {self.time_limit_s!r}")

    def _check_n_planes(self) -> None:
        _need(self.n_planes, int, "task.n_planes")
        if self.n_planes < 3:
            raise ProtocolError(f"task.n_planes must be >= 3, got {self.n_planes!r}")

    def _check_depth_step_px(self) -> None:
        if self.depth_step_px is None:
            return
        _need(self.depth_step_px, (int, float), "task.depth_step_px")
        if not (math.isfinite(self.depth_step_px) and self.depth_step_px > 0):
            raise ProtocolError(f"task.depth_step_px must be > 0, got {self.depth_step_px!r}")

    def _check_scene_shape_px(self) -> None:
        if self.scene_shape_px is not None:
            self._pair(self.scene_shape_px, "task.scene_shape_px", 16)

    def _check_scene_grid(self) -> None:
        self._pair(self.scene_grid, "task.scene_grid", 1)

    def _check_repetitions(self) -> None:
        _need(self.repetitions, int, "task.repetitions")
        if self.repetitions < 1:
            raise ProtocolError(f"task.repetitions must be >= 1, got {self.repetitions!r}")

    def _check_trial_order(self) -> None:
        _choice(self.trial_order, ("random", "listed"), "task.trial_order")

    def to_dict(self) -> dict[str, Any]:
        """Return the ``[task]`` table as plain data (``None`` fields left out, as in TOML)."""
        return {k: v for k, v in super().to_dict().items() if v is not None}


def task_from_table(table: Any) -> ActiveSearchSpec:
    """Build the task spec from a protocol's ``[task]`` table, checking every field.

    Raises
    ------
    ProtocolError
        One line naming the field: unknown type or key, missing field, bad value.
    """
    if not isinstance(table, dict):
        raise ProtocolError(f"[task] must be a table, got {type(table).__name__}")
    if "type" not in table:
        raise ProtocolError(f"[task] is missing field type (one of {', '.join(TASK_TYPES)})")
    _choice(table["type"], TASK_TYPES, "task.type")
    return ActiveSearchSpec.from_dict(dict(table), where="task")


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
