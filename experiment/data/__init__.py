"""Study data around the trial log: monitor profiles and the Psych-DS export.

- :mod:`experiment.data.monitors`: named monitor files (``protocols/monitors/*.toml``: width,
  distance, resolution, gamma) that override a protocol's display geometry.
- :mod:`experiment.data.psychds`: participant metadata and the Psych-DS dataset written by
  ``confocal session export``.
"""

from __future__ import annotations

__all__: list[str] = []
