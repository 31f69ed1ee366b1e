"""The subject's screen: moderngl presenter with physical geometry, exact magnification, timing.

This is the only module that imports :mod:`moderngl` (house style H13); it is imported lazily by
the console and the presenter process, never as a side effect of ``import experiment``.

What is drawn
-------------
The border frame and the background are plain clears; one fragment shader, scissored to the
image (or text) rectangle, draws every pixel inside it:

- *stimulus*: the stimulus fills a rectangle of the protocol's physical size (cm, converted with the
  monitor's pixels per cm), centred; everything around it has the border colour (Jung et al. 2015,
  Sec. 3.1: a blue border). Each screen pixel takes the value of exactly one stimulus cell, chosen
  with integer arithmetic (``cell = ((2 x + 1) n) // (2 w)``: nearest neighbour at the pixel
  centre), so cells are crisp, uniform blocks whose sizes differ by at most one pixel (none when
  the scale is an integer). No texture filtering is involved.
- *blank* (between trials): the image area in the stimulus's "0" colour, the border around it,
  an optional fixation cross in the centre.
- *text* (instructions, pause, end): white text on black, rendered with Pillow into a texture.
- optional *phosphene view* (beyond the paper): every cell drawn as a Gaussian or disc phosphene
  at the cell centre, with a set size and a fraction of dropped-out (dead) phosphenes.

Gamma correction (protocol's ``gamma``) is applied in the shader to stimulus luminance only:
stimulus values are fractions of maximum luminance, sent to the screen as ``v ** (1 / gamma)``.
Colours (border, text, fixation) are device RGB values as written in the protocol (``0, 0, 255``
is the paper's blue whatever the gamma). For binary stimuli gamma changes nothing (0 and 1 are
fixed points).

Timing
------
Every flip is followed by ``glFinish`` and a time stamp from the injected clock (H17), as
PsychoPy does. In a window with vsync, flips are locked to the refresh; :meth:`Presenter.pump`
redraws and flips once per refresh while a stimulus is up, so the offset record carries every
frame interval and the number of dropped frames (intervals over 1.5 refresh periods). The refresh
rate is measured at start (:meth:`Presenter.measure_refresh`) and a failed timing self-test refuses
to start unless skipped (H12). Offscreen (EGL) there is no refresh: flips are ``glFinish`` only and
``refresh_hz`` is None.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import moderngl
import numpy as np

from experiment.clock import Clock, PerfCounterClock
from experiment.errors import ConfocalError
from experiment.interfaces import FlipRecord

__all__ = [
    "PAPER_SCREEN_SHAPE_PX",
    "PAPER_VIEWING_DISTANCE_CM",
    "PAPER_IMAGE_SIZE_CM",
    "PAPER_SCREEN_WIDTH_CM",
    "PAPER_BORDER_RGB",
    "INPUT_KEYS",
    "ScreenGeometry",
    "PhospheneSpec",
    "PresenterError",
    "TimingCheckFailed",
    "Presenter",
    "stimulus_rect_px",
    "cell_index",
    "expected_frame",
    "count_dropped",
]

logger = logging.getLogger(__name__)

#: Subject's screen (rows, cols), px. Source: Jung et al. 2015, Sec. 3.1 (21" CRT, 1280x1024).
PAPER_SCREEN_SHAPE_PX: tuple[int, int] = (1024, 1280)
#: Viewing distance, cm. Source: Jung et al. 2015, Sec. 3.1 ("80 cm").
PAPER_VIEWING_DISTANCE_CM: float = 80.0
#: Displayed image size (height, width) in cm. Source: Jung et al. 2015, Sec. 3.1
#: ("14.6 x 9.7 cm", i.e. 10.4 x 6.9 deg at 80 cm).
PAPER_IMAGE_SIZE_CM: tuple[float, float] = (9.7, 14.6)
#: Visible width of the CRT, cm. Ours, not the paper's: the paper gives no width; this value makes
#: its 492 x 327 px working image exactly 14.6 x 9.7 cm (492 px / 14.6 cm = 33.7 px/cm, and
#: 1280 px / 33.7 px/cm = 37.98 cm), which is what a 21" CRT's visible width is.
PAPER_SCREEN_WIDTH_CM: float = 1280 * 14.6 / 492
#: Border colour around the image, device RGB 0-255. Source: Jung et al. 2015, Sec. 3.1 ("blue").
PAPER_BORDER_RGB: tuple[int, int, int] = (0, 0, 255)

#: Fixation cross arm length (half-width), degrees; ours, not the paper's (a small cross).
FIXATION_HALF_DEG: float = 0.25
#: Fixation cross line thickness, px; ours.
FIXATION_THICKNESS_PX: int = 3
#: A frame interval above this many refresh periods counts as a dropped frame (PsychoPy's rule).
DROPPED_FRAME_FACTOR: float = 1.5

#: Keys of the subject's window reported as input when input is on
#: (:meth:`Presenter.enable_input`): moderngl-window key name -> the name sent to the console
#: (the names of :data:`experiment.active.engine.KEYMAP`). The wheel is reported as
#: ``WheelUp``/``WheelDown`` and a mouse drag as ``drag`` with its box.
INPUT_KEYS: dict[str, str] = {
    "UP": "Up",
    "DOWN": "Down",
    "PAGE_UP": "PageUp",
    "PAGE_DOWN": "PageDown",
    "ESCAPE": "Escape",
    "ENTER": "Enter",
}


class PresenterError(ConfocalError):
    """The presenter cannot open or draw (no OpenGL context, wrong screen mode, closed window)."""


class TimingCheckFailed(PresenterError):
    """The frame-timing self-test failed (no vsync or irregular flips); see skip_timing_check."""


def _check_rgb(name: str, rgb: Any) -> tuple[int, int, int]:
    try:
        vals = tuple(int(v) for v in rgb)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be three integers 0-255, got {rgb!r}") from None
    if len(vals) != 3 or any(not 0 <= v <= 255 for v in vals):
        raise ValueError(f"{name} must be three integers 0-255, got {rgb!r}")
    return vals  # type: ignore[return-value]


@dataclass(frozen=True)
class ScreenGeometry:
    """Physical geometry and colours of the subject's screen.

    Parameters
    ----------
    screen_shape_px : (rows, cols)
        Resolution of the subject's screen, pixels.
    screen_width_cm : float
        Visible width of the screen, cm (square pixels assumed).
    viewing_distance_cm : float
        Eye-to-screen distance, cm.
    image_size_cm : (height_cm, width_cm)
        Size at which every stimulus is drawn, cm.
    border_rgb : (r, g, b)
        Colour of the frame around the image, device RGB 0-255.
    border_width_px : int or None
        Width of that frame, px; None fills the whole surround with the border colour.
    background_rgb : (r, g, b)
        Colour of the screen beyond the frame, device RGB 0-255.
    gamma : float
        Display gamma; stimulus luminance ``v`` is output as ``v ** (1 / gamma)``.
    stimulus_on_rgb, stimulus_off_rgb : (r, g, b)
        Device colours of stimulus value 1 and 0 (white and black).
    fixation : bool
        Whether the blank screen between trials shows a fixation cross.
    """

    screen_shape_px: tuple[int, int]
    screen_width_cm: float
    viewing_distance_cm: float
    image_size_cm: tuple[float, float]
    border_rgb: tuple[int, int, int] = PAPER_BORDER_RGB
    border_width_px: int | None = None
    background_rgb: tuple[int, int, int] = (0, 0, 0)
    gamma: float = 1.0
    stimulus_on_rgb: tuple[int, int, int] = (255, 255, 255)
    stimulus_off_rgb: tuple[int, int, int] = (0, 0, 0)
    fixation: bool = True

    def __post_init__(self) -> None:
        shape = tuple(int(v) for v in self.screen_shape_px)
        if len(shape) != 2 or min(shape) < 1:
            raise ValueError(
                f"screen_shape_px must be (rows, cols) > 0, got {self.screen_shape_px!r}"
            )
        object.__setattr__(self, "screen_shape_px", shape)
        size = tuple(float(v) for v in self.image_size_cm)
        if len(size) != 2 or min(size) <= 0:
            raise ValueError(
                f"image_size_cm must be (height_cm, width_cm) > 0, got {self.image_size_cm!r}"
            )
        object.__setattr__(self, "image_size_cm", size)
        for name in ("screen_width_cm", "viewing_distance_cm", "gamma"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if self.border_width_px is not None and not (
            isinstance(self.border_width_px, int) and self.border_width_px >= 0
        ):
            raise ValueError(
                f"border_width_px must be an int >= 0 or None, got {self.border_width_px!r}"
            )
        for name in ("border_rgb", "background_rgb", "stimulus_on_rgb", "stimulus_off_rgb"):
            object.__setattr__(self, name, _check_rgb(name, getattr(self, name)))

    @classmethod
    def jung2015(cls, **overrides: Any) -> ScreenGeometry:
        """Return the paper's geometry (1280x1024, 80 cm, 14.6 x 9.7 cm image, blue border)."""
        kw: dict[str, Any] = dict(
            screen_shape_px=PAPER_SCREEN_SHAPE_PX,
            screen_width_cm=PAPER_SCREEN_WIDTH_CM,
            viewing_distance_cm=PAPER_VIEWING_DISTANCE_CM,
            image_size_cm=PAPER_IMAGE_SIZE_CM,
            border_rgb=PAPER_BORDER_RGB,
        )
        kw.update(overrides)
        return cls(**kw)

    @classmethod
    def from_display_spec(cls, spec: Any) -> ScreenGeometry:
        """Build the geometry from a protocol's display spec (``experiment.protocol.DisplaySpec``).

        Accepts any object or mapping with the spec's field names; see :func:`_spec_fields`.
        """
        return cls(**_spec_fields(spec))

    @property
    def px_per_cm(self) -> float:
        """Pixels per cm on the screen (horizontal, square pixels)."""
        return self.screen_shape_px[1] / self.screen_width_cm

    @property
    def px_per_deg(self) -> float:
        """Pixels per degree of visual angle at the screen centre."""
        return 2.0 * self.viewing_distance_cm * math.tan(math.radians(0.5)) * self.px_per_cm

    @property
    def image_size_deg(self) -> tuple[float, float]:
        """Visual angle (height_deg, width_deg) of the image at the viewing distance."""
        return tuple(  # type: ignore[return-value]
            math.degrees(2 * math.atan(s / (2 * self.viewing_distance_cm)))
            for s in self.image_size_cm
        )

    @property
    def image_shape_px(self) -> tuple[int, int]:
        """Image size on screen (rows, cols), pixels: the cm size times px/cm, rounded."""
        return tuple(  # type: ignore[return-value]
            max(1, int(round(s * self.px_per_cm))) for s in self.image_size_cm
        )

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-serialisable dict (inverse of :meth:`from_dict`)."""
        d = asdict(self)
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ScreenGeometry:
        """Build from :meth:`to_dict` output."""
        return cls(**d)


def _spec_fields(spec: Any) -> dict[str, Any]:
    """Map a display spec (object or mapping) onto :class:`ScreenGeometry` keyword arguments.

    Understands either our own field names or the common alternatives
    (``resolution_px``/``screen_px`` as ``(cols, rows)`` or ``(rows, cols)`` with explicit names,
    ``monitor_width_cm``, ``image_width_cm``/``image_height_cm``, ``border_colour``...).
    """

    def get(*names: str, default: Any = None) -> Any:
        for n in names:
            if isinstance(spec, dict) and n in spec:
                return spec[n]
            if not isinstance(spec, dict) and hasattr(spec, n):
                return getattr(spec, n)
        return default

    out: dict[str, Any] = {}
    shape = get("screen_shape_px", "resolution_shape_px")
    if shape is None:
        rows = get("screen_rows_px", "screen_height_px", "resolution_rows_px")
        cols = get("screen_cols_px", "screen_width_px", "resolution_cols_px")
        if rows is not None and cols is not None:
            shape = (rows, cols)
    if shape is None:
        raise ValueError(f"display spec has no screen resolution: {spec!r}")
    out["screen_shape_px"] = tuple(shape)
    out["screen_width_cm"] = get("screen_width_cm", "monitor_width_cm")
    out["viewing_distance_cm"] = get("viewing_distance_cm", "distance_cm")
    size = get("image_size_cm")
    if size is None:
        size = (get("image_height_cm"), get("image_width_cm"))
    out["image_size_cm"] = tuple(size)
    for ours, names in {
        "border_rgb": ("border_rgb", "border_colour_rgb", "border_color_rgb", "border_colour"),
        "gamma": ("gamma",),
        "border_width_px": ("border_width_px",),
        "background_rgb": ("background_rgb",),
        "stimulus_on_rgb": ("stimulus_on_rgb",),
        "stimulus_off_rgb": ("stimulus_off_rgb",),
        "fixation": ("fixation",),
    }.items():
        v = get(*names)
        if v is not None:
            out[ours] = v
    if isinstance(out.get("border_rgb"), str):
        out["border_rgb"] = _named_colour(out["border_rgb"])
    return out


_NAMED = {
    "blue": (0, 0, 255),
    "black": (0, 0, 0),
    "white": (255, 255, 255),
    "grey": (128, 128, 128),
    "gray": (128, 128, 128),
    "red": (255, 0, 0),
    "green": (0, 255, 0),
}


def _named_colour(name: str) -> tuple[int, int, int]:
    s = name.strip().lower()
    if s in _NAMED:
        return _NAMED[s]
    if s.startswith("#") and len(s) == 7:
        return tuple(int(s[i : i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]
    raise ValueError(f"border colour must be a name ({', '.join(_NAMED)}) or #rrggbb, got {name!r}")


@dataclass(frozen=True)
class PhospheneSpec:
    """Phosphene view: each stimulus cell drawn as a phosphene (beyond the paper).

    Parameters
    ----------
    kind : {'gaussian', 'disc'}
    size : float
        Phosphene diameter as a fraction of the spacing (disc: diameter; gaussian: FWHM), > 0.
    dropout : float
        Fraction of phosphenes that never light, in [0, 1).
    spacing_deg : float or None
        Centre-to-centre spacing, degrees; None keeps the protocol's image size
        (spacing = cell pitch).
    seed : int
        Seed of the dropout pattern (fixed per session so the same phosphenes are dead throughout).
    """

    kind: Literal["gaussian", "disc"] = "gaussian"
    size: float = 0.8
    dropout: float = 0.0
    spacing_deg: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in ("gaussian", "disc"):
            raise ValueError(f"kind must be 'gaussian' or 'disc', got {self.kind!r}")
        if not self.size > 0:
            raise ValueError(f"size must be > 0, got {self.size!r}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout!r}")
        if self.spacing_deg is not None and not self.spacing_deg > 0:
            raise ValueError(f"spacing_deg must be > 0 or None, got {self.spacing_deg!r}")

    def alive_mask(self, shape_px: tuple[int, int]) -> np.ndarray:
        """Return the bool (rows, cols) mask of phosphenes that light (dropout from ``seed``)."""
        rng = np.random.default_rng(self.seed)
        return rng.random(shape_px) >= self.dropout


def stimulus_rect_px(
    geometry: ScreenGeometry,
    stimulus_shape_px: tuple[int, int],
    *,
    integer_scale: bool = False,
    phosphenes: PhospheneSpec | None = None,
) -> tuple[int, int, int, int]:
    """Return where a stimulus is drawn: ``(top, left, rows, cols)``, screen px from the top-left.

    Parameters
    ----------
    geometry : ScreenGeometry
    stimulus_shape_px : (rows, cols)
        The stimulus's native resolution (cells).
    integer_scale : bool
        Round the magnification to the nearest integer (>= 1) so that every cell is the same size;
        the physical size then differs from the protocol's by less than half a cell.
    phosphenes : PhospheneSpec or None
        With ``spacing_deg`` set, the size is ``cells x spacing`` instead of the protocol's.

    Returns
    -------
    (top, left, rows, cols) : ints
        The image is centred; ``rows, cols`` are the protocol's size in pixels, rounded.
    """
    n_rows, n_cols = (int(v) for v in stimulus_shape_px)
    if n_rows < 1 or n_cols < 1:
        raise ValueError(f"stimulus_shape_px must be (rows, cols) > 0, got {stimulus_shape_px!r}")
    if phosphenes is not None and phosphenes.spacing_deg is not None:
        pitch = phosphenes.spacing_deg * geometry.px_per_deg
        rows, cols = int(round(n_rows * pitch)), int(round(n_cols * pitch))
    else:
        rows, cols = geometry.image_shape_px
    if integer_scale:
        k = max(1, int(round(cols / n_cols)))
        rows, cols = n_rows * k, n_cols * k
    screen_rows, screen_cols = geometry.screen_shape_px
    if rows > screen_rows or cols > screen_cols:
        raise PresenterError(
            f"image of {cols}x{rows} px does not fit the {screen_cols}x{screen_rows} px screen; "
            "check screen_width_cm and image_size_cm"
        )
    return (screen_rows - rows) // 2, (screen_cols - cols) // 2, rows, cols


def cell_index(pixel: np.ndarray, n_cells: int, extent_px: int) -> np.ndarray:
    """Return the stimulus cell under each screen pixel (nearest neighbour at the pixel centre).

    ``cell = floor((pixel + 0.5) * n_cells / extent_px)``, computed exactly in integers as the
    shader does. ``pixel`` counts from the image's first row or column.
    """
    pixel = np.asarray(pixel, dtype=np.int64)
    return ((2 * pixel + 1) * n_cells) // (2 * extent_px)


def expected_frame(
    geometry: ScreenGeometry, image: np.ndarray, *, integer_scale: bool = False
) -> np.ndarray:
    """Return the (rows, cols, 3) uint8 frame the presenter should draw for a stimulus.

    A reference written with numpy only (no GL), for tests and for ``--screenshot`` checks. Grey
    values are gamma-corrected and rounded like an 8-bit framebuffer (round to nearest); a colour
    photo (rows, cols, 3) is drawn as it is, each channel gamma-corrected.
    """
    img = _as_stimulus(image)
    top, left, rows, cols = stimulus_rect_px(geometry, img.shape[:2], integer_scale=integer_scale)
    frame = np.empty((*geometry.screen_shape_px, 3), dtype=np.uint8)
    b = geometry.border_width_px
    if b is None:
        frame[:] = geometry.border_rgb
    else:
        frame[:] = geometry.background_rgb
        frame[max(0, top - b) : top + rows + b, max(0, left - b) : left + cols + b] = (
            geometry.border_rgb
        )
    r = cell_index(np.arange(rows), img.shape[0], rows)
    c = cell_index(np.arange(cols), img.shape[1], cols)
    v = img[np.ix_(r, c)].astype(np.float64) ** (1.0 / geometry.gamma)
    if img.ndim == 3:
        rgb = v
    else:
        fg = np.asarray(geometry.stimulus_on_rgb, np.float64) / 255
        bg = np.asarray(geometry.stimulus_off_rgb, np.float64) / 255
        rgb = bg + (fg - bg) * v[..., None]
    frame[top : top + rows, left : left + cols] = np.round(rgb * 255).astype(np.uint8)
    return frame


def _as_stimulus(image: np.ndarray) -> np.ndarray:
    """Check a stimulus (H6) and return it as float32 (rows, cols) or (rows, cols, 3) in [0, 1]."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.float32:
        pass  # a colour training photo
    elif image.ndim != 2:
        raise ValueError(
            f"image must be 2-D (rows, cols) or a float32 colour photo (rows, cols, 3), "
            f"got shape {image.shape}"
        )
    if image.dtype == np.bool_:
        return image.astype(np.float32)
    if image.dtype != np.float32:
        raise TypeError(f"image must be bool or float32, got dtype {image.dtype}")
    if image.size and not (np.isfinite(image).all() and image.min() >= 0 and image.max() <= 1):
        raise ValueError(
            f"image values must be in [0, 1], got [{float(image.min())}, {float(image.max())}]"
        )
    return image


_VERTEX = """
#version 330
void main() {
    vec2 p = vec2((gl_VertexID == 1) ? 3.0 : -1.0, (gl_VertexID == 2) ? 3.0 : -1.0);
    gl_Position = vec4(p, 0.0, 1.0);
}
"""

# Integer pixel coordinates with the origin at the top-left, so that rows match numpy's.
_FRAGMENT = """
#version 330
uniform int u_mode;          // 0 stimulus, 1 blank (+fixation), 2 text
uniform ivec2 u_screen;      // (cols, rows)
uniform ivec4 u_rect;        // (left, top, cols, rows)
uniform ivec2 u_grid;        // stimulus (cols, rows)
uniform vec3 u_border;
uniform int u_border_px;     // frame width, -1 = the whole surround
uniform vec3 u_background;
uniform vec3 u_fg;
uniform vec3 u_bg;
uniform float u_inv_gamma;
uniform int u_fixation;      // half-length of the cross arms in px, 0 = none
uniform int u_fix_thick;
uniform vec3 u_fix_rgb;
uniform int u_phos;          // 0 off, 1 gaussian, 2 disc
uniform float u_phos_size;   // diameter (disc) or FWHM (gaussian) as a fraction of the pitch
uniform ivec4 u_text_rect;   // (left, top, cols, rows)
uniform sampler2D u_stim;    // R32F (RGB32F for colour), row 0 = top row of the stimulus
uniform int u_colour;        // 1: u_stim is a colour photo, drawn as it is
uniform sampler2D u_text;    // R8 coverage, row 0 = top
out vec4 f_color;

vec3 lum_to_rgb(float v) {
    return mix(u_bg, u_fg, pow(clamp(v, 0.0, 1.0), u_inv_gamma));
}

float phosphene(ivec2 p) {
    // p: pixel inside the image rect. Sum of the 3x3 neighbouring phosphenes' profiles.
    vec2 pitch = vec2(u_rect.zw) / vec2(u_grid);
    vec2 pos = vec2(p) + 0.5;
    ivec2 c0 = ivec2(floor(pos / pitch));
    float d_size = u_phos_size * min(pitch.x, pitch.y);
    float sigma = d_size / 2.3548;
    float total = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 c = c0 + ivec2(dx, dy);
            if (c.x < 0 || c.y < 0 || c.x >= u_grid.x || c.y >= u_grid.y) continue;
            float v = texelFetch(u_stim, c, 0).r;
            vec2 d = pos - (vec2(c) + 0.5) * pitch;
            float r2 = dot(d, d);
            if (u_phos == 1) total += v * exp(-r2 / (2.0 * sigma * sigma));
            else if (r2 <= 0.25 * d_size * d_size) total += v;
        }
    }
    return min(total, 1.0);
}

void main() {
    ivec2 q = ivec2(gl_FragCoord.xy);
    ivec2 pix = ivec2(q.x, u_screen.y - 1 - q.y);   // (col, row) from the top-left
    if (u_mode == 2) {
        vec3 c = vec3(0.0);
        ivec2 t = pix - u_text_rect.xy;
        if (t.x >= 0 && t.y >= 0 && t.x < u_text_rect.z && t.y < u_text_rect.w) {
            c = vec3(texelFetch(u_text, t, 0).r);
        }
        f_color = vec4(c, 1.0);
        return;
    }
    ivec2 p = pix - u_rect.xy;
    if (p.x < 0 || p.y < 0 || p.x >= u_rect.z || p.y >= u_rect.w) {
        ivec2 out_by = max(max(-p, p - u_rect.zw + 1), ivec2(0));
        bool in_frame = u_border_px < 0 || max(out_by.x, out_by.y) <= u_border_px;
        f_color = vec4(in_frame ? u_border : u_background, 1.0);
        return;
    }
    if (u_mode == 1) {
        vec3 c = u_bg;
        ivec2 d = abs(pix - u_screen / 2);
        int h = u_fix_thick / 2;
        if (u_fixation > 0 && ((d.x <= u_fixation && d.y <= h) || (d.y <= u_fixation && d.x <= h)))
            c = u_fix_rgb;
        f_color = vec4(c, 1.0);
        return;
    }
    if (u_colour == 1) {
        ivec2 cell = ((2 * p + 1) * u_grid) / (2 * u_rect.zw);
        vec3 c = clamp(texelFetch(u_stim, cell, 0).rgb, 0.0, 1.0);
        f_color = vec4(pow(c, vec3(u_inv_gamma)), 1.0);
        return;
    }
    float v;
    if (u_phos > 0) {
        v = phosphene(p);
    } else {
        ivec2 cell = ((2 * p + 1) * u_grid) / (2 * u_rect.zw);
        v = texelFetch(u_stim, cell, 0).r;
    }
    f_color = vec4(lum_to_rgb(v), 1.0);
}
"""


@dataclass
class _StimulusTiming:
    onset_s: float
    last_flip_s: float
    intervals_ms: list[float] = field(default_factory=list)


class Presenter:
    """The subject's screen drawn with moderngl; implements :class:`experiment.interfaces.Display`.

    Use :meth:`offscreen` (EGL, no window; the test twin and ``--screenshot``) or :meth:`windowed`
    (a moderngl-window/pyglet window on a chosen screen).

    Parameters
    ----------
    ctx : moderngl.Context
    geometry : ScreenGeometry
    clock : Clock
        Time stamps of flips (H17).
    window : moderngl_window BaseWindow or None
        The window whose buffers are swapped; None draws into an offscreen framebuffer.
    integer_scale : bool
        Round the magnification to an integer (equal-size cells); see :func:`stimulus_rect_px`.
    phosphenes : PhospheneSpec or None
        Draw cells as phosphenes.
    """

    def __init__(
        self,
        ctx: moderngl.Context,
        geometry: ScreenGeometry,
        *,
        clock: Clock | None = None,
        window: Any = None,
        integer_scale: bool = False,
        phosphenes: PhospheneSpec | None = None,
    ) -> None:
        self.ctx = ctx
        self.geometry = geometry
        self.clock = clock if clock is not None else PerfCounterClock()
        self.window = window
        self.integer_scale = integer_scale
        self.phosphenes = phosphenes
        self.refresh_hz: float | None = None
        rows, cols = geometry.screen_shape_px
        if window is None or ctx.screen is None:  # offscreen, or a test window without a screen
            max_px = int(ctx.info.get("GL_MAX_RENDERBUFFER_SIZE", 0) or 0)
            if max_px and max(rows, cols) > max_px:
                raise PresenterError(
                    f"screen {cols}x{rows} px is larger than this GL driver's largest framebuffer "
                    f"({max_px}x{max_px} px); use a smaller screen size (display.screen_width_px, "
                    "display.screen_height_px or --screen-px)"
                )
            self._fbo = ctx.framebuffer(color_attachments=[ctx.renderbuffer((cols, rows), 4)])
        else:
            self._fbo = ctx.screen
            fb_cols, fb_rows = window.buffer_size
            if (fb_rows, fb_cols) != (rows, cols):
                raise PresenterError(
                    f"the window's framebuffer is {fb_cols}x{fb_rows} px but the protocol's screen "
                    f"is {cols}x{rows} px; set the screen to the protocol's resolution"
                )
        self._prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        self._vao = ctx.vertex_array(self._prog, [])
        self._stim_tex: moderngl.Texture | None = None
        self._text_tex: moderngl.Texture | None = None
        self._mode = 1
        self._text_box = (0, 0, 0, 0)
        self._timing: _StimulusTiming | None = None
        self._closed = False
        #: Subject input collected since the last :meth:`poll_inputs` (see :meth:`enable_input`).
        self.inputs: deque[dict[str, Any]] = deque()
        g = geometry
        self._set("u_screen", (cols, rows))
        self._set("u_border", tuple(c / 255 for c in g.border_rgb))
        self._set("u_border_px", -1 if g.border_width_px is None else g.border_width_px)
        self._set("u_background", tuple(c / 255 for c in g.background_rgb))
        self._set("u_fg", tuple(c / 255 for c in g.stimulus_on_rgb))
        self._set("u_bg", tuple(c / 255 for c in g.stimulus_off_rgb))
        self._set("u_inv_gamma", 1.0 / g.gamma)
        fix = int(round(FIXATION_HALF_DEG * g.px_per_deg)) if g.fixation else 0
        self._set("u_fixation", fix)
        self._set("u_fix_thick", FIXATION_THICKNESS_PX)
        self._set("u_fix_rgb", (0.5, 0.5, 0.5))
        self._set("u_stim", 0)
        self._set("u_text", 1)
        self._set("u_phos", 0)
        top, left, r, c = stimulus_rect_px(g, g.image_shape_px)
        self._set("u_rect", (left, top, c, r))
        self._rect = (left, top, c, r)

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def offscreen(cls, geometry: ScreenGeometry, **kwargs: Any) -> Presenter:
        """Open a headless presenter (EGL standalone context, offscreen framebuffer).

        Raises
        ------
        PresenterError
            When no OpenGL 3.3 context can be created.
        """
        try:
            ctx = moderngl.create_standalone_context(require=330, backend="egl")
        except Exception as exc:  # noqa: BLE001 - any back-end failure means "no context"
            try:
                ctx = moderngl.create_standalone_context(require=330)
            except Exception:  # noqa: BLE001
                raise PresenterError(f"no headless OpenGL 3.3 context: {exc}") from exc
        return cls(ctx, geometry, **kwargs)

    @classmethod
    def windowed(
        cls,
        geometry: ScreenGeometry,
        *,
        screen: int | None = None,
        fullscreen: bool = True,
        vsync: bool = True,
        title: str = "confocal: subject screen",
        **kwargs: Any,
    ) -> Presenter:
        """Open a window (moderngl-window, pyglet) at the protocol's resolution on ``screen``.

        ``screen`` is an index into pyglet's screen list (0 = first); full screen uses that screen's
        current mode, which must equal the protocol's resolution.
        """
        try:
            import moderngl_window
            import pyglet
        except Exception as exc:  # noqa: BLE001 - pyglet raises on import without a display
            raise PresenterError(f"cannot open a window (no display?): {exc}") from exc
        rows, cols = geometry.screen_shape_px
        screens = pyglet.display.get_display().get_screens()
        if screen is not None and not 0 <= screen < len(screens):
            raise PresenterError(f"screen must be in 0..{len(screens) - 1}, got {screen}")
        target = screens[screen if screen is not None else 0]
        window_cls = moderngl_window.get_local_window_cls("pyglet")
        window = window_cls(
            title=title,
            size=(cols, rows),
            fullscreen=False,
            resizable=False,
            vsync=vsync,
            gl_version=(3, 3),
            cursor=not fullscreen,
        )
        window._window.set_location(target.x, target.y)
        if fullscreen:
            window._window.set_fullscreen(True, screen=target)
            window._buffer_width, window._buffer_height = window._window.get_framebuffer_size()
        moderngl_window.activate_context(window=window)
        try:
            return cls(window.ctx, geometry, window=window, **kwargs)
        except Exception:
            window.close()
            raise

    # -- subject input ------------------------------------------------------------------------

    def enable_input(self) -> None:
        """Report the subject's keys, wheel and mouse drags in :attr:`inputs` (active search).

        Each input is a dict with ``t_s`` (clock time) and ``key`` (a value of
        :data:`INPUT_KEYS`, ``WheelUp``/``WheelDown``, or ``drag`` with ``box``: ``[x0, y0, x1,
        y1]`` as fractions of the stimulus rectangle, top-left origin, clipped to [0, 1]).
        Escape stops closing the window (moderngl-window's default): it is the un-zoom key.
        Offscreen, input arrives only through :meth:`post_input`.
        """
        w = self.window
        if w is None:
            return
        keys = w.keys
        named = {getattr(keys, k): v for k, v in INPUT_KEYS.items() if hasattr(keys, k)}
        w.exit_key = None
        start: dict[str, tuple[float, float]] = {}

        def on_key(key: Any, action: Any, modifiers: Any) -> None:
            if action == keys.ACTION_PRESS and key in named:
                self.post_input({"key": named[key]})

        def on_scroll(dx: float, dy: float) -> None:
            if dy:
                self.post_input({"key": "WheelUp" if dy > 0 else "WheelDown"})

        def on_press(x: float, y: float, button: Any) -> None:
            start["xy"] = self.stimulus_fraction(x, y)

        def on_release(x: float, y: float, button: Any) -> None:
            a = start.pop("xy", None)
            if a is None:
                return
            b = self.stimulus_fraction(x, y)
            box = [min(a[0], b[0]), min(a[1], b[1]), max(a[0], b[0]), max(a[1], b[1])]
            self.post_input({"key": "drag", "box": box})

        w.key_event_func = on_key
        w.mouse_scroll_event_func = on_scroll
        w.mouse_press_event_func = on_press
        w.mouse_release_event_func = on_release

    def stimulus_fraction(self, x: float, y: float) -> tuple[float, float]:
        """Map a window point (top-left origin, window units) to fractions of the stimulus."""
        ratio = float(getattr(self.window, "pixel_ratio", 1.0) or 1.0) if self.window else 1.0
        left, top, cols, rows = self._rect
        fx = (x * ratio - left) / max(cols, 1)
        fy = (y * ratio - top) / max(rows, 1)
        return float(min(max(fx, 0.0), 1.0)), float(min(max(fy, 0.0), 1.0))

    def post_input(self, event: dict[str, Any]) -> None:
        """Queue one subject input (stamped with the clock unless it has ``t_s``)."""
        self.inputs.append({"t_s": self.clock.now_s(), **event})

    def poll_inputs(self) -> list[dict[str, Any]]:
        """Return and forget the inputs queued so far, oldest first."""
        out = list(self.inputs)
        self.inputs.clear()
        return out

    def _set(self, name: str, value: Any) -> None:
        if name in self._prog:
            self._prog[name].value = value

    # -- drawing and flipping -----------------------------------------------------------------

    def _gl_box(self, left: int, top: int, cols: int, rows: int) -> tuple[int, int, int, int]:
        """Convert a top-left-origin box to GL's bottom-left (x, y, width, height), clipped."""
        screen_rows, screen_cols = self.geometry.screen_shape_px
        x0, y0 = max(0, left), max(0, top)
        x1, y1 = min(screen_cols, left + cols), min(screen_rows, top + rows)
        return x0, screen_rows - y1, max(0, x1 - x0), max(0, y1 - y0)

    def _draw(self) -> None:
        # Only the image (or text) rectangle runs the fragment shader; the border frame and the
        # background are plain clears. The shader alone decides every image pixel; this just
        # spares a software rasteriser (llvmpipe) shading a million pixels of flat colour.
        fbo, g = self._fbo, self.geometry
        fbo.use()
        if self._mode == 2:
            fbo.clear(0.0, 0.0, 0.0, 1.0)
            box = self._gl_box(*self._text_box)
        else:
            border = tuple(c / 255 for c in g.border_rgb)
            left, top, cols, rows = self._rect
            b = g.border_width_px
            if b is None:
                fbo.clear(*border, 1.0)
            else:
                fbo.clear(*(c / 255 for c in g.background_rgb), 1.0)
                fbo.clear(
                    *border,
                    1.0,
                    viewport=self._gl_box(left - b, top - b, cols + 2 * b, rows + 2 * b),
                )
            box = self._gl_box(left, top, cols, rows)
        self._prog["u_mode"].value = self._mode
        if self._stim_tex is not None:
            self._stim_tex.use(0)
        if self._text_tex is not None:
            self._text_tex.use(1)
        self.ctx.scissor = box
        try:
            self._vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            self.ctx.scissor = None

    def _flip(self) -> float:
        if self._closed:
            raise PresenterError("the presenter is closed")
        if self.window is not None:
            if self.window.is_closing:
                raise PresenterError("the subject's window was closed")
            self.window.swap_buffers()
        self.ctx.finish()
        return self.clock.now_s()

    def pump(self) -> float:
        """Redraw the current screen and flip once (once per refresh); return the flip time, s."""
        self._draw()
        t = self._flip()
        if self._timing is not None:
            self._timing.intervals_ms.append((t - self._timing.last_flip_s) * 1e3)
            self._timing.last_flip_s = t
        return t

    def _upload_stimulus(self, img: np.ndarray) -> None:
        if self._stim_tex is not None:
            self._stim_tex.release()
        rows, cols = img.shape[:2]
        colour = img.ndim == 3
        # Colour photos are training material shown as photos, never as phosphenes.
        phos = None if colour else self.phosphenes
        if phos is not None:
            img = img * phos.alive_mask(img.shape)
        tex = self.ctx.texture(
            (cols, rows),
            3 if colour else 1,
            np.ascontiguousarray(img, np.float32).tobytes(),
            dtype="f4",
        )
        self._set("u_colour", 1 if colour else 0)
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._stim_tex = tex
        top, left, r, c = stimulus_rect_px(
            self.geometry, (rows, cols), integer_scale=self.integer_scale, phosphenes=phos
        )
        self._set("u_rect", (left, top, c, r))
        self._rect = (left, top, c, r)
        self._set("u_grid", (cols, rows))
        self._set("u_phos", 0 if phos is None else (1 if phos.kind == "gaussian" else 2))
        if phos is not None:
            self._set("u_phos_size", float(phos.size))

    def show_stimulus(self, image: np.ndarray) -> FlipRecord:
        """Draw ``image`` and flip; return the onset flip.

        ``image`` is bool or float32 in [0, 1], (rows, cols), or a float32 colour photo
        (rows, cols, 3).
        """
        img = _as_stimulus(image)
        self._upload_stimulus(img)
        self._mode = 0
        self._draw()
        t = self._flip()
        self._timing = _StimulusTiming(onset_s=t, last_flip_s=t)
        return FlipRecord(onset_s=t, refresh_hz=self.refresh_hz)

    def clear(self) -> FlipRecord:
        """Replace the stimulus by the blank/fixation screen and flip.

        Returns the offset flip: ``onset_s`` is the offset time; ``frame_intervals_ms`` and
        ``dropped_frames`` cover the stimulus from its onset to this flip (empty if none was up).
        """
        self._mode = 1
        self._draw()
        t = self._flip()
        timing, self._timing = self._timing, None
        if timing is None:
            return FlipRecord(onset_s=t, refresh_hz=self.refresh_hz)
        intervals = (*timing.intervals_ms, (t - timing.last_flip_s) * 1e3)
        return FlipRecord(
            onset_s=t,
            frame_intervals_ms=tuple(intervals),
            dropped_frames=count_dropped(intervals, self.refresh_hz),
            refresh_hz=self.refresh_hz,
        )

    def show_blank(self) -> float:
        """Show the blank/fixation screen; return the flip time, s."""
        self._timing = None
        self._mode = 1
        self._draw()
        return self._flip()

    def show_text(self, text: str) -> None:
        """Show an instruction, pause or end screen (white text on black, centred)."""
        from PIL import Image, ImageDraw, ImageFont

        rows, cols = self.geometry.screen_shape_px
        size = max(12, int(round(0.6 * self.geometry.px_per_deg)))
        font = ImageFont.load_default(size=size)
        probe = ImageDraw.Draw(Image.new("L", (1, 1)))
        box = [
            int(math.floor(v))
            for v in probe.multiline_textbbox((0, 0), text, font=font, align="center")
        ]
        box[2:] = [v + 1 for v in box[2:]]
        w = max(1, min(cols, box[2] - box[0] + 2))
        h = max(1, min(rows, box[3] - box[1] + 2))
        im = Image.new("L", (w, h), 0)
        ImageDraw.Draw(im).multiline_text(
            (-box[0] + 1, -box[1] + 1), text, fill=255, font=font, align="center"
        )
        if self._text_tex is not None:
            self._text_tex.release()
        self._text_tex = self.ctx.texture((w, h), 1, im.tobytes())
        self._text_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._text_box = ((cols - w) // 2, (rows - h) // 2, w, h)
        self._set("u_text_rect", self._text_box)
        self._timing = None
        self._mode = 2
        self._draw()
        self._flip()

    def read_pixels(self) -> np.ndarray:
        """Return the last drawn frame as (rows, cols, 3) uint8, row 0 at the top of the screen."""
        rows, cols = self.geometry.screen_shape_px
        if self.window is not None:
            self._draw()  # the back buffer after a swap is undefined; redraw the current screen
        data = self._fbo.read(components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(rows, cols, 3)[::-1].copy()

    def screenshot(self, path: str | Path) -> Path:
        """Write the current frame to a PNG at the screen's full resolution; return the path."""
        from PIL import Image

        path = Path(path)
        Image.fromarray(self.read_pixels(), "RGB").save(path)
        return path

    def measure_refresh(self, n_frames: int = 60, *, check: bool = True) -> float | None:
        """Flip ``n_frames`` blank frames and return the measured refresh rate, Hz.

        Offscreen there is no refresh and None is returned. With ``check``, raise
        :class:`TimingCheckFailed` when the flips are not vsync-locked (faster than 300 Hz) or
        irregular (more than 10 % of intervals off the median by over 20 %).
        """
        if self.window is None:
            self.refresh_hz = None
            return None
        self._mode = 1
        times = []
        for _ in range(n_frames + 1):
            self._draw()
            times.append(self._flip())
        intervals = np.diff(times)
        median = float(np.median(intervals))
        hz = 1.0 / median if median > 0 else float("inf")
        irregular = float(np.mean(np.abs(intervals - median) > 0.2 * median))
        self.refresh_hz = hz
        logger.info("measured refresh %.2f Hz, %.0f%% irregular intervals", hz, 100 * irregular)
        if check and (hz > 300 or irregular > 0.1):
            raise TimingCheckFailed(
                f"frame-timing self-test failed: {hz:.1f} Hz measured, {100 * irregular:.0f}% of "
                "intervals irregular (is vsync on?); pass --skip-timing-check to run anyway "
                "(the choice is logged)"
            )
        return hz

    def close(self) -> None:
        """Release the GL objects and close the window (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for obj in (self._stim_tex, self._text_tex, self._vao, self._prog):
            if obj is not None:
                obj.release()
        if self.window is not None:
            self.window.close()
            self.window.destroy()
        if self._fbo is not self.ctx.screen:
            self._fbo.release()
        if self.window is None or self.ctx.screen is None:
            self.ctx.release()

    def __enter__(self) -> Presenter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def count_dropped(intervals_ms: Any, refresh_hz: float | None) -> int:
    """Return how many frame intervals exceed 1.5 refresh periods (0 without a refresh)."""
    if not refresh_hz:
        return 0
    limit = DROPPED_FRAME_FACTOR * 1e3 / refresh_hz
    return int(sum(1 for d in intervals_ms if d > limit))
