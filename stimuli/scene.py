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

import math
from dataclasses import dataclass

import numpy as np

from stimuli import jung2015
from stimuli.errors import InputError

__all__ = ["Layer", "ThinLensCamera"]


@dataclass(frozen=True, eq=False)
class Layer:
    """One fronto-parallel plane of a scene.

    Parameters
    ----------
    name : str
        What the layer is ("mug", "shelf", "wall").
    texture : ndarray of shape (rows, cols), float32 in [0, 1]
        Luminance seen by the reference pinhole camera, centred on the optical axis.
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
        if self.focal_length_mm <= 0 or self.f_number <= 0:
            raise InputError("focal_length_mm and f_number must be > 0")
        if not (0 < self.hfov_deg < 180):
            raise InputError(f"hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if self.focus_m * 1000.0 <= self.focal_length_mm:
            raise InputError(
                f"focus_m must exceed the focal length, got {self.focus_m!r} m"
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
