"""The ``[task]`` table of a protocol: ``type = "active_search"`` (beyond the paper's static study).

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
the implant shows. The session that runs such a task is :mod:`experiment.active`; its trial plan
is :func:`experiment.active.task.plan_trials`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

from experiment.protocol.fields import (
    ProtocolError,
    _choice,
    _need_bool,
    _need_distinct,
    _need_int,
    _need_ints,
    _need_number,
    _need_str,
    _need_table,
    _need_text,
    _optional,
    _Spec,
)

__all__ = [
    "TASK_TYPES",
    "ACTIVE_CONDITIONS",
    "JUNG2015_GRID_PX",
    "ActiveSearchSpec",
    "task_from_table",
]

#: Task types a protocol's ``[task]`` table may name.
TASK_TYPES: tuple[str, ...] = ("active_search",)

#: Conditions of an active-search trial (see the module docstring).
ACTIVE_CONDITIONS: tuple[str, ...] = ("decluttered", "cluttered")

#: Implant grid of the paper's light-field simulation, (rows, cols) = 28x35 = 980 cells.
#: Source: Jung et al. 2015, Sec. 4.1 and Fig. 13.
JUNG2015_GRID_PX: tuple[int, int] = (28, 35)


def _pair(minimum: int) -> Any:
    return partial(_need_ints, count=2, minimum=minimum)


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

    _prefix = "task."
    _checks = {
        "type": partial(_choice, choices=TASK_TYPES),
        "scene": partial(_need_text, empty="must name a scene or a light-field path"),
        "targets": partial(_need_distinct, noun="a target", item=_need_str),
        "conditions": partial(
            _need_distinct, noun="a condition", item=partial(_choice, choices=ACTIVE_CONDITIONS)
        ),
        "grid_px": _pair(1),
        "zoom_allowed": _need_bool,
        "time_limit_s": _need_number,
        "n_planes": partial(_need_int, minimum=3),
        "depth_step_px": _optional(_need_number),
        "scene_shape_px": _optional(_pair(16)),
        "scene_grid": _pair(1),
        "repetitions": partial(_need_int, minimum=1),
        "trial_order": partial(_choice, choices=("random", "listed")),
    }

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
    _need_table(table, "task")
    if "type" not in table:
        raise ProtocolError(f"[task] is missing field type (one of {', '.join(TASK_TYPES)})")
    _choice(table["type"], "task.type", TASK_TYPES)
    return ActiveSearchSpec.from_dict(dict(table), where="task")
