"""Synthetic photo pairs: nameable objects in front of cluttered backgrounds (issue 2).

Each scene imitates one photo of the paper's study (Jung et al. 2015, Sec. 3.1): a household
or office object, about 10 deg wide, bottom centre, 0.8 m from the camera, in front of its own
cluttered background at 1.5-3 m (a patterned wall, a shelf of books or binders, clothes on a
rail or a pin board, hanging cables). Every part is a drawn shape with shading or texture
(filled outlines, gradients, highlights), evaluated as anti-aliased signed-distance fields on
whole-array numpy grids.

Scenes are :class:`stimuli.scene.Layer` stacks in the reference pinhole camera's image
coordinates, with a margin around the camera image (``margin_px``) so that off-centre views of
a light field still see texture at their borders. :func:`write_pairs` renders each scene with
:func:`stimuli.scene.render_pair` (f/22 and f/1.7) and writes a PAIRS folder for
``confocal stimuli build``.

Units: object drawings use *object units* (1 unit = the object's nominal width, 10 deg at
0.8 m, about 194 px at 492x327), with y up and the object's base at y = 0. Backgrounds are drawn
in metres on their own plane, y up, origin on the optical axis.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.io import check_missing_or_empty, save_png, staged_folder
from stimuli.manifest import OBJECTS_COLUMNS
from stimuli.scene import Layer, ThinLensCamera, centre_crop_offset, render_pair

__all__ = [
    "ObjectKind",
    "object_kinds",
    "make_scene",
    "object_mask",
    "object_width_px",
    "write_pairs",
    "OBJECT_WIDTH_DEG",
    "BACKGROUND_DEPTHS_M",
    "OBJECTS_CSV_COLUMNS",
]

#: Angular width of each object, degrees. Source: Jung et al. 2015, Sec. 3.1 ("about 10 deg").
OBJECT_WIDTH_DEG: float = 10.0

#: Depth range of the cluttered background, metres (nearest, farthest). Ours, not the paper's:
#: the paper's backgrounds (shelves, clothes, wires, files) were "behind" the object at 80 cm;
#: 1.5-3 m gives circles of confusion of about 20-32 px at f/1.7 and 1.6-2.5 px at f/22.
BACKGROUND_DEPTHS_M: tuple[float, float] = (1.5, 3.0)

#: Columns of ``objects.csv``: the builder's per-object table, defined in :mod:`stimuli.manifest`.
OBJECTS_CSV_COLUMNS: tuple[str, ...] = OBJECTS_COLUMNS

#: Texture margin around the camera image on each side, as a fraction of the image width.
#: Ours: enough for the parallax of the outermost views of a small-baseline light field.
_MARGIN_FRACTION = 0.1

#: Gap between the object's base and the bottom of the image, fraction of the image height (ours).
_BASE_GAP_FRACTION = 0.03

#: Width of the dark outline drawn around object parts, object units (about 1.5 px at 492x327).
_OUTLINE_UNITS = 0.008

_OUTLINE_VALUE = 0.06

#: Range of the contrast factor applied to each background layer around mid-grey. Ours, not the
#: paper's: with full-contrast drawings the set's mean wide-DOF edge fraction was about 14 %,
#: twice the paper's 7.7 % (Sec. 2.2); lowering background contrast brings it nearer.
_BACKGROUND_CONTRAST: tuple[float, float] = (0.55, 0.8)


# --------------------------------------------------------------------------------------------
# Object kinds
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObjectKind:
    """A kind of object the synthetic set can draw, with the answers that score as correct.

    Parameters
    ----------
    name : str
        Identifier used in folder names (``"desk_lamp"``).
    display_name : str
        What the object is called (``"desk lamp"``).
    synonyms : tuple of str
        Other names accepted as correct.
    uses : tuple of str
        Descriptions of its use accepted as correct.
    """

    name: str
    display_name: str
    synonyms: tuple[str, ...]
    uses: tuple[str, ...]


_KINDS: tuple[ObjectKind, ...] = (
    ObjectKind(
        "cup",
        "cup",
        ("teacup", "coffee cup", "cup and saucer"),
        ("drinking", "drink tea", "drink coffee"),
    ),
    ObjectKind(
        "mug", "mug", ("coffee mug", "tea mug", "cup"), ("drinking", "drink coffee", "drink tea")
    ),
    ObjectKind(
        "desk_lamp",
        "desk lamp",
        ("lamp", "table lamp", "reading lamp", "light"),
        ("lighting", "reading light", "give light"),
    ),
    ObjectKind(
        "bottle",
        "bottle",
        ("wine bottle", "glass bottle", "beer bottle"),
        ("holding liquid", "drinking", "pouring"),
    ),
    ObjectKind("scissors", "scissors", ("shears", "pair of scissors"), ("cutting", "cut paper")),
    ObjectKind(
        "key", "key", ("house key", "door key"), ("opening a lock", "unlock a door", "locking")
    ),
    ObjectKind(
        "glasses",
        "glasses",
        ("eyeglasses", "spectacles", "sunglasses", "specs"),
        ("seeing", "reading", "correct vision"),
    ),
    ObjectKind(
        "hammer", "hammer", ("claw hammer", "mallet"), ("hammering", "drive nails", "pull nails")
    ),
    ObjectKind(
        "umbrella",
        "umbrella",
        ("parasol", "brolly"),
        ("rain protection", "keep dry", "shade from sun"),
    ),
    ObjectKind(
        "teapot",
        "teapot",
        ("tea pot", "kettle", "pot"),
        ("making tea", "pouring tea", "serving tea"),
    ),
    ObjectKind(
        "clock",
        "alarm clock",
        ("clock", "alarm", "timepiece"),
        ("telling time", "waking up", "alarm"),
    ),
    ObjectKind(
        "light_bulb",
        "light bulb",
        ("bulb", "lightbulb", "lamp bulb"),
        ("lighting", "give light", "lamp"),
    ),
    ObjectKind("fork", "fork", ("table fork", "dinner fork"), ("eating", "eat food", "cutlery")),
    ObjectKind(
        "spoon",
        "spoon",
        ("teaspoon", "tablespoon", "soup spoon"),
        ("eating", "stirring", "eat soup"),
    ),
    ObjectKind(
        "toothbrush",
        "toothbrush",
        ("tooth brush", "brush"),
        ("brushing teeth", "cleaning teeth", "dental hygiene"),
    ),
    ObjectKind(
        "phone",
        "mobile phone",
        ("phone", "cell phone", "smartphone", "cellphone", "mobile"),
        ("calling", "phone calls", "texting", "communication"),
    ),
    ObjectKind("book", "book", ("open book", "notebook"), ("reading", "learning", "study")),
    ObjectKind(
        "wine_glass", "wine glass", ("glass", "goblet", "wineglass"), ("drinking", "drink wine")
    ),
    ObjectKind(
        "padlock", "padlock", ("lock", "combination lock"), ("locking", "security", "lock a door")
    ),
    ObjectKind(
        "headphones",
        "headphones",
        ("headset", "earphones", "headphone", "cans"),
        ("listening to music", "listening", "hearing audio"),
    ),
    ObjectKind(
        "screwdriver",
        "screwdriver",
        ("screw driver", "driver"),
        ("turning screws", "tighten screws", "repair"),
    ),
    ObjectKind(
        "shoe",
        "shoe",
        ("sneaker", "trainer", "running shoe", "boot"),
        ("wearing", "walking", "running", "footwear"),
    ),
    ObjectKind("chair", "chair", ("seat", "stool"), ("sitting", "sit on")),
    ObjectKind("pen", "pen", ("ballpoint pen", "ballpoint", "biro"), ("writing", "write")),
    ObjectKind(
        "watch", "wristwatch", ("watch", "wrist watch"), ("telling time", "time", "wear on wrist")
    ),
    ObjectKind(
        "remote",
        "remote control",
        ("remote", "tv remote", "controller", "clicker"),
        ("changing channels", "control the tv", "switching the tv"),
    ),
)


def object_kinds() -> list[ObjectKind]:
    """Return the object kinds the synthetic set can draw, in the order :func:`write_pairs` uses.

    The first 20 are the main set (the paper's study had 20 objects), the next 3 are for
    training trials, and the rest are spares that :func:`write_pairs` uses when asked for more
    objects.

    Returns
    -------
    list of ObjectKind
        Distinct names; each with at least one synonym and one use.

    Examples
    --------
    >>> object_kinds()[4].name, object_kinds()[4].synonyms
    ('scissors', ('shears', 'pair of scissors'))
    """
    return list(_KINDS)


# --------------------------------------------------------------------------------------------
# Signed-distance drawing kit (vectorised over pixels; loops only over shapes and vertices)
# --------------------------------------------------------------------------------------------

Field = Callable[[np.ndarray, np.ndarray], np.ndarray]
Value = float | Field


@dataclass(frozen=True)
class _Shape:
    """A region given by its signed distance (negative inside, units) and a bounding box."""

    sdf: Field
    bbox: tuple[float, float, float, float]  # x0, y0, x1, y1

    def __or__(self, other: _Shape) -> _Shape:
        a, b = self, other
        box = (
            min(a.bbox[0], b.bbox[0]),
            min(a.bbox[1], b.bbox[1]),
            max(a.bbox[2], b.bbox[2]),
            max(a.bbox[3], b.bbox[3]),
        )
        return _Shape(lambda x, y: np.minimum(a.sdf(x, y), b.sdf(x, y)), box)

    def __and__(self, other: _Shape) -> _Shape:
        a, b = self, other
        box = (
            max(a.bbox[0], b.bbox[0]),
            max(a.bbox[1], b.bbox[1]),
            min(a.bbox[2], b.bbox[2]),
            min(a.bbox[3], b.bbox[3]),
        )
        return _Shape(lambda x, y: np.maximum(a.sdf(x, y), b.sdf(x, y)), box)

    def __sub__(self, other: _Shape) -> _Shape:
        a, b = self, other
        return _Shape(lambda x, y: np.maximum(a.sdf(x, y), -b.sdf(x, y)), a.bbox)


def _circle(cx: float, cy: float, r: float) -> _Shape:
    return _Shape(lambda x, y: np.hypot(x - cx, y - cy) - r, (cx - r, cy - r, cx + r, cy + r))


def _ellipse(cx: float, cy: float, rx: float, ry: float) -> _Shape:
    def sdf(x, y):
        px, py = (x - cx) / rx, (y - cy) / ry
        k0 = np.hypot(px, py)
        k1 = np.hypot(px / rx, py / ry)
        return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)

    return _Shape(sdf, (cx - rx, cy - ry, cx + rx, cy + ry))


def _box(
    cx: float, cy: float, w: float, h: float, r: float = 0.0, angle_deg: float = 0.0
) -> _Shape:
    hw, hh = w / 2.0 - r, h / 2.0 - r
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def sdf(x, y):
        dx, dy = x - cx, y - cy
        u = np.abs(c * dx + s * dy) - hw
        v = np.abs(-s * dx + c * dy) - hh
        outside = np.hypot(np.maximum(u, 0.0), np.maximum(v, 0.0))
        return outside + np.minimum(np.maximum(u, v), 0.0) - r

    ext_x = abs(c) * w / 2 + abs(s) * h / 2
    ext_y = abs(s) * w / 2 + abs(c) * h / 2
    return _Shape(sdf, (cx - ext_x, cy - ext_y, cx + ext_x, cy + ext_y))


def _capsule(x0: float, y0: float, x1: float, y1: float, r: float) -> _Shape:
    ex, ey = x1 - x0, y1 - y0
    ee = max(ex * ex + ey * ey, 1e-12)

    def sdf(x, y):
        wx, wy = x - x0, y - y0
        t = np.clip((wx * ex + wy * ey) / ee, 0.0, 1.0)
        return np.hypot(wx - ex * t, wy - ey * t) - r

    return _Shape(sdf, (min(x0, x1) - r, min(y0, y1) - r, max(x0, x1) + r, max(y0, y1) + r))


def _polygon(points: Sequence[tuple[float, float]]) -> _Shape:
    v = np.asarray(points, dtype=np.float64)

    def sdf(x, y):
        d = (x - v[0, 0]) ** 2 + (y - v[0, 1]) ** 2
        sign = np.ones_like(x)
        n = len(v)
        for i in range(n):
            j = i - 1
            ex, ey = v[j, 0] - v[i, 0], v[j, 1] - v[i, 1]
            wx, wy = x - v[i, 0], y - v[i, 1]
            t = np.clip((wx * ex + wy * ey) / max(ex * ex + ey * ey, 1e-12), 0.0, 1.0)
            bx, by = wx - ex * t, wy - ey * t
            d = np.minimum(d, bx * bx + by * by)
            c1 = y >= v[i, 1]
            c2 = y < v[j, 1]
            c3 = ex * wy > ey * wx
            flip = (c1 & c2 & c3) | (~c1 & ~c2 & ~c3)
            sign = np.where(flip, -sign, sign)
        return sign * np.sqrt(d)

    return _Shape(sdf, (v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()))


def _ring(cx: float, cy: float, r: float, width: float) -> _Shape:
    h = width / 2.0
    return _Shape(
        lambda x, y: np.abs(np.hypot(x - cx, y - cy) - r) - h,
        (cx - r - h, cy - r - h, cx + r + h, cy + r + h),
    )


def _stroke(shape: _Shape, width: float) -> _Shape:
    h = width / 2.0
    x0, y0, x1, y1 = shape.bbox
    return _Shape(lambda x, y: np.abs(shape.sdf(x, y)) - h, (x0 - h, y0 - h, x1 + h, y1 + h))


def _halfplane(nx: float, ny: float, c: float, box: tuple[float, float, float, float]) -> _Shape:
    """Points with ``nx * x + ny * y <= c`` (``(nx, ny)`` a unit normal), within ``box``."""
    return _Shape(lambda x, y: nx * x + ny * y - c, box)


_BIG = (-1e3, -1e3, 1e3, 1e3)


def _above(y0: float) -> _Shape:
    return _halfplane(0.0, -1.0, -y0, _BIG)


def _below(y0: float) -> _Shape:
    return _halfplane(0.0, 1.0, y0, _BIG)


def _rotate(shape: _Shape, angle_deg: float, cx: float, cy: float) -> _Shape:
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def sdf(x, y):
        dx, dy = x - cx, y - cy
        return shape.sdf(cx + c * dx + s * dy, cy - s * dx + c * dy)

    x0, y0, x1, y1 = shape.bbox
    corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]]) - [cx, cy]
    rx = cx + c * corners[:, 0] - s * corners[:, 1]
    ry = cy + s * corners[:, 0] + c * corners[:, 1]
    return _Shape(sdf, (rx.min(), ry.min(), rx.max(), ry.max()))


def _bezier(points: Sequence[tuple[float, float]], n: int = 24) -> np.ndarray:
    """Points along a cubic Bezier curve, shape (n, 2)."""
    p = np.asarray(points, dtype=np.float64)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (
        (1 - t) ** 3 * p[0] + 3 * (1 - t) ** 2 * t * p[1] + 3 * (1 - t) * t**2 * p[2] + t**3 * p[3]
    )


# Shading fields -----------------------------------------------------------------------------


def _cyl(xc: float, half_w: float, base: float, *, spec: float = 0.3, axis: str = "x") -> Field:
    """Shading of an upright cylinder lit from the upper left: diffuse plus a specular streak."""

    def f(x, y):
        u = np.clip(((x if axis == "x" else y) - xc) / half_w, -1.0, 1.0)
        nz = np.sqrt(1.0 - u * u)
        diffuse = np.clip(0.8 * nz - 0.45 * u, 0.0, 1.0)
        hl = spec * np.exp(-(((u + 0.45) / 0.12) ** 2))
        return np.clip(base * (0.35 + 0.75 * diffuse) + hl, 0.0, 1.0)

    return f


def _sphere(cx: float, cy: float, r: float, base: float, *, spec: float = 0.35) -> Field:
    """Shading of a sphere (or a bulging surface) lit from the upper left."""

    def f(x, y):
        u, v = (x - cx) / r, (y - cy) / r
        nz = np.sqrt(np.clip(1.0 - u * u - v * v, 0.0, 1.0))
        diffuse = np.clip(-0.45 * u + 0.5 * v + 0.74 * nz, 0.0, 1.0)
        hl = spec * np.exp(-(((u + 0.35) ** 2 + (v - 0.4) ** 2) / 0.03))
        return np.clip(base * (0.3 + 0.8 * diffuse) + hl, 0.0, 1.0)

    return f


def _lin(x0: float, y0: float, x1: float, y1: float, v0: float, v1: float) -> Field:
    """Linear gradient from ``v0`` at (x0, y0) to ``v1`` at (x1, y1)."""
    ex, ey = x1 - x0, y1 - y0
    ee = max(ex * ex + ey * ey, 1e-12)

    def f(x, y):
        t = np.clip(((x - x0) * ex + (y - y0) * ey) / ee, 0.0, 1.0)
        return v0 + (v1 - v0) * t

    return f


def _stripes(
    period: float, v0: float, v1: float, angle_deg: float = 0.0, duty: float = 0.5
) -> Field:
    """Hard stripes across the direction ``angle_deg`` (0 = vertical stripes)."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def f(x, y):
        t = np.mod((c * x + s * y) / period, 1.0)
        return np.where(t < duty, v0, v1)

    return f


def _metal(base: float, angle_deg: float = 0.0) -> Field:
    """Polished metal: soft bands of reflection along ``angle_deg``."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def f(x, y):
        t = c * x + s * y
        return np.clip(base + 0.22 * np.sin(t * 23.0) + 0.12 * np.sin(t * 57.0 + 1.0), 0.0, 1.0)

    return f


# Canvas -------------------------------------------------------------------------------------


class _Canvas:
    """Premultiplied luminance + alpha texture with a units-to-pixels mapping (y up)."""

    def __init__(
        self, shape_px: tuple[int, int], px_per_unit: float, origin_rc: tuple[float, float]
    ):
        self.shape = shape_px
        self.ppu = float(px_per_unit)
        self.r0, self.c0 = origin_rc
        self.c = np.zeros(shape_px, dtype=np.float32)
        self.a = np.zeros(shape_px, dtype=np.float32)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the canvas, units."""
        rows, cols = self.shape
        return (
            (0 - self.c0) / self.ppu,
            (self.r0 - (rows - 1)) / self.ppu,
            (cols - 1 - self.c0) / self.ppu,
            self.r0 / self.ppu,
        )

    def _grid(self, bbox, pad_px: float):
        x0, y0, x1, y1 = bbox
        rows, cols = self.shape
        c_lo = max(0, int(math.floor(self.c0 + x0 * self.ppu - pad_px)))
        c_hi = min(cols, int(math.ceil(self.c0 + x1 * self.ppu + pad_px)) + 1)
        r_lo = max(0, int(math.floor(self.r0 - y1 * self.ppu - pad_px)))
        r_hi = min(rows, int(math.ceil(self.r0 - y0 * self.ppu + pad_px)) + 1)
        if c_lo >= c_hi or r_lo >= r_hi:
            return None
        xs = ((np.arange(c_lo, c_hi) - self.c0) / self.ppu).astype(np.float32)
        ys = ((self.r0 - np.arange(r_lo, r_hi)) / self.ppu).astype(np.float32)
        return (slice(r_lo, r_hi), slice(c_lo, c_hi)), xs[None, :], ys[:, None]

    def paint(
        self,
        shape: _Shape,
        value: Value,
        *,
        opacity: float = 1.0,
        outline: float = 0.0,
        outline_value: float = _OUTLINE_VALUE,
    ) -> None:
        """Composite ``value`` over the canvas inside ``shape``; optional outline (width, units)."""
        grid = self._grid(shape.bbox, 2.0 + outline * self.ppu)
        if grid is None:
            return
        # Fields broadcast a (1, cols) x against a (rows, 1) y.
        sl, x, y = grid
        d = shape.sdf(x, y) * np.float32(self.ppu)
        cov = np.clip(0.5 - d, 0.0, 1.0) * opacity
        v = value(x, y) if callable(value) else value
        self.c[sl] = cov * v + (1.0 - cov) * self.c[sl]
        self.a[sl] = cov + (1.0 - cov) * self.a[sl]
        if outline > 0:
            cov_o = np.clip(0.5 - (np.abs(d) - outline * self.ppu / 2.0), 0.0, 1.0) * opacity
            self.c[sl] = cov_o * outline_value + (1.0 - cov_o) * self.c[sl]
            self.a[sl] = cov_o + (1.0 - cov_o) * self.a[sl]

    def place(self, bottom_row: float, centre_col: float) -> None:
        """Shift the drawing by whole pixels: lowest row to ``bottom_row``, box centred on a column.

        Tilted drawings (utensils, keys) lift off their base or drift sideways when rotated;
        this puts every object on the same base line, centred, as in the paper's photos.
        """
        rows, cols = np.nonzero(self.a > 0.5)
        if rows.size == 0:
            return
        dr = int(round(bottom_row - rows.max()))
        dc = int(round(centre_col - (cols.min() + cols.max()) / 2.0))
        for name in ("c", "a"):
            src = getattr(self, name)
            dst = np.zeros_like(src)
            h, w = src.shape
            dst[max(dr, 0) : h + min(dr, 0), max(dc, 0) : w + min(dc, 0)] = src[
                max(-dr, 0) : h + min(-dr, 0), max(-dc, 0) : w + min(-dc, 0)
            ]
            setattr(self, name, dst)

    def fill(self, value: Value) -> None:
        """Cover the whole canvas, opaque."""
        sl, x, y = self._grid(self.extent, 0)
        v = value(x, y) if callable(value) else value
        self.c[sl] = v
        self.a[sl] = 1.0

    def layer(self, name: str, depth_m: float) -> Layer:
        """Return the canvas as a Layer (texture un-premultiplied, float32 in [0, 1])."""
        a = np.clip(self.a, 0.0, 1.0)
        t = np.where(a > 1e-6, self.c / np.maximum(a, 1e-6), 0.0)
        return Layer(
            name,
            np.clip(t, 0.0, 1.0).astype(np.float32),
            a.astype(np.float32),
            float(depth_m),
        )


def _noise(rng: np.random.Generator, shape: tuple[int, int], sigma_px: float) -> np.ndarray:
    """Smooth noise in [-1, 1] (Gaussian-filtered white noise, normalised)."""
    n = gaussian_filter(rng.standard_normal(shape), sigma_px, mode="wrap")
    return n / (np.abs(n).max() + 1e-12)


# --------------------------------------------------------------------------------------------
# Objects (object units: 1 = nominal width, base at y = 0, y up, centred on x = 0)
# --------------------------------------------------------------------------------------------

OL = _OUTLINE_UNITS


def _draw_cup(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.75, 0.92)
    cv.paint(_ellipse(0, 0.05, 0.5, 0.055), _lin(0, 0.1, 0, 0.0, 0.9, 0.55), outline=OL)
    cv.paint(_ellipse(0, 0.07, 0.3, 0.03), 0.5)
    cv.paint(_ring(0.37, 0.38, 0.12, 0.05), _metal(base * 0.9, 45), outline=OL)
    body = _polygon([(-0.25, 0.08), (0.25, 0.08), (0.33, 0.64), (-0.33, 0.64)]) | _ellipse(
        0, 0.09, 0.25, 0.035
    )
    cv.paint(body, _cyl(0, 0.33, base), outline=OL)
    band = body & _box(0, 0.47, 1.0, 0.07)
    cv.paint(band, _cyl(0, 0.33, base * 0.45, spec=0.15))
    for k in range(-2, 3):
        cv.paint(_circle(k * 0.1, 0.3, 0.025), _cyl(0, 0.33, base * 0.5, spec=0.1))
    cv.paint(_ellipse(0, 0.64, 0.33, 0.06), _lin(0, 0.7, 0, 0.58, 0.55, 0.85), outline=OL)
    cv.paint(_ellipse(0, 0.63, 0.29, 0.042), 0.18)


def _draw_mug(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.35, 0.6)
    handle = _stroke(_box(0.35, 0.38, 0.3, 0.4, r=0.12), 0.075)
    cv.paint(handle - _box(0.1, 0.38, 0.3, 0.6), _metal(base, 80), outline=OL)
    body = _box(0, 0.37, 0.66, 0.74, r=0.03)
    cv.paint(body, _cyl(0, 0.33, base, spec=0.4), outline=OL)
    cv.paint(_circle(-0.02, 0.4, 0.14), 0.92, outline=OL)
    cv.paint(_polygon([(-0.1, 0.42), (-0.02, 0.3), (0.06, 0.42), (-0.02, 0.5)]), 0.15)
    for i, w in enumerate((0.34, 0.22)):
        cv.paint(_box(-0.02, 0.17 - 0.05 * i, w, 0.022, r=0.01), 0.95)
    cv.paint(_ellipse(0, 0.74, 0.33, 0.05), _lin(0, 0.79, 0, 0.69, base * 0.6, base * 1.2))
    cv.paint(_ellipse(0, 0.735, 0.3, 0.038), 0.12, outline=OL)


def _draw_desk_lamp(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.3, 0.55)
    cv.paint(
        _ellipse(0.05, 0.05, 0.32, 0.06), _lin(0, 0.1, 0, 0.0, base * 1.3, base * 0.7), outline=OL
    )
    cv.paint(_box(0.05, 0.1, 0.3, 0.08, r=0.03), _metal(base), outline=OL)
    j1, j2, head = (0.05, 0.13), (-0.22, 0.78), (0.2, 1.12)
    cv.paint(_capsule(*j1, *j2, 0.028), _metal(base * 1.2, 110), outline=OL)
    cv.paint(_capsule(j1[0] + 0.06, j1[1], j2[0] + 0.06, j2[1], 0.01), 0.85, outline=OL / 2)
    cv.paint(_capsule(*j2, *head, 0.025), _metal(base * 1.2, 40), outline=OL)
    cv.paint(_circle(*j2, 0.05), _sphere(j2[0], j2[1], 0.05, 0.7), outline=OL)
    cv.paint(_circle(*j1, 0.045), _sphere(j1[0], j1[1], 0.045, 0.7), outline=OL)
    # Conical shade pointing down to the right; the bulb glows in its mouth.
    shade = _rotate(
        _polygon([(-0.08, 0.0), (0.08, 0.0), (0.22, -0.34), (-0.22, -0.34)])
        | _ellipse(0, 0.0, 0.08, 0.04),
        35.0,
        0,
        0,
    )
    shade = _Shape(
        lambda x, y, s=shade: s.sdf(x - head[0], y - head[1]),
        (
            shade.bbox[0] + head[0],
            shade.bbox[1] + head[1],
            shade.bbox[2] + head[0],
            shade.bbox[3] + head[1],
        ),
    )
    cv.paint(shade, _cyl(head[0] + 0.1, 0.25, base * 1.3, spec=0.35), outline=OL)
    mouth_x = head[0] + 0.34 * math.sin(math.radians(35))
    mouth_y = head[1] - 0.34 * math.cos(math.radians(35))
    rim = _rotate(_ellipse(mouth_x, mouth_y, 0.22, 0.06), 35.0, mouth_x, mouth_y)
    cv.paint(rim, 0.97, outline=OL)
    cv.paint(_rotate(_ellipse(mouth_x, mouth_y, 0.1, 0.035), 35.0, mouth_x, mouth_y), 1.0)
    cv.paint(_circle(*head, 0.04), _sphere(head[0], head[1], 0.04, 0.7), outline=OL)


def _draw_bottle(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.2, 0.4)
    glass = _cyl(0, 0.22, base, spec=0.55)
    body = _box(0, 0.4, 0.44, 0.78, r=0.05)
    shoulder = _polygon([(-0.22, 0.74), (0.22, 0.74), (0.08, 1.0), (-0.08, 1.0)])
    neck = _box(0, 1.12, 0.15, 0.3, r=0.02)
    cv.paint(body | shoulder | neck, glass, outline=OL)
    cv.paint(_box(0, 1.28, 0.17, 0.1, r=0.015), _stripes(0.02, 0.75, 0.45), outline=OL)
    label = _box(0, 0.38, 0.445, 0.34)
    cv.paint(label, _cyl(0, 0.22, 0.95, spec=0.1), outline=OL)
    cv.paint(_ellipse(0, 0.43, 0.13, 0.08), _cyl(0, 0.22, 0.35, spec=0.0), outline=OL / 2)
    for i, w in enumerate((0.28, 0.2, 0.24)):
        cv.paint(_box(0, 0.3 - 0.045 * i, w, 0.018), 0.25)
    cv.paint(_box(0, 1.0, 0.18, 0.05), _cyl(0, 0.09, 0.9, spec=0.1), outline=OL / 2)


def _draw_scissors(cv: _Canvas, rng: np.random.Generator) -> None:
    handle = rng.uniform(0.1, 0.3)
    pivot = (0.0, 0.62)
    for sign in (-1.0, 1.0):
        tip = (sign * 0.33, 1.38)
        ring_c = (-sign * 0.26, 0.22)
        dx, dy = tip[0] - pivot[0], tip[1] - pivot[1]
        n = math.hypot(dx, dy)
        px, py = -dy / n, dx / n
        blade = _polygon(
            [
                (ring_c[0] * 0.45 + px * 0.05, 0.38 + py * 0.05),
                (pivot[0] + px * 0.055, pivot[1] + py * 0.055),
                tip,
                (pivot[0] - px * 0.04, pivot[1] - py * 0.04),
                (ring_c[0] * 0.45 - px * 0.05, 0.38 - py * 0.05),
            ]
        )
        cv.paint(blade, _metal(0.72, math.degrees(math.atan2(dy, dx)) + 90), outline=OL)
        cv.paint(
            _ring(ring_c[0], ring_c[1], 0.15, 0.07), _sphere(*ring_c, 0.2, handle + 0.2), outline=OL
        )
        cv.paint(
            _capsule(ring_c[0] * 0.45, 0.38, ring_c[0] * 0.8, 0.3, 0.045), handle + 0.1, outline=OL
        )
    cv.paint(_circle(*pivot, 0.035), _sphere(*pivot, 0.035, 0.8), outline=OL)


def _draw_key(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.55, 0.75)
    ang = rng.uniform(10.0, 22.0)
    cy = 0.38

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, 0.0, cy)

    bow = _circle(-0.3, cy, 0.22) - _circle(-0.4, cy, 0.065)
    shaft = _box(0.2, cy, 0.62, 0.1, r=0.01)
    teeth = _polygon(
        [
            (0.1, cy - 0.04),
            (0.1, cy - 0.13),
            (0.16, cy - 0.17),
            (0.22, cy - 0.11),
            (0.28, cy - 0.17),
            (0.34, cy - 0.12),
            (0.4, cy - 0.16),
            (0.46, cy - 0.1),
            (0.5, cy - 0.04),
        ]
    )
    cv.paint(R(bow | shaft | teeth), _metal(base, ang + 90), outline=OL)
    cv.paint(R(_box(0.24, cy + 0.01, 0.5, 0.018)), base * 0.45)
    cv.paint(R(_ring(-0.3, cy, 0.17, 0.015)), base * 0.5)
    cv.paint(R(_ring(-0.4, cy, 0.1, 0.04)), 0.35, outline=OL / 2)


def _draw_glasses(cv: _Canvas, rng: np.random.Generator) -> None:
    frame = rng.uniform(0.05, 0.25)
    cy = 0.3
    for sx in (-1.0, 1.0):
        cv.paint(_capsule(sx * 0.47, cy + 0.1, sx * 0.5, 0.03, 0.02), frame + 0.15, outline=OL)
    for sx in (-1.0, 1.0):
        lens = _box(sx * 0.24, cy, 0.4, 0.3, r=0.11)
        cv.paint(
            lens,
            _lin(sx * 0.24 - 0.2, cy + 0.15, sx * 0.24 + 0.2, cy - 0.15, 0.75, 0.5),
            opacity=0.55,
        )
        cv.paint(
            _capsule(sx * 0.24 - 0.1, cy - 0.02, sx * 0.24 - 0.02, cy + 0.1, 0.018),
            0.97,
            opacity=0.8,
        )
        cv.paint(_stroke(lens, 0.05), _metal(frame + 0.1, 30), outline=OL)
    bridge = _ring(0, cy + 0.02, 0.09, 0.04) & _above(cy + 0.04)
    cv.paint(bridge, frame + 0.1, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(_circle(sx * 0.44, cy + 0.1, 0.02), 0.8)


def _draw_hammer(cv: _Canvas, rng: np.random.Generator) -> None:
    wood = rng.uniform(0.55, 0.75)
    grain = _noise(rng, (8, 64), 2.0)

    def wood_f(x, y):
        gi = np.clip(((y + 0.0) * 40).astype(int), 0, 63)
        return np.clip(wood + 0.12 * np.sin(x * 160 + grain[0, gi] * 3) * 0.5 + 0.4 * (x * 2), 0, 1)

    cv.paint(_box(0.0, 0.48, 0.11, 0.94, r=0.05), wood_f, outline=OL)
    grip = _box(0.0, 0.2, 0.13, 0.38, r=0.06)
    cv.paint(grip, lambda x, y: 0.15 + 0.12 * (np.sin(y * 120) > 0.3), outline=OL)
    head = _box(0.0, 1.0, 0.5, 0.17, r=0.02)
    face = _box(0.3, 1.0, 0.12, 0.22, r=0.02)
    claw = _polygon(
        [
            (-0.24, 1.08),
            (-0.45, 1.04),
            (-0.6, 0.92),
            (-0.62, 0.84),
            (-0.52, 0.9),
            (-0.38, 0.95),
            (-0.24, 0.93),
        ]
    )
    cv.paint(head | face | claw, _metal(0.55, 90), outline=OL)
    cv.paint(_polygon([(-0.62, 0.84), (-0.5, 0.955), (-0.58, 0.98)]), 0.3)
    cv.paint(_box(0.36, 1.0, 0.015, 0.2), 0.9)


def _draw_umbrella(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.2, 0.45)
    top, cy = (0.0, 1.22), 0.78
    canopy = _ellipse(0, cy, 0.56, 0.44) & _above(cy)
    for k in range(5):
        canopy = canopy - _ellipse(-0.42 + k * 0.21, cy, 0.105, 0.05)
    cv.paint(_capsule(0, cy, 0, 0.15, 0.018), _metal(0.6), outline=OL)
    hook = _ring(0.09, 0.15, 0.09, 0.04) & _below(0.15)
    cv.paint(hook, 0.2, outline=OL)

    def panels(x, y):
        ang = np.arctan2(y - cy, x)
        return np.where(np.sin(ang * 8) > 0, base, base * 2.0) * (0.75 + 0.25 * (y - cy) / 0.44)

    cv.paint(canopy, panels, outline=OL)
    for k in range(5):
        end = (-0.42 + k * 0.21, cy + 0.015)
        cv.paint(_capsule(*top, *end, 0.006), 0.1)
    cv.paint(_capsule(0, 1.2, 0, 1.32, 0.018), 0.3, outline=OL)


def _draw_teapot(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.7, 0.9)
    cv.paint(_ring(0.38, 0.42, 0.15, 0.055), _metal(base * 0.8, 45), outline=OL)
    spout = _polygon(
        [
            (-0.25, 0.25),
            (-0.45, 0.45),
            (-0.58, 0.66),
            (-0.64, 0.68),
            (-0.6, 0.6),
            (-0.47, 0.34),
            (-0.28, 0.45),
        ]
    )
    cv.paint(spout, _lin(-0.6, 0.7, -0.3, 0.3, base, base * 0.6), outline=OL)
    cv.paint(_box(0, 0.05, 0.38, 0.08, r=0.02), base * 0.6, outline=OL)
    body = _ellipse(0, 0.37, 0.38, 0.3)
    cv.paint(body, _sphere(0, 0.37, 0.42, base), outline=OL)
    for k in range(-2, 3):
        cx, cyy = k * 0.13, 0.36 + 0.02 * (abs(k) == 1)
        cv.paint(_circle(cx, cyy, 0.035), 0.3)
        for j in range(5):
            a = j * 2 * math.pi / 5
            cv.paint(_circle(cx + 0.05 * math.cos(a), cyy + 0.05 * math.sin(a), 0.025), 0.5)
    cv.paint(_ellipse(0, 0.66, 0.22, 0.045), base * 0.7, outline=OL)
    cv.paint(_ellipse(0, 0.68, 0.18, 0.08) & _above(0.67), _sphere(0, 0.67, 0.2, base), outline=OL)
    cv.paint(_circle(0, 0.79, 0.04), _sphere(0, 0.79, 0.04, base * 0.8), outline=OL)


def _draw_clock(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.3, 0.6)
    c = (0.0, 0.56)
    for sx in (-1.0, 1.0):
        cv.paint(_capsule(sx * 0.22, 0.2, sx * 0.3, 0.02, 0.03), 0.3, outline=OL)
        bell = _circle(sx * 0.26, 0.98, 0.14) & _above(0.94)
        cv.paint(
            _rotate(bell, -sx * 25, sx * 0.26, 0.9),
            _sphere(sx * 0.3, 1.0, 0.16, base * 1.3),
            outline=OL,
        )
    cv.paint(_capsule(0, 0.98, 0, 1.12, 0.02), 0.35, outline=OL)
    cv.paint(_box(0, 1.12, 0.2, 0.04, r=0.015), 0.35, outline=OL)
    cv.paint(_circle(*c, 0.42), _sphere(*c, 0.45, base), outline=OL)
    cv.paint(_circle(*c, 0.35), _lin(-0.3, 0.85, 0.3, 0.3, 0.98, 0.82), outline=OL)
    for k in range(12):
        a = k * math.pi / 6
        r0 = 0.27 if k % 3 else 0.24
        cv.paint(
            _capsule(
                c[0] + r0 * math.sin(a),
                c[1] + r0 * math.cos(a),
                c[0] + 0.31 * math.sin(a),
                c[1] + 0.31 * math.cos(a),
                0.012 if k % 3 else 0.02,
            ),
            0.1,
        )
    h, m = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi)
    cv.paint(_capsule(*c, c[0] + 0.16 * math.sin(h), c[1] + 0.16 * math.cos(h), 0.022), 0.05)
    cv.paint(_capsule(*c, c[0] + 0.25 * math.sin(m), c[1] + 0.25 * math.cos(m), 0.015), 0.05)
    cv.paint(_circle(*c, 0.03), 0.4, outline=OL)


def _draw_light_bulb(cv: _Canvas, rng: np.random.Generator) -> None:
    cy = 0.86
    globe = _circle(0, cy, 0.33) | _polygon(
        [(-0.26, 0.66), (0.26, 0.66), (0.14, 0.4), (-0.14, 0.4)]
    )
    cv.paint(globe, _sphere(0, cy, 0.4, 0.8, spec=0.25), outline=OL)
    fil = [(-0.1, 0.5), (-0.07, 0.86)] + [
        (-0.07 + 0.14 * k / 6, 0.86 + 0.04 * (k % 2)) for k in range(7)
    ]
    fil += [(0.1, 0.5)]
    for p, q in zip(fil[:-1], fil[1:], strict=True):
        cv.paint(_capsule(*p, *q, 0.008), 0.2)
    cv.paint(_capsule(-0.22, 0.95, -0.14, 1.07, 0.02), 1.0, opacity=0.9)
    cv.paint(_box(0, 0.3, 0.3, 0.2, r=0.02), _lin(0, 0.3, 0, 0.3, 0.6, 0.6), outline=OL)

    def thread(x, y):
        return np.clip(
            0.35 + 0.35 * np.sin((y - 0.12 * x) * 110) + 0.25 * _cyl(0, 0.15, 0.6)(x, y), 0, 1
        )

    cv.paint(_box(0, 0.3, 0.3, 0.2, r=0.02), thread, outline=OL)
    cv.paint(_box(0, 0.16, 0.18, 0.08, r=0.02), 0.12, outline=OL)
    cv.paint(_ellipse(0, 0.1, 0.06, 0.035), _metal(0.7), outline=OL)
    del rng


def _utensil(
    cv: _Canvas, ang: float, head: Callable[[], tuple[_Shape, Field]], base: float
) -> None:
    cx, cy = 0.0, 0.65

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, cx, cy)

    handle = _polygon([(-0.06, 0.1), (0.06, 0.1), (0.035, 0.85), (-0.035, 0.85)]) | _ellipse(
        0, 0.12, 0.065, 0.07
    )
    cv.paint(R(handle), lambda x, y: _metal(base, ang)(x, y), outline=OL)
    shape, shade = head()
    cv.paint(R(shape), shade, outline=OL)
    cv.paint(R(_capsule(-0.01, 0.15, -0.01, 0.7, 0.008)), 0.97, opacity=0.8)


def _draw_fork(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(20.0, 32.0) * rng.choice([-1, 1])

    def head():
        s = _polygon(
            [(-0.035, 0.84), (0.035, 0.84), (0.12, 1.0), (0.12, 1.06), (-0.12, 1.06), (-0.12, 1.0)]
        )
        for k in range(4):
            x = -0.1 + k * 0.0667
            s = s | _box(x, 1.2, 0.038, 0.3, r=0.018)
        return s, _metal(0.7, 90)

    _utensil(cv, ang, head, 0.7)


def _draw_spoon(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(20.0, 32.0) * rng.choice([-1, 1])

    def head():
        s = _ellipse(0, 1.08, 0.14, 0.23) | _polygon(
            [(-0.035, 0.84), (0.035, 0.84), (0.05, 0.9), (-0.05, 0.9)]
        )

        def concave(x, y):
            u, v = x / 0.14, (y - 1.08) / 0.23
            return np.clip(
                0.45
                + 0.35 * u
                - 0.25 * v
                + 0.45 * np.exp(-((u - 0.3) ** 2 + (v + 0.3) ** 2) / 0.08),
                0,
                1,
            )

        return s, concave

    _utensil(cv, ang, head, 0.72)


def _draw_toothbrush(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(28.0, 38.0) * rng.choice([-1, 1])
    base = rng.uniform(0.6, 0.85)
    cx, cy = 0.0, 0.7

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, cx, cy)

    handle = _box(0, 0.45, 0.13, 0.8, r=0.06) | _polygon(
        [(-0.05, 0.84), (0.05, 0.84), (0.035, 1.1), (-0.035, 1.1)]
    )
    head = _box(0, 1.2, 0.1, 0.24, r=0.04)
    cv.paint(R(handle | head), _cyl(0, 0.065, base, spec=0.45), outline=OL)
    cv.paint(
        R(_box(0, 0.38, 0.08, 0.46, r=0.04)),
        lambda x, y: 0.15 + 0.15 * (np.sin(y * 160) > 0),
        outline=OL,
    )
    for i in range(6):
        for j in range(2):
            tuft = _box(-0.08 - j * 0.045, 1.1 + i * 0.04, 0.045, 0.032, r=0.008)
            cv.paint(R(tuft), 0.95 - 0.25 * ((i + j) % 2), outline=OL / 2, outline_value=0.4)


def _draw_phone(cv: _Canvas, rng: np.random.Generator) -> None:
    body = _box(0, 0.6, 0.62, 1.16, r=0.08)
    cv.paint(_box(0.315, 0.85, 0.02, 0.16, r=0.008), 0.4)
    cv.paint(body, _lin(-0.3, 1.2, 0.3, 0.0, 0.3, 0.08), outline=OL)
    screen = _box(0, 0.6, 0.55, 1.06, r=0.05)
    wall_v = rng.uniform(0.3, 0.6)
    cv.paint(screen, _lin(0, 1.13, 0, 0.07, wall_v + 0.3, wall_v - 0.2))
    for i in range(5):
        for j in range(4):
            v = rng.uniform(0.15, 1.0)
            cv.paint(
                _box(-0.195 + j * 0.13, 0.96 - i * 0.16, 0.09, 0.09, r=0.025), v, outline=OL / 2
            )
    for j in range(4):
        cv.paint(
            _box(-0.195 + j * 0.13, 0.16, 0.09, 0.09, r=0.025),
            rng.uniform(0.5, 1.0),
            outline=OL / 2,
        )
    cv.paint(_box(0, 0.245, 0.5, 0.003), 0.9)
    cv.paint(_capsule(-0.06, 1.1, 0.06, 1.1, 0.016), 0.02)
    cv.paint(_box(0, 0.1, 0.16, 0.012, r=0.006), 0.9)


def _draw_book(cv: _Canvas, rng: np.random.Generator) -> None:
    cover = rng.uniform(0.15, 0.4)
    cv.paint(
        _polygon([(-0.56, 0.04), (0.56, 0.04), (0.58, 0.8), (0.0, 0.74), (-0.58, 0.8)]),
        cover,
        outline=OL,
    )
    for sx in (-1.0, 1.0):
        page = _polygon(
            [
                (0.0, 0.1),
                (sx * 0.25, 0.14),
                (sx * 0.52, 0.1),
                (sx * 0.53, 0.82),
                (sx * 0.25, 0.86),
                (0.0, 0.8),
            ]
        )
        cv.paint(
            page, lambda x, y: np.clip(0.95 - 0.35 * np.exp(-np.abs(x) / 0.06), 0, 1), outline=OL
        )
        for i in range(12):
            y = 0.74 - i * 0.048
            x = 0.06
            while x < 0.44:
                w = rng.uniform(0.03, 0.09)
                x1 = min(x + w, 0.46)
                bow = 0.04 * (1 - abs((x + x1) / 2 - 0.25) / 0.25)
                cv.paint(_box(sx * (x + x1) / 2, y + bow, x1 - x, 0.014), 0.2)
                x = x1 + 0.02
    cv.paint(_capsule(0, 0.1, 0, 0.8, 0.004), 0.3)


def _draw_wine_glass(cv: _Canvas, rng: np.random.Generator) -> None:
    wine = rng.uniform(0.1, 0.3)
    glass = _cyl(0, 0.25, 0.75, spec=0.5)
    bowl = _ellipse(0, 0.98, 0.26, 0.34) & _below(1.3)
    cv.paint(_ellipse(0, 0.06, 0.28, 0.05), glass, opacity=0.85, outline=OL)
    cv.paint(_box(0, 0.38, 0.04, 0.64, r=0.02), glass, opacity=0.85, outline=OL)
    cv.paint(bowl, glass, opacity=0.6, outline=OL)
    cv.paint(bowl & _below(0.96), _cyl(0, 0.25, wine * 2, spec=0.25), opacity=0.95)
    cv.paint(_ellipse(0, 0.96, 0.255, 0.035), wine * 2.5, outline=OL / 2)
    cv.paint(_stroke(_ellipse(0, 1.3, 0.2, 0.03), 0.012), 0.15)
    cv.paint(_capsule(-0.16, 0.9, -0.13, 1.2, 0.018), 1.0, opacity=0.85)


def _draw_padlock(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.5, 0.7)
    shackle = (
        (_ring(0, 0.68, 0.19, 0.075) & _above(0.68))
        | _box(-0.19, 0.6, 0.075, 0.18)
        | _box(0.19, 0.6, 0.075, 0.18)
    )
    cv.paint(shackle, _metal(0.75, 0), outline=OL)
    body = _box(0, 0.3, 0.62, 0.52, r=0.07)
    cv.paint(body, _cyl(0, 0.31, base, spec=0.4), outline=OL)
    cv.paint(_box(0, 0.5, 0.62, 0.03), base * 0.5)
    cv.paint(_box(0, 0.1, 0.62, 0.03), base * 0.5)
    cv.paint(
        _circle(0, 0.33, 0.06)
        | _polygon([(-0.035, 0.33), (0.035, 0.33), (0.05, 0.2), (-0.05, 0.2)]),
        0.05,
    )
    for sx in (-1.0, 1.0):
        cv.paint(_circle(sx * 0.24, 0.3, 0.02), _sphere(sx * 0.24, 0.3, 0.02, 0.9), outline=OL / 2)


def _draw_headphones(cv: _Canvas, rng: np.random.Generator) -> None:
    base = rng.uniform(0.15, 0.35)
    cy = 0.56
    band = _ring(0, cy, 0.4, 0.08) & _above(cy)
    cv.paint(band, _sphere(0, cy + 0.2, 0.6, base + 0.2), outline=OL)
    pad = _ring(0, cy, 0.35, 0.035) & _above(cy + 0.2)
    cv.paint(pad, lambda x, y: base * 0.6 + 0.2 * (np.sin(np.arctan2(y - cy, x) * 40) > 0))
    for sx in (-1.0, 1.0):
        cv.paint(_box(sx * 0.4, cy - 0.05, 0.05, 0.18), _metal(0.75, 90), outline=OL)
        cv.paint(
            _box(sx * 0.33, 0.32, 0.1, 0.36, r=0.04), _lin(0, 0.5, 0, 0.1, 0.55, 0.3), outline=OL
        )
        cup = _box(sx * 0.43, 0.32, 0.17, 0.44, r=0.08)
        cv.paint(cup, _sphere(sx * 0.43, 0.32, 0.3, base + 0.15), outline=OL)
        cv.paint(_circle(sx * 0.43, 0.32, 0.04), 0.9, outline=OL / 2)


def _draw_screwdriver(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(22.0, 32.0) * rng.choice([-1, 1])
    base = rng.uniform(0.55, 0.8)

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, 0.0, 0.7)

    tip = _polygon([(-0.03, 1.3), (0.03, 1.3), (0.022, 1.4), (-0.022, 1.4)])
    cv.paint(R(_box(0, 0.98, 0.06, 0.66) | tip), _cyl(0, 0.03, 0.75, spec=0.5), outline=OL)
    cv.paint(R(_box(0, 0.62, 0.13, 0.08, r=0.02)), _cyl(0, 0.065, 0.6, spec=0.4), outline=OL)
    handle = _box(0, 0.34, 0.24, 0.52, r=0.1) | _polygon(
        [(-0.1, 0.52), (0.1, 0.52), (0.065, 0.6), (-0.065, 0.6)]
    )
    cv.paint(R(handle), _cyl(0, 0.12, base, spec=0.45), outline=OL)
    for k in range(4):
        groove = _box(-0.075 + k * 0.05, 0.3, 0.022, 0.36, r=0.011)
        cv.paint(R(groove), _cyl(0, 0.12, base * 0.35, spec=0.1))
    cv.paint(R(_box(0, 0.1, 0.2, 0.035, r=0.015)), base * 0.4)


def _draw_shoe(cv: _Canvas, rng: np.random.Generator) -> None:
    upper_v = rng.uniform(0.2, 0.45)
    outline_pts = np.concatenate(
        [
            _bezier([(0.52, 0.1), (0.55, 0.3), (0.54, 0.5), (0.46, 0.58)], 10),
            _bezier([(0.46, 0.58), (0.38, 0.5), (0.3, 0.47), (0.2, 0.52)], 8),
            _bezier([(0.2, 0.52), (0.16, 0.66), (0.08, 0.66), (0.04, 0.58)], 8),
            _bezier([(0.04, 0.58), (-0.1, 0.42), (-0.3, 0.32), (-0.5, 0.27)], 10),
            _bezier([(-0.5, 0.27), (-0.62, 0.24), (-0.66, 0.16), (-0.6, 0.1)], 8),
        ]
    )
    upper = _polygon([tuple(p) for p in outline_pts])
    cv.paint(upper, _lin(0, 0.6, 0, 0.1, upper_v * 1.5, upper_v * 0.8), outline=OL)
    toe = _polygon([tuple(p) for p in outline_pts[-14:]] + [(-0.3, 0.12), (-0.3, 0.3)])
    cv.paint(toe & upper, 0.88, outline=OL)
    for k in range(6):
        cv.paint(_circle(-0.52 + k * 0.035, 0.2 + 0.012 * k, 0.007), 0.45)
    heel = _polygon([(0.53, 0.1), (0.38, 0.1), (0.42, 0.46), (0.5, 0.56)]) & upper
    cv.paint(heel, 0.82, outline=OL)
    stripe = _polygon(
        [tuple(p) for p in _bezier([(-0.2, 0.16), (0.0, 0.2), (0.15, 0.3), (0.3, 0.4)], 10)]
        + [tuple(p) for p in _bezier([(0.28, 0.3), (0.15, 0.22), (0.0, 0.16), (-0.2, 0.16)], 10)]
    )
    cv.paint(stripe, 0.97, outline=OL)
    sole = _box(-0.06, 0.055, 1.2, 0.11, r=0.05)
    cv.paint(sole, _stripes(0.035, 0.93, 0.72, 90), outline=OL)
    eyes_a = [(0.1 - 0.055 * k, 0.56 - 0.045 * k) for k in range(5)]
    eyes_b = [(x - 0.07, y - 0.07) for x, y in eyes_a]
    for k in range(4):
        cv.paint(_capsule(*eyes_a[k], *eyes_b[k + 1], 0.011), 0.96, outline=OL / 2)
        cv.paint(_capsule(*eyes_b[k], *eyes_a[k + 1], 0.011), 0.96, outline=OL / 2)
    for e in eyes_a + eyes_b:
        cv.paint(_circle(*e, 0.013), 0.05)


def _draw_chair(cv: _Canvas, rng: np.random.Generator) -> None:
    wood = rng.uniform(0.45, 0.7)
    grain = _stripes(0.03, wood, wood * 0.8, 0)
    for sx in (-1.0, 1.0):
        cv.paint(_box(sx * 0.26, 0.35, 0.045, 0.5), wood * 0.6, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(_box(sx * 0.28, 1.0, 0.06, 0.9, r=0.02), grain, outline=OL)
    cv.paint(
        _box(0, 1.36, 0.7, 0.14, r=0.04), _lin(0, 1.43, 0, 1.29, wood * 1.2, wood * 0.8), outline=OL
    )
    for k in range(-1, 2):
        cv.paint(_box(k * 0.14, 1.0, 0.06, 0.56), grain, outline=OL)
    seat = _polygon([(-0.4, 0.58), (0.4, 0.58), (0.34, 0.7), (-0.34, 0.7)])
    cv.paint(seat, _lin(0, 0.7, 0, 0.58, wood * 1.25, wood * 0.9), outline=OL)
    cv.paint(_box(0, 0.555, 0.8, 0.05), wood * 0.6, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(_box(sx * 0.36, 0.27, 0.06, 0.56), _cyl(sx * 0.36, 0.03, wood), outline=OL)
    cv.paint(_box(0, 0.2, 0.66, 0.03), wood * 0.7, outline=OL)


def _draw_pen(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(22.0, 34.0) * rng.choice([-1, 1])
    base = rng.uniform(0.15, 0.4)

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, 0.0, 0.7)

    cv.paint(R(_polygon([(-0.035, 0.12), (0.035, 0.12), (0.006, 0.02), (-0.006, 0.02)])), 0.75,
             outline=OL)  # fmt: skip
    cv.paint(R(_box(0, 0.3, 0.085, 0.36, r=0.02)), _cyl(0, 0.043, 0.25, spec=0.3), outline=OL)
    for k in range(6):
        cv.paint(R(_box(0, 0.2 + 0.04 * k, 0.085, 0.012)), 0.08)
    cv.paint(R(_box(0, 0.9, 0.1, 0.84, r=0.04)), _cyl(0, 0.05, base + 0.3, spec=0.5), outline=OL)
    cv.paint(R(_box(0, 1.34, 0.1, 0.04)), _metal(0.8, 90 + ang), outline=OL)
    cv.paint(R(_box(0.065, 1.15, 0.035, 0.42, r=0.015)), _metal(0.75, 90 + ang), outline=OL)
    cv.paint(R(_ellipse(0, 1.4, 0.045, 0.04)), base, outline=OL)


def _draw_watch(cv: _Canvas, rng: np.random.Generator) -> None:
    strap = rng.uniform(0.15, 0.35)
    c = (0.0, 0.62)
    for sy in (-1.0, 1.0):
        band = _box(0, c[1] + sy * 0.42, 0.3, 0.5, r=0.04)
        cv.paint(band, _lin(-0.15, 0, 0.15, 0, strap * 1.4, strap * 0.8), outline=OL)
        for k in range(3):
            cv.paint(_box(0, c[1] + sy * (0.3 + 0.1 * k), 0.26, 0.008), strap * 0.5)
    for k in range(4):
        cv.paint(_ellipse(0, c[1] - 0.44 - 0.06 * k, 0.022, 0.016), 0.05)
    cv.paint(_box(0.3, c[1], 0.07, 0.08, r=0.015), _metal(0.7, 90), outline=OL)
    cv.paint(_circle(*c, 0.3), _sphere(*c, 0.34, 0.75), outline=OL)
    cv.paint(_circle(*c, 0.245), _lin(-0.2, 0.85, 0.2, 0.4, 0.98, 0.8), outline=OL)
    for k in range(12):
        a = k * math.pi / 6
        r0 = 0.19 if k % 3 else 0.16
        p0 = (c[0] + r0 * math.sin(a), c[1] + r0 * math.cos(a))
        p1 = (c[0] + 0.22 * math.sin(a), c[1] + 0.22 * math.cos(a))
        cv.paint(_capsule(*p0, *p1, 0.008 if k % 3 else 0.014), 0.1)
    h, m = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi)
    cv.paint(_capsule(*c, c[0] + 0.11 * math.sin(h), c[1] + 0.11 * math.cos(h), 0.016), 0.05)
    cv.paint(_capsule(*c, c[0] + 0.18 * math.sin(m), c[1] + 0.18 * math.cos(m), 0.011), 0.05)
    cv.paint(_circle(*c, 0.02), 0.3)


def _draw_remote(cv: _Canvas, rng: np.random.Generator) -> None:
    ang = rng.uniform(-12.0, 12.0)
    base = rng.uniform(0.12, 0.3)

    def R(s: _Shape) -> _Shape:
        return _rotate(s, ang, 0.0, 0.6)

    cv.paint(R(_box(0, 0.62, 0.36, 1.2, r=0.08)), _cyl(0, 0.18, base, spec=0.25), outline=OL)
    cv.paint(R(_circle(-0.09, 1.1, 0.04)), 0.5, outline=OL / 2)
    cv.paint(R(_ring(0, 0.84, 0.1, 0.06)), 0.7, outline=OL / 2)
    cv.paint(R(_circle(0, 0.84, 0.04)), 0.85, outline=OL / 2)
    for i in range(4):
        for j in range(3):
            cv.paint(
                R(_box(-0.1 + 0.1 * j, 0.58 - 0.09 * i, 0.07, 0.05, r=0.02)), 0.8, outline=OL / 2
            )
    for j in range(2):
        cv.paint(R(_box(-0.07 + 0.14 * j, 0.17, 0.1, 0.08, r=0.03)), 0.55, outline=OL / 2)


_DRAW: dict[str, Callable[[_Canvas, np.random.Generator], None]] = {
    "cup": _draw_cup,
    "mug": _draw_mug,
    "desk_lamp": _draw_desk_lamp,
    "bottle": _draw_bottle,
    "scissors": _draw_scissors,
    "key": _draw_key,
    "glasses": _draw_glasses,
    "hammer": _draw_hammer,
    "umbrella": _draw_umbrella,
    "teapot": _draw_teapot,
    "clock": _draw_clock,
    "light_bulb": _draw_light_bulb,
    "fork": _draw_fork,
    "spoon": _draw_spoon,
    "toothbrush": _draw_toothbrush,
    "phone": _draw_phone,
    "book": _draw_book,
    "wine_glass": _draw_wine_glass,
    "padlock": _draw_padlock,
    "headphones": _draw_headphones,
    "screwdriver": _draw_screwdriver,
    "shoe": _draw_shoe,
    "chair": _draw_chair,
    "pen": _draw_pen,
    "watch": _draw_watch,
    "remote": _draw_remote,
}


# --------------------------------------------------------------------------------------------
# Backgrounds (metres on the layer's plane, origin on the optical axis, y up)
# --------------------------------------------------------------------------------------------


def _bg_wall(cv: _Canvas, rng: np.random.Generator) -> None:
    x0, y0, x1, y1 = cv.extent
    kind = rng.choice(["bricks", "stripes", "tiles", "diamonds", "dots"])
    v0, v1 = rng.uniform(0.25, 0.45), rng.uniform(0.7, 0.9)
    if kind == "bricks":
        h, w = 0.075, 0.2

        def f(x, y):
            row = np.floor(y / h)
            xs = x + (row % 2) * w / 2
            mortar = (np.mod(y, h) < 0.012) | (np.mod(xs, w) < 0.012)
            tone = 0.08 * np.sin(row * 12.9898 + np.floor(xs / w) * 78.233)
            return np.where(mortar, v1, v0 + tone)

    elif kind == "stripes":
        f = _stripes(rng.uniform(0.06, 0.12), v0, v1, 0.0, duty=rng.uniform(0.3, 0.6))
    elif kind == "tiles":
        s = rng.uniform(0.1, 0.16)

        def f(x, y):
            grout = (np.mod(x, s) < 0.01) | (np.mod(y, s) < 0.01)
            checker = (np.floor(x / s) + np.floor(y / s)) % 2
            return np.where(grout, 0.15, v0 + (v1 - v0) * checker)

    elif kind == "diamonds":
        s = rng.uniform(0.08, 0.14)

        def f(x, y):
            u = np.abs(np.mod(x / s, 1.0) - 0.5) + np.abs(np.mod(y / s, 1.0) - 0.5)
            return np.where(u < 0.3, v0, v1)

    else:
        s = rng.uniform(0.06, 0.1)

        def f(x, y):
            u, v = np.mod(x / s, 1.0) - 0.5, np.mod(y / s + 0.5 * np.floor(x / s), 1.0) - 0.5
            return np.where(u * u + v * v < 0.08, v0, v1)

    cv.fill(f)
    for _ in range(rng.integers(2, 5)):
        cx, cy = rng.uniform(x0, x1), rng.uniform(y0, y1)
        w, h = rng.uniform(0.2, 0.45), rng.uniform(0.2, 0.45)
        cv.paint(_box(cx, cy, w + 0.05, h + 0.05), rng.uniform(0.05, 0.2))
        pic = _box(cx, cy, w, h)
        cv.paint(
            pic, _lin(cx - w / 2, cy, cx + w / 2, cy, rng.uniform(0.4, 1), rng.uniform(0, 0.6))
        )
        for _ in range(rng.integers(2, 6)):
            px, py = cx + rng.uniform(-w / 2, w / 2), cy + rng.uniform(-h / 2, h / 2)
            cv.paint(_circle(px, py, rng.uniform(0.02, 0.08)) & pic, rng.uniform(0, 1))
            cv.paint(_box(px, py, rng.uniform(0.02, 0.12), 0.012) & pic, rng.uniform(0, 1))


def _book_row(
    cv: _Canvas, rng: np.random.Generator, xa: float, xb: float, y_shelf: float, h_max: float
) -> None:
    x = xa + rng.uniform(0.0, 0.03)
    while x < xb - 0.02:
        r = rng.random()
        if r < 0.12:
            x += rng.uniform(0.03, 0.09)
            continue
        if r < 0.3:
            w, h = rng.uniform(0.06, 0.085), min(h_max, rng.uniform(0.26, 0.3))
            w = min(w, xb - x)
            v = rng.uniform(0.1, 0.9)
            cv.paint(
                _box(x + w / 2, y_shelf + h / 2, w, h, r=0.004),
                v,
                outline=0.004,
                outline_value=0.05,
            )
            cv.paint(
                _box(x + w / 2, y_shelf + h * 0.62, w * 0.6, h * 0.25), 0.95 if v < 0.5 else 0.1
            )
            cv.paint(_circle(x + w / 2, y_shelf + h * 0.2, w * 0.18), 0.05)
            x += w + 0.002
            continue
        w, h = rng.uniform(0.018, 0.05), min(h_max, rng.uniform(0.15, 0.28))
        w = min(w, xb - x)
        v = rng.uniform(0.05, 0.95)
        lean = rng.uniform(8, 18) if rng.random() < 0.08 else 0.0
        cx, cy = x + w / 2, y_shelf + h / 2
        book = _rotate(_box(cx, cy, w, h, r=0.002), lean, x + w, y_shelf)
        cv.paint(book, _cyl(cx, w / 2, v, spec=0.1), outline=0.003, outline_value=0.05)
        for _ in range(rng.integers(0, 3)):
            by = rng.uniform(y_shelf + 0.02, y_shelf + h - 0.03)
            band = _rotate(_box(cx, by, w * 0.9, rng.uniform(0.006, 0.025)), lean, x + w, y_shelf)
            cv.paint(band, 1.0 - v if rng.random() < 0.6 else rng.uniform(0, 1))
        x += w + (h * math.sin(math.radians(lean)) if lean else 0.0) + rng.uniform(0.0, 0.004)


def _bg_shelf(cv: _Canvas, rng: np.random.Generator) -> None:
    x0, y0, x1, y1 = cv.extent
    board = rng.uniform(0.45, 0.8)
    left = x0 if rng.random() < 0.5 else rng.uniform(x0, x0 + 0.3)
    right = x1 if rng.random() < 0.5 else rng.uniform(x1 - 0.3, x1)
    cv.paint(_box((left + right) / 2, (y0 + y1) / 2, right - left, y1 - y0 + 0.1), 0.12)
    spacing = rng.uniform(0.3, 0.36)
    ys = np.arange(y0 - rng.uniform(0, spacing), y1 + spacing, spacing)
    posts = np.arange(left, right + 0.01, rng.uniform(0.6, 0.85))
    for y in ys:
        for xa, xb in zip(posts[:-1], posts[1:], strict=False):
            _book_row(cv, rng, xa + 0.025, xb - 0.025, y + 0.012, spacing - 0.05)
        if rng.random() < 0.3:
            _book_row(cv, rng, posts[-1] + 0.025, right - 0.02, y + 0.012, spacing - 0.05)
    for y in ys:
        cv.paint(
            _box((left + right) / 2, y, right - left, 0.025),
            _lin(0, y + 0.012, 0, y - 0.012, board, board * 0.6),
            outline=0.003,
            outline_value=0.1,
        )
    for p in list(posts) + [right]:
        cv.paint(
            _box(p, (y0 + y1) / 2, 0.03, y1 - y0 + 0.1),
            _cyl(p, 0.015, board, spec=0.1),
            outline=0.003,
            outline_value=0.1,
        )


def _shirt(cv: _Canvas, rng: np.random.Generator, cx: float, top: float) -> None:
    w, h = rng.uniform(0.34, 0.44), rng.uniform(0.6, 0.8)
    hook = _ring(cx, top + 0.06, 0.035, 0.008) & _above(top + 0.05)
    cv.paint(hook, 0.6, outline=0.003)
    cv.paint(
        _polygon([(cx, top + 0.03), (cx + w / 2, top - 0.05), (cx - w / 2, top - 0.05)])
        - _polygon(
            [(cx, top + 0.01), (cx + w / 2 - 0.04, top - 0.04), (cx - w / 2 + 0.04, top - 0.04)]
        ),
        0.3,
    )
    # Painted as separate pieces (sleeves, torso, shoulders): a union would evaluate every
    # piece's distance over the whole shirt, and the seams between pieces look like seams.
    pieces = [
        _box(cx + sx * (w / 2 + 0.02), top - 0.17, 0.11, 0.25, r=0.01, angle_deg=sx * 18.0)
        for sx in (-1.0, 1.0)
    ]
    pieces.append(_box(cx, top - (h + 0.05) / 2, w - 0.03, h - 0.05, r=0.01))
    pieces.append(
        _polygon(
            [
                (cx - 0.06, top),
                (cx + 0.06, top),
                (cx + w / 2, top - 0.05),
                (cx + w / 2 - 0.015, top - 0.09),
                (cx - w / 2 + 0.015, top - 0.09),
                (cx - w / 2, top - 0.05),
            ]
        )
    )
    pat = rng.choice(["stripes", "check", "solid", "hstripes"])
    v0, v1 = rng.uniform(0.05, 0.45), rng.uniform(0.55, 0.95)
    if pat == "stripes":
        base = _stripes(rng.uniform(0.025, 0.06), v0, v1, 0)
    elif pat == "hstripes":
        base = _stripes(rng.uniform(0.03, 0.07), v0, v1, 90)
    elif pat == "check":
        p = rng.uniform(0.05, 0.09)

        def base(x, y):
            return v0 + (v1 - v0) * 0.5 * (
                (np.mod(x, p) < p / 2).astype(float) + (np.mod(y, p) < p / 2)
            )

    else:

        def base(x, y):
            return np.full_like(x, v0 + 0.2)

    def folds(x, y):
        return np.clip(base(x, y) * (0.8 + 0.2 * np.sin((x - cx) * 60 + y * 5)), 0, 1)

    for piece in pieces:
        cv.paint(piece, folds, outline=0.004, outline_value=0.05)
    cv.paint(
        _polygon([(cx - 0.06, top), (cx, top - 0.07), (cx + 0.06, top), (cx, top - 0.02)]),
        0.9,
        outline=0.003,
    )
    if pat == "solid":
        for k in range(5):
            cv.paint(_circle(cx, top - 0.12 - k * 0.1, 0.008), 0.95)


def _bg_clothes(cv: _Canvas, rng: np.random.Generator) -> None:
    x0, y0, x1, y1 = cv.extent
    rail_y = y1 - rng.uniform(0.05, 0.2)
    side = rng.choice([-1, 1])
    xa, xb = (x0, rng.uniform(-0.1, 0.25)) if side < 0 else (rng.uniform(-0.25, 0.1), x1)
    cv.paint(
        _capsule(xa, rail_y, xb, rail_y, 0.012),
        _cyl(rail_y, 0.012, 0.8, spec=0.3, axis="y"),
        outline=0.003,
    )
    xs = np.sort(rng.uniform(xa + 0.1, xb - 0.1, size=rng.integers(4, 8)))
    for x in xs:
        _shirt(cv, rng, float(x), rail_y - 0.02)


def _bg_pinboard(cv: _Canvas, rng: np.random.Generator) -> None:
    x0, y0, x1, y1 = cv.extent
    side = rng.choice([-1, 1])
    w, h = rng.uniform(0.5, 0.8), rng.uniform(0.45, 0.65)
    cx = side * rng.uniform(0.15, 0.35)
    cy = rng.uniform(y1 - h / 2 - 0.2, y1 - h / 2)
    cork = _noise(rng, cv.shape, 1.0)
    board = _box(cx, cy, w, h)
    rs, cs = cv._grid(_BIG, 0)[0]  # whole-canvas slices, for indexing the noise

    def cork_f(x, y):
        rr = np.clip(np.round(cv.r0 - y * cv.ppu).astype(int), 0, cv.shape[0] - 1)
        cc = np.clip(np.round(cv.c0 + x * cv.ppu).astype(int), 0, cv.shape[1] - 1)
        return np.clip(0.55 + 0.25 * cork[rr, cc], 0, 1)

    del rs, cs
    cv.paint(_box(cx, cy, w + 0.04, h + 0.04), 0.25, outline=0.004)
    cv.paint(board, cork_f)
    for _ in range(rng.integers(5, 10)):
        px, py = (
            cx + rng.uniform(-w / 2 + 0.05, w / 2 - 0.05),
            cy + rng.uniform(-h / 2 + 0.06, h / 2 - 0.06),
        )
        pw, ph = rng.uniform(0.08, 0.18), rng.uniform(0.08, 0.2)
        ang = rng.uniform(-12, 12)
        note = _rotate(_box(px, py, pw, ph), ang, px, py)
        cv.paint(note, rng.choice([0.95, 0.85, 0.75]), outline=0.002, outline_value=0.3)
        for k in range(int(ph / 0.018) - 1):
            ly = py + ph / 2 - 0.02 - k * 0.018
            lw = pw * rng.uniform(0.4, 0.8)
            cv.paint(_rotate(_box(px - pw / 2 + 0.01 + lw / 2, ly, lw, 0.005), ang, px, py), 0.15)
        cv.paint(_circle(px, py + ph / 2 - 0.012, 0.01), rng.uniform(0, 0.4), outline=0.002)


def _bg_cables(cv: _Canvas, rng: np.random.Generator) -> None:
    x0, y0, x1, y1 = cv.extent
    for _ in range(rng.integers(3, 7)):
        if rng.random() < 0.6:  # hanging from the top
            xa, xb = rng.uniform(x0, x1, 2)
            p = [
                (xa, y1 + 0.05),
                (xa + rng.uniform(-0.2, 0.2), rng.uniform(y0, y1)),
                (xb + rng.uniform(-0.2, 0.2), rng.uniform(y0, y1)),
                (xb, rng.choice([y0 - 0.05, y1 + 0.05])),
            ]
        else:  # across
            p = [
                (x0 - 0.05, rng.uniform(y0, y1)),
                (rng.uniform(x0, x1), rng.uniform(y0 - 0.2, y1)),
                (rng.uniform(x0, x1), rng.uniform(y0 - 0.2, y1)),
                (x1 + 0.05, rng.uniform(y0, y1)),
            ]
        pts = _bezier(p, 24)
        r = rng.uniform(0.003, 0.007)
        v = rng.uniform(0.02, 0.2) if rng.random() < 0.7 else rng.uniform(0.75, 0.95)
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            cv.paint(_capsule(a[0], a[1], b[0], b[1], r), v)
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            cv.paint(
                _capsule(a[0] - r / 3, a[1] + r / 3, b[0] - r / 3, b[1] + r / 3, r / 4),
                min(1.0, v + 0.35),
            )


# --------------------------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------------------------


def _kind(kind: str | ObjectKind) -> ObjectKind:
    name = kind.name if isinstance(kind, ObjectKind) else kind
    for k in _KINDS:
        if k.name == name:
            return k
    raise InputError(f"kind must be one of {[k.name for k in _KINDS]}, got {name!r}")


def _texture_shape(camera: ThinLensCamera, margin_px: int) -> tuple[int, int]:
    return (camera.shape_px[0] + 2 * margin_px, camera.shape_px[1] + 2 * margin_px)


def object_width_px(camera: ThinLensCamera) -> float:
    """Return the image width of a 10 deg wide object seen by ``camera``, pixels.

    Parameters
    ----------
    camera : ThinLensCamera

    Returns
    -------
    float
        ``2 * focal_length_px * tan(5 deg)`` (pinhole projection of an object centred on the
        axis); about 194 px for the paper's 492 px wide, 25 deg field.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (objects about 10 deg wide).

    Examples
    --------
    >>> round(object_width_px(ThinLensCamera()), 1)
    194.2
    """
    return 2.0 * camera.focal_length_px * math.tan(math.radians(OBJECT_WIDTH_DEG) / 2.0)


def make_scene(
    kind: str | ObjectKind,
    *,
    rng: np.random.Generator | int | None = None,
    camera: ThinLensCamera | None = None,
    margin_px: int | None = None,
) -> list[Layer]:
    """Build the layered scene of one object in front of its own cluttered background.

    Parameters
    ----------
    kind : str or ObjectKind
        One of :func:`object_kinds` (by ``name``).
    rng : numpy.random.Generator, int or None
        Source of all random choices (object variant and background).
    camera : ThinLensCamera, optional
        Sets the image size and projection. Default: ``ThinLensCamera()``.
    margin_px : int >= 0, optional
        Texture margin around the camera image on each side, pixels. Default: 10 % of the
        image width.

    Returns
    -------
    list of Layer
        Farthest first: a wall (2.7-3.0 m), a shelf (2.0-2.6 m), clothes or a pin board
        (1.6-2.0 m), cables (1.5-1.7 m), and the object (``"object:<name>"``) at the camera's
        focus distance, 10 deg wide, bottom centre. Textures have shape
        ``(rows + 2 * margin_px, cols + 2 * margin_px)``.

    Raises
    ------
    InputError
        If ``kind`` is unknown or ``margin_px`` is negative.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (objects about 10 deg wide at ~80 cm in front of shelves,
    clothes, wires and files).
    """
    k = _kind(kind)
    rng = np.random.default_rng(rng)
    # The object gets its own stream, drawn first: how many numbers the background uses
    # (which varies with the image size) then never changes the object.
    obj_rng = np.random.default_rng(rng.integers(0, 2**63))
    cam = ThinLensCamera() if camera is None else camera
    if not isinstance(cam, ThinLensCamera):
        raise InputError(f"camera must be a ThinLensCamera, got {type(cam).__name__}")
    if margin_px is None:
        margin_px = int(round(_MARGIN_FRACTION * cam.shape_px[1]))
    if isinstance(margin_px, bool) or not isinstance(margin_px, (int, np.integer)) or margin_px < 0:
        raise InputError(f"margin_px must be an integer >= 0, got {margin_px!r}")
    shape = _texture_shape(cam, int(margin_px))
    centre = ((shape[0] - 1) / 2.0, (shape[1] - 1) / 2.0)
    f_px = cam.focal_length_px

    layers = []
    near, far = BACKGROUND_DEPTHS_M
    depths = {
        "wall": rng.uniform(2.7, far),
        "shelf": rng.uniform(2.0, 2.6),
        "middle": rng.uniform(1.6, 2.0),
        "cables": rng.uniform(near, 1.7),
    }
    for name, draw in (
        ("wall", _bg_wall),
        ("shelf", _bg_shelf),
        ("middle", _bg_clothes if rng.random() < 0.5 else _bg_pinboard),
        ("cables", _bg_cables),
    ):
        cv = _Canvas(shape, f_px / depths[name], centre)
        draw(cv, rng)
        label = draw.__name__.removeprefix("_bg_")
        layer = cv.layer(label, depths[name])
        # The background is lit less evenly than the object on the table: its contrast is
        # lowered around mid-grey by a random factor (ours; it brings the wide-DOF edge
        # fraction of the set near the paper's, see _BACKGROUND_CONTRAST).
        contrast = rng.uniform(*_BACKGROUND_CONTRAST)
        tex = (0.5 + contrast * (layer.texture - 0.5)).astype(np.float32)
        layers.append(Layer(layer.name, tex, layer.alpha, layer.depth_m))

    r0, _ = centre_crop_offset(shape, cam.shape_px)
    bottom_row = r0 + cam.shape_px[0] - 1 - _BASE_GAP_FRACTION * cam.shape_px[0]
    scale = obj_rng.uniform(0.94, 1.06)
    centre_col = centre[1] + obj_rng.uniform(-0.03, 0.03) * object_width_px(cam)
    obj = _Canvas(shape, object_width_px(cam) * scale, (bottom_row, centre_col))
    _DRAW[k.name](obj, obj_rng)
    obj.place(bottom_row, centre_col)
    layers.append(obj.layer(f"object:{k.name}", cam.focus_m))
    return layers


def object_mask(layers: Sequence[Layer], camera: ThinLensCamera) -> np.ndarray:
    """Return the object layer's alpha cropped to the camera image, float32 in [0, 1].

    Parameters
    ----------
    layers : sequence of Layer
        A scene from :func:`make_scene` (its one layer named ``"object:..."``).
    camera : ThinLensCamera

    Returns
    -------
    ndarray of shape ``camera.shape_px``, float32 in [0, 1]

    Raises
    ------
    InputError
        If no layer's name starts with ``"object:"``.
    """
    for layer in layers:
        if layer.name.startswith("object:"):
            r0, c0 = centre_crop_offset(layer.alpha.shape, camera.shape_px)
            rows, cols = camera.shape_px
            return np.ascontiguousarray(
                layer.alpha[r0 : r0 + rows, c0 : c0 + cols], dtype=np.float32
            )
    raise InputError("layers must hold one layer named 'object:<kind>', found none")


# --------------------------------------------------------------------------------------------
# PAIRS folder
# --------------------------------------------------------------------------------------------


#: Kinds used for main objects, in order: the 20 main kinds, then the spares (ours).
_MAIN_ORDER: tuple[int, ...] = (*range(20), *range(23, len(_KINDS)))
#: Kinds used for training objects, in order (ours).
_TRAINING_ORDER: tuple[int, ...] = (20, 21, 22)


def _assign_kinds(n_main: int, n_training: int) -> tuple[list[ObjectKind], list[ObjectKind]]:
    """Main kinds first from the main order; training kinds from what is left."""
    order = list(_MAIN_ORDER) + list(_TRAINING_ORDER)
    main = order[:n_main]
    left = [i for i in list(_TRAINING_ORDER) + list(_MAIN_ORDER)[::-1] if i not in main]
    return [_KINDS[i] for i in main], [_KINDS[i] for i in left[:n_training]]


def _check_count(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def write_pairs(
    out_dir: str | os.PathLike,
    *,
    n_objects: int = 20,
    n_training: int = 3,
    seed: int = 0,
    shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX,
) -> Path:
    """Render synthetic photo pairs and write a PAIRS folder for the stimulus builder.

    Main objects are drawn from the 20 main kinds of :func:`object_kinds` (then the spare
    kinds), training objects from the 3 training kinds (then unused main kinds, last first).
    Main object ``i`` (0-based) is drawn from ``SeedSequence(seed, spawn_key=(0, i))`` and
    training object ``j`` from ``spawn_key=(1, j)``, so a scene does not depend on how many
    objects are written.

    Layout of ``out_dir``:

    =============================  =============================================================
    ``objNN_<kind>/wide.png``      f/22 photo, 8-bit grey, ``shape_px``
    ``objNN_<kind>/narrow.png``    f/1.7 photo, 8-bit grey, ``shape_px``
    ``objNN_<kind>/mask.png``      the object's alpha (coverage, 255 = object), for tests
    ``trainNN_<kind>/...``         the same for training objects
    ``objects.csv``                one row per object, columns :data:`OBJECTS_CSV_COLUMNS`
    ``synth.json``                 seed, camera, depths and package version (provenance)
    =============================  =============================================================

    ``objects.csv`` columns: ``object`` (folder name), ``name`` (display name), ``synonyms``
    and ``uses`` (``;``-separated), ``role`` (``main`` or ``training``); ``sobel_threshold``,
    ``crop``, ``plane_depth_m`` and ``plane_disparity_px`` are left empty for the builder.

    Parameters
    ----------
    out_dir : str or path-like
        Folder to create: a new or empty folder (a non-empty one is refused, never replaced).
        Written to a staging folder beside it and renamed at the end.
    n_objects : int >= 1
        Main objects.
    n_training : int >= 0
        Training objects (after the main ones); ``n_objects + n_training`` at most the number
        of :func:`object_kinds` (26).
    seed : int >= 0
        Seed of every random choice.
    shape_px : (rows, cols)
        Photo size, pixels (the paper's working size by default; e.g. ``(1024, 1536)`` for the
        benchmark). Each at least 32.

    Returns
    -------
    Path
        ``out_dir``.

    Raises
    ------
    InputError
        If ``out_dir`` exists and is not empty or is a file, or a count,
        ``seed`` or ``shape_px`` is invalid.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (20 objects, f/1.7 and f/22 photos).
    """
    n_obj = _check_count("n_objects", n_objects, 1)
    n_tr = _check_count("n_training", n_training, 0)
    if n_obj + n_tr > len(_KINDS):
        raise InputError(
            f"n_objects + n_training must be <= {len(_KINDS)} (the kinds available), "
            f"got {n_obj} + {n_tr}"
        )
    seed_i = _check_count("seed", seed, 0)
    try:
        rows, cols = (int(v) for v in shape_px)
    except (TypeError, ValueError):
        raise InputError(f"shape_px must be (rows, cols), got {shape_px!r}") from None
    if rows < 32 or cols < 32:
        raise InputError(f"shape_px must be at least (32, 32), got {shape_px!r}")
    out = Path(out_dir)
    check_missing_or_empty(out)

    camera = ThinLensCamera(shape_px=(rows, cols))
    main_kinds, training_kinds = _assign_kinds(n_obj, n_tr)
    jobs = [("main", i, k) for i, k in enumerate(main_kinds)]
    jobs += [("training", i, k) for i, k in enumerate(training_kinds)]
    with staged_folder(out) as tmp:
        records = []
        scenes = []
        for role, i, kind in jobs:
            prefix = "obj" if role == "main" else "train"
            folder = f"{prefix}{i + 1:02d}_{kind.name}"
            # One independent stream per (role, index): an object's scene does not depend on
            # how many objects of either role are written.
            child = np.random.SeedSequence(seed_i, spawn_key=(int(role == "training"), i))
            layers = make_scene(kind, rng=np.random.default_rng(child), camera=camera)
            wide, narrow = render_pair(layers, camera=camera)
            d = tmp / folder
            d.mkdir()
            save_png(wide, d / "wide.png")
            save_png(narrow, d / "narrow.png")
            save_png(object_mask(layers, camera), d / "mask.png")
            records.append(
                {
                    "object": folder,
                    "name": kind.display_name,
                    "synonyms": ";".join(kind.synonyms),
                    "uses": ";".join(kind.uses),
                    "role": role,
                    "sobel_threshold": "",
                    "crop": "",
                    "plane_depth_m": "",
                    "plane_disparity_px": "",
                }
            )
            scenes.append(
                {
                    "object": folder,
                    "layers": [{"name": la.name, "depth_m": round(la.depth_m, 4)} for la in layers],
                }
            )
        with open(tmp / "objects.csv", "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=list(OBJECTS_CSV_COLUMNS))
            w.writeheader()
            w.writerows(records)
        from stimuli import __version__

        meta = {
            "generator": "stimuli.synth.write_pairs",
            "version": __version__,
            "seed": seed_i,
            "n_objects": n_obj,
            "n_training": n_tr,
            "camera": {
                "shape_px": [rows, cols],
                "focal_length_mm": camera.focal_length_mm,
                "hfov_deg": camera.hfov_deg,
                "focus_m": camera.focus_m,
                "wide_f_number": jung2015.WIDE_F_NUMBER,
                "narrow_f_number": jung2015.NARROW_F_NUMBER,
            },
            "object_width_deg": OBJECT_WIDTH_DEG,
            "scenes": scenes,
        }
        (tmp / "synth.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
    return out
