"""Image pipeline of active confocal imaging: scenes, light fields, refocus, de-clutter, compress.

Imports neither ``experiment`` nor ``analysis`` (house style H1).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from stimuli.compress import compress, compress_grey, grid_shape
from stimuli.errors import InputError
from stimuli.io import load_gray, save_png

try:
    __version__ = version("active-confocal")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"

__all__ = ["compress", "compress_grey", "grid_shape", "InputError", "load_gray", "save_png"]
