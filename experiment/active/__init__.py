"""Active search as a study (issue 14, points 5 and 6): the task, its event log, simulated
searchers, and the ``confocal demo --active`` rendering. GL-free: it runs headless on the CPU
pipeline of :mod:`stimuli`."""

from experiment.active.engine import ViewerState, apply_action
from experiment.active.session import ActiveSession
from experiment.active.task import ActiveSearchSpec

__all__ = ["ActiveSession", "ActiveSearchSpec", "ViewerState", "apply_action"]
