"""A subject's session in the trial log, from opening to closing; shared by every kind of session.

The recognition :class:`~experiment.session.engine.Session` and the active-search
:class:`~experiment.active.session.ActiveSession` differ in what they plan and record, not in how
a session lives in the log:

1. :func:`check_subject_and_seed` refuses a blank subject or a bad seed.
2. :func:`session_to_resume` decides between a new session and the subject's unfinished one; a
   complete subject is refused (``SessionComplete``) unless ``--new-session REASON``
   (:func:`check_new_session_reason`) asks for a further session.
3. A new session: :func:`create_session` decides again and writes the ``sessions`` row with its
   provenance (:func:`software_provenance`), the plan, the lock and the ``new_session`` and
   ``open`` events in one ``BEGIN IMMEDIATE`` transaction. Deciding and creating are one
   transaction, so two processes started at the same moment make one session: the one that
   writes second finds the other's session (:class:`SessionAppeared`), and its caller resumes
   that one instead -- refused while the first process holds it.
4. A resumed one: :func:`stored_seed` checks the seed, :func:`reopen` takes the lock and logs a
   ``crash`` (when the last run ended without closing) and the ``resume`` event together; a
   lock held on another host is taken over only with the operator's reason
   (``--take-over-lock REASON``), logged as a ``lock_taken_over`` event.
5. :class:`LoggedSession` logs events, marks the session complete (dropping its lock in the same
   transaction) and closes it (``close`` event).

References
----------
Jung et al. 2015, Sec. 3.2 (procedure).
"""

from __future__ import annotations

import json
import logging
import platform
import socket
from collections.abc import Callable
from typing import Any

import numpy as np

from experiment.clock import Clock
from experiment.interfaces import ClosesOnExit
from experiment.log import ResumeMismatch, SessionComplete, TrialLog, TrialLogError
from experiment.log.locks import TAKE_OVER_OPTION
from experiment.protocol import ProtocolSpec
from stimuli.flagnames import param
from stimuli.software import git_commit

__all__ = [
    "LoggedSession",
    "SessionAppeared",
    "check_new_session_reason",
    "check_subject_and_seed",
    "create_session",
    "open_or_create",
    "reopen",
    "session_to_resume",
    "software_provenance",
    "stored_seed",
]

logger = logging.getLogger(__name__)


class SessionAppeared(TrialLogError):
    """Another process wrote a session of the subject between the decision and the creation.

    Raised by :func:`create_session` (nothing is written); the caller decides again, which
    resumes that session (refused while its process holds it) or reports it complete.
    """


def software_provenance() -> dict[str, str | None]:
    """Return ``{'software_version', 'git_commit', 'machine'}`` for the sessions row (H15)."""
    try:
        from stimuli import __version__ as version
    except ImportError:  # pragma: no cover - stimuli is part of the same distribution
        version = None
    commit = git_commit()
    machine = (
        f"{socket.gethostname()} ({platform.system()} {platform.machine()}, "
        f"Python {platform.python_version()})"
    )
    return {"software_version": version, "git_commit": commit, "machine": machine}


def check_new_session_reason(reason: str | None) -> None:
    """Refuse a blank or multi-line ``new_session`` reason (None: no new session asked for).

    Raises
    ------
    TrialLogError
        Naming ``new_session`` (``--new-session`` on the command line) and what is expected.
    """
    if reason is None:
        return
    if not isinstance(reason, str) or not reason.strip() or not reason.isprintable():
        raise TrialLogError(
            f"{param('new_session')} needs the reason for another session on one line, e.g. "
            f"{param('new_session', 're-test after new glasses')}; got {reason!r}"
        )


def check_subject_and_seed(subject: object, seed: object) -> None:
    """Refuse a subject that is not a non-empty string, or a seed that is not None or >= 0.

    Raises
    ------
    ValueError
        Naming ``subject`` or ``seed`` and the value given.
    """
    if not isinstance(subject, str) or not subject.strip():
        raise ValueError(f"subject must be a non-empty string, got {subject!r}")
    if seed is not None and (
        isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0
    ):
        raise ValueError(f"seed must be a non-negative integer or None, got {seed!r}")


def session_to_resume(log: TrialLog, subject: str, new_session: str | None) -> dict | None:
    """Return the subject's unfinished session row to resume, or None to create a session.

    Raises
    ------
    TrialLogError
        ``new_session`` is blank or multi-line, or given while another session of the subject
        is unfinished.
    SessionComplete
        The subject's session is complete and ``new_session`` is None (or names a completed
        session).
    """
    check_new_session_reason(new_session)
    decision, existing = log.session_to_open(subject, new_session=new_session)
    if decision == "complete":
        raise SessionComplete(log.complete_message(existing), existing)
    return existing if decision == "resume" else None


def create_session(
    log: TrialLog,
    protocol: ProtocolSpec,
    subject: str,
    clock: Clock,
    *,
    seed: int,
    write_plan: Callable[[int], None],
    open_note: str,
    new_session: str | None = None,
    **columns: Any,
) -> int:
    """Write a new session in one transaction and return its id.

    The ``sessions`` row (the protocol, its hashes, ``seed``, the primary rater, the software's
    provenance and ``columns``: ``display_json``, ``stimset_path``, ``stimset_manifest_sha256``,
    ``responder``, ...), then the plan (``write_plan(session_id)``), the lock, the
    ``new_session`` event (with the operator's reason, when given) and the ``open`` event.

    The transaction (``BEGIN IMMEDIATE``: no other process writes until it ends) first decides
    again what running the subject does (:meth:`TrialLog.session_to_open`): a session of the
    subject written since the caller's decision -- the same subject started twice at once --
    is never doubled.

    Raises
    ------
    SessionAppeared
        The subject has a session now that the caller's decision did not see (nothing is
        written).
    SessionLocked
        Another live process holds the lock (nothing is written).
    """
    prov = software_provenance()
    with log.atomic():
        decision, row = log.session_to_open(subject, new_session=new_session)
        if decision != "new":
            raise SessionAppeared(
                f"{log.path}: another process started session {row['session_id']} of subject "
                f"{subject} at the same moment; run the command again to resume or report it"
            )
        sid = log.create_session(
            subject=subject,
            protocol_name=protocol.name,
            protocol_sha256=protocol.content_sha256(),
            protocol_file_sha256=protocol.source_sha256,
            protocol_path=protocol.source_path,
            protocol_json=json.dumps(protocol.to_dict(), sort_keys=True),
            seed=str(seed),
            primary_rater=protocol.scoring.primary_rater,
            **columns,
            **prov,
        )
        write_plan(sid)
        log.acquire_lock(sid)
        if new_session is not None:
            log.add_event(sid, "new_session", new_session, clock.now_s())
        log.add_event(sid, "open", open_note, clock.now_s())
    return sid


def stored_seed(log: TrialLog, subject: str, row: dict, seed: int | None) -> int:
    """Return the unfinished session's stored root seed; ``seed`` must be None or the same.

    Raises
    ------
    ResumeMismatch
        ``seed`` differs from the stored one.
    """
    stored = int(row["seed"])
    if seed is not None and int(seed) != stored:
        raise ResumeMismatch(
            f"{log.path}: subject {subject} has unfinished session {row['session_id']} with "
            f"seed {stored}, not {seed}; omit {param('seed')} to resume it"
        )
    return stored


def open_or_create(
    log: TrialLog,
    subject: str,
    new_session: str | None,
    resume: Callable[[dict], Any],
    create: Callable[[], Any],
) -> Any:
    """Resume the subject's unfinished session or create one, whatever the timing.

    ``resume(row)`` resumes the unfinished session ``row``; ``create()`` makes a session
    through :func:`create_session`. When another process created the subject's session between
    the decision and the creation (:class:`SessionAppeared`), the decision is taken again: that
    session is resumed (refused with ``SessionLocked`` while its process holds it) or reported
    complete.

    Raises
    ------
    SessionComplete, SessionLocked, TrialLogError
        As :func:`session_to_resume`, ``resume`` and ``create`` raise them.
    """
    existing = session_to_resume(log, subject, new_session)
    if existing is None:
        try:
            return create()
        except SessionAppeared:
            existing = session_to_resume(log, subject, new_session)
            if existing is None:  # created and completed meanwhile under another reason
                raise
    return resume(existing)


def reopen(
    log: TrialLog,
    session_id: int,
    clock: Clock,
    describe: Callable[[], tuple[str, str]],
    then: Callable[[], None] | None = None,
    *,
    take_over: str | None = None,
) -> dict | None:
    """Lock an unfinished session to resume it; log the crash it recovers from, and the resume.

    One transaction: the lock is taken; ``describe()`` returns what was committed (for the
    ``crash`` event, logged when the previous run ended without closing) and the ``resume``
    event's note; ``then()`` adds what else the resume writes. ``take_over`` (the operator's
    reason, ``--take-over-lock REASON``) takes over a lock held on another host; the
    ``lock_taken_over`` event names this process, its host and user, the old holder and the
    reason.

    Returns
    -------
    dict or None
        The stale lock of the run that crashed (``pid``, ``host``, ``acquired_at``), or None.

    Raises
    ------
    SessionComplete
        Another process completed the session since the caller decided to resume it (the
        check and the lock are one transaction).
    SessionLocked
        Another live process has the session open (or one on another host, without
        ``take_over``).
    """
    with log.atomic():
        row = log.session(session_id)
        if row["status"] != "open":  # completed by another process since the decision
            raise SessionComplete(log.complete_message(row), row)
        stale = log.acquire_lock(session_id, take_over=take_over)
        if stale is not None and stale.get("taken_over") is not None:
            log.add_event(
                session_id,
                "lock_taken_over",
                f"{TAKE_OVER_OPTION} by {_who()}: lock of pid {stale['pid']} on "
                f"{stale['host']} (since {stale['acquired_at']}) taken over; reason: "
                f"{stale['taken_over']}",
                clock.now_s(),
            )
        committed, resumed = describe()
        if stale is not None:
            log.add_event(
                session_id,
                "crash",
                f"previous run (pid {stale['pid']} on {stale['host']}, since "
                f"{stale['acquired_at']}) ended without closing; {committed}",
                clock.now_s(),
            )
        log.add_event(session_id, "resume", resumed, clock.now_s())
        if then is not None:
            then()
    if stale is not None:
        logger.warning("session %s: previous run crashed; %s", session_id, resumed)
    return stale


def _who() -> str:
    """Name this process, its host and its user, for the ``lock_taken_over`` event."""
    import getpass
    import os

    try:
        user = getpass.getuser()
    except (KeyError, OSError):  # no user name in a bare container
        user = f"uid {os.getuid()}"
    return f"user {user}, pid {os.getpid()} on {socket.gethostname()}"


class LoggedSession(ClosesOnExit):
    """What every session does with its row in the trial log: events, completion, closing.

    A subclass sets ``log``, ``session_id`` and ``clock`` and defines :meth:`progress`.
    """

    log: TrialLog
    session_id: int
    clock: Clock
    _closed: bool = False

    def progress(self) -> tuple[int, int]:
        """Return ``(answered, total)`` trials."""
        raise NotImplementedError

    def log_event(self, kind: str, note: str = "") -> None:
        """Append an event (pause, resume, abort, note, crash, ...) stamped with the clock."""
        self.log.add_event(self.session_id, kind, note, self.clock.now_s())

    def _mark_complete(self, t_s: float) -> None:
        """Mark the session completed, with its ``complete`` event, and drop its lock.

        Inside the caller's transaction, so that the last answer, the completion and the lock's
        end commit together.
        """
        self.log.finish_session(self.session_id)
        self.log.add_event(self.session_id, "complete", "", t_s)

    def close(self) -> None:
        """Log a ``close`` event and release the session lock (the log stays open)."""
        if self._closed:
            return
        a, n = self.progress()
        try:
            self.log_event("close", f"{a} of {n} trials answered")
        finally:
            self.log.release_lock(self.session_id)
            self._closed = True
