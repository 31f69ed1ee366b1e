"""The trial log writer: one append-only SQLite file per study (house style H16).

:class:`TrialLog` opens (or creates, :mod:`experiment.log.logfile`) a log, migrates it
(:mod:`experiment.log.schema`) and writes sessions, schedules, trials, scores, events and locks;
its read-only queries come from :class:`~experiment.log.readers.LogQueries`.

Durability: WAL journal, ``synchronous=FULL``; each onset is one transaction, and each answered
trial (its ``trials`` row and its first ``scores`` row) is one transaction, committed before the
next stimulus is shown. A full disk rolls the open transaction back and ends with one line
(:class:`TrialLogError`); every acknowledged trial stays. Read-only opens never write beside the
file: without a ``-wal`` file (no writer) the database is opened ``immutable``. The crash tests
inject faults at each write step through :data:`~experiment.log.faults.FAULT_ENV`
(:func:`~experiment.log.faults.fault_point`).
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from experiment.interfaces import Answer, ClosesOnExit, FlipRecord
from experiment.log import locks, schema
from experiment.log.errors import TrialLogError
from experiment.log.faults import fault_point
from experiment.log.logfile import check_writable, create_log_file, identify_log_file
from experiment.log.readers import LogQueries
from experiment.log.schema import utc_now
from experiment.protocol import SCORES
from experiment.trials import Schedule, Trial

__all__ = ["TrialLog", "WAL_CHECKPOINT_PAGES", "WAL_SIZE_LIMIT_BYTES"]

#: Pages written to the WAL before SQLite copies them into the log (a passive checkpoint, which
#: never waits for a reader). Ours: 32 pages (128 KB at SQLite's 4 KB page) is a few trials'
#: commits, so a checkpoint's extra fsync comes every few trials; SQLite's default is 1000.
WAL_CHECKPOINT_PAGES = 32
#: Size the WAL file is truncated to when a checkpoint lets it restart, bytes (ours: twice the
#: checkpoint interval, so one large transaction -- a schedule -- does not stay on disk).
WAL_SIZE_LIMIT_BYTES = 2 * WAL_CHECKPOINT_PAGES * 4096


class TrialLog(ClosesOnExit, LogQueries):
    """An open trial log (SQLite file, or ``":memory:"`` as the test twin).

    Parameters
    ----------
    path : str or Path
        The study's ``.sqlite`` file (created if missing), or ``":memory:"``.
    readonly : bool
        Open without writing anything (``session status``/``export``; readers while a session
        writes). A read-only log is never migrated.

    Raises
    ------
    TrialLogError
        The file is not writable (when ``readonly`` is False), corrupt, not a trial log, or from
        a newer version of this software.
    """

    def __init__(self, path: str | Path = ":memory:", *, readonly: bool = False) -> None:
        self.path = str(path)
        self.readonly = readonly
        self._token = uuid.uuid4().hex
        self._held: set[int] = set()
        self._depth = 0
        memory = self.path == ":memory:"
        kind = "memory"
        if not memory:
            p = Path(self.path)
            if readonly and not p.exists():
                raise TrialLogError(f"{p}: trial log not found")
            kind = identify_log_file(p)  # reads only: a foreign file is refused untouched
            if readonly and kind == "new":
                raise TrialLogError(f"{p}: empty file, not a confocal trial log")
            if not readonly:
                check_writable(p)
                if kind == "new":
                    create_log_file(p)
        try:
            self._connect()
            tables = {
                r[0] for r in self._fetch("SELECT name FROM sqlite_master WHERE type='table'")
            }
        except sqlite3.DatabaseError as exc:
            raise TrialLogError(
                f"{self.path}: not a readable SQLite trial log ({exc}); nothing was changed"
            ) from None
        if tables and "schema_migrations" not in tables:
            self._con.close()
            raise TrialLogError(
                f"{self.path}: an SQLite file but not a confocal trial log "
                "(no schema_migrations table); nothing was changed"
            )
        if tables:  # refuse a newer schema before anything is written (WAL mode, migrations)
            self._check_version()
        if readonly:
            if not tables:
                self._con.close()
                raise TrialLogError(f"{self.path}: empty file, not a confocal trial log")
        else:
            try:
                if not memory:
                    mode = self._con.execute("PRAGMA journal_mode = WAL").fetchone()[0]
                    if mode.lower() != "wal":
                        raise TrialLogError(f"{self.path}: could not enable WAL (got {mode})")
                self._con.execute("PRAGMA synchronous = FULL")
                self._con.execute("PRAGMA foreign_keys = ON")
                if not memory:
                    self._bound_wal()
                self._migrate()
            except sqlite3.OperationalError as exc:
                self._con.close()
                raise TrialLogError(f"{self.path}: cannot write the trial log ({exc})") from None
        self._check_version()

    def _connect(self) -> None:
        """Open the connection: read-write, or read-only (``immutable`` while no WAL exists)."""
        self._immutable = False
        if self.readonly and self.path != ":memory:":
            uri = Path(self.path).resolve().as_uri() + "?mode=ro"
            if not Path(self.path + "-wal").exists():
                # No WAL file: no writer has the log open, and a mode=ro connection to a
                # WAL database would still create -wal/-shm files beside it and leave them.
                uri += "&immutable=1"
                self._immutable = True
            self._con = sqlite3.connect(uri, uri=True, isolation_level=None, timeout=10.0)
        else:
            self._con = sqlite3.connect(self.path, isolation_level=None, timeout=10.0)
        self._con.row_factory = sqlite3.Row
        self._con.execute("PRAGMA busy_timeout = 10000")

    def _reopen_after_write(self) -> bool:
        """Reopen once, through the writer's WAL, after a read failed as "malformed".

        An ``immutable`` connection assumes nobody writes the file; a writer that opened it
        since (the same subject started twice at once) can make a read fail as "malformed".
        Reopen once -- through the WAL the writer keeps now -- and let the query run again.
        """
        if not getattr(self, "_immutable", False) or getattr(self, "_reopened", False):
            return False
        self._reopened = True
        self._con.close()
        self._connect()
        return True

    def _bound_wal(self) -> None:
        """Keep the write-ahead log small while a session writes (:data:`WAL_CHECKPOINT_PAGES`).

        SQLite's default copies the WAL into the file only every 1000 pages (4 MB) and never
        shrinks it, so a session's WAL grew ~25 KB a trial to several times the finished log.
        Checkpointing every :data:`WAL_CHECKPOINT_PAGES` pages (passive: it never waits for a
        reader) and truncating the WAL to :data:`WAL_SIZE_LIMIT_BYTES` when it restarts keeps
        the WAL near that size; each checkpoint is crash-safe (SQLite's own protocol).
        """
        self._con.execute(f"PRAGMA wal_autocheckpoint = {WAL_CHECKPOINT_PAGES}")
        self._con.execute(f"PRAGMA journal_size_limit = {WAL_SIZE_LIMIT_BYTES}")

    def _check_version(self) -> None:
        v = self.schema_version()
        if v > schema.latest_version():
            self._con.close()
            raise TrialLogError(
                f"{self.path}: schema version {v} is newer than this software knows "
                f"({schema.latest_version()}); upgrade confocal"
            )

    # -- transactions -------------------------------------------------------------------------

    @contextmanager
    def atomic(self) -> Iterator[sqlite3.Connection]:
        """Run a block in one transaction (a savepoint when nested); roll back on any exception."""
        if self.readonly:
            raise TrialLogError(f"{self.path}: opened read-only; cannot write")
        if self._depth == 0:
            try:
                fault_point("begin")
                self._con.execute("BEGIN IMMEDIATE")
            except sqlite3.OperationalError as exc:
                self._raise_write_error(exc)
            self._depth += 1
            try:
                yield self._con
                fault_point("commit")
                self._con.execute("COMMIT")
            except BaseException as exc:
                self._depth -= 1
                if self._con.in_transaction:
                    self._con.execute("ROLLBACK")
                if isinstance(exc, sqlite3.OperationalError):
                    self._raise_write_error(exc)
                raise
            self._depth -= 1
            fault_point("committed")
        else:
            name = f"sp{self._depth}"
            self._con.execute(f"SAVEPOINT {name}")
            self._depth += 1
            try:
                yield self._con
            except BaseException:
                self._depth -= 1
                self._con.execute(f"ROLLBACK TO {name}")
                self._con.execute(f"RELEASE {name}")
                raise
            self._depth -= 1
            self._con.execute(f"RELEASE {name}")

    def _raise_write_error(self, exc: sqlite3.OperationalError) -> None:
        """Turn SQLite's disk-full and I/O errors into one line; the last commit is intact."""
        text = " ".join(str(exc).split())
        if "full" in text or "disk i/o" in text.lower():
            raise TrialLogError(
                f"{self.path}: the disk is full ({text}); the write was rolled back, so the log "
                "holds every trial up to the last one acknowledged; free space and run the same "
                "command again to resume"
            ) from None
        raise exc

    def _migrate(self) -> None:
        """Apply every migration not yet recorded, each in its own transaction."""
        self._con.execute(schema.MIGRATIONS_TABLE)
        done = {r[0] for r in self._con.execute("SELECT version FROM schema_migrations")}
        # schema.MIGRATIONS is read here, not imported by name, so that a test can stand an
        # older schema in for it and make a log as an earlier version of confocal did
        for version, name, sql in schema.MIGRATIONS:
            if version in done:
                continue
            with self.atomic() as con:
                # decided again inside the write transaction: another process opening the
                # same old log at the same moment may have applied it since the read above
                if con.execute(
                    "SELECT 1 FROM schema_migrations WHERE version = ?", (version,)
                ).fetchone():
                    continue
                schema.apply_migration(con, version, name, sql)

    # -- sessions -----------------------------------------------------------------------------

    def create_session(self, **columns: Any) -> int:
        """Insert a ``sessions`` row (status ``open``) and return its ``session_id``."""
        allowed = {
            "subject",
            "protocol_name",
            "protocol_sha256",
            "protocol_file_sha256",
            "protocol_path",
            "protocol_json",
            "display_json",
            "stimset_path",
            "stimset_manifest_sha256",
            "seed",
            "primary_rater",
            "responder",
            "software_version",
            "git_commit",
            "machine",
            "observer",
            "observer_params",
            "participant_json",
            "monitor_json",
        }
        bad = sorted(set(columns) - allowed)
        if bad:
            raise ValueError(f"unknown sessions column {bad[0]!r}")
        cols = sorted(columns)
        with self.atomic() as con:
            cur = con.execute(
                f"INSERT INTO sessions ({', '.join(cols)}, started_at, status) "
                f"VALUES ({', '.join('?' for _ in cols)}, ?, 'open')",
                tuple(columns[c] for c in cols) + (utc_now(),),
            )
            return int(cur.lastrowid)

    def finish_session(self, session_id: int) -> None:
        """Mark a session completed (all planned trials answered) and drop its lock row.

        One transaction (inside the caller's, with the last answer): a completed session is
        never "open" in any process, so a kill right after this commit leaves no lock behind.
        """
        with self.atomic() as con:
            con.execute(
                "UPDATE sessions SET status = 'completed', ended_at = ? WHERE session_id = ?",
                (utc_now(), session_id),
            )
            con.execute("DELETE FROM locks WHERE session_id = ?", (session_id,))

    # -- schedule -----------------------------------------------------------------------------

    def write_schedule(self, session_id: int, schedule: Schedule) -> None:
        """Write the whole planned schedule (one transaction, before the first trial)."""
        with self.atomic() as con:
            con.executemany(
                f"INSERT INTO schedule (session_id, {', '.join(schema.SCHEDULE_COLUMNS)}) "
                f"VALUES (?, {', '.join('?' for _ in schema.SCHEDULE_COLUMNS)})",
                [
                    (
                        session_id,
                        t.index,
                        t.part,
                        t.block,
                        t.object,
                        t.object_name,
                        t.condition,
                        t.level,
                        t.window,
                        t.pixels,
                        t.path,
                        t.sha256,
                        t.pass_allowed_after_s,
                        t.repetition,
                        int(t.break_before),
                    )
                    for t in schedule.trials
                ],
            )

    # -- trials and scores --------------------------------------------------------------------

    def record(
        self, session_id: int, trial: Trial, flip: FlipRecord, answer: Answer, recognized: bool
    ) -> None:
        """Write one answered trial and its first (primary) score in one durable transaction.

        Raises
        ------
        TrialLogError
            The trial was already recorded (``UNIQUE(session_id, trial_index)``).
        """
        now = utc_now()
        try:
            with self.atomic() as con:
                if not con.execute(
                    "SELECT 1 FROM viewings WHERE session_id = ? AND trial_index = ?",
                    (session_id, trial.index),
                ).fetchone():  # a caller that did not log the onset: log it with the answer
                    self._insert_viewing(con, session_id, trial.index, flip.onset_s)
                fault_point("record.trial")
                con.execute(
                    "INSERT INTO trials (session_id, trial_index, object, condition, level, "
                    "pixels, stimulus_sha256, onset_s, offset_s, dropped_frames, refresh_hz, "
                    "frame_intervals_ms, response, rt_s, recorded_at) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        session_id,
                        trial.index,
                        trial.object,
                        trial.condition,
                        trial.level,
                        trial.pixels,
                        trial.sha256,
                        flip.onset_s,
                        flip.offset_s,
                        flip.dropped_frames,
                        flip.refresh_hz,
                        json.dumps(list(flip.frame_intervals_ms)),
                        answer.response,
                        answer.rt_s,
                        now,
                    ),
                )
                fault_point("record.score")
                con.execute(
                    "INSERT INTO scores (session_id, trial_index, score, recognized, rater, "
                    "is_primary, scored_at) VALUES (?, ?, ?, ?, ?, 1, ?)",
                    (session_id, trial.index, answer.score, int(recognized), answer.rater, now),
                )
        except sqlite3.IntegrityError as exc:
            raise TrialLogError(
                f"{self.path}: cannot record trial {trial.index} of session {session_id} ({exc})"
            ) from None

    def record_onset(self, session_id: int, trial_index: int, onset_s: float | None) -> int:
        """Log that a trial's stimulus is on the screen, durably, before any answer exists.

        Returns
        -------
        int
            How many times this trial has now been shown (2 or more: a repeat viewing, e.g. the
            stimulus was shown, the program crashed before the answer was logged, and the
            resumed session showed it again).
        """
        with self.atomic() as con:
            self._insert_viewing(con, session_id, trial_index, onset_s)
            return self.viewings(session_id, trial_index)

    def _insert_viewing(
        self, con: sqlite3.Connection, session_id: int, trial_index: int, onset_s: float | None
    ) -> None:
        fault_point("onset.insert")
        con.execute(
            "INSERT INTO viewings (session_id, trial_index, onset_s, shown_at, pid) "
            "VALUES (?, ?, ?, ?, ?)",
            (session_id, trial_index, onset_s, utc_now(), os.getpid()),
        )

    def add_score(
        self,
        session_id: int,
        trial_index: int,
        score: str,
        recognized: bool,
        rater: str,
        *,
        note: str = "",
    ) -> None:
        """Append a re-scoring of an answered trial (never updates the old scores)."""
        if score not in SCORES:
            raise ValueError(f"score must be one of {', '.join(SCORES)}, got {score!r}")
        with self.atomic() as con:
            first = con.execute(
                "SELECT rater FROM scores WHERE session_id = ? AND trial_index = ? "
                "ORDER BY score_id LIMIT 1",
                (session_id, trial_index),
            ).fetchone()
            if first is None:
                raise TrialLogError(
                    f"{self.path}: trial {trial_index} of session {session_id} has no answer "
                    "to re-score"
                )
            primary_rater = con.execute(
                "SELECT primary_rater FROM sessions WHERE session_id = ?", (session_id,)
            ).fetchone()[0]
            is_primary = int(rater in (first[0], primary_rater))
            con.execute(
                "INSERT INTO scores (session_id, trial_index, score, recognized, rater, "
                "is_primary, scored_at, note) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (
                    session_id,
                    trial_index,
                    score,
                    int(recognized),
                    rater,
                    is_primary,
                    utc_now(),
                    note,
                ),
            )

    # -- events and locks ---------------------------------------------------------------------

    def add_event(
        self, session_id: int | None, kind: str, note: str = "", clock_s: float | None = None
    ) -> None:
        """Append an event (pause, resume, abort, note, break, crash, open, close, complete)."""
        if not kind or not isinstance(kind, str):
            raise ValueError(f"kind must be a non-empty string, got {kind!r}")
        with self.atomic() as con:
            con.execute(
                "INSERT INTO events (session_id, kind, note, clock_s, at, pid, host) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (session_id, kind, note, clock_s, utc_now(), os.getpid(), socket.gethostname()),
            )

    def acquire_lock(
        self, session_id: int, *, take_over: str | None = None
    ) -> dict[str, Any] | None:
        """Claim a session for this process, in one transaction.

        Returns the stale lock row that was taken over (a crashed run), or None; raises
        :class:`~experiment.log.errors.SessionLocked` when a live process (or one on another
        host, unless ``take_over`` gives the operator's reason) holds the session
        (:func:`~experiment.log.locks.claim_session`).
        """
        with self.atomic() as con:
            stale = locks.claim_session(
                con, self.path, session_id, self._token, take_over=take_over
            )
        self._held.add(session_id)
        return stale

    def release_lock(self, session_id: int) -> None:
        """Release this process's claim on a session (no-op if not held)."""
        if session_id not in self._held:
            return
        with self.atomic() as con:
            locks.release_session(con, session_id, self._token)
        self._held.discard(session_id)

    def save_copy(self, path: str | Path) -> None:
        """Write the whole log to a new SQLite file ``path`` (sqlite3's online backup).

        For logs kept in memory (``:memory:``, e.g. simulated subjects in ``confocal demo``):
        the copy is a complete trial log, written to a temporary file and renamed.
        """
        p = Path(path)
        tmp = p.with_name(f".{p.name}.{uuid.uuid4().hex}.tmp")
        try:
            dest = sqlite3.connect(tmp)
            try:
                self._con.backup(dest)
            finally:
                dest.close()
            os.replace(tmp, p)
        finally:
            tmp.unlink(missing_ok=True)

    def close(self) -> None:
        """Release held locks and close the connection."""
        if getattr(self, "_con", None) is None:
            return
        for sid in list(self._held):
            try:
                self.release_lock(sid)
            except (sqlite3.DatabaseError, TrialLogError):
                pass  # the lock row stays and is detected as stale by the next run
        self._con.close()
        self._con = None  # type: ignore[assignment]
