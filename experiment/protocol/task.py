"""The ``[task]`` table of a protocol: ``type = "active_search"`` (beyond the paper's static study).

In an active-search trial the subject drives the confocal viewer (depth keys, jumps between the
detected planes, zoom) through a light-field scene to find a cued object and name it; the
operator scores the answer as in the static study (Jung et al. 2015, Sec. 3.2). A protocol file
with a ``[task]`` table needs no ``[[blocks]]``::

    [task]
    type = "active_search"
    scene = ["synthetic:random_three_plane", "synthetic:three_plane", "scenes/lytro.toml"]
    targets = ["pedestrian", "tree", "building"]
    conditions = ["decluttered", "cluttered"]
    counterbalance = "latin_square"
    grid_px = [28, 35]

``scene`` is one scene or a list of several; each scene is searched for each listed target it
holds. ``synthetic:random_three_plane`` puts the objects at new columns and depths in every
trial (drawn from the session's seed and logged), so a subject cannot learn where they are; a
``.toml`` scene is a recorded light field with its targets (:mod:`experiment.active.scenefile`).
With ``counterbalance = "latin_square"`` the conditions run in blocks whose order follows the
rows of a balanced Latin square across subjects.

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
    "COUNTERBALANCE_SCHEMES",
    "JUNG2015_GRID_PX",
    "ActiveSearchSpec",
    "task_from_table",
]

#: Task types a protocol's ``[task]`` table may name.
TASK_TYPES: tuple[str, ...] = ("active_search",)

#: Conditions of an active-search trial (see the module docstring).
ACTIVE_CONDITIONS: tuple[str, ...] = ("decluttered", "cluttered")

#: How condition order varies across subjects: ``none`` (trials of all conditions interleaved,
#: in ``trial_order``), ``latin_square`` (one block per condition; the block order is the row of
#: a balanced Latin square given by the subject's index).
COUNTERBALANCE_SCHEMES: tuple[str, ...] = ("none", "latin_square")

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
    scene : str or tuple of str
        One scene or several: ``"synthetic:three_plane"`` (Fig. 10 scene),
        ``"synthetic:random_three_plane"`` (its objects at new places in every trial), a scene
        description (``.toml``: a recorded light field and its targets) or a light-field
        file/folder path. Paths are read from the protocol's folder.
    targets : tuple of str
        Objects to find: one trial per scene x target it holds x condition x repetition.
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
    counterbalance : {'none', 'latin_square'}
        Condition order across subjects (:data:`COUNTERBALANCE_SCHEMES`).
    """

    type: str
    scene: str | tuple[str, ...]
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
    counterbalance: str = "none"

    _prefix = "task."
    _checks = {
        "type": partial(_choice, choices=TASK_TYPES),
        "scene": lambda v, name: (
            _need_text(v, name, empty="must name a scene or a light-field path")
            if not isinstance(v, tuple)
            else _need_distinct(
                v,
                name,
                noun="a scene",
                item=partial(_need_text, empty="must name a scene or a light-field path"),
                expected="a scene or a non-empty list of scenes",
            )
        ),
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
        "counterbalance": partial(_choice, choices=COUNTERBALANCE_SCHEMES),
    }

    @property
    def scenes(self) -> tuple[str, ...]:
        """The scenes, as a tuple (one scene or several)."""
        return (self.scene,) if isinstance(self.scene, str) else tuple(self.scene)

    def to_dict(self) -> dict[str, Any]:
        """Return the ``[task]`` table as plain data (``None`` fields left out, as in TOML).

        ``counterbalance = "none"`` is left out too, so a protocol written before that field
        existed keeps its content hash (and its unfinished sessions can resume).
        """
        out = {k: v for k, v in super().to_dict().items() if v is not None}
        if out.get("counterbalance") == "none":
            del out["counterbalance"]
        return out


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
