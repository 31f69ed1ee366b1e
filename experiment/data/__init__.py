"""Study data around the trial log: monitor profiles and the Psych-DS export.

- :mod:`experiment.data.monitors`: named monitor files (``protocols/monitors/*.toml``: width,
  distance, resolution, gamma) that override a protocol's display geometry.
- :mod:`experiment.data.psychds`: participant metadata and the Psych-DS dataset written by
  ``confocal session export``.
- :mod:`experiment.data.subjects`: the one rule for subject codes (``--subject``).
- :mod:`experiment.data.identifying`: what makes a text identifying (an e-mail address, a phone
  number, a full date), for participant fields, subject codes and exported answers.
"""

from __future__ import annotations

__all__: list[str] = []
