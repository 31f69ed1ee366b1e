"""Demonstrations that run the whole system on synthetic data (``confocal demo``).

- :mod:`experiment.demos.study`: the recognition study (synth, build, simulated sessions,
  analysis, report).
- :mod:`experiment.demos.lightfield`: the light-field figures (``confocal demo --lightfield``).
"""

__all__: list[str] = []
