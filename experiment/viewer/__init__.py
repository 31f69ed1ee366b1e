"""The live active-confocal viewer: GPU refocus, implant views, event log.

Only modules inside this package import ``moderngl``/``moderngl_window``, and only where they
draw (house style H13); the state machine and event log are GL-free. The implant layouts it
draws are :mod:`stimuli.implants` (GL-free, shared with stimulus building and sessions).
"""

from __future__ import annotations

from experiment.viewer.events import ViewerEvent, ViewerEventLog

__all__ = ["ViewerEvent", "ViewerEventLog"]
