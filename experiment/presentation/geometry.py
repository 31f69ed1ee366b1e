"""The subject's screen's physical geometry: resolution, size in cm, viewing distance, colours.

GL-free (numpy only): the console, the presenter process and the tests build a
:class:`ScreenGeometry` from a protocol's ``[display]`` without an OpenGL context.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from stimuli import jung2015

__all__ = [
    "PAPER_SCREEN_SHAPE_PX",
    "PAPER_VIEWING_DISTANCE_CM",
    "PAPER_IMAGE_SIZE_CM",
    "PAPER_SCREEN_WIDTH_CM",
    "PAPER_BORDER_RGB",
    "ScreenGeometry",
]

#: The paper's screen (Jung et al. 2015, Sec. 3.1), from :mod:`stimuli.jung2015` where every
#: number the paper fixes lives; named here as the presenter's defaults.
PAPER_SCREEN_SHAPE_PX: tuple[int, int] = jung2015.SCREEN_SHAPE_PX
PAPER_VIEWING_DISTANCE_CM: float = jung2015.VIEWING_DISTANCE_CM
PAPER_IMAGE_SIZE_CM: tuple[float, float] = jung2015.IMAGE_SIZE_CM
PAPER_SCREEN_WIDTH_CM: float = jung2015.SCREEN_WIDTH_CM
PAPER_BORDER_RGB: tuple[int, int, int] = jung2015.BORDER_RGB


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
