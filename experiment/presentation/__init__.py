"""The subject's screen.

The moderngl presenter, its separate process and display twins.
Its commands (``confocal present``, ``confocal score``) live in
:mod:`experiment.commands`.

- :mod:`experiment.presentation.presenter`: the GL presenter (window, offscreen, headless).
- :mod:`experiment.presentation.geometry`: the screen's physical geometry and colours (GL-free).
- :mod:`experiment.presentation.frame`: where a stimulus lands, phosphenes, the expected frame.
- :mod:`experiment.presentation.drawing`: the presenter's GLSL program and text image.
- :mod:`experiment.presentation.timing`: dropped frames and the refresh self-test.
- :mod:`experiment.presentation.window`: the subject's window and the subject's input.
- :mod:`experiment.presentation.errors`: :class:`~experiment.presentation.errors.PresenterError`.
- :mod:`experiment.presentation.process`: the presenter in its own process (JSON-lines protocol).
- :mod:`experiment.presentation.displays`: the ``Display`` twins used without a screen.
- :mod:`experiment.presentation.implant`: an implant layout as the presenter's phosphenes.
"""

__all__: list[str] = []
