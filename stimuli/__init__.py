"""Image pipeline of active confocal imaging: scenes, light fields, refocus, de-clutter, compress.

Imports neither ``experiment`` nor ``analysis`` (house style H1). The names below are imported
from their modules on first use, so ``import stimuli.errors`` (and every ``confocal ... --help``)
does not load numpy and Pillow.
"""

from __future__ import annotations

import lazy_loader

#: Where each public name lives (``lazy_loader``, as scikit-image does).
_getattr_public, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "compress": ["compress", "compress_grey", "grid_shape"],
        "errors": ["InputError"],
        "io": ["load_gray", "save_png"],
    },
)


def __getattr__(name: str) -> object:
    """Return a public name, or ``__version__``, on first use.

    The version is looked up in the installed package's metadata only when asked for:
    ``importlib.metadata`` takes 0.025 s to import, paid by every ``confocal ... --help``.
    """
    if name != "__version__":
        return _getattr_public(name)
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("active-confocal")
    except PackageNotFoundError:  # running from a source tree that was not installed
        value = "0+unknown"
    globals()["__version__"] = value
    return value
