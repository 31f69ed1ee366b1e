"""Errors of the experiment engine meaning "the user's input or files are wrong" (exit status 2)."""

from __future__ import annotations

__all__ = ["ConfocalError"]


class ConfocalError(Exception):
    """Base of the experiment engine's user-facing errors (bad protocol, refused session, ...).

    The message is one line naming the file or field and what was expected; the command line
    prints it without a traceback and exits with status 2. Subclass it for domain states
    (``ProtocolError``, ``TrialLogError``, ``ResumeMismatch``).
    """

    exit_code = 2
