"""The live active-confocal viewer (issue 14): GPU refocus, implant layouts, event log.

Only modules inside this package import ``moderngl``/``moderngl_window``, and only where they
draw (house style H13); the state machine, implant layouts and event log are GL-free.
"""

from __future__ import annotations

from experiment.viewer.events import ViewerEvent, ViewerEventLog

__all__ = ["ViewerEvent", "ViewerEventLog"]
