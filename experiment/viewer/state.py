"""The viewer's state machine: pure Python, no GL.

:class:`ViewerState` is everything the screen shows (depth, plane, zoom box, implant, levels,
threshold, mode, obstacle range, marker, video frame). :func:`apply_event` maps a state and one
input event (a key name, a wheel step, a dragged box, a click) to the next state; the renderer
draws a given state, so the whole interaction is testable without a window, and a log of events
replays to the same states.

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
    "ViewerState",
    "ViewerModel",
    "apply_event",
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
        Name of the implant layout.
    levels : int
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
    implant: str
    plane: int | None = None
    zoom: tuple[int, int, int, int] | None = None
    levels: int = 2
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
        """Inverse of :meth:`to_dict`."""
        d = dict(d)
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
    implant_levels : tuple of int
        Brightness levels of each implant in ``implants`` (empty: not known, ``g`` always
        cycles); ``g`` does nothing on an implant with 2 (on/off only).
    """

    shape_px: tuple[int, int]
    disparity_range_px: tuple[float, float]
    step_px: float
    planes_px: tuple[float, ...] = ()
    implants: tuple[str, ...] = ("argus2",)
    auto_threshold: float = 0.1
    n_frames: int = 1
    implant_levels: tuple[int, ...] = ()
    depth_at: Any = field(default=None, compare=False, repr=False)

    def clamp(self, d: float) -> float:
        """Clamp a disparity to the range."""
        lo, hi = self.disparity_range_px
        return float(min(hi, max(lo, d)))

    def plane_of(self, d: float) -> int | None:
        """Index of the detected plane at disparity ``d`` (within a tenth of a step), or None."""
        for k, p in enumerate(self.planes_px):
            if abs(p - d) <= 0.1 * self.step_px:
                return k
        return None

    def is_binary(self, implant: str) -> bool:
        """Whether ``implant`` shows on/off phosphenes only (its layout has 2 levels)."""
        if implant not in self.implants or len(self.implant_levels) != len(self.implants):
            return False
        return self.implant_levels[self.implants.index(implant)] <= 2

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
    if x1 - x0 < 8 or y1 - y0 < 8:  # too small to de-clutter: ignore the drag (ours)
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
            k = next((i for i, p in enumerate(planes) if p < s.disparity_px), len(planes) - 1)
        else:
            k = max((i for i, p in enumerate(planes) if p > s.disparity_px), default=0)
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
        k = (GREY_LEVELS.index(s.levels) + 1) % len(GREY_LEVELS) if s.levels in GREY_LEVELS else 0
        return replace(s, levels=GREY_LEVELS[k])
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
