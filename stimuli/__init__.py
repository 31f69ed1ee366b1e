"""Image pipeline of active confocal imaging: scenes, light fields, refocus, de-clutter, compress.

Imports neither ``experiment`` nor ``analysis`` (house style H1). The names below are imported
from their modules on first use, so ``import stimuli.errors`` (and every ``confocal ... --help``)
does not load numpy and Pillow.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

import lazy_loader

try:
    __version__ = version("active-confocal")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"

#: Where each public name lives (``lazy_loader``, as scikit-image does).
__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "compress": ["compress", "compress_grey", "grid_shape"],
        "errors": ["InputError"],
        "io": ["load_gray", "save_png"],
    },
)
