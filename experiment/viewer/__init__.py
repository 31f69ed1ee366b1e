"""The live active-confocal viewer: GPU refocus, implant views, event log.

Only modules inside this package import ``moderngl``/``moderngl_window``, and only where they
draw (house style H13); the state machine and event log are GL-free. The implant layouts it
draws are :mod:`stimuli.implants` (GL-free, shared with stimulus building and sessions).
"""

from __future__ import annotations

import importlib

__all__ = ["ViewerEvent", "ViewerEventLog"]


def __getattr__(name: str) -> object:
    """Return a public name, importing :mod:`experiment.viewer.events` on first use.

    ``confocal view --help`` imports :mod:`experiment.commands.view` without the event log (and
    sqlite3).
    """
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module("experiment.viewer.events"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Return the public names, imported or not."""
    return sorted(set(globals()) | set(__all__))
