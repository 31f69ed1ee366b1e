"""The trial log's schema: numbered migrations, the ``tidy_trials`` view, the file's identity.

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

Never edit a released migration: append one. A test pins the SQL of every migration
(whitespace-normalised), so an existing log migrates exactly as before.
"""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime

from experiment.protocol import SCORES

__all__ = [
    "APPLICATION_ID",
    "TIDY_COLUMNS",
    "MIGRATIONS",
    "MIGRATIONS_TABLE",
    "SCHEDULE_COLUMNS",
    "latest_version",
    "split_sql",
    "apply_migration",
    "utc_now",
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
        {_tidy_view_sql()}        """,
    ),
)


def _migration_study_metadata(version: int) -> tuple[int, str, str]:
    """Return the migration that labels simulated sessions and stores study metadata.

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
    """Return migration 3: the ``active_events`` table of the active-search task.

    Numbered 3 so that it applies in any order relative to migration 2 (a log is migrated by
    applying every version not yet recorded).
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
    """Return the migration that logs every stimulus onset (``viewings``).

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


def _migration_audio(version: int) -> tuple[int, str, str]:
    """Return the migration that stores the subject's spoken answers (``experiment/audio/``).

    One row per trial: the recording's file beside the log and the voice onset found in it. The
    operator's keystroke time stays in ``trials.rt_s``; the view ``voice_trials`` names both.
    """
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


def _migration_application_id(version: int) -> tuple[int, str, str]:
    """Return the migration that marks the file as a confocal trial log (self-contained).

    New logs get the id when the file is created; this gives it to logs made before, on their
    first write (so :func:`~experiment.log.logfile.identify_log_file` can tell them from other
    programs' files).
    """
    return (
        version,
        "application_id: the file says it is a confocal trial log",
        f"PRAGMA application_id = {APPLICATION_ID};",
    )


MIGRATIONS += (
    _migration_study_metadata(2),
    _active_events_migration(),
    _migration_viewings(4),
    _migration_audio(5),
    _migration_application_id(6),
)

#: Columns of the ``schedule`` table a :class:`~experiment.trials.Trial` fills, in order.
SCHEDULE_COLUMNS: tuple[str, ...] = (
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

#: The table that records the applied migrations.
MIGRATIONS_TABLE = (
    "CREATE TABLE IF NOT EXISTS schema_migrations ("
    "version INTEGER PRIMARY KEY, name TEXT NOT NULL, applied_at TEXT NOT NULL)"
)


def latest_version() -> int:
    """Return the newest schema version this software knows (the last migration's number)."""
    return max(m[0] for m in MIGRATIONS)


def split_sql(script: str) -> list[str]:
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


def apply_migration(con: sqlite3.Connection, version: int, name: str, sql: str) -> None:
    """Run one migration's statements and record it in ``schema_migrations``.

    The caller holds the transaction (the whole new file, or one migration of an old log).
    """
    for stmt in split_sql(sql):
        con.execute(stmt)
    con.execute(
        "INSERT INTO schema_migrations (version, name, applied_at) VALUES (?, ?, ?)",
        (version, name, utc_now()),
    )


def utc_now() -> str:
    """Return the current UTC wall-clock time, ISO 8601 (for provenance, not for timing)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds")
