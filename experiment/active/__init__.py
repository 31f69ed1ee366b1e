"""Active search as a study.

The task, its event log, a person searching (:mod:`~experiment.active.live`, with the operator's
:mod:`~experiment.console.active`), simulated searchers, and the ``confocal demo --active``
rendering. GL-free: the keys move the viewer's state machine (:mod:`experiment.viewer.state`) and
the views come from its CPU renderer (:mod:`experiment.viewer.reference`); a person's screen is the
presenter process.
"""

import importlib

__all__ = ["ActiveSession", "ActiveSearchSpec", "ViewerState", "apply_action"]

#: The module each public name comes from. They are imported on first use, so that
#: ``confocal active --help`` (which imports :mod:`experiment.commands.active`) does not load numpy,
#: Pillow and the trial log.
_HOME = {
    "ActiveSession": "experiment.active.session",
    "ActiveSearchSpec": "experiment.protocol.task",
    "ViewerState": "experiment.viewer.state",
    "apply_action": "experiment.viewer.state",
}


def __getattr__(name: str) -> object:
    """Return a public name, importing its module on first use."""
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOME[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Return the public names, imported or not."""
    return sorted(set(globals()) | set(__all__))
