"""The light-field type: a grid of views (:class:`LightField`) and its geometry (:class:`Geometry`).

Conventions (view order, centre view, the sign of disparity) are those of :mod:`stimuli.lightfield`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from stimuli.errors import InputError
from stimuli.io import luma

__all__ = ["Geometry", "LightField", "ANISOTROPY_RATIO", "is_one_dimensional"]


#: A grid with at least this many times more views along one axis than the other is treated as
#: 1-D by ``declutter='auto'`` (ours: refocusing then blurs three times more along one axis).
ANISOTROPY_RATIO: float = 3.0


def is_one_dimensional(grid: tuple[int, int]) -> bool:
    """Return whether a view grid ``(n_u, n_v)`` is 1-D or strongly anisotropic.

    Examples
    --------
    >>> is_one_dimensional((1, 7)), is_one_dimensional((3, 9)), is_one_dimensional((7, 7))
    (True, True, False)
    """
    a, b = sorted(int(v) for v in grid)
    return a == 1 or b >= ANISOTROPY_RATIO * a


@dataclass(frozen=True)
class Geometry:
    """How disparity (pixels per view step) relates to depth (metres).

    Parameters
    ----------
    kind : {'camera_array', 'lens_array'}
    focal_length_px : float > 0
        Camera array: focal length of each view, pixels.
    baseline_m : float > 0
        Camera array: distance between neighbouring views, metres.
    convergence_m : float > 0
        Camera array: depth of zero disparity (``inf`` for parallel cameras).
    lens_pitch_mm, lens_focal_mm : float > 0
        Lens array: lenslet pitch and focal length (the lens-to-sensor gap), mm.
    relay_minification : float > 0
        Lens array: the relay optics shrink the scene by this factor in width *and* depth (ours,
        a simplification: the intermediate image is modelled as the scene scaled uniformly).
    pixel_mm : float > 0
        Lens array: sensor pixel size, mm.
    near_m, far_m : float or None
        Range of depths this geometry may be asked about, metres.
    """

    kind: Literal["camera_array", "lens_array"]
    focal_length_px: float | None = None
    baseline_m: float | None = None
    convergence_m: float = math.inf
    lens_pitch_mm: float | None = None
    lens_focal_mm: float | None = None
    relay_minification: float = 1.0
    pixel_mm: float | None = None
    near_m: float | None = None
    far_m: float | None = None

    def __post_init__(self) -> None:
        self._check_kind()
        self._check_positive()
        self._check_range()

    def _check_kind(self) -> None:
        if self.kind not in ("camera_array", "lens_array"):
            raise InputError(
                f"geometry kind must be 'camera_array' or 'lens_array', got {self.kind!r}"
            )

    def _check_positive(self) -> None:
        needed = (
            ("focal_length_px", "baseline_m")
            if self.kind == "camera_array"
            else ("lens_pitch_mm", "lens_focal_mm", "pixel_mm")
        )
        for name in (*needed, "convergence_m", "relay_minification"):
            value = getattr(self, name)
            if value is None or not (isinstance(value, (int, float)) and value > 0):
                raise InputError(f"geometry {name} must be a number > 0, got {value!r}")

    def _check_range(self) -> None:
        for name in ("near_m", "far_m"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"geometry {name} must be a finite number > 0, got {v!r}")
        if self.near_m is not None and self.far_m is not None and self.near_m >= self.far_m:
            raise InputError(
                f"geometry near_m must be < far_m, got {self.near_m!r} and {self.far_m!r}"
            )

    def check_depth(self, depth_m: float) -> float:
        """Return ``depth_m`` as a float, or raise if it is outside the geometry's range."""
        try:
            z = float(depth_m)
        except (TypeError, ValueError):
            raise InputError(f"depth_m must be a number, got {depth_m!r}") from None
        if not (math.isfinite(z) and z > 0):
            raise InputError(f"depth_m must be a finite number > 0, got {depth_m!r}")
        lo = self.near_m if self.near_m is not None else 0.0
        hi = self.far_m if self.far_m is not None else math.inf
        if not (lo <= z <= hi):
            raise InputError(f"depth_m {z:g} is outside the geometry's range [{lo:g}, {hi:g}] m")
        return z

    def disparity_px(self, depth_m: float) -> float:
        """Return the disparity (pixels per view step) of a plane at ``depth_m`` metres."""
        z = self.check_depth(depth_m)
        if self.kind == "camera_array":
            return self.focal_length_px * self.baseline_m * (1.0 / z - 1.0 / self.convergence_m)
        z_mm = z * 1000.0 / self.relay_minification
        return -z_mm * self.pixel_mm / (self.lens_focal_mm * self.lens_pitch_mm)

    def depth_m(self, disparity_px: float) -> float:
        """Return the depth in metres of the plane with ``disparity_px`` (``inf`` if none)."""
        d = float(disparity_px)
        if self.kind == "camera_array":
            inv = d / (self.focal_length_px * self.baseline_m) + 1.0 / self.convergence_m
            return 1.0 / inv if inv > 0 else math.inf
        if d >= 0:
            return math.inf if d > 0 else 0.0
        z_mm = -d * self.lens_focal_mm * self.lens_pitch_mm / self.pixel_mm
        return z_mm * self.relay_minification / 1000.0

    def to_dict(self) -> dict:
        """Return the non-default fields as a plain dict (TOML/JSON friendly)."""
        out: dict = {"kind": self.kind}
        for name in (
            "focal_length_px",
            "baseline_m",
            "convergence_m",
            "lens_pitch_mm",
            "lens_focal_mm",
            "relay_minification",
            "pixel_mm",
            "near_m",
            "far_m",
        ):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, float) and math.isinf(v)):
                out[name] = v
        return out

    @classmethod
    def from_dict(cls, data: dict) -> Geometry:
        """Build from a dict such as the ``[geometry]`` table of ``lightfield.toml``."""
        known = set(cls.__dataclass_fields__)
        unknown = set(data) - known
        if unknown:
            raise InputError(f"geometry: unknown keys {sorted(unknown)}; expected {sorted(known)}")
        if "kind" not in data:
            raise InputError("geometry: 'kind' is required ('camera_array' or 'lens_array')")
        return cls(**data)


@dataclass(frozen=True, eq=False)
class LightField:
    """A light field: a ``(n_u, n_v)`` grid of views and, optionally, its geometry.

    Parameters
    ----------
    views : ndarray of shape (n_u, n_v, rows, cols) or (n_u, n_v, rows, cols, C), float32 in [0, 1]
    geometry : Geometry or None
        Without it, planes are addressed by disparity only.
    source : str
        Where the views came from (a path, or ``"array"``).
    """

    views: np.ndarray
    geometry: Geometry | None = None
    source: str = "array"
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        v = np.asarray(self.views)
        if v.ndim not in (4, 5):
            raise InputError(
                f"light field must be (n_u, n_v, rows, cols[, C]), got shape {v.shape}"
            )
        if v.ndim == 5 and v.shape[4] not in (1, 3):
            raise InputError(f"light field channel axis must have 1 or 3 entries, got {v.shape}")
        if min(v.shape[:4]) < 1:
            raise InputError(f"light field has an empty axis: shape {v.shape}")
        if np.issubdtype(v.dtype, np.integer) or v.dtype == bool:
            raise InputError(
                f"light field views must be float in [0, 1], got dtype {v.dtype} "
                "(convert with stimuli.io.to_float01)"
            )
        if not np.issubdtype(v.dtype, np.floating):
            raise InputError(f"light field views must be float in [0, 1], got dtype {v.dtype}")
        if not np.all(np.isfinite(v)):
            raise InputError("light field has NaN or infinite values")
        lo, hi = float(v.min()), float(v.max())
        if lo < 0.0 or hi > 1.0:
            raise InputError(f"light field must be in [0, 1], got range [{lo:.4g}, {hi:.4g}]")
        if v.dtype != np.float32:
            v = v.astype(np.float32)
        object.__setattr__(self, "views", v)

    @property
    def grid(self) -> tuple[int, int]:
        """Number of views ``(n_u, n_v)``."""
        return self.views.shape[0], self.views.shape[1]

    @property
    def shape_px(self) -> tuple[int, int]:
        """Size of one view ``(rows, cols)``."""
        return self.views.shape[2], self.views.shape[3]

    @property
    def centre_index(self) -> tuple[int, int]:
        """Grid index of the centre view, ``(n_u // 2, n_v // 2)``."""
        return self.views.shape[0] // 2, self.views.shape[1] // 2

    def centre_view(self) -> np.ndarray:
        """Return the centre view, the all-in-focus ("cluttered") image (a copy)."""
        cu, cv = self.centre_index
        return self.views[cu, cv].copy()

    def gray(self) -> LightField:
        """Return the light field converted to luminance (Rec. 709 weights, as ``load_gray``)."""
        if self.views.ndim == 4:
            return self
        v = self.views
        g = np.clip(v[..., 0].astype(np.float32), 0.0, 1.0) if v.shape[4] == 1 else luma(v)
        return LightField(g, self.geometry, self.source, dict(self.meta))

    def binned(self, factor: int) -> LightField:
        """Return the light field with each view box-averaged over ``factor x factor`` pixels.

        Disparities scale by ``1 / factor``; the geometry is dropped (it refers to full pixels).
        """
        if factor == 1:
            return self
        if isinstance(factor, bool) or not isinstance(factor, int) or factor < 1:
            raise InputError(f"factor must be an integer >= 1, got {factor!r}")
        r, c = self.shape_px
        r2, c2 = r // factor, c // factor
        if r2 < 2 or c2 < 2:
            raise InputError(f"cannot bin views of {r}x{c} px by {factor}")
        v = self.views[:, :, : r2 * factor, : c2 * factor]
        v = v.reshape(v.shape[0], v.shape[1], r2, factor, c2, factor, *v.shape[4:])
        v = v.mean(axis=(3, 5), dtype=np.float32)
        return LightField(np.clip(v, 0.0, 1.0), None, self.source, dict(self.meta))

    def view_binned(self, factor: int) -> LightField:
        """Return the light field with blocks of ``factor x factor`` neighbouring views averaged.

        Each new view is a wider sub-aperture (less noise, more depth of field per view); one new
        view step is ``factor`` old ones, so disparities scale by ``factor``. A camera-array
        baseline (or a lens array's pixel size) is scaled to match. Views beyond the last whole
        block are dropped. Lens arrays with many small views (41x41 px lenslets) need it.
        """
        if isinstance(factor, bool) or not isinstance(factor, int) or factor < 1:
            raise InputError(f"view binning must be an integer >= 1, got {factor!r}")
        if factor == 1:
            return self
        n_u, n_v = self.grid
        if (n_u > 1 and n_u < factor) or (n_v > 1 and n_v < factor):
            raise InputError(f"cannot bin a {n_u}x{n_v} grid of views by {factor}")
        fu, fv = (factor if n_u > 1 else 1), (factor if n_v > 1 else 1)
        a, b = n_u // fu, n_v // fv
        v = self.views[: a * fu, : b * fv]
        v = v.reshape(a, fu, b, fv, *v.shape[2:]).mean(axis=(1, 3), dtype=np.float32)
        g = self.geometry
        if g is not None:
            from dataclasses import replace

            if g.kind == "camera_array":
                g = replace(g, baseline_m=g.baseline_m * factor)
            else:
                g = replace(g, pixel_mm=g.pixel_mm * factor)
        meta = dict(self.meta, view_bin=factor)
        return LightField(np.clip(v, 0.0, 1.0), g, self.source, meta)

    def cropped(self, box_xywh: tuple[int, int, int, int]) -> LightField:
        """Return the light field with every view cropped to ``(x, y, w, h)`` pixels.

        Disparities and geometry are unchanged. Use it to drop borders that are the same in
        every view (lens vignetting, a sensor frame): such borders have zero disparity and
        make a false plane at 0 in a depth scan.
        """
        try:
            x, y, w, h = (int(v) for v in box_xywh)
        except (TypeError, ValueError):
            raise InputError(f"crop box must be (x, y, w, h), got {box_xywh!r}") from None
        rows, cols = self.shape_px
        if w < 2 or h < 2 or x < 0 or y < 0 or x + w > cols or y + h > rows:
            raise InputError(
                f"crop box {box_xywh!r} must be at least 2x2 px inside the {cols}x{rows} views"
            )
        meta = dict(self.meta, crop=[x, y, w, h])
        if "views_read" in self.meta:  # only these hold data: the others stay zero, untouched
            v = np.zeros((*self.views.shape[:2], h, w, *self.views.shape[4:]), self.views.dtype)
            for u, t in self.meta["views_read"]:
                v[u, t] = self.views[u, t, y : y + h, x : x + w]
        else:
            v = np.ascontiguousarray(self.views[:, :, y : y + h, x : x + w])
        return LightField.checked_already(v, self.geometry, self.source, meta)

    @classmethod
    def checked_already(
        cls, views: np.ndarray, geometry: Geometry | None, source: str, meta: dict
    ) -> LightField:
        """Return a light field of ``views`` already known to be valid, without checking them.

        For views taken from a checked light field (a crop, a merge of two reads of one
        capture): float32, (n_u, n_v, rows, cols[, C]), finite, in [0, 1]. The checks pass over
        every value, as long as a copy of the light field.
        """
        lf = object.__new__(cls)
        for name, value in (("views", views), ("geometry", geometry), ("source", source)):
            object.__setattr__(lf, name, value)
        object.__setattr__(lf, "meta", meta)
        return lf

    def disparity_px(self, depth_m: float) -> float:
        """Return the disparity of a plane at ``depth_m`` (needs a geometry)."""
        if self.geometry is None:
            raise InputError(
                f"{self.source}: no geometry (lightfield.toml) known, so depths cannot be given "
                "in metres; give a disparity in pixels per view step instead"
            )
        return self.geometry.disparity_px(depth_m)

    def depth_m(self, disparity_px: float) -> float | None:
        """Return the depth in metres of a disparity, or ``None`` without a geometry."""
        if self.geometry is None:
            return None
        return self.geometry.depth_m(disparity_px)

    def max_disparity_px(self) -> float:
        """Largest |disparity| for which the outermost views still overlap the centre view."""
        cu, cv = self.centre_index
        max_off = max(cu, self.views.shape[0] - 1 - cu, cv, self.views.shape[1] - 1 - cv, 1)
        return (min(self.shape_px) - 1) / max_off
