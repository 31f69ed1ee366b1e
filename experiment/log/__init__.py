"""The trial log: one append-only SQLite file per study (house style H16).

Rooms:

- :mod:`~experiment.log.schema`: numbered migrations, the ``tidy_trials`` view (the contract with
  ``analysis``), the file's application id, schema versions.
- :mod:`~experiment.log.logfile`: a file is identified, reading only, before anything writes it;
  a new log is made whole under a temporary name.
- :mod:`~experiment.log.triallog`: :class:`TrialLog`, the open log and its writes (one durable
  transaction per onset and per answered trial).
- :mod:`~experiment.log.readers`: the read-only queries every open log answers.
- :mod:`~experiment.log.locks`: which process has a session open, and whether it still lives.
- :mod:`~experiment.log.faults`: fault injection at each write step, for the crash tests.
- :mod:`~experiment.log.errors`: :class:`TrialLogError` and its kinds (exit status 2).
"""

from __future__ import annotations

from experiment.log.errors import ResumeMismatch, SessionComplete, SessionLocked, TrialLogError
from experiment.log.faults import FAULT_ENV, FAULT_STEPS, fault_point
from experiment.log.logfile import identify_log_file
from experiment.log.schema import APPLICATION_ID, MIGRATIONS, TIDY_COLUMNS, utc_now
from experiment.log.triallog import TrialLog

__all__ = [
    "TrialLog",
    "TrialLogError",
    "SessionLocked",
    "ResumeMismatch",
    "SessionComplete",
    "MIGRATIONS",
    "TIDY_COLUMNS",
    "APPLICATION_ID",
    "FAULT_ENV",
    "FAULT_STEPS",
    "fault_point",
    "identify_log_file",
    "utc_now",
]
