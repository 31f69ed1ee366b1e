"""The viewer's state machine, shared by ``confocal view`` and active search: pure Python, no GL.

:class:`ViewerState` is everything the screen shows (depth, plane, zoom box, implant, grey
levels, threshold, mode, obstacle range, marker, video frame). :func:`apply_event` maps a state
and one input event (a key name, a wheel step, a dragged box, a click) to the next state; the
renderer (:class:`experiment.viewer.reference.CpuRenderer`) draws a given state, so the whole
interaction is testable without a window, and a log of events replays to the same states.

Active search uses the same state and the same transition function: its input *actions*
(:data:`ACTIONS`, the names its event log records and :mod:`analysis.active` counts) are names
for a subset of the viewer's events (:data:`ACTION_EVENTS`), and :func:`apply_action` applies one
through :func:`apply_event`. A search's :class:`ViewerModel` differs from the viewer's only in
its settings (``plane_tolerance_px``, ``min_zoom_px``, ``zoom_allowed``).

Keys (names as :func:`apply_event` takes them)
-----------------------------------------------
==================  =========================================================================
key                 effect
==================  =========================================================================
up / right, wheel   depth one step nearer (larger disparity); in obstacle mode: the range's
                    far edge
down / left         one step farther
page_up / page_down previous (nearer) / next (farther) detected plane
1 .. 9              jump to detected plane 1 .. 9 (nearest first)
escape              un-zoom (never quits: the window's own exit key is off)
i                   next implant
g                   next grey-level setting (2 = binary de-cluttered edges); nothing on an
                    implant whose layout is on/off only (the window says why)
[ / ]               Sobel threshold down / up by a factor 1.25 (from the automatic value)
a                   automatic (Otsu) threshold
o                   obstacle mode on/off (range: the current depth to the nearest)
e                   confocal-extension mode on/off (focus ``extension_px`` in front of the marker)
- / =               extension distance smaller / larger
v                   temporal averaging of the implant view on/off (video)
n / p               next / previous video frame
m                   implant pane: phosphenes, pulse2percept scoreboard, axon map (the viewer)
? / h               key help drawn over the view on/off
q                   quit (the window asks ``y`` to confirm while a session is logging)
==================  =========================================================================

:data:`KEY_HELP` holds the same table as lines, for the in-window help and ``view --help``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

__all__ = [
    "MODES",
    "GREY_LEVELS",
    "THRESHOLD_FACTOR",
    "KEY_HELP",
    "ACTIONS",
    "ACTION_EVENTS",
    "KEYMAP",
    "ViewerState",
    "ViewerModel",
    "apply_event",
    "apply_action",
    "check_zoom_box",
]

#: Viewer modes (Jung et al. 2015, Sec. 5): free search, obstacle avoidance, confocal extension.
MODES: tuple[str, ...] = ("free", "obstacle", "extension")

#: Grey-level settings the ``g`` key cycles through (ours); 2 = the paper's binary edges.
GREY_LEVELS: tuple[int, ...] = (2, 4, 8)

#: Factor of one threshold key press (ours: about 20 presses span a factor of 100).
THRESHOLD_FACTOR: float = 1.25


#: Key bindings as (keys, effect) lines: the in-window help (``?``/``h``) and ``view --help``.
KEY_HELP: tuple[tuple[str, str], ...] = (
    ("wheel, up/right", "depth one step nearer (obstacle mode: the range's far edge)"),
    ("down/left", "depth one step farther"),
    ("PgUp/PgDn, 1..9", "previous / next detected plane; plane 1..9 (nearest first)"),
    ("drag, Esc", "zoom to a box on the centre view; Esc un-zooms (never quits)"),
    ("click", "mark a point (confocal extension focuses in front of it)"),
    ("i", "next implant"),
    ("g", "grey levels 2 / 4 / 8 (implants with more than on/off levels)"),
    ("[ ]  a", "edge threshold down / up; a: automatic"),
    ("o", "obstacle mode: show only the depth range (alert when something enters)"),
    ("e  - =", "confocal extension on/off; its distance smaller / larger"),
    ("v  n p", "video: averaging on/off; next / previous frame"),
    ("m", "implant pane: phosphenes / pulse2percept scoreboard / axon map"),
    ("? h", "this help on/off"),
    ("q", "quit (then y to confirm while logging)"),
)


#: Active search's input actions and the viewer event each one is (``None``: the state does not
#: change; ``zoom`` is a ``drag`` with the action's box). The active-search event log records
#: these names (``key`` rows' ``action``), which the analysis counts.
ACTION_EVENTS: dict[str, tuple[str, dict[str, Any]] | None] = {
    "depth_near": ("key", {"key": "up"}),
    "depth_far": ("key", {"key": "down"}),
    "plane_next": ("key", {"key": "page_down"}),
    "plane_prev": ("key", {"key": "page_up"}),
    "zoom": ("drag", {}),
    "unzoom": ("key", {"key": "escape"}),
    "answer": None,
    "pass": None,
}

#: Input actions of the active-search task (keys map onto these).
ACTIONS: tuple[str, ...] = tuple(ACTION_EVENTS)

#: Default keys of a person's active search (moderngl-window key names) and the actions they
#: send; a drag sends ``zoom`` with its box. The session logs the key and the action separately,
#: so a display may remap keys without changing what the analysis counts.
KEYMAP: dict[str, str] = {
    "Up": "depth_near",
    "Down": "depth_far",
    "PageUp": "plane_prev",
    "PageDown": "plane_next",
    "Escape": "unzoom",
    "Enter": "answer",
}

#: Disparities closer than this are the same when choosing the next plane (float noise).
_EPS = 1e-9


@dataclass(frozen=True)
class ViewerState:
    """What the viewer shows.

    Attributes
    ----------
    disparity_px : float
        Focused plane, pixels per view step (larger = nearer).
    plane : int or None
        Index into the detected planes (nearest first) when the depth sits on one, else None.
    zoom : (x, y, w, h) or None
        Crop box in view pixels (x = column), applied before de-clutter and compress.
    implant : str
        Name of the implant layout ("" in active search, whose grid is the task's).
    grey_levels : int
        2: binary compression of the de-cluttered edges (paper); more: the confocal image
        compressed to that many grey levels (Fig. 2's grey compression).
    threshold : float or None
        Sobel threshold; None = automatic (Otsu on the confocal image).
    mode : {'free', 'obstacle', 'extension'}
    obstacle_px : (near, far) or None
        Obstacle range as disparities, ``near >= far`` (pixels per view step).
    marker : (x, y) or None
        Marked point in view pixels (confocal extension).
    extension_px : float
        Extension: focus this many px per view step nearer than the marker's depth.
    frame : int
        Video frame index (0 for a still light field).
    averaging : bool
        Temporal averaging of the implant view (video).
    help : bool
        The key help is drawn over the view.
    percept : {'phosphenes', 'scoreboard', 'axonmap'}
        What the implant pane draws: the layout's phosphenes or a pulse2percept model's
        percept (the viewer's ``m`` key; :data:`experiment.viewer.app.PERCEPTS`).
    """

    disparity_px: float
    implant: str = ""
    plane: int | None = None
    zoom: tuple[int, int, int, int] | None = None
    grey_levels: int = 2
    threshold: float | None = None
    mode: Literal["free", "obstacle", "extension"] = "free"
    obstacle_px: tuple[float, float] | None = None
    marker: tuple[int, int] | None = None
    extension_px: float = 0.0
    frame: int = 0
    averaging: bool = False
    help: bool = False
    percept: str = "phosphenes"

    def to_dict(self) -> dict[str, Any]:
        """Return the state as JSON-friendly data (for the event log)."""
        d = asdict(self)
        for k in ("zoom", "obstacle_px", "marker"):
            if d[k] is not None:
                d[k] = list(d[k])
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ViewerState:
        """Inverse of :meth:`to_dict`.

        Also reads the states of logs written before the grey-level count was named
        ``grey_levels`` (they call it ``levels``).
        """
        d = dict(d)
        if "levels" in d and "grey_levels" not in d:
            d["grey_levels"] = d.pop("levels")
        for k in ("zoom", "obstacle_px", "marker"):
            if d.get(k) is not None:
                d[k] = tuple(d[k])
        return cls(**d)


@dataclass(frozen=True)
class ViewerModel:
    """What the state machine needs to know about the data (fixed while the viewer runs).

    Attributes
    ----------
    shape_px : (rows, cols)
        View size.
    disparity_range_px : (low, high)
        Depths the viewer may focus, pixels per view step.
    step_px : float
        One arrow/wheel step, pixels per view step.
    planes_px : tuple of float
        Detected object planes, nearest first.
    implants : tuple of str
        Implant names the ``i`` key cycles through.
    auto_threshold : float
        The automatic threshold at the start (base of the ``[``/``]`` keys).
    n_frames : int
        Video frames (1 for a still).
    implant_grey_levels : tuple of int
        Brightness levels of each implant in ``implants`` (empty: not known, ``g`` always
        cycles); ``g`` does nothing on an implant with 2 (on/off only).
    depth_at : callable (x, y) -> float, optional
        Per-pixel disparity of the view (confocal extension); None: the marker sets no depth.
    plane_tolerance_px : float or None
        A depth within this of a detected plane is on it (None: a tenth of ``step_px``; active
        search: 1e-6, only the plane itself).
    min_zoom_px : int
        Smallest zoom box either way, view pixels (the viewer: 8, enough to de-clutter; active
        search: 2).
    zoom_allowed : bool
        Whether a drag zooms (an active-search task may forbid it).
    """

    shape_px: tuple[int, int]
    disparity_range_px: tuple[float, float]
    step_px: float
    planes_px: tuple[float, ...] = ()
    implants: tuple[str, ...] = ("argus2",)
    auto_threshold: float = 0.1
    n_frames: int = 1
    implant_grey_levels: tuple[int, ...] = ()
    depth_at: Any = field(default=None, compare=False, repr=False)
    plane_tolerance_px: float | None = None
    min_zoom_px: int = 8
    zoom_allowed: bool = True

    def clamp(self, d: float) -> float:
        """Clamp a disparity to the range."""
        lo, hi = self.disparity_range_px
        return float(min(hi, max(lo, d)))

    @property
    def near_px(self) -> float:
        """The nearest disparity the keys reach (the range's high end)."""
        return float(self.disparity_range_px[1])

    @property
    def far_px(self) -> float:
        """The farthest disparity the keys reach (the range's low end)."""
        return float(self.disparity_range_px[0])

    def plane_of(self, d: float) -> int | None:
        """Index of the detected plane at disparity ``d`` (within the tolerance), or None."""
        tol = 0.1 * self.step_px if self.plane_tolerance_px is None else self.plane_tolerance_px
        for k, p in enumerate(self.planes_px):
            if abs(p - d) <= tol:
                return k
        return None

    def is_binary(self, implant: str) -> bool:
        """Whether ``implant`` shows on/off phosphenes only (its layout has 2 levels)."""
        levels = self.implant_grey_levels
        if implant not in self.implants or len(levels) != len(self.implants):
            return False
        return levels[self.implants.index(implant)] <= 2

    def initial_state(self, implant: str | None = None) -> ViewerState:
        """Return the first state: the nearest detected plane (or the middle of the range)."""
        lo, hi = self.disparity_range_px
        d = self.planes_px[0] if self.planes_px else 0.5 * (lo + hi)
        return ViewerState(
            disparity_px=float(d),
            implant=implant or self.implants[0],
            plane=0 if self.planes_px else None,
        )


def _with_depth(model: ViewerModel, s: ViewerState, d: float) -> ViewerState:
    d = model.clamp(d)
    return replace(s, disparity_px=d, plane=model.plane_of(d))


def check_zoom_box(model: ViewerModel, box: Any) -> tuple[int, int, int, int]:
    """Return a zoom box ``(x, y, w, h)`` that lies inside the view, or raise.

    Parameters
    ----------
    model : ViewerModel
    box : sequence of 4 int
        ``x, y, w, h`` in view pixels.

    Raises
    ------
    ValueError
        Not 4 integers, or not at least ``model.min_zoom_px`` either way inside the view.
    """
    try:
        x, y, w, h = (int(v) for v in box)
    except (TypeError, ValueError):
        raise ValueError(f"box must be (x, y, w, h), got {box!r}") from None
    rows, cols = model.shape_px
    n = model.min_zoom_px
    if w < n or h < n or x < 0 or y < 0 or x + w > cols or y + h > rows:
        raise ValueError(f"box {box!r} must be at least {n}x{n} px inside the {cols}x{rows} view")
    return x, y, w, h


def _check_box(model: ViewerModel, box: Any) -> tuple[int, int, int, int] | None:
    try:
        x, y, w, h = (int(round(float(v))) for v in box)
    except (TypeError, ValueError):
        return None
    if w < 0:
        x, w = x + w, -w
    if h < 0:
        y, h = y + h, -h
    rows, cols = model.shape_px
    x0, y0 = max(0, x), max(0, y)
    x1, y1 = min(cols, x + w), min(rows, y + h)
    if x1 - x0 < model.min_zoom_px or y1 - y0 < model.min_zoom_px:  # too small: ignored
        return None
    return (x0, y0, x1 - x0, y1 - y0)


def apply_event(
    model: ViewerModel, state: ViewerState, kind: str, payload: dict[str, Any]
) -> ViewerState:
    """Return the state after one input event (pure; unknown events leave the state as is).

    Parameters
    ----------
    model : ViewerModel
    state : ViewerState
    kind : {'key', 'wheel', 'drag', 'click', 'frame'}
        ``key``: ``payload["key"]`` a name from the module table; ``wheel``: ``payload["dy"]``
        steps (positive = nearer); ``drag``: ``payload["box"] = [x, y, w, h]`` in view pixels;
        ``click``: ``payload["x"], payload["y"]`` in view pixels (sets the marker);
        ``frame``: ``payload["frame"]`` video frame.

    Returns
    -------
    ViewerState
    """
    s = state
    if kind == "wheel":
        n = float(payload.get("dy", 0))
        if s.mode == "obstacle" and s.obstacle_px is not None:
            near, far = s.obstacle_px
            far = min(near, model.clamp(far + n * model.step_px))
            return replace(s, obstacle_px=(near, far))
        return _with_depth(model, s, s.disparity_px + n * model.step_px)
    if kind == "drag":
        if not model.zoom_allowed:
            return s
        box = _check_box(model, payload.get("box"))
        return s if box is None else replace(s, zoom=box)
    if kind == "click":
        rows, cols = model.shape_px
        x, y = int(payload.get("x", -1)), int(payload.get("y", -1))
        if not (0 <= x < cols and 0 <= y < rows):
            return s
        s = replace(s, marker=(x, y))
        if s.mode == "extension" and model.depth_at is not None:
            return _with_depth(model, s, float(model.depth_at(x, y)) + s.extension_px)
        return s
    if kind == "frame":
        f = int(payload.get("frame", 0))
        return replace(s, frame=max(0, min(model.n_frames - 1, f)))
    if kind != "key":
        return s
    key = str(payload.get("key", ""))
    if key in ("up", "right"):
        return apply_event(model, s, "wheel", {"dy": 1})
    if key in ("down", "left"):
        return apply_event(model, s, "wheel", {"dy": -1})
    planes = model.planes_px
    if key in ("page_up", "page_down") and planes:
        if s.plane is not None:
            k = s.plane + (1 if key == "page_down" else -1)
        elif key == "page_down":  # the first plane farther than the current depth
            d = s.disparity_px - _EPS
            k = next((i for i, p in enumerate(planes) if p < d), len(planes) - 1)
        else:
            k = max((i for i, p in enumerate(planes) if p > s.disparity_px + _EPS), default=0)
        k = max(0, min(len(planes) - 1, k))
        return replace(s, disparity_px=float(planes[k]), plane=k)
    if len(key) == 1 and key.isdigit() and key != "0":
        k = int(key) - 1
        if k < len(planes):
            return replace(s, disparity_px=float(planes[k]), plane=k)
        return s
    if key == "escape":
        return replace(s, zoom=None)
    if key == "i":
        names = model.implants
        k = (names.index(s.implant) + 1) % len(names) if s.implant in names else 0
        return replace(s, implant=names[k])
    if key == "g":
        if model.is_binary(s.implant):
            return s
        g = s.grey_levels
        k = (GREY_LEVELS.index(g) + 1) % len(GREY_LEVELS) if g in GREY_LEVELS else 0
        return replace(s, grey_levels=GREY_LEVELS[k])
    if key in ("[", "]"):
        t = s.threshold if s.threshold is not None else model.auto_threshold
        t = t * (THRESHOLD_FACTOR if key == "]" else 1.0 / THRESHOLD_FACTOR)
        return replace(s, threshold=float(max(t, 1e-4)))
    if key == "a":
        return replace(s, threshold=None)
    if key == "o":
        if s.mode == "obstacle":
            return replace(s, mode="free")
        rng = s.obstacle_px or (model.disparity_range_px[1], s.disparity_px)
        return replace(s, mode="obstacle", obstacle_px=rng)
    if key == "e":
        return replace(s, mode="free" if s.mode == "extension" else "extension")
    if key in ("-", "="):
        delta = model.step_px * (1 if key == "=" else -1)
        s = replace(s, extension_px=s.extension_px + delta)
        if s.mode == "extension" and s.marker is not None and model.depth_at is not None:
            return _with_depth(model, s, float(model.depth_at(*s.marker)) + s.extension_px)
        return s
    if key == "v":
        return replace(s, averaging=not s.averaging)
    if key in ("?", "h"):
        return replace(s, help=not s.help)
    if key in ("n", "p"):
        f = s.frame + (1 if key == "n" else -1)
        return replace(s, frame=max(0, min(model.n_frames - 1, f)))
    return s


def apply_action(
    model: ViewerModel, state: ViewerState, action: str, *, box: Any = None
) -> ViewerState:
    """Return the state after one active-search action (its viewer event, :func:`apply_event`).

    Parameters
    ----------
    model : ViewerModel
    state : ViewerState
    action : str
        One of :data:`ACTIONS` (``answer`` and ``pass`` leave the state as is).
    box : (x, y, w, h), optional
        The zoom box (``zoom`` only), checked by :func:`check_zoom_box`.

    Raises
    ------
    ValueError
        An unknown action, or a zoom without a valid box (where zoom is allowed).

    Examples
    --------
    >>> m = ViewerModel((10, 10), (0.5, 6.0), 0.5, planes_px=(4.0, 1.0), plane_tolerance_px=1e-6)
    >>> s = apply_action(m, ViewerState(6.0), "plane_next")
    >>> (s.disparity_px, s.plane)
    (4.0, 0)
    >>> apply_action(m, s, "depth_far").disparity_px
    3.5
    """
    if action not in ACTION_EVENTS:
        raise ValueError(f"action must be one of {', '.join(ACTIONS)}, got {action!r}")
    if action == "zoom":
        if not model.zoom_allowed:
            return state
        if box is None:
            raise ValueError("zoom needs a box (x, y, w, h)")
        return apply_event(model, state, "drag", {"box": list(check_zoom_box(model, box))})
    event = ACTION_EVENTS[action]
    return state if event is None else apply_event(model, state, event[0], dict(event[1]))
