"""Signed-distance drawing kit: shapes, shading fields and the canvas they are painted on.

Every part of a synthetic scene is a :class:`Shape` (a signed-distance function, negative
inside, plus a bounding box) painted on a :class:`Canvas` with a grey value or a shading field
(:data:`Field`), anti-aliased over one pixel. Everything is evaluated on whole-array numpy grids;
loops run only over shapes and polygon vertices.

Coordinates are the caller's drawing units (object units for objects, metres on the layer's plane
for backgrounds), with y up.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

from stimuli.scene import Layer

__all__ = [
    "Field",
    "Value",
    "Shape",
    "Canvas",
    "circle",
    "ellipse",
    "box",
    "capsule",
    "polygon",
    "ring",
    "stroke",
    "halfplane",
    "above",
    "below",
    "rotate",
    "rotator",
    "translate",
    "random_tilt_deg",
    "bezier",
    "cylinder",
    "sphere",
    "gradient",
    "stripes",
    "metal",
    "smooth_noise",
    "OUTLINE_UNITS",
    "OUTLINE_VALUE",
]

#: Width of the dark outline drawn around object parts, object units (about 1.5 px at 492x327).
OUTLINE_UNITS = 0.008

#: Grey level of the outline (ours: near black, like the ink line of a drawing).
OUTLINE_VALUE = 0.06


#: A grey value (or signed distance) as a function of ``(x, y)`` arrays that broadcast, units.
Field = Callable[[np.ndarray, np.ndarray], np.ndarray]
#: What a shape is painted with: a constant grey level in [0, 1] or a shading field.
Value = float | Field


@dataclass(frozen=True)
class Shape:
    """A region given by its signed distance (negative inside, units) and a bounding box."""

    sdf: Field
    bbox: tuple[float, float, float, float]  # x0, y0, x1, y1

    def __or__(self, other: Shape) -> Shape:
        a, b = self, other
        box = (*map(min, a.bbox[:2], b.bbox[:2]), *map(max, a.bbox[2:], b.bbox[2:]))
        return Shape(lambda x, y: np.minimum(a.sdf(x, y), b.sdf(x, y)), box)

    def __and__(self, other: Shape) -> Shape:
        a, b = self, other
        box = (*map(max, a.bbox[:2], b.bbox[:2]), *map(min, a.bbox[2:], b.bbox[2:]))
        return Shape(lambda x, y: np.maximum(a.sdf(x, y), b.sdf(x, y)), box)

    def __sub__(self, other: Shape) -> Shape:
        a, b = self, other
        return Shape(lambda x, y: np.maximum(a.sdf(x, y), -b.sdf(x, y)), a.bbox)


def circle(cx: float, cy: float, r: float) -> Shape:
    """Return the disc of radius ``r`` centred on ``(cx, cy)``, units."""
    return Shape(lambda x, y: np.hypot(x - cx, y - cy) - r, (cx - r, cy - r, cx + r, cy + r))


def ellipse(cx: float, cy: float, rx: float, ry: float) -> Shape:
    """Return the axis-aligned ellipse with half-axes ``rx``, ``ry`` (approximate distance)."""

    def sdf(x, y):
        px, py = (x - cx) / rx, (y - cy) / ry
        k0 = np.hypot(px, py)
        k1 = np.hypot(px / rx, py / ry)
        return k0 * (k0 - 1.0) / np.maximum(k1, 1e-9)

    return Shape(sdf, (cx - rx, cy - ry, cx + rx, cy + ry))


def box(cx: float, cy: float, w: float, h: float, r: float = 0.0, angle_deg: float = 0.0) -> Shape:
    """Return a ``w`` by ``h`` box centred on ``(cx, cy)``.

    Corner radius ``r``, turned by ``angle_deg``.
    """
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
    return Shape(sdf, (cx - ext_x, cy - ext_y, cx + ext_x, cy + ext_y))


def capsule(x0: float, y0: float, x1: float, y1: float, r: float) -> Shape:
    """Return the segment from ``(x0, y0)`` to ``(x1, y1)`` thickened by radius ``r``."""
    ex, ey = x1 - x0, y1 - y0
    ee = max(ex * ex + ey * ey, 1e-12)

    def sdf(x, y):
        wx, wy = x - x0, y - y0
        t = np.clip((wx * ex + wy * ey) / ee, 0.0, 1.0)
        return np.hypot(wx - ex * t, wy - ey * t) - r

    return Shape(sdf, (min(x0, x1) - r, min(y0, y1) - r, max(x0, x1) + r, max(y0, y1) + r))


def polygon(points: Sequence[tuple[float, float]]) -> Shape:
    """Return the polygon with these vertices (any winding; exact signed distance)."""
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

    return Shape(sdf, (v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()))


def ring(cx: float, cy: float, r: float, width: float) -> Shape:
    """Return the annulus of radius ``r`` and thickness ``width`` centred on ``(cx, cy)``."""
    h = width / 2.0
    return Shape(
        lambda x, y: np.abs(np.hypot(x - cx, y - cy) - r) - h,
        (cx - r - h, cy - r - h, cx + r + h, cy + r + h),
    )


def stroke(shape: Shape, width: float) -> Shape:
    """Return the band of thickness ``width`` along the outline of ``shape``."""
    h = width / 2.0
    x0, y0, x1, y1 = shape.bbox
    return Shape(lambda x, y: np.abs(shape.sdf(x, y)) - h, (x0 - h, y0 - h, x1 + h, y1 + h))


def halfplane(nx: float, ny: float, c: float, bbox: tuple[float, float, float, float]) -> Shape:
    """Return the points with ``nx * x + ny * y <= c`` (``(nx, ny)`` a unit normal), in ``bbox``."""
    return Shape(lambda x, y: nx * x + ny * y - c, bbox)


#: Bounding box of a half-plane: far beyond any drawing, units or metres.
_EVERYWHERE = (-1e3, -1e3, 1e3, 1e3)


def above(y0: float) -> Shape:
    """Return the half-plane ``y >= y0``."""
    return halfplane(0.0, -1.0, -y0, _EVERYWHERE)


def below(y0: float) -> Shape:
    """Return the half-plane ``y <= y0``."""
    return halfplane(0.0, 1.0, y0, _EVERYWHERE)


def rotate(shape: Shape, angle_deg: float, cx: float, cy: float) -> Shape:
    """Return ``shape`` turned by ``angle_deg`` (counter-clockwise) about ``(cx, cy)``."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def sdf(x, y):
        dx, dy = x - cx, y - cy
        return shape.sdf(cx + c * dx + s * dy, cy - s * dx + c * dy)

    x0, y0, x1, y1 = shape.bbox
    corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]]) - [cx, cy]
    rx = cx + c * corners[:, 0] - s * corners[:, 1]
    ry = cy + s * corners[:, 0] + c * corners[:, 1]
    return Shape(sdf, (rx.min(), ry.min(), rx.max(), ry.max()))


def rotator(angle_deg: float, cx: float, cy: float) -> Callable[[Shape], Shape]:
    """Return a function that turns a shape by ``angle_deg`` about ``(cx, cy)`` (tilted objects)."""

    def turn(shape: Shape) -> Shape:
        return rotate(shape, angle_deg, cx, cy)

    return turn


def translate(shape: Shape, dx: float, dy: float) -> Shape:
    """Return ``shape`` moved by ``(dx, dy)``, units."""
    x0, y0, x1, y1 = shape.bbox
    return Shape(lambda x, y: shape.sdf(x - dx, y - dy), (x0 + dx, y0 + dy, x1 + dx, y1 + dy))


def random_tilt_deg(rng: np.random.Generator, low_deg: float, high_deg: float) -> float:
    """Return a tilt of ``low_deg`` to ``high_deg``, to the left or right at random, degrees."""
    return rng.uniform(low_deg, high_deg) * rng.choice([-1, 1])


def bezier(points: Sequence[tuple[float, float]], n: int = 24) -> np.ndarray:
    """Return ``n`` points along the cubic Bezier curve of four control points, shape (n, 2)."""
    p = np.asarray(points, dtype=np.float64)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (
        (1 - t) ** 3 * p[0] + 3 * (1 - t) ** 2 * t * p[1] + 3 * (1 - t) * t**2 * p[2] + t**3 * p[3]
    )


def cylinder(xc: float, half_w: float, base: float, *, spec: float = 0.3, axis: str = "x") -> Field:
    """Return the shading of an upright cylinder lit from the upper left (diffuse + highlight)."""

    def f(x, y):
        u = np.clip(((x if axis == "x" else y) - xc) / half_w, -1.0, 1.0)
        nz = np.sqrt(1.0 - u * u)
        diffuse = np.clip(0.8 * nz - 0.45 * u, 0.0, 1.0)
        hl = spec * np.exp(-(((u + 0.45) / 0.12) ** 2))
        return np.clip(base * (0.35 + 0.75 * diffuse) + hl, 0.0, 1.0)

    return f


def sphere(cx: float, cy: float, r: float, base: float, *, spec: float = 0.35) -> Field:
    """Return the shading of a sphere (or a bulging surface) lit from the upper left."""

    def f(x, y):
        u, v = (x - cx) / r, (y - cy) / r
        nz = np.sqrt(np.clip(1.0 - u * u - v * v, 0.0, 1.0))
        diffuse = np.clip(-0.45 * u + 0.5 * v + 0.74 * nz, 0.0, 1.0)
        hl = spec * np.exp(-(((u + 0.35) ** 2 + (v - 0.4) ** 2) / 0.03))
        return np.clip(base * (0.3 + 0.8 * diffuse) + hl, 0.0, 1.0)

    return f


def gradient(x0: float, y0: float, x1: float, y1: float, v0: float, v1: float) -> Field:
    """Return the linear gradient from ``v0`` at (x0, y0) to ``v1`` at (x1, y1)."""
    ex, ey = x1 - x0, y1 - y0
    ee = max(ex * ex + ey * ey, 1e-12)

    def f(x, y):
        t = np.clip(((x - x0) * ex + (y - y0) * ey) / ee, 0.0, 1.0)
        return v0 + (v1 - v0) * t

    return f


def stripes(
    period: float, v0: float, v1: float, angle_deg: float = 0.0, duty: float = 0.5
) -> Field:
    """Return hard stripes across the direction ``angle_deg`` (0 = vertical stripes)."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def f(x, y):
        t = np.mod((c * x + s * y) / period, 1.0)
        return np.where(t < duty, v0, v1)

    return f


def metal(base: float, angle_deg: float = 0.0) -> Field:
    """Return polished metal: soft bands of reflection along ``angle_deg``."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))

    def f(x, y):
        t = c * x + s * y
        return np.clip(base + 0.22 * np.sin(t * 23.0) + 0.12 * np.sin(t * 57.0 + 1.0), 0.0, 1.0)

    return f


class Canvas:
    """Premultiplied luminance + alpha texture with a units-to-pixels mapping (y up).

    Parameters
    ----------
    shape_px : (rows, cols)
    px_per_unit : float
        Pixels per drawing unit (object units or metres on the layer's plane).
    origin_rc : (row, col)
        Pixel position of the drawing's origin (may be fractional).
    """

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
        shape: Shape,
        value: Value,
        *,
        opacity: float = 1.0,
        outline: float = 0.0,
        outline_value: float = OUTLINE_VALUE,
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


def smooth_noise(rng: np.random.Generator, shape: tuple[int, int], sigma_px: float) -> np.ndarray:
    """Return smooth noise in [-1, 1] (Gaussian-filtered white noise, normalised)."""
    n = gaussian_filter(rng.standard_normal(shape), sigma_px, mode="wrap")
    return n / (np.abs(n).max() + 1e-12)
