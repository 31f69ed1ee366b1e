"""The subject's screen: the moderngl presenter, its separate process, display twins, and the
``confocal present`` / ``confocal score`` commands.

- :mod:`experiment.presentation.presenter`: the GL presenter (window, offscreen, headless).
- :mod:`experiment.presentation.process`: the presenter in its own process (JSON-lines protocol).
- :mod:`experiment.presentation.displays`: the ``Display`` twins used without a screen.
- :mod:`experiment.presentation.implant`: an implant layout as the presenter's phosphenes.
- :mod:`experiment.presentation.cli`: ``confocal present`` and ``confocal score``.
"""

__all__: list[str] = []
