"""The viewer's state machine for active search, and the CPU rendering of each state (GL-free).

A :class:`ViewerState` is what the subject has chosen: the depth in focus (disparity, px per
view step), which detected plane that is (if any) and the zoom box. :func:`apply_action` is the
pure transition function for the keys; :class:`Renderer` computes what each pane shows for a
state (confocal image, de-cluttered edges, implant grid) with the numpy pipeline of
:mod:`stimuli` (through :mod:`experiment.active.adapter`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from experiment.active import adapter

__all__ = ["ACTIONS", "KEYMAP", "ViewerState", "SearchContext", "View", "apply_action", "Renderer"]

#: Input actions of the active-search task (keys map onto these).
ACTIONS: tuple[str, ...] = (
    "depth_near",
    "depth_far",
    "plane_next",
    "plane_prev",
    "zoom",
    "unzoom",
    "answer",
    "pass",
)

#: Default keys of a live viewer (moderngl-window key names) and the actions they send; a drag
#: sends ``zoom`` with its box. The session logs the key and the action separately, so a viewer
#: may remap keys without changing what the analysis counts.
KEYMAP: dict[str, str] = {
    "Up": "depth_near",
    "Down": "depth_far",
    "PageUp": "plane_prev",
    "PageDown": "plane_next",
    "Escape": "unzoom",
    "Enter": "answer",
}

_EPS = 1e-9


@dataclass(frozen=True)
class ViewerState:
    """What the viewer shows.

    Parameters
    ----------
    depth_px : float
        Disparity in focus, px per view step (larger = nearer).
    plane : int or None
        Index of the detected plane at ``depth_px`` (nearest = 0), None between planes.
    zoom : (x, y, w, h) or None
        Zoom box in view pixels (crop before de-clutter and compression, Fig. 14).
    """

    depth_px: float
    plane: int | None = None
    zoom: tuple[int, int, int, int] | None = None


@dataclass(frozen=True)
class SearchContext:
    """Fixed facts of a trial that the transitions need.

    Parameters
    ----------
    planes_px : tuple of float
        Detected object planes, nearest first (decreasing disparity).
    near_px, far_px : float
        Ends of the depth range the keys can reach (near_px > far_px).
    depth_step_px : float > 0
        Disparity change per depth key.
    shape_px : (rows, cols)
        View size (zoom boxes are clipped to it).
    zoom_allowed : bool
    """

    planes_px: tuple[float, ...]
    near_px: float
    far_px: float
    depth_step_px: float
    shape_px: tuple[int, int]
    zoom_allowed: bool = True

    def plane_at(self, depth_px: float) -> int | None:
        """Return the index of the detected plane at ``depth_px`` (None if none)."""
        for k, p in enumerate(self.planes_px):
            if abs(p - depth_px) <= 1e-6:
                return k
        return None


def _check_box(box, shape_px: tuple[int, int]) -> tuple[int, int, int, int]:
    try:
        x, y, w, h = (int(v) for v in box)
    except (TypeError, ValueError):
        raise ValueError(f"box must be (x, y, w, h), got {box!r}") from None
    rows, cols = shape_px
    if w < 2 or h < 2 or x < 0 or y < 0 or x + w > cols or y + h > rows:
        raise ValueError(f"box {box!r} must be at least 2x2 px inside the {cols}x{rows} view")
    return x, y, w, h


def apply_action(state: ViewerState, action: str, ctx: SearchContext, *, box=None) -> ViewerState:
    """Return the state after one input action (``answer``/``pass`` leave it unchanged).

    Parameters
    ----------
    state : ViewerState
    action : str
        One of :data:`ACTIONS`.
    ctx : SearchContext
    box : (x, y, w, h), optional
        The zoom box (``zoom`` only).

    Raises
    ------
    ValueError
        An unknown action, or a zoom without a valid box.

    Examples
    --------
    >>> ctx = SearchContext((4.0, 1.0), 6.0, 0.5, 0.5, (10, 10))
    >>> s = apply_action(ViewerState(6.0), "plane_next", ctx)
    >>> (s.depth_px, s.plane)
    (4.0, 0)
    >>> apply_action(s, "depth_far", ctx).depth_px
    3.5
    """
    if action not in ACTIONS:
        raise ValueError(f"action must be one of {', '.join(ACTIONS)}, got {action!r}")
    d = state.depth_px
    if action in ("depth_near", "depth_far"):
        step = ctx.depth_step_px if action == "depth_near" else -ctx.depth_step_px
        nd = float(np.clip(d + step, ctx.far_px, ctx.near_px))
        return replace(state, depth_px=nd, plane=ctx.plane_at(nd))
    if action in ("plane_next", "plane_prev"):
        ps = ctx.planes_px
        if not ps:
            return state
        if action == "plane_next":  # farther: the next plane with a smaller disparity
            if state.plane is not None:
                k = min(state.plane + 1, len(ps) - 1)
            else:
                far = [i for i, p in enumerate(ps) if p < d - _EPS]
                k = far[0] if far else len(ps) - 1
        else:
            if state.plane is not None:
                k = max(state.plane - 1, 0)
            else:
                near = [i for i, p in enumerate(ps) if p > d + _EPS]
                k = near[-1] if near else 0
        return replace(state, depth_px=float(ps[k]), plane=k)
    if action == "zoom":
        if not ctx.zoom_allowed:
            return state
        if box is None:
            raise ValueError("zoom needs a box (x, y, w, h)")
        return replace(state, zoom=_check_box(box, ctx.shape_px))
    if action == "unzoom":
        return replace(state, zoom=None)
    return state


@dataclass(frozen=True, eq=False)
class View:
    """What the panes show for one state.

    Attributes
    ----------
    confocal : ndarray (rows, cols), float32 in [0, 1]
        The confocal image at the state's depth.
    source : ndarray (rows, cols), float32 in [0, 1]
        What the implant path starts from: the confocal image (de-cluttered condition) or the
        centre view (cluttered condition).
    edges : ndarray (h, w), bool
        De-cluttered edges of ``source`` (cropped to the zoom box).
    grid : ndarray of shape grid_px, bool
        The implant's view (compressed edges).
    """

    confocal: np.ndarray
    source: np.ndarray
    edges: np.ndarray
    grid: np.ndarray


class Renderer:
    """Compute the panes of a state with the CPU pipeline, caching refocused images by depth.

    Parameters
    ----------
    scene : adapter.Scene
    grid_px : (rows, cols)
    condition : {'decluttered', 'cluttered'}
    """

    def __init__(self, scene: adapter.Scene, grid_px: tuple[int, int], condition: str) -> None:
        if condition not in ("decluttered", "cluttered"):
            raise ValueError(f"condition must be decluttered or cluttered, got {condition!r}")
        self.scene = scene
        self.grid_px = tuple(grid_px)
        self.condition = condition
        self._confocal: dict[float, np.ndarray] = {}
        self._centre = scene.centre_view()

    def confocal(self, depth_px: float) -> np.ndarray:
        """Return the confocal image at a disparity (cached)."""
        key = round(float(depth_px), 9)
        if key not in self._confocal:
            self._confocal[key] = adapter.refocus_image(self.scene, key)
        return self._confocal[key]

    def render(self, state: ViewerState) -> View:
        """Return the panes for ``state``."""
        conf = self.confocal(state.depth_px)
        src = conf if self.condition == "decluttered" else self._centre
        edges, grid = adapter.implant_view(src, self.grid_px, zoom_box_xywh=state.zoom)
        return View(conf, src, edges, grid)
