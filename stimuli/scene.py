"""Layered-scene model: fronto-parallel planes seen by a camera.

A scene is a list of :class:`Layer` objects, each a texture with an alpha mask at one depth.
Textures are given in the image coordinates of the *reference* pinhole camera (the centre view):
a layer's texture is what a pinhole camera at the origin, looking down +z, would record of that
plane alone. Textures may be larger than the camera image (a margin, centred on the optical
axis), so that off-centre views of a light field still see texture at their borders.

The same scene is rendered two ways:

* photo pairs through a thin lens (:class:`ThinLensCamera`): each layer is blurred by its own
  circle of confusion and the layers are composited back to front (occlusion respected);
* light fields through a grid of pinhole views (``stimuli.lightfield``), each layer shifted by
  its disparity.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.ndimage import correlate
from scipy.signal import fftconvolve

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = [
    "Layer",
    "ThinLensCamera",
    "disc_kernel",
    "centre_crop_offset",
    "render_thin_lens",
    "render_pair",
    "MIN_BLUR_DIAMETER_PX",
]

#: Supersampling per pixel axis when integrating the disc PSF over each kernel pixel. Ours, not
#: the paper's: 16x16 sub-samples put the kernel's area error well below 1 % for discs >= 1 px.
_KERNEL_SUBSAMPLES = 16

#: Kernels up to this side length are applied by direct correlation, larger ones by FFT
#: (ours: the cross-over measured on 492x327 images, where a 7x7 direct pass costs about one FFT).
_DIRECT_MAX_SIDE = 7

#: Discs at least this wide (pixels) are applied at reduced resolution (ours: never at the
#: paper's 492x327, where f/1.7 gives at most ~32 px; at 1536 px wide the CoC reaches ~100 px
#: and a full-resolution FFT per layer dominates the rendering time).
_DOWNSAMPLE_MIN_DIAMETER_PX = 48.0

#: Disc diameter, in low-resolution pixels, that the reduction factor aims at (ours).
_DOWNSAMPLE_TARGET_PX = 24.0

#: Circles of confusion below this diameter are treated as a point (no blur), pixels. Ours: a
#: disc smaller than one pixel is inside the pixel's own footprint.
MIN_BLUR_DIAMETER_PX = 1.0


@dataclass(frozen=True, eq=False)
class Layer:
    """One fronto-parallel plane of a scene.

    Parameters
    ----------
    name : str
        What the layer is ("mug", "shelf", "wall").
    texture : ndarray of shape (rows, cols), float32 in [0, 1]
        Luminance seen by the reference pinhole camera, centred on the optical axis; at least
        the camera image's size, larger for a margin (see :func:`centre_crop_offset` for
        where the camera image lies in it). Not premultiplied by ``alpha``.
    alpha : ndarray of shape (rows, cols), float32 in [0, 1]
        Coverage of the layer (1 = opaque). Same shape as ``texture``.
    depth_m : float > 0
        Distance of the plane from the camera, metres.
    """

    name: str
    texture: np.ndarray
    alpha: np.ndarray
    depth_m: float

    def __post_init__(self) -> None:
        t = np.asarray(self.texture)
        a = np.asarray(self.alpha)
        if t.ndim != 2 or a.shape != t.shape:
            raise InputError(
                f"layer {self.name!r}: texture and alpha must be 2-D of one shape, "
                f"got {t.shape} and {a.shape}"
            )
        if not (math.isfinite(self.depth_m) and self.depth_m > 0):
            raise InputError(f"layer {self.name!r}: depth_m must be > 0, got {self.depth_m!r}")


@dataclass(frozen=True)
class ThinLensCamera:
    """A thin-lens camera: focal length, field of view, aperture and focus distance.

    Defaults are the paper's photo study (Sec. 3.1): 50 mm lens, 25 deg horizontal field,
    focused on the object at 0.8 m, images at the 492x327 working size.

    Parameters
    ----------
    shape_px : (rows, cols)
        Image size, pixels.
    focal_length_mm : float
    hfov_deg : float
        Horizontal field of view, degrees.
    f_number : float
        Aperture (1.7 narrow DOF, 22 wide DOF in the paper).
    focus_m : float
        Focus distance, metres.
    """

    shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX
    focal_length_mm: float = jung2015.CAMERA_FOCAL_LENGTH_MM
    hfov_deg: float = jung2015.CAMERA_HFOV_DEG
    f_number: float = jung2015.WIDE_F_NUMBER
    focus_m: float = jung2015.OBJECT_DISTANCE_M

    def __post_init__(self) -> None:
        shape = self.shape_px
        if (
            not isinstance(shape, tuple)
            or len(shape) != 2
            or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in shape)
            or min(shape) < 1
        ):
            raise InputError(f"shape_px must be (rows, cols) of positive integers, got {shape!r}")
        for name in ("focal_length_mm", "f_number"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"{name} must be a finite number > 0, got {value!r}")
        if not (0 < self.hfov_deg < 180):
            raise InputError(f"hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if not (math.isfinite(self.focus_m) and self.focus_m * 1000.0 > self.focal_length_mm):
            raise InputError(
                f"focus_m must exceed the focal length ({self.focal_length_mm} mm), "
                f"got {self.focus_m!r} m"
            )

    @property
    def sensor_width_mm(self) -> float:
        """Sensor width that gives the horizontal field of view, mm."""
        return 2.0 * self.focal_length_mm * math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def pixel_pitch_mm(self) -> float:
        """Size of one pixel on the sensor, mm."""
        return self.sensor_width_mm / self.shape_px[1]

    @property
    def focal_length_px(self) -> float:
        """Focal length in pixels (for pinhole projection and disparities)."""
        return self.focal_length_mm / self.pixel_pitch_mm

    @property
    def aperture_mm(self) -> float:
        """Entrance-pupil diameter, mm."""
        return self.focal_length_mm / self.f_number

    def coc_diameter_px(self, depth_m: float) -> float:
        """Diameter of the circle of confusion of a point at ``depth_m``, pixels.

        Thin-lens formula ``c = A * |z - s| / z * f / (s - f)`` with aperture ``A = f / N``,
        object distance ``z``, focus distance ``s`` and focal length ``f`` (all in mm).
        """
        if depth_m <= 0:
            raise InputError(f"depth_m must be > 0, got {depth_m!r}")
        f = self.focal_length_mm
        s = self.focus_m * 1000.0
        z = depth_m * 1000.0
        c_mm = self.aperture_mm * abs(z - s) / z * f / (s - f)
        return c_mm / self.pixel_pitch_mm


@lru_cache(maxsize=256)
def _disc_kernel_cached(diameter_milli_px: int) -> np.ndarray:
    if diameter_milli_px == 0:
        k = np.ones((1, 1), dtype=np.float64)
        k.setflags(write=False)
        return k
    radius = diameter_milli_px / 2000.0
    half = int(math.ceil(radius - 0.5)) if radius > 0.5 else 0
    n = 2 * half + 1
    sub = _KERNEL_SUBSAMPLES
    # Sub-sample centres of every kernel pixel: the kernel is the disc's area inside each pixel.
    offs = (np.arange(n * sub, dtype=np.float64) + 0.5) / sub - half - 0.5
    inside = (offs[:, None] ** 2 + offs[None, :] ** 2) <= radius * radius
    k = inside.reshape(n, sub, n, sub).sum(axis=(1, 3)).astype(np.float64)
    k /= k.sum()
    k.setflags(write=False)
    return k


def disc_kernel(diameter_px: float) -> np.ndarray:
    """Return the normalised disc point-spread function of a circle of confusion.

    Each kernel pixel holds the area of the disc inside that pixel (integrated on a 16x16
    sub-pixel grid), so the PSF is physically sized to fractions of a pixel.

    Parameters
    ----------
    diameter_px : float >= 0
        Diameter of the circle of confusion, pixels. Below ``MIN_BLUR_DIAMETER_PX`` the
        kernel is the 1x1 identity.

    Returns
    -------
    ndarray of shape (n, n), float64, sums to 1
        ``n`` is odd, the disc is centred on the middle pixel. Read-only (cached).

    Raises
    ------
    InputError
        If ``diameter_px`` is negative or not finite.

    Examples
    --------
    >>> disc_kernel(0.5).shape
    (1, 1)
    >>> round(float(disc_kernel(7.0).sum()), 6)
    1.0
    """
    d = float(diameter_px)
    if not (math.isfinite(d) and d >= 0):
        raise InputError(f"diameter_px must be a finite number >= 0, got {diameter_px!r}")
    if d < MIN_BLUR_DIAMETER_PX:
        return _disc_kernel_cached(0)
    return _disc_kernel_cached(int(round(d * 1000.0)))


def centre_crop_offset(
    texture_shape: tuple[int, int], shape_px: tuple[int, int]
) -> tuple[int, int]:
    """Return the (row, col) offset of a ``shape_px`` camera image inside a larger texture.

    The camera image is the centred window ``texture[r0:r0 + rows, c0:c0 + cols]`` with
    ``r0 = (T_rows - rows) // 2`` and ``c0 = (T_cols - cols) // 2`` (when the margin is odd the
    extra pixel is on the bottom/right). Light-field rendering uses the same convention.

    Parameters
    ----------
    texture_shape : (rows, cols)
        Texture size, pixels; each at least the camera's.
    shape_px : (rows, cols)
        Camera image size, pixels.

    Returns
    -------
    (r0, c0) : tuple of int

    Raises
    ------
    InputError
        If the texture is smaller than the camera image along an axis.

    Examples
    --------
    >>> centre_crop_offset((20, 31), (10, 10))
    (5, 10)
    """
    tr, tc = (int(v) for v in texture_shape)
    r, c = (int(v) for v in shape_px)
    if tr < r or tc < c:
        raise InputError(
            f"texture_shape must be at least the camera's shape_px {(r, c)}, got {(tr, tc)}"
        )
    return ((tr - r) // 2, (tc - c) // 2)


def _check_layers(layers: Sequence[Layer], shape_px: tuple[int, int]) -> list[Layer]:
    if isinstance(layers, (Layer, str, bytes)) or not isinstance(layers, Sequence):
        raise InputError(f"layers must be a sequence of Layer, got {type(layers).__name__}")
    if len(layers) == 0:
        raise InputError("layers must hold at least one Layer, got an empty sequence")
    out = []
    for i, layer in enumerate(layers):
        if not isinstance(layer, Layer):
            raise InputError(f"layers[{i}] must be a Layer, got {type(layer).__name__}")
        check_gray(layer.texture, f"layer {layer.name!r} texture")
        check_gray(layer.alpha, f"layer {layer.name!r} alpha")
        tshape = np.shape(layer.texture)
        if tshape[0] < shape_px[0] or tshape[1] < shape_px[1]:
            raise InputError(
                f"layer {layer.name!r}: texture shape {tshape} is smaller than the camera's "
                f"shape_px {tuple(shape_px)}"
            )
        out.append(layer)
    return out


def _region(planes: np.ndarray, shape_px: tuple[int, int], margin_px: int) -> np.ndarray:
    """Return the centred ``shape_px`` crop of (n, T_rows, T_cols) planes plus ``margin_px`` a side.

    Where the texture has no margin left, it is extended by reflection, so that blur never
    darkens the image border.
    """
    rows, cols = shape_px
    r0, c0 = centre_crop_offset(planes.shape[1:], shape_px)
    m = margin_px
    padded = np.pad(planes, ((0, 0), (m, m), (m, m)), mode="reflect")
    # In padded coordinates the crop starts at (r0 + m, c0 + m); take m more on each side.
    return padded[:, r0 : r0 + rows + 2 * m, c0 : c0 + cols + 2 * m]


def _upsample_axis(a: np.ndarray, axis: int, factor: int, start: int, n: int) -> np.ndarray:
    """Linear interpolation of block means back to full-resolution pixels ``start .. start+n-1``.

    Block ``i`` of ``factor`` pixels has its centre at full-resolution coordinate
    ``factor * i + (factor - 1) / 2``.
    """
    pos = (np.arange(start, start + n, dtype=np.float64) - (factor - 1) / 2.0) / factor
    i0 = np.clip(np.floor(pos).astype(np.intp), 0, a.shape[axis] - 2)
    w = (pos - i0).astype(np.float32)
    shape = [1] * a.ndim
    shape[axis] = n
    w = w.reshape(shape)
    return np.take(a, i0, axis=axis) * (1 - w) + np.take(a, i0 + 1, axis=axis) * w


def _blur_crop(planes: np.ndarray, diameter_px: float, shape_px: tuple[int, int]) -> np.ndarray:
    """Blur (n, T_rows, T_cols) planes by a disc and return the centred ``shape_px`` crop.

    Only the crop plus the kernel's half-width is convolved. Large discs (diameter at least
    ``_DOWNSAMPLE_MIN_DIAMETER_PX``) are applied to ``f x f`` block means, with
    ``f = floor(diameter / _DOWNSAMPLE_TARGET_PX)``, and interpolated back linearly: the box
    adds a variance of ``f**2 / 12`` px^2 to the disc's ``diameter**2 / 16`` (under 0.5 %), and
    a disc of 24 or more low-resolution pixels is smooth enough for linear interpolation.
    """
    rows, cols = shape_px
    kernel = disc_kernel(diameter_px)
    h = kernel.shape[0] // 2
    if h == 0:
        r0, c0 = centre_crop_offset(planes.shape[1:], shape_px)
        return planes[:, r0 : r0 + rows, c0 : c0 + cols] * np.float32(kernel[0, 0])
    if diameter_px >= _DOWNSAMPLE_MIN_DIAMETER_PX:
        f = int(diameter_px // _DOWNSAMPLE_TARGET_PX)
        m = h + 2 * f
        region = _region(planes, shape_px, m + f)
        n_r, n_c = region.shape[1] // f, region.shape[2] // f
        small = region[:, : n_r * f, : n_c * f].reshape(-1, n_r, f, n_c, f).mean(axis=(2, 4))
        k_small = disc_kernel(diameter_px / f).astype(np.float32)
        blurred = fftconvolve(small, k_small[None, :, :], mode="same", axes=(1, 2))
        out = _upsample_axis(blurred.astype(np.float32), 1, f, m + f, rows)
        return _upsample_axis(out, 2, f, m + f, cols)
    region = _region(planes, shape_px, h)
    k32 = kernel.astype(np.float32)
    if kernel.shape[0] <= _DIRECT_MAX_SIDE:
        # The disc is symmetric, so correlation equals convolution.
        full = correlate(region, k32[None, :, :], mode="nearest")
        return full[:, h : h + rows, h : h + cols]
    return fftconvolve(region, k32[None, :, :], mode="valid", axes=(1, 2))


def render_thin_lens(layers: Sequence[Layer], camera: ThinLensCamera) -> np.ndarray:
    """Render a layered scene through a thin lens: defocus blur per layer, then occlusion.

    Each layer's premultiplied texture (``texture * alpha``) and its alpha are convolved with
    the disc PSF of the layer's circle of confusion (:meth:`ThinLensCamera.coc_diameter_px`),
    centre-cropped to the camera image, and composited back to front with the "over"
    operator: ``out = blurred(texture * alpha) + (1 - blurred(alpha)) * out``. Behind all
    layers the scene is black. This is the usual layered depth-of-field approximation: a
    layer's blur is not occluded by nearer layers' blur (exact for a far-to-near stack of
    fronto-parallel planes except at occlusion boundaries, within about one CoC).

    Parameters
    ----------
    layers : sequence of Layer
        Any order; sorted by ``depth_m`` (farthest first; ties keep the given order).
        Textures are in the reference pinhole camera's image coordinates, centred on the
        optical axis, each at least ``camera.shape_px``.
    camera : ThinLensCamera

    Returns
    -------
    ndarray of shape ``camera.shape_px``, float32 in [0, 1]

    Raises
    ------
    InputError
        If ``layers`` is empty or not a sequence of Layer, a texture or alpha is not a
        [0, 1] float image, or a texture is smaller than the camera image.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (narrow f/1.7 and wide f/22 depth-of-field photos).
    Potmesil & Chakravarty (1981), circle of confusion of a thin lens.

    Examples
    --------
    >>> cam = ThinLensCamera(shape_px=(4, 6))
    >>> wall = Layer("wall", np.full((4, 6), 0.5, np.float32), np.ones((4, 6), np.float32), 0.8)
    >>> float(render_thin_lens([wall], cam).max())
    0.5
    """
    if not isinstance(camera, ThinLensCamera):
        raise InputError(f"camera must be a ThinLensCamera, got {type(camera).__name__}")
    shape_px = (int(camera.shape_px[0]), int(camera.shape_px[1]))
    checked = _check_layers(layers, shape_px)
    order = sorted(range(len(checked)), key=lambda i: -checked[i].depth_m)
    out = np.zeros(shape_px, dtype=np.float32)
    for i in order:
        layer = checked[i]
        texture = np.asarray(layer.texture, dtype=np.float32)
        alpha = np.asarray(layer.alpha, dtype=np.float32)
        diameter = camera.coc_diameter_px(layer.depth_m)
        if alpha.min() >= 1.0:
            # An opaque layer stays opaque under blur (reflected margins): skip its alpha.
            out = _blur_crop(texture[None], diameter, shape_px)[0]
            continue
        blurred = _blur_crop(np.stack([texture * alpha, alpha]), diameter, shape_px)
        out = blurred[0] + (1.0 - blurred[1]) * out
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def render_pair(
    layers: Sequence[Layer], *, camera: ThinLensCamera | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Render the paper's photo pair: wide depth of field (f/22) and narrow (f/1.7).

    Parameters
    ----------
    layers : sequence of Layer
    camera : ThinLensCamera, optional
        Geometry and focus; its ``f_number`` is replaced by the paper's two apertures.
        Default: ``ThinLensCamera()`` (50 mm, 25 deg, focus 0.8 m, 492x327).

    Returns
    -------
    wide, narrow : ndarray of shape ``camera.shape_px``, float32 in [0, 1]
        The "conventional" (f/22) and "confocal" (f/1.7) photos.

    Raises
    ------
    InputError
        As :func:`render_thin_lens`.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (f/1.7 and f/22 photos of each object).
    """
    cam = ThinLensCamera() if camera is None else camera
    if not isinstance(cam, ThinLensCamera):
        raise InputError(f"camera must be a ThinLensCamera, got {type(cam).__name__}")
    wide = render_thin_lens(layers, dataclasses.replace(cam, f_number=jung2015.WIDE_F_NUMBER))
    narrow = render_thin_lens(layers, dataclasses.replace(cam, f_number=jung2015.NARROW_F_NUMBER))
    return wide, narrow
