"""Image pipeline of active confocal imaging: scenes, light fields, refocus, de-clutter, compress.

Imports neither ``experiment`` nor ``analysis`` (house style H1). The names below are imported
from their modules on first use, so ``import stimuli.errors`` (and every ``confocal ... --help``)
does not load numpy and Pillow.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import Any

try:
    __version__ = version("active-confocal")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"

#: Where each public name lives.
_HOME = {
    "compress": "stimuli.compress",
    "compress_grey": "stimuli.compress",
    "grid_shape": "stimuli.compress",
    "InputError": "stimuli.errors",
    "load_gray": "stimuli.io",
    "save_png": "stimuli.io",
}

__all__ = list(_HOME)


def __getattr__(name: str) -> Any:
    """Import the module that holds ``name`` on first use (PEP 562)."""
    if name not in _HOME:
        raise AttributeError(f"module 'stimuli' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOME[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOME))
