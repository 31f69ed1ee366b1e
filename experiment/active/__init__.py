"""Active search as a study: the task, its event log, a person searching
(:mod:`~experiment.active.live`, with the operator's :mod:`~experiment.console.active`), simulated
searchers, and the ``confocal demo --active`` rendering. GL-free: the views come from the CPU
pipeline of :mod:`stimuli`; a person's screen is the presenter process."""

from experiment.active.engine import ViewerState, apply_action
from experiment.active.session import ActiveSession
from experiment.protocol.task import ActiveSearchSpec

__all__ = ["ActiveSession", "ActiveSearchSpec", "ViewerState", "apply_action"]
