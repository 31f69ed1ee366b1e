"""Hand-drawn objects and cluttered backgrounds for the synthetic photo pairs.

- :mod:`stimuli.objects.drawing`: the signed-distance drawing kit (shapes, shading, canvas).
- :mod:`stimuli.objects.registry`: the object kinds (names, accepted answers) and who draws each.
- :mod:`stimuli.objects.kitchen`, :mod:`~stimuli.objects.tools`, :mod:`~stimuli.objects.home`,
  :mod:`~stimuli.objects.devices`, :mod:`~stimuli.objects.personal`: one module per family of
  objects.
- :mod:`stimuli.objects.backgrounds`: the clutter behind each object (wall, shelf, clothes or a
  pin board, cables).

Scenes are put together, rendered and written by :mod:`stimuli.synth`.
"""

from __future__ import annotations

__all__: list[str] = []
