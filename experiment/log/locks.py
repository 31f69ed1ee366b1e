"""Session locks: which process has a session open, and whether that process still lives.

Locking: a session is claimed by a ``locks`` row (pid, host, process start time), written in an
``IMMEDIATE`` transaction. A second process finding a live holder is refused. A row whose process
is gone (no such pid, a zombie, or the pid reused by a younger process) is a stale lock left by a
crash: it is taken over and the caller logs a ``crash`` event. We chose a row over an ``fcntl``
lock file because the row also tells *who* holds the session (shown by ``session status``) and
its staleness is exactly the "did the last run end cleanly" fact we must log.

A holder on another host cannot be checked for liveness: it is refused with its host named,
unless the operator takes the lock over (``--take-over-lock REASON``: the machine was renamed,
e.g. a laptop on another network or a new container, and no program there runs the session);
the caller then logs a ``lock_taken_over`` event naming who took it and why. A live holder on
this host is refused even then. Completing a session deletes its lock row in the transaction
that marks it complete (:meth:`~experiment.log.triallog.TrialLog.finish_session`), so a kill
after that commit leaves no lock behind.
"""

from __future__ import annotations

import os
import socket
import sqlite3
from pathlib import Path
from typing import Any

from experiment.log.errors import SessionLocked, TrialLogError
from experiment.log.schema import utc_now
from stimuli.flagnames import param

__all__ = [
    "TAKE_OVER_OPTION",
    "check_take_over_reason",
    "claim_session",
    "lock_is_stale",
    "release_session",
    "process_start",
    "pid_alive",
]

#: The command-line option that takes over a lock whose process is gone (on another host).
TAKE_OVER_OPTION = "--take-over-lock"


def check_take_over_reason(reason: str | None) -> None:
    """Refuse a blank or multi-line take-over reason (None: no take-over asked for).

    Raises
    ------
    TrialLogError
        Naming ``--take-over-lock`` and what is expected.
    """
    if reason is None:
        return
    if not isinstance(reason, str) or not reason.strip() or not reason.isprintable():
        raise TrialLogError(
            f"{param('take_over_lock')} needs the reason on one line, e.g. "
            f"{param('take_over_lock', 'laptop renamed on the clinic network')}; got {reason!r}"
        )


def lock_is_stale(row: dict[str, Any]) -> bool | None:
    """Return whether a lock row's process is gone: True/False on this host, None on another.

    On another host its liveness cannot be checked from here.
    """
    if row["host"] != socket.gethostname():
        return None
    return not pid_alive(row["pid"], row["proc_start"])


def claim_session(
    con: sqlite3.Connection,
    path: str,
    session_id: int,
    token: str,
    *,
    take_over: str | None = None,
) -> dict[str, Any] | None:
    """Write this process's ``locks`` row for a session, inside the caller's transaction.

    Parameters
    ----------
    con : sqlite3.Connection
        The log's connection, in an ``IMMEDIATE`` transaction.
    path : str
        The log's path, for messages.
    session_id : int
    token : str
        The opening :class:`~experiment.log.triallog.TrialLog`'s own token: the same log
        claiming again keeps its claim.
    take_over : str, optional
        The operator's reason to take over a lock held on another host (whose process cannot
        be checked from here). A live holder on this host is refused even with a reason.

    Returns
    -------
    dict or None
        The stale lock row that was taken over (a crashed run), or None; when ``take_over``
        was needed (another host) or given, the row has ``taken_over`` set to the reason.

    Raises
    ------
    SessionLocked
        A live process on this host holds the session, or a process on another host does and
        ``take_over`` is None.
    """
    host = socket.gethostname()
    me = os.getpid()
    row = con.execute("SELECT * FROM locks WHERE session_id = ?", (session_id,)).fetchone()
    stale = None
    if row is not None:
        row = dict(row)
        mine = row["pid"] == me and row["token"] == token and row["host"] == host
        if not mine:
            if row["host"] != host and take_over is None:
                raise SessionLocked(
                    f"{path}: session {session_id} is open on host {row['host']} "
                    f"(pid {row['pid']}, since {row['acquired_at']}); refusing to open it "
                    f"twice. If no program on {row['host']} runs it any more (e.g. this "
                    f"machine was renamed), add {param('take_over_lock', 'REASON')}"
                )
            if row["host"] == host and pid_alive(row["pid"], row["proc_start"]):
                raise SessionLocked(
                    f"{path}: session {session_id} is already open in another "
                    f"process (pid {row['pid']} on {host}, since {row['acquired_at']}); "
                    "refusing to open it twice"
                )
            stale = row
            if take_over is not None:
                stale["taken_over"] = take_over
        con.execute("DELETE FROM locks WHERE session_id = ?", (session_id,))
    con.execute(
        "INSERT INTO locks (session_id, pid, host, proc_start, token, acquired_at) "
        "VALUES (?, ?, ?, ?, ?, ?)",
        (session_id, me, host, process_start(me), token, utc_now()),
    )
    return stale


def release_session(con: sqlite3.Connection, session_id: int, token: str) -> None:
    """Delete the ``locks`` row that ``token`` wrote for a session (inside a transaction)."""
    con.execute("DELETE FROM locks WHERE session_id = ? AND token = ?", (session_id, token))


def _proc_stat(pid: int) -> list[str] | None:
    """Return the fields of ``/proc/PID/stat`` after the command name, or None."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # the command name (field 2) may hold spaces; it ends at the last ')'
    return text[text.rfind(")") + 2 :].split()


def process_start(pid: int) -> str | None:
    """Return a process's start time (clock ticks since boot, ``/proc``), or None if unknown."""
    st = _proc_stat(pid)
    return st[19] if st and len(st) > 19 else None


def pid_alive(pid: int, proc_start: str | None) -> bool:
    """Return whether process ``pid`` runs and is the one that started at ``proc_start``.

    A zombie, or a pid reused by a younger process, is not alive: its lock is stale.
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    st = _proc_stat(pid)
    if st is not None:
        if st[0] in ("Z", "X"):
            return False
        if proc_start is not None and len(st) > 19 and st[19] != proc_start:
            return False  # the pid was reused by another process
    return True
