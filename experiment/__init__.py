"""Experiment engine: protocols, schedules, sessions, the SQLite trial log, presenter and console.

The ``confocal`` command's root lives in :mod:`experiment.cli`.
"""

from __future__ import annotations

from experiment.errors import ConfocalError

__all__ = ["ConfocalError"]
