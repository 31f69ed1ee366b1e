"""The trial log's errors: one line for the operator, exit status 2 (:class:`ConfocalError`)."""

from __future__ import annotations

from typing import Any

from experiment.errors import ConfocalError

__all__ = ["TrialLogError", "SessionLocked", "ResumeMismatch", "SessionComplete"]


class TrialLogError(ConfocalError):
    """The trial log cannot be opened or written (read-only, corrupt, not a trial log)."""


class SessionLocked(TrialLogError):
    """Another live process has the session open."""


class ResumeMismatch(TrialLogError):
    """An unfinished session exists but its protocol, stimulus set or seed differ."""


class SessionComplete(TrialLogError):
    """The subject's session is complete; running it again needs ``--new-session REASON``.

    ``session`` is the completed ``sessions`` row. ``confocal session run`` and ``active run``
    check before opening the log to write, report the session and exit 0.
    """

    def __init__(self, message: str, session: dict[str, Any]) -> None:
        super().__init__(message)
        self.session = session
