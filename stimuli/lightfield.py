"""Light fields: a grid of views plus its geometry, and the loaders that build one.

Conventions
-----------
Views are stored as ``(n_u, n_v, rows, cols)`` (grey) or ``(n_u, n_v, rows, cols, C)``,
``float32`` in [0, 1] (house style H6). ``u`` indexes the view grid from top to bottom and ``v``
from left to right. View offsets are measured from the *centre view* ``(n_u // 2, n_v // 2)``:
``du = u - n_u // 2``, ``dv = v - n_v // 2``.

Disparity ``d`` is in pixels per view step, with the sign convention of the HCI benchmark
(Honauer et al. 2016), larger = nearer: a scene point seen at ``(y, x)`` in the centre view is
seen at ``(y - d * du, x - d * dv)`` in the view at offset ``(du, dv)``::

    I_centre(y, x) = I_(du, dv)(y - d * du, x - d * dv)

For a camera array looking in parallel, ``d = focal_length_px * baseline_m / depth_m`` (> 0).
Middlebury's ``disp1 / 8`` and HCI's ground truth use this convention as they are
(``SOURCES.md``). For a lens array the views are orthographic, the disparity grows with the
distance from the array and the pixel order under a lenslet mirrors the viewing direction, so
``d = -(depth_mm / relay_minification) * pixel_mm / (lens_focal_mm * lens_pitch_mm) < 0``: still
"larger = nearer".

Modules
-------
* :mod:`stimuli.lfviews`: the :class:`LightField` type and its :class:`Geometry`;
* :mod:`stimuli.lfload`: :func:`load_lightfield`, one loader per input format;
* :mod:`stimuli.elemental`: lens-array elemental images to views and back;
* :mod:`stimuli.pfm`: PFM files (ground-truth disparity and depth maps).

Every public name of those modules is importable from here.

The inputs :func:`load_lightfield` reads (folders of views, ``.npy``/``.npz`` arrays, elemental
images) and the optional TOML file beside them are described in :mod:`stimuli.lfload`.
"""

from __future__ import annotations

from stimuli.elemental import elemental_from_views, views_from_elemental
from stimuli.lfload import ARRAY_AXES, load_lightfield
from stimuli.lfviews import Geometry, LightField
from stimuli.pfm import read_pfm, write_pfm

__all__ = [
    "Geometry",
    "LightField",
    "load_lightfield",
    "views_from_elemental",
    "elemental_from_views",
    "read_pfm",
    "write_pfm",
    "ARRAY_AXES",
]
