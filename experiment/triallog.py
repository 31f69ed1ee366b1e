"""The trial log: one append-only SQLite file per study (house style H16).

Schema (created by numbered migrations, recorded in ``schema_migrations``)
----------------------------------------------------------------------------
``sessions``   one row per session: subject, protocol (name, content and file sha256, JSON),
               display spec, stimulus-set path and manifest sha256, seed, software version, git
               commit, machine, start/end (UTC), status ``open``/``completed``, primary rater,
               the simulated observer with its parameters (NULL for a person), participant
               metadata and monitor profile (JSON; migration 2).
``schedule``   the planned trials, written whole before the first trial;
               primary key (session_id, trial_index).
``trials``     one row per answered trial: object, condition, level, pixels, stimulus sha256,
               onset/offset (session clock, s), dropped frames, response text, rt_s, recorded_at;
               ``UNIQUE(session_id, trial_index)``. Rows are never updated or deleted (triggers).
``scores``     append-only scorings: score, recognized, rater, is_primary, scored_at. The trial's
               own scoring is primary; a re-score by the same rater (or by the protocol's primary
               rater) is primary too; other raters' scores are kept beside it for agreement.
``viewings``   (schema 4) one row per stimulus onset, committed when the frame is shown and
               before any answer exists, so a crash between onset and answer leaves the viewing
               on record; append-only.
``events``     pause, resume, abort, note, break, crash (detected at restart), open, close,
               complete, repeat_viewing (a trial shown again, e.g. after such a crash),
               new_session (a further session of a subject who already has one; the note is the
               operator's reason, given with ``--new-session REASON``).
``locks``      the process that has a session open: pid, host, process start time, token.
``active_events`` (migration 3, active search, :mod:`experiment.active`) one row per event of an
               active-search session, append-only: ``session_id, trial, attempt, seq, t_s, kind,
               payload`` (JSON object), ``recorded_at``; ``UNIQUE(session_id, seq)``. ``trial``
               is NULL for session-level rows (the ``plan``). Kinds: ``plan``, ``trial_start``,
               ``key``, ``state``, ``answer``, ``score``, ``attempt_abandoned``. The schema of each
               payload is documented in :mod:`experiment.active.eventlog`.
``tidy_trials`` (VIEW) one row per answered trial: ``subject, session, object, condition, level,
               window, pixels, recognized, response, score, rater, rt_s, part, trial_index,
               simulated, observer, viewings, repeat_viewing``, with ``recognized`` from the latest
               primary score and ``simulated`` 1 for a simulated observer's session (``observer``
               names it; it is ``human`` otherwise). This is what the analysis reads.

Durability: WAL journal, ``synchronous=FULL``; each onset is one transaction, and each answered
trial (its ``trials`` row and its first ``scores`` row) is one transaction, committed before the
next stimulus is shown. A full disk rolls the open transaction back and ends with one line
(:class:`TrialLogError`); every acknowledged trial stays. Read-only opens never write beside the
file: without a ``-wal`` file (no writer) the database is opened ``immutable``. The crash tests
inject faults at each write step through :data:`FAULT_ENV` (:func:`fault_point`).

Identity: a trial log says what it is in SQLite's header, ``PRAGMA application_id`` =
:data:`APPLICATION_ID` (set when the file is created, and by a migration on logs made before
that). Before anything opens a file to write, :func:`identify_log_file` decides by reading only
(the header's bytes, then, for a header without the id, the schema through an ``immutable``
connection or a private copy of the file and its WAL): our id, or id 0 with confocal's own
``schema_migrations`` rows and tables, is a trial log; anything else (another program's id, an
SQLite file without our schema, a file that is not SQLite, a folder) is refused with one line and
is left byte-identical, with nothing created beside it. A new log is made whole under a
temporary name (id, WAL header, every migration) and linked into place, so a crash never
leaves a half-made file.
A 0-byte file is taken as a new log only with no ``-wal``/``-shm``/``-journal`` beside it: it
holds nothing to harm, and it is replaced whole (renamed over), never written in place; with such
a file beside it, it is another program's database in the middle of a write, and is refused.

Locking: a session is claimed by a ``locks`` row (pid, host, process start time), written in an
``IMMEDIATE`` transaction. A second process finding a live holder is refused. A row whose process
is gone (no such pid, a zombie, or the pid reused by a younger process) is a stale lock left by a
crash: it is taken over and the caller logs a ``crash`` event. We chose a row over an ``fcntl``
lock file because the row also tells *who* holds the session (shown by ``session status``) and
its staleness is exactly the "did the last run end cleanly" fact we must log; a holder on another
host cannot be checked for liveness and is refused with its host named.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import sqlite3
import stat
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError
from experiment.interfaces import Answer, FlipRecord
from experiment.protocol import SCORES
from experiment.session.schedule import Schedule, Trial

__all__ = [
    "TrialLogError",
    "SessionLocked",
    "ResumeMismatch",
    "MIGRATIONS",
    "TIDY_COLUMNS",
    "TrialLog",
    "FAULT_ENV",
    "FAULT_STEPS",
    "fault_point",
    "APPLICATION_ID",
    "SessionComplete",
    "identify_log_file",
]

#: SQLite ``PRAGMA application_id`` of a confocal trial log: the ASCII bytes ``Cnfl`` (ours; any
#: fixed value not registered by another format would do).
APPLICATION_ID = 0x436E666C

#: Columns of the ``tidy_trials`` view, in order (the contract with ``analysis``).
TIDY_COLUMNS: tuple[str, ...] = (
    "subject",
    "session",
    "object",
    "condition",
    "level",
    "window",
    "pixels",
    "recognized",
    "response",
    "score",
    "rater",
    "rt_s",
    "part",
    "trial_index",
    "simulated",
    "observer",
    "viewings",
    "repeat_viewing",
)

_SCORE_LIST = ", ".join(f"'{s}'" for s in SCORES)

#: ``tidy_trials`` columns added by later migrations: ``simulated`` (1 for a simulated observer's
#: session) and ``observer`` (its name, ``human`` for people), from schema 2.
_TIDY_SIMULATED = """CASE WHEN s.observer IS NULL THEN 0 ELSE 1 END AS simulated,
               COALESCE(s.observer, 'human') AS observer"""

#: From schema 4: ``viewings`` counts the logged onsets of the trial (0 for trials answered
#: before schema 4 was applied, when onsets were not logged); ``repeat_viewing`` is 1 when the
#: subject saw the stimulus more than once (a crash between onset and answer, then a resume
#: that showed it again).
_TIDY_VIEWINGS = """(SELECT count(*) FROM viewings v
                WHERE v.session_id = t.session_id AND v.trial_index = t.trial_index) AS viewings,
               (SELECT count(*) > 1 FROM viewings v
                WHERE v.session_id = t.session_id AND v.trial_index = t.trial_index)
                   AS repeat_viewing"""


def _tidy_view_sql(*extra_columns: str) -> str:
    """``CREATE VIEW tidy_trials``: schema 1's columns, then ``extra_columns`` (SELECT terms)."""
    extra = "".join(f",\n               {c}" for c in extra_columns)
    return f"""
        CREATE VIEW tidy_trials AS
        SELECT s.subject AS subject,
               t.session_id AS session,
               t.object AS object,
               t.condition AS condition,
               t.level AS level,
               p.window AS window,
               t.pixels AS pixels,
               sc.recognized AS recognized,
               t.response AS response,
               sc.score AS score,
               sc.rater AS rater,
               t.rt_s AS rt_s,
               p.part AS part,
               t.trial_index AS trial_index{extra}
        FROM trials t
        JOIN sessions s ON s.session_id = t.session_id
        JOIN schedule p ON p.session_id = t.session_id AND p.trial_index = t.trial_index
        JOIN scores sc ON sc.score_id = (
            SELECT max(q.score_id) FROM scores q
            WHERE q.session_id = t.session_id AND q.trial_index = t.trial_index
              AND q.is_primary = 1)
        ORDER BY t.session_id, t.trial_index;
"""


#: Environment variable that injects a fault at a write step (tests of crash safety):
#: ``STEP@N=ACTION``, where STEP is a step name of :data:`FAULT_STEPS` or ``any``, N counts the
#: hits of that step in this process (1-based), and ACTION is ``exit`` (``os._exit(137)`` at that
#: hit, as a SIGKILL would end the process) or ``enospc`` (SQLite's "database or disk is full" at
#: that hit and every later one).
FAULT_ENV = "CONFOCAL_FAULT"

#: The write steps where a fault can be injected, in the order a trial passes through them.
FAULT_STEPS: tuple[str, ...] = (
    "begin",
    "onset.insert",
    "record.trial",
    "record.score",
    "commit",
    "committed",
)

_fault_spec: tuple[str, int, str] | None | bool = False  # False: not parsed yet
_fault_hits: dict[str, int] = {}


def fault_point(step: str) -> None:
    """Count a write step and inject the fault of :data:`FAULT_ENV` when it is due.

    A no-op when the variable is unset; used by the crash-safety tests to choose kill points
    at every write step instead of by sleeping.
    """
    global _fault_spec
    if _fault_spec is False:
        _fault_spec = _parse_fault(os.environ.get(FAULT_ENV, ""))
    if _fault_spec is None:
        return
    want, n, action = _fault_spec
    _fault_hits[step] = _fault_hits.get(step, 0) + 1
    _fault_hits["any"] = _fault_hits.get("any", 0) + 1
    if want not in (step, "any"):
        return
    if action == "exit" and _fault_hits[want] == n:
        os._exit(137)
    if action == "enospc" and _fault_hits[want] >= n:  # a full disk stays full
        raise sqlite3.OperationalError("database or disk is full")


def _parse_fault(text: str) -> tuple[str, int, str] | None:
    if not text.strip():
        return None
    try:
        where, action = text.strip().split("=")
        step, n = where.split("@")
        spec = (step, int(n), action)
    except ValueError:
        raise ValueError(f"{FAULT_ENV} must look like STEP@N=exit|enospc, got {text!r}") from None
    if spec[0] not in (*FAULT_STEPS, "any") or spec[1] < 1 or spec[2] not in ("exit", "enospc"):
        raise ValueError(f"{FAULT_ENV} must look like STEP@N=exit|enospc, got {text!r}")
    return spec


#: Numbered schema migrations: (version, name, SQL). Never edit a released one; append.
MIGRATIONS: tuple[tuple[int, str, str], ...] = (
    (
        1,
        "initial schema",
        f"""
        CREATE TABLE sessions (
            session_id INTEGER PRIMARY KEY,
            subject TEXT NOT NULL,
            protocol_name TEXT NOT NULL,
            protocol_sha256 TEXT NOT NULL,
            protocol_file_sha256 TEXT,
            protocol_path TEXT,
            protocol_json TEXT NOT NULL,
            display_json TEXT NOT NULL,
            stimset_path TEXT NOT NULL,
            stimset_manifest_sha256 TEXT NOT NULL,
            seed TEXT NOT NULL,
            primary_rater TEXT NOT NULL,
            responder TEXT,
            software_version TEXT,
            git_commit TEXT,
            machine TEXT,
            started_at TEXT NOT NULL,
            ended_at TEXT,
            status TEXT NOT NULL CHECK (status IN ('open', 'completed'))
        );
        CREATE INDEX sessions_subject ON sessions(subject);
        CREATE TABLE schedule (
            session_id INTEGER NOT NULL REFERENCES sessions(session_id),
            trial_index INTEGER NOT NULL CHECK (trial_index >= 0),
            part TEXT NOT NULL,
            block INTEGER NOT NULL,
            object TEXT NOT NULL,
            object_name TEXT NOT NULL,
            condition TEXT NOT NULL,
            level INTEGER NOT NULL,
            window INTEGER NOT NULL,
            pixels INTEGER NOT NULL,
            path TEXT NOT NULL,
            sha256 TEXT NOT NULL,
            pass_allowed_after_s REAL NOT NULL,
            repetition INTEGER NOT NULL,
            break_before INTEGER NOT NULL,
            PRIMARY KEY (session_id, trial_index)
        );
        CREATE TABLE trials (
            trial_id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL,
            trial_index INTEGER NOT NULL,
            object TEXT NOT NULL,
            condition TEXT NOT NULL,
            level INTEGER NOT NULL,
            pixels INTEGER NOT NULL,
            stimulus_sha256 TEXT NOT NULL,
            onset_s REAL,
            offset_s REAL,
            dropped_frames INTEGER,
            refresh_hz REAL,
            frame_intervals_ms TEXT,
            response TEXT NOT NULL,
            rt_s REAL,
            recorded_at TEXT NOT NULL,
            UNIQUE (session_id, trial_index),
            FOREIGN KEY (session_id, trial_index) REFERENCES schedule(session_id, trial_index)
        );
        CREATE TABLE scores (
            score_id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL,
            trial_index INTEGER NOT NULL,
            score TEXT NOT NULL CHECK (score IN ({_SCORE_LIST})),
            recognized INTEGER NOT NULL CHECK (recognized IN (0, 1)),
            rater TEXT NOT NULL,
            is_primary INTEGER NOT NULL CHECK (is_primary IN (0, 1)),
            scored_at TEXT NOT NULL,
            note TEXT NOT NULL DEFAULT '',
            FOREIGN KEY (session_id, trial_index) REFERENCES trials(session_id, trial_index)
        );
        CREATE INDEX scores_trial ON scores(session_id, trial_index);
        CREATE TABLE events (
            event_id INTEGER PRIMARY KEY,
            session_id INTEGER REFERENCES sessions(session_id),
            kind TEXT NOT NULL,
            note TEXT NOT NULL DEFAULT '',
            clock_s REAL,
            at TEXT NOT NULL,
            pid INTEGER,
            host TEXT
        );
        CREATE TABLE locks (
            session_id INTEGER PRIMARY KEY REFERENCES sessions(session_id),
            pid INTEGER NOT NULL,
            host TEXT NOT NULL,
            proc_start TEXT,
            token TEXT NOT NULL,
            acquired_at TEXT NOT NULL
        );
        CREATE TRIGGER trials_no_update BEFORE UPDATE ON trials
            BEGIN SELECT RAISE(ABORT, 'trials are append-only'); END;
        CREATE TRIGGER trials_no_delete BEFORE DELETE ON trials
            BEGIN SELECT RAISE(ABORT, 'trials are append-only'); END;
        CREATE TRIGGER scores_no_update BEFORE UPDATE ON scores
            BEGIN SELECT RAISE(ABORT, 'scores are append-only'); END;
        CREATE TRIGGER scores_no_delete BEFORE DELETE ON scores
            BEGIN SELECT RAISE(ABORT, 'scores are append-only'); END;
        CREATE TRIGGER schedule_no_update BEFORE UPDATE ON schedule
            BEGIN SELECT RAISE(ABORT, 'the schedule is fixed once written'); END;
        CREATE VIEW tidy_trials AS
        SELECT s.subject AS subject,
               t.session_id AS session,
               t.object AS object,
               t.condition AS condition,
               t.level AS level,
               p.window AS window,
               t.pixels AS pixels,
               sc.recognized AS recognized,
               t.response AS response,
               sc.score AS score,
               sc.rater AS rater,
               t.rt_s AS rt_s,
               p.part AS part,
               t.trial_index AS trial_index
        FROM trials t
        JOIN sessions s ON s.session_id = t.session_id
        JOIN schedule p ON p.session_id = t.session_id AND p.trial_index = t.trial_index
        JOIN scores sc ON sc.score_id = (
            SELECT max(q.score_id) FROM scores q
            WHERE q.session_id = t.session_id AND q.trial_index = t.trial_index
              AND q.is_primary = 1)
        ORDER BY t.session_id, t.trial_index;
        """,
    ),
)


def _migration_study_metadata(version: int) -> tuple[int, str, str]:
    """Return the migration that labels simulated sessions and stores study metadata (issue 15).

    ``sessions`` gains ``observer`` (the simulated observer's name; NULL for a human subject) and
    ``observer_params`` (its parameters, JSON), back-filled from ``responder = 'sim:NAME'``;
    ``participant_json`` (participant metadata entered at session start: age, sex, ...) and
    ``monitor_json`` (the monitor profile used: name, sha256, fields). The ``tidy_trials`` view
    gains ``simulated`` (1/0) and ``observer`` (``human`` for people), so every export and
    analysis can tell simulated data from real data.
    """
    return (
        version,
        "observer, observer_params, participant_json, monitor_json; simulated in tidy_trials",
        """
        ALTER TABLE sessions ADD COLUMN observer TEXT;
        ALTER TABLE sessions ADD COLUMN observer_params TEXT;
        ALTER TABLE sessions ADD COLUMN participant_json TEXT;
        ALTER TABLE sessions ADD COLUMN monitor_json TEXT;
        UPDATE sessions SET observer = substr(responder, 5)
            WHERE responder LIKE 'sim:%' AND observer IS NULL;
        DROP VIEW tidy_trials;
        """
        + _tidy_view_sql(_TIDY_SIMULATED),
    )


def _active_events_migration() -> tuple[int, str, str]:
    """Migration 3: the ``active_events`` table of the active-search task (issue 14).

    Self-contained so that it can be renumbered at a merge; numbered 3 so that it applies in any
    order relative to migration 2 (``_migrate`` applies every version not yet recorded).
    """
    return (
        3,
        "active-search events",
        """
        CREATE TABLE active_events (
            event_id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL REFERENCES sessions(session_id),
            trial INTEGER CHECK (trial IS NULL OR trial >= 0),
            attempt INTEGER NOT NULL DEFAULT 0 CHECK (attempt >= 0),
            seq INTEGER NOT NULL CHECK (seq >= 0),
            t_s REAL NOT NULL,
            kind TEXT NOT NULL,
            payload TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(payload)),
            recorded_at TEXT NOT NULL,
            UNIQUE (session_id, seq)
        );
        CREATE INDEX active_events_trial ON active_events(session_id, trial, attempt);
        CREATE TRIGGER active_events_no_update BEFORE UPDATE ON active_events
            BEGIN SELECT RAISE(ABORT, 'active events are append-only'); END;
        CREATE TRIGGER active_events_no_delete BEFORE DELETE ON active_events
            BEGIN SELECT RAISE(ABORT, 'active events are append-only'); END;
        """,
    )


def _migration_viewings(version: int) -> tuple[int, str, str]:
    """Return the migration that logs every stimulus onset (``viewings``; issue 10).

    ``tidy_trials`` gains ``viewings`` and ``repeat_viewing`` (and keeps ``simulated`` and
    ``observer`` from the study-metadata migration).
    """
    return (
        version,
        "viewings: every stimulus onset, committed when the frame is shown",
        f"""
        CREATE TABLE viewings (
            viewing_id INTEGER PRIMARY KEY,
            session_id INTEGER NOT NULL,
            trial_index INTEGER NOT NULL,
            onset_s REAL,
            shown_at TEXT NOT NULL,
            pid INTEGER,
            FOREIGN KEY (session_id, trial_index) REFERENCES schedule(session_id, trial_index)
        );
        CREATE INDEX viewings_trial ON viewings(session_id, trial_index);
        CREATE TRIGGER viewings_no_update BEFORE UPDATE ON viewings
            BEGIN SELECT RAISE(ABORT, 'viewings are append-only'); END;
        CREATE TRIGGER viewings_no_delete BEFORE DELETE ON viewings
            BEGIN SELECT RAISE(ABORT, 'viewings are append-only'); END;
        DROP VIEW tidy_trials;
        {_tidy_view_sql(_TIDY_SIMULATED, _TIDY_VIEWINGS)}
        """,
    )


MIGRATIONS += (
    _migration_study_metadata(2),
    _active_events_migration(),
    _migration_viewings(4),
)


def _migration_audio(version: int) -> tuple[int, str, str]:
    """Issue 15, point 3 (self-contained; see ``experiment/audio/``): the subject's spoken answer
    per trial, its file beside the log, and the voice onset found in it. The operator's
    keystroke time stays in ``trials.rt_s``; the view ``voice_trials`` names both."""
    return (
        version,
        "audio recordings and voice onset",
        """
        CREATE TABLE audio (
            session_id INTEGER NOT NULL,
            trial_index INTEGER NOT NULL,
            path TEXT NOT NULL,
            sha256 TEXT NOT NULL,
            samplerate_hz INTEGER NOT NULL CHECK (samplerate_hz > 0),
            duration_s REAL NOT NULL CHECK (duration_s >= 0),
            start_s REAL NOT NULL,
            voice_rt_s REAL,
            method_json TEXT NOT NULL,
            recorded_at TEXT NOT NULL,
            UNIQUE (session_id, trial_index),
            FOREIGN KEY (session_id, trial_index) REFERENCES trials(session_id, trial_index)
        );
        CREATE TRIGGER audio_no_update BEFORE UPDATE ON audio
            BEGIN SELECT RAISE(ABORT, 'audio rows are append-only'); END;
        CREATE TRIGGER audio_no_delete BEFORE DELETE ON audio
            BEGIN SELECT RAISE(ABORT, 'audio rows are append-only'); END;
        CREATE VIEW voice_trials AS
        SELECT t.session_id AS session,
               t.trial_index AS trial_index,
               t.rt_s AS key_rt_s,
               a.voice_rt_s AS voice_rt_s,
               a.path AS audio_path,
               a.sha256 AS audio_sha256
        FROM trials t
        LEFT JOIN audio a ON a.session_id = t.session_id AND a.trial_index = t.trial_index
        ORDER BY t.session_id, t.trial_index;
        """,
    )


MIGRATIONS += (_migration_audio(5),)


def _migration_application_id(version: int) -> tuple[int, str, str]:
    """Return the migration that marks the file as a confocal trial log (self-contained).

    New logs get the id when the file is created; this gives it to logs made before, on their
    first write (so :func:`identify_log_file` can tell them from other programs' files).
    """
    return (
        version,
        "application_id: the file says it is a confocal trial log",
        f"PRAGMA application_id = {APPLICATION_ID};",
    )


MIGRATIONS += (_migration_application_id(6),)

_SCHEDULE_COLS = (
    "trial_index",
    "part",
    "block",
    "object",
    "object_name",
    "condition",
    "level",
    "window",
    "pixels",
    "path",
    "sha256",
    "pass_allowed_after_s",
    "repetition",
    "break_before",
)


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


#: The table that records the applied migrations.
_MIGRATIONS_TABLE = (
    "CREATE TABLE IF NOT EXISTS schema_migrations ("
    "version INTEGER PRIMARY KEY, name TEXT NOT NULL, applied_at TEXT NOT NULL)"
)
#: The first bytes of every SQLite 3 database file.
_SQLITE_MAGIC = b"SQLite format 3\x00"
#: Files SQLite keeps beside a database while it is written.
_SIDE_SUFFIXES = ("-wal", "-shm", "-journal")
#: Tables every confocal trial log has (migration 1).
_CORE_TABLES = ("sessions", "schedule", "trials", "scores", "events", "locks")


def identify_log_file(path: str | Path) -> str:
    """Decide, reading only, whether ``path`` may be opened as a confocal trial log.

    Nothing is written, created or renamed: the header is read as bytes; a header without our
    :data:`APPLICATION_ID` (a log made before it was set, or not ours) is checked through an
    ``immutable`` read-only connection, or, when a ``-wal`` file lies beside it (a log whose
    last run was killed), through a private copy of the file and its WAL in a temporary folder.

    Returns
    -------
    str
        ``"new"``: no such file, or a 0-byte file with no ``-wal``/``-shm``/``-journal`` beside
        it (it holds nothing, and is replaced whole by a new log); ``"trial log"``: a confocal
        trial log (our application id, or id 0 with confocal's ``schema_migrations`` rows --
        migration 1 -- and its core tables).

    Raises
    ------
    TrialLogError
        One line naming the file: a folder or other non-file, unreadable, not SQLite, another
        program's SQLite file (its own application id, or no confocal schema).
    """
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        return "new"
    except OSError as exc:
        raise TrialLogError(f"{p}: cannot read ({exc.strerror}); nothing was changed") from None
    if stat.S_ISDIR(st.st_mode):
        raise TrialLogError(f"{p}: a folder, not a trial log file; expected a .sqlite file")
    if not stat.S_ISREG(st.st_mode):
        raise TrialLogError(f"{p}: not a regular file, so not a trial log; nothing was changed")
    if st.st_size == 0:
        beside = [f"{p.name}{s}" for s in _SIDE_SUFFIXES if Path(f"{p}{s}").exists()]
        if beside:
            raise TrialLogError(
                f"{p}: an empty file with {beside[0]} beside it (a database another program is "
                "writing), not a confocal trial log; nothing was changed"
            )
        return "new"
    try:
        with open(p, "rb") as f:
            head = f.read(100)
    except OSError as exc:
        raise TrialLogError(f"{p}: cannot read ({exc.strerror}); nothing was changed") from None
    if len(head) < 100 or not head.startswith(_SQLITE_MAGIC):
        raise TrialLogError(
            f"{p}: not a readable SQLite trial log (not an SQLite file); nothing was changed"
        )
    app_id = int.from_bytes(head[68:72], "big", signed=True)
    if app_id == APPLICATION_ID:
        return "trial log"
    if app_id != 0:
        raise TrialLogError(
            f"{p}: an SQLite file of another program (application_id {app_id:#x}), not a "
            "confocal trial log; nothing was changed"
        )
    problem = _probe_schema(p)
    if problem:
        raise TrialLogError(
            f"{p}: an SQLite file but not a confocal trial log ({problem}); nothing was changed"
        )
    return "trial log"


def _probe_schema(p: Path) -> str | None:
    """Return why ``p`` (SQLite, application id 0 in its header) is not a trial log, or None."""
    wal = Path(f"{p}-wal")
    try:
        if wal.exists() and wal.stat().st_size > 0:
            # the WAL may hold the newest pages (even our application id): read a private
            # copy, since a connection to the original could write -shm beside it
            with tempfile.TemporaryDirectory(prefix="confocal-probe-") as tmp:
                copy = Path(tmp) / "probe.sqlite"
                shutil.copyfile(p, copy)
                shutil.copyfile(wal, f"{copy}-wal")
                con = sqlite3.connect(copy)
                try:
                    return _schema_problem(con)
                finally:
                    con.close()
        con = sqlite3.connect(p.resolve().as_uri() + "?mode=ro&immutable=1", uri=True)
        try:
            return _schema_problem(con)
        finally:
            con.close()
    except (OSError, sqlite3.DatabaseError) as exc:
        return f"unreadable: {' '.join(str(exc).split())}"


def _schema_problem(con: sqlite3.Connection) -> str | None:
    app_id = con.execute("PRAGMA application_id").fetchone()[0]
    if app_id == APPLICATION_ID:
        return None
    if app_id != 0:
        return f"application_id {app_id:#x} of another program"
    tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    if "schema_migrations" not in tables:
        return "no schema_migrations table" if tables else "an SQLite file with no tables"
    cols = [r[1] for r in con.execute("PRAGMA table_info(schema_migrations)")]
    if cols[:3] != ["version", "name", "applied_at"]:
        return f"its schema_migrations table has columns {', '.join(cols)}, not confocal's"
    first = con.execute("SELECT name FROM schema_migrations WHERE version = 1").fetchone()
    if first is None or first[0] != MIGRATIONS[0][1]:
        return "its schema_migrations rows are not confocal's migrations"
    missing = [t for t in _CORE_TABLES if t not in tables]
    if missing:
        return f"no {missing[0]} table"
    return None


def utc_now() -> str:
    """Return the current UTC wall-clock time, ISO 8601 (for provenance, not for timing)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds")


def _proc_stat(pid: int) -> list[str] | None:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    # the command name (field 2) may hold spaces; it ends at the last ')'
    return text[text.rfind(")") + 2 :].split()


def _proc_start(pid: int) -> str | None:
    st = _proc_stat(pid)
    return st[19] if st and len(st) > 19 else None


def _pid_alive(pid: int, proc_start: str | None) -> bool:
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


class TrialLog:
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
                # the mode bits too: root may write anything, but a file marked read-only
                # (chmod a-w) means "do not touch" whoever runs the session
                if p.exists() and (not os.access(p, os.W_OK) or not p.stat().st_mode & 0o222):
                    raise TrialLogError(
                        f"{p}: trial log is read-only (no write permission); nothing was changed"
                    )
                parent = p.parent if str(p.parent) else Path(".")
                if not parent.is_dir():
                    raise TrialLogError(f"{p}: folder {parent} does not exist")
                if not os.access(parent, os.W_OK) or not parent.stat().st_mode & 0o222:
                    raise TrialLogError(
                        f"{p}: folder {parent} is read-only (SQLite needs it for its WAL files); "
                        "nothing was changed"
                    )
                if kind == "new":
                    _create_log_file(p)
        try:
            if readonly and not memory:
                uri = Path(self.path).resolve().as_uri() + "?mode=ro"
                if not Path(self.path + "-wal").exists():
                    # No WAL file: no writer has the log open, and a mode=ro connection to a
                    # WAL database would still create -wal/-shm files beside it and leave them.
                    uri += "&immutable=1"
                self._con = sqlite3.connect(uri, uri=True, isolation_level=None, timeout=10.0)
            else:
                self._con = sqlite3.connect(self.path, isolation_level=None, timeout=10.0)
            self._con.row_factory = sqlite3.Row
            self._con.execute("PRAGMA busy_timeout = 10000")
            tables = {
                r[0] for r in self._con.execute("SELECT name FROM sqlite_master WHERE type='table'")
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
                self._migrate()
            except sqlite3.OperationalError as exc:
                self._con.close()
                raise TrialLogError(f"{self.path}: cannot write the trial log ({exc})") from None
        self._check_version()

    def _check_version(self) -> None:
        v = self.schema_version()
        if v > max(m[0] for m in MIGRATIONS):
            self._con.close()
            raise TrialLogError(
                f"{self.path}: schema version {v} is newer than this software knows "
                f"({max(m[0] for m in MIGRATIONS)}); upgrade confocal"
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
        self._con.execute(_MIGRATIONS_TABLE)
        done = {r[0] for r in self._con.execute("SELECT version FROM schema_migrations")}
        for version, name, sql in MIGRATIONS:
            if version in done:
                continue
            with self.atomic() as con:
                for stmt in _split_sql(sql):
                    con.execute(stmt)
                con.execute(
                    "INSERT INTO schema_migrations (version, name, applied_at) VALUES (?, ?, ?)",
                    (version, name, utc_now()),
                )

    def schema_version(self) -> int:
        """Return the highest applied migration number (0 for an empty file)."""
        try:
            row = self._con.execute("SELECT max(version) FROM schema_migrations").fetchone()
        except sqlite3.OperationalError:
            return 0
        return int(row[0] or 0)

    def execute(self, sql: str, params: tuple | dict = ()) -> list[sqlite3.Row]:
        """Run a read query and return all rows (for status, export and tests)."""
        try:
            return self._con.execute(sql, params).fetchall()
        except sqlite3.DatabaseError as exc:
            raise TrialLogError(f"{self.path}: query failed ({exc})") from None

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

    def session(self, session_id: int) -> dict[str, Any]:
        """Return one ``sessions`` row as a dict."""
        rows = self.execute("SELECT * FROM sessions WHERE session_id = ?", (session_id,))
        if not rows:
            raise TrialLogError(f"{self.path}: no session {session_id}")
        return dict(rows[0])

    def sessions(self) -> list[dict[str, Any]]:
        """Return all ``sessions`` rows, oldest first."""
        return [dict(r) for r in self.execute("SELECT * FROM sessions ORDER BY session_id")]

    def unfinished_session(self, subject: str) -> dict[str, Any] | None:
        """Return the subject's latest ``open`` session, or None."""
        rows = self.execute(
            "SELECT * FROM sessions WHERE subject = ? AND status = 'open' "
            "ORDER BY session_id DESC LIMIT 1",
            (subject,),
        )
        return dict(rows[0]) if rows else None

    def new_session_reason(self, session_id: int) -> str | None:
        """Return the reason a session was started as a further session (None for a first)."""
        rows = self.execute(
            "SELECT note FROM events WHERE session_id = ? AND kind = 'new_session' "
            "ORDER BY event_id LIMIT 1",
            (session_id,),
        )
        return rows[0][0] if rows else None

    def session_progress(self, session_id: int) -> tuple[int, int]:
        """Return ``(answered, planned)`` trials of a recognition or an active-search session."""
        planned = self.planned_count(session_id)
        if planned:
            return self.answered_count(session_id), planned
        try:
            plan = self._con.execute(
                "SELECT payload FROM active_events WHERE session_id = ? AND kind = 'plan' "
                "ORDER BY seq LIMIT 1",
                (session_id,),
            ).fetchone()
            if plan is None:
                return 0, 0
            answered = self._con.execute(
                "SELECT count(DISTINCT trial) FROM active_events "
                "WHERE session_id = ? AND kind = 'answer'",
                (session_id,),
            ).fetchone()[0]
        except sqlite3.OperationalError:  # a log from before active search
            return 0, 0
        return int(answered), len(json.loads(plan[0]).get("trials", []))

    def session_to_open(
        self, subject: str, *, new_session: str | None = None
    ) -> tuple[str, dict[str, Any] | None]:
        """Decide what running a subject's session does now; reads only.

        Parameters
        ----------
        subject : str
        new_session : str, optional
            The operator's reason for a further session (``--new-session REASON``). The reason
            names that session: the same command again resumes it or reports it complete.

        Returns
        -------
        (str, dict or None)
            ``("resume", row)``: the subject's unfinished session; ``("complete", row)``: the
            subject's session is complete (the latest one, or the one started with this
            reason) and nothing is to be run; ``("new", None)``: start a session.

        Raises
        ------
        TrialLogError
            ``new_session`` is given while another unfinished session exists.
        """
        open_row = self.unfinished_session(subject)
        if open_row is not None:
            sid = int(open_row["session_id"])
            if new_session is None or new_session == self.new_session_reason(sid):
                return "resume", open_row
            answered, planned = self.session_progress(sid)
            raise TrialLogError(
                f"{self.path}: subject {subject} has unfinished session {sid} ({answered}/"
                f"{planned} trials answered); finish it first: run the command without "
                "--new-session to resume it"
            )
        done = self.execute(
            "SELECT * FROM sessions WHERE subject = ? AND status = 'completed' "
            "ORDER BY session_id DESC",
            (subject,),
        )
        if not done:
            return "new", None
        if new_session is None:
            return "complete", dict(done[0])
        for row in done:
            if self.new_session_reason(int(row["session_id"])) == new_session:
                return "complete", dict(row)
        return "new", None

    def complete_message(self, row: dict[str, Any]) -> str:
        """Return the line that reports a completed session: subject, date, trials answered."""
        sid = int(row["session_id"])
        answered, planned = self.session_progress(sid)
        day = (row.get("ended_at") or row.get("started_at") or "")[:10]
        reason = self.new_session_reason(sid)
        return (
            f"subject {row['subject']}: session {sid} is complete (ended {day} UTC, "
            f"{answered}/{planned} trials answered"
            + (f"; new session: {reason}" if reason else "")
            + f"); nothing was run or written. To run {row['subject']} again, add "
            "--new-session REASON"
        )

    def finish_session(self, session_id: int) -> None:
        """Mark a session completed (all planned trials answered)."""
        with self.atomic() as con:
            con.execute(
                "UPDATE sessions SET status = 'completed', ended_at = ? WHERE session_id = ?",
                (utc_now(), session_id),
            )

    # -- schedule -----------------------------------------------------------------------------

    def write_schedule(self, session_id: int, schedule: Schedule) -> None:
        """Write the whole planned schedule (one transaction, before the first trial)."""
        with self.atomic() as con:
            con.executemany(
                f"INSERT INTO schedule (session_id, {', '.join(_SCHEDULE_COLS)}) "
                f"VALUES (?, {', '.join('?' for _ in _SCHEDULE_COLS)})",
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

    def read_schedule(self, session_id: int) -> Schedule:
        """Return the saved schedule of a session."""
        rows = self.execute(
            f"SELECT {', '.join(_SCHEDULE_COLS)} FROM schedule WHERE session_id = ? "
            "ORDER BY trial_index",
            (session_id,),
        )
        trials = []
        for r in rows:
            d = dict(r)
            d["index"] = d.pop("trial_index")
            trials.append(Trial.from_dict(d))
        return Schedule(trials)

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

    def viewings(self, session_id: int, trial_index: int) -> int:
        """Return how many onsets of a trial are logged (0 if never shown, or before schema 4)."""
        return int(
            self.execute(
                "SELECT count(*) FROM viewings WHERE session_id = ? AND trial_index = ?",
                (session_id, trial_index),
            )[0][0]
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

    def last_committed_trial(self, session_id: int) -> int | None:
        """Return the highest answered ``trial_index`` of a session (None if none)."""
        row = self.execute(
            "SELECT max(trial_index) FROM trials WHERE session_id = ?", (session_id,)
        )[0]
        return None if row[0] is None else int(row[0])

    def answered_count(self, session_id: int) -> int:
        """Return the number of answered trials of a session."""
        return int(
            self.execute("SELECT count(*) FROM trials WHERE session_id = ?", (session_id,))[0][0]
        )

    def planned_count(self, session_id: int) -> int:
        """Return the number of planned trials of a session."""
        return int(
            self.execute("SELECT count(*) FROM schedule WHERE session_id = ?", (session_id,))[0][0]
        )

    def tidy_trials(self) -> list[dict[str, Any]]:
        """Return the ``tidy_trials`` view as a list of dicts (columns :data:`TIDY_COLUMNS`)."""
        return [dict(r) for r in self.execute("SELECT * FROM tidy_trials")]

    def latest_scores(self, rater: str) -> dict[tuple[int, int], str]:
        """Return ``{(session_id, trial_index): score}``: each trial's latest score by ``rater``."""
        rows = self.execute(
            "SELECT session_id, trial_index, score FROM scores WHERE rater = ? ORDER BY score_id",
            (rater,),
        )
        return {(r[0], r[1]): r[2] for r in rows}

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

    def events(self, session_id: int | None = None) -> list[dict[str, Any]]:
        """Return events (of one session, or all), oldest first."""
        if session_id is None:
            return [dict(r) for r in self.execute("SELECT * FROM events ORDER BY event_id")]
        return [
            dict(r)
            for r in self.execute(
                "SELECT * FROM events WHERE session_id = ? ORDER BY event_id", (session_id,)
            )
        ]

    def acquire_lock(self, session_id: int) -> dict[str, Any] | None:
        """Claim a session for this process.

        Returns
        -------
        dict or None
            The stale lock row that was taken over (a crashed run), or None.

        Raises
        ------
        SessionLocked
            A live process (or one on another host) holds the session.
        """
        host = socket.gethostname()
        me = os.getpid()
        with self.atomic() as con:
            row = con.execute("SELECT * FROM locks WHERE session_id = ?", (session_id,)).fetchone()
            stale = None
            if row is not None:
                row = dict(row)
                mine = row["pid"] == me and row["token"] == self._token and row["host"] == host
                if not mine:
                    if row["host"] != host:
                        raise SessionLocked(
                            f"{self.path}: session {session_id} is open on host {row['host']} "
                            f"(pid {row['pid']}, since {row['acquired_at']}); refusing to open it "
                            "twice"
                        )
                    if _pid_alive(row["pid"], row["proc_start"]):
                        raise SessionLocked(
                            f"{self.path}: session {session_id} is already open in another "
                            f"process (pid {row['pid']} on {host}, since {row['acquired_at']}); "
                            "refusing to open it twice"
                        )
                    stale = row
                con.execute("DELETE FROM locks WHERE session_id = ?", (session_id,))
            con.execute(
                "INSERT INTO locks (session_id, pid, host, proc_start, token, acquired_at) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (session_id, me, host, _proc_start(me), self._token, utc_now()),
            )
        self._held.add(session_id)
        return stale

    def release_lock(self, session_id: int) -> None:
        """Release this process's claim on a session (no-op if not held)."""
        if session_id not in self._held:
            return
        with self.atomic() as con:
            con.execute(
                "DELETE FROM locks WHERE session_id = ? AND token = ?", (session_id, self._token)
            )
        self._held.discard(session_id)

    def locks(self) -> list[dict[str, Any]]:
        """Return the current lock rows."""
        return [dict(r) for r in self.execute("SELECT * FROM locks ORDER BY session_id")]

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

    def __enter__(self) -> TrialLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _create_log_file(p: Path) -> None:
    """Make a new, empty trial log at ``p``: built under a temporary name, then linked in.

    The file gets :data:`APPLICATION_ID`, the WAL header and every migration before it has its
    name, so a crash leaves either no file or a whole empty trial log (at worst a temporary
    ``.*.new`` file beside it). A 0-byte file at ``p`` (see :func:`identify_log_file`) is
    renamed over whole.
    """
    tmp = p.with_name(f".{p.name}.{uuid.uuid4().hex}.new")
    try:
        try:
            con = sqlite3.connect(tmp, isolation_level=None)
            try:
                con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                con.execute("PRAGMA journal_mode = WAL")
                con.execute("BEGIN IMMEDIATE")
                con.execute(_MIGRATIONS_TABLE)
                for version, name, sql in MIGRATIONS:
                    for stmt in _split_sql(sql):
                        con.execute(stmt)
                    con.execute(
                        "INSERT INTO schema_migrations (version, name, applied_at) "
                        "VALUES (?, ?, ?)",
                        (version, name, utc_now()),
                    )
                con.execute("COMMIT")
            finally:
                con.close()  # the last connection: the WAL is checkpointed into the file
        except sqlite3.DatabaseError as exc:
            raise TrialLogError(f"{p}: cannot create the trial log ({exc})") from None
        try:
            os.link(tmp, p)  # never replaces a file made meanwhile by another process
        except FileExistsError:
            if p.stat().st_size == 0 and identify_log_file(p) == "new":
                os.replace(tmp, p)
            # else: another process made the log meanwhile; the caller opens that one
        _fsync_dir(p.parent)
    finally:
        for suffix in ("", *_SIDE_SUFFIXES):
            Path(f"{tmp}{suffix}").unlink(missing_ok=True)


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder if str(folder) else ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _split_sql(script: str) -> list[str]:
    """Split a migration into statements (triggers contain ';' inside BEGIN ... END)."""
    out, buf = [], ""
    for line in script.splitlines(keepends=True):
        buf += line
        if sqlite3.complete_statement(buf):
            if buf.strip():
                out.append(buf.strip())
            buf = ""
    if buf.strip():
        out.append(buf.strip())
    return out
