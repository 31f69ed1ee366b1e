"""The analysis's own reader of a confocal trial log: identified first, base tables only, bounded.

An ``.sqlite`` file handed to ``confocal analyze`` may come from anywhere (a collaborator, a
download). SQLite runs whatever a file's own views say when they are queried, so a file whose
``tidy_trials`` view recurses without end would make a reader that trusts it read until memory
runs out. This reader therefore:

1. **identifies** the file before reading any data: SQLite's ``PRAGMA application_id`` is the
   trial log's (:data:`APPLICATION_ID`), or 0 with confocal's own ``schema_migrations`` table
   (logs made before the id was set); its schema version (``max(version)`` there) is a whole
   number >= 1 whose first migration is confocal's ``initial schema``. Anything else is refused
   with one line naming the file. (The experiment engine identifies logs the same way in
   ``experiment/log/logfile.py``; the analysis may not import it, so the contract is restated
   here: the id and the migration name are the schema's constants.)
2. reads the **base tables** ``sessions``, ``schedule``, ``trials`` and ``scores`` (each must be
   an ordinary table, not a view or a virtual table) with one plain ``SELECT`` each, never a view
   the file brings, and joins them here as the log's ``tidy_trials`` view does: one row per
   answered trial, scored by the latest primary score.
3. **bounds** what one file may make it read: at most :data:`MAX_INPUT_BYTES` on disk (with its
   write-ahead log), at most :data:`MAX_INPUT_ROWS` rows per table, at most
   :data:`MAX_VALUE_BYTES` per value, and a budget of SQLite steps (a progress handler); past any
   of them the file is refused with one line.

The connection is opened read-only (``immutable`` when no write-ahead log is beside it), with
``trusted_schema`` off and ``query_only`` on.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pandas as pd

from analysis.errors import DataError

__all__ = [
    "APPLICATION_ID",
    "FIRST_MIGRATION",
    "MAX_INPUT_BYTES",
    "MAX_INPUT_ROWS",
    "MAX_VALUE_BYTES",
    "open_log",
    "check_input_size",
    "identify_log",
    "read_log_trials",
]

#: ``PRAGMA application_id`` of a confocal trial log: the ASCII bytes ``Cnfl`` (the schema's
#: constant, ``experiment/log/schema.py``).
APPLICATION_ID = 0x436E666C
#: The name of migration 1 in ``schema_migrations`` (the schema's constant).
FIRST_MIGRATION = "initial schema"
#: Largest input file read, bytes (ours: 1 GiB, some 400 times a 2,000-subject study's log).
MAX_INPUT_BYTES = 1 << 30
#: Most rows read from one table or one file (ours: 2 million trials, 300 times the 6,400
#: trials of Jung et al. 2015's 20 subjects).
MAX_INPUT_ROWS = 2_000_000
#: Longest single value (text or blob) SQLite may hand over, bytes (ours; a response is a few
#: words).
MAX_VALUE_BYTES = 1 << 20
#: SQLite virtual-machine steps one file may cost, counted by a progress handler every
#: :data:`_STEP` steps (ours: reading a log costs 29 steps a trial, measured on a 20,000-trial
#: log; this is some 30 times that for :data:`MAX_INPUT_ROWS` rows in each of the 4 tables).
MAX_STEPS = 2_000_000_000
_STEP = 1000

#: Base tables and the columns read from each (``observer`` of ``sessions`` from schema 2 on).
_COLUMNS: dict[str, tuple[str, ...]] = {
    "sessions": ("session_id", "subject"),
    "schedule": ("session_id", "trial_index", "part", "window"),
    "trials": (
        "session_id",
        "trial_index",
        "object",
        "condition",
        "level",
        "pixels",
        "response",
        "rt_s",
    ),
    "scores": (
        "score_id",
        "session_id",
        "trial_index",
        "score",
        "recognized",
        "rater",
        "is_primary",
    ),
}


def _line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def check_input_size(path: Path) -> None:
    """Refuse an input file (with its ``-wal`` file) larger than :data:`MAX_INPUT_BYTES`.

    Raises
    ------
    DataError
        One line naming the file, its size and the limit.
    """
    size = path.stat().st_size
    wal = Path(f"{path}-wal")
    if wal.is_file():
        size += wal.stat().st_size
    if size > MAX_INPUT_BYTES:
        raise DataError(
            f"{path}: {size / 2**30:.1f} GiB is larger than the {MAX_INPUT_BYTES / 2**30:g} GiB "
            "an input may be; split the trials into several files"
        )


def open_log(path: Path) -> sqlite3.Connection:
    """Open an SQLite file read-only for a hostile-safe read, leaving nothing beside it.

    Without a ``-wal`` file no writer has it open, and it is opened ``immutable`` (``mode=ro``
    alone would create ``-wal``/``-shm`` files beside a WAL-mode log). The connection trusts
    nothing in the file's schema (``trusted_schema`` off, ``query_only`` on), hands over no
    value longer than :data:`MAX_VALUE_BYTES`, and stops after :data:`MAX_STEPS` steps.

    Raises
    ------
    DataError
        The file cannot be opened as SQLite (one line naming it).
    """
    uri = f"{path.resolve().as_uri()}?mode=ro"
    if not Path(f"{path}-wal").exists():
        uri += "&immutable=1"
    try:
        con = sqlite3.connect(uri, uri=True)
    except sqlite3.Error as exc:
        raise DataError(f"{path}: cannot open SQLite file ({_line(exc)})") from exc
    con.setlimit(sqlite3.SQLITE_LIMIT_LENGTH, MAX_VALUE_BYTES)
    steps = [0]

    def budget() -> int:
        steps[0] += _STEP
        return steps[0] > MAX_STEPS  # nonzero: SQLite stops the statement ("interrupted")

    try:
        con.execute("PRAGMA trusted_schema = OFF")
        con.execute("PRAGMA query_only = ON")
        con.execute("PRAGMA cell_size_check = ON")
        con.execute("PRAGMA mmap_size = 0")
    except sqlite3.DatabaseError as exc:
        con.close()
        raise DataError(f"{path}: cannot read SQLite file ({_line(exc)})") from exc
    con.set_progress_handler(budget, _STEP)
    return con


def identify_log(con: sqlite3.Connection, path: Path) -> int:
    """Identify an open SQLite file as a confocal trial log; return its schema version.

    Raises
    ------
    DataError
        Another program's application id, no confocal ``schema_migrations``, a base table that
        is missing or is a view, or a missing column (one line naming the file).
    """
    app_id = con.execute("PRAGMA application_id").fetchone()[0]
    if app_id not in (0, APPLICATION_ID):
        raise DataError(
            f"{path}: an SQLite file of another program (application_id {app_id:#x}), not a "
            "confocal trial log"
        )
    kinds = {
        name: (kind, sql or "")
        for kind, name, sql in con.execute("SELECT type, name, sql FROM sqlite_master")
    }
    if kinds.get("schema_migrations", ("",))[0] != "table":
        raise DataError(f"{path}: not a confocal trial log (no schema_migrations table)")
    try:
        row = con.execute(
            "SELECT (SELECT name FROM schema_migrations WHERE version = 1), "
            "(SELECT max(version) FROM schema_migrations)"
        ).fetchone()
    except sqlite3.DatabaseError as exc:
        raise DataError(f"{path}: not a confocal trial log ({_line(exc)})") from None
    first, version = row
    if first != FIRST_MIGRATION or not isinstance(version, int) or version < 1:
        raise DataError(
            f"{path}: not a confocal trial log (its schema_migrations are not confocal's)"
        )
    for table, columns in _COLUMNS.items():
        kind, sql = kinds.get(table, ("", ""))
        if kind != "table" or sql.lstrip().upper().startswith("CREATE VIRTUAL"):
            what = f"a {kind}" if kind else "missing"
            raise DataError(
                f"{path}: not a confocal trial log (its {table} table is {what}; only "
                "ordinary tables are read)"
            )
        have = {r[1] for r in con.execute(f"PRAGMA table_info({table})")}
        lacking = [c for c in columns if c not in have]
        if lacking:
            raise DataError(
                f"{path}: trial log (schema {version}) lacks column {table}.{lacking[0]}"
            )
    return version


def _table(con: sqlite3.Connection, path: Path, table: str, columns: tuple[str, ...]):
    sql = f"SELECT {', '.join(columns)} FROM {table} LIMIT {MAX_INPUT_ROWS + 1}"
    df = pd.read_sql_query(sql, con)
    if len(df) > MAX_INPUT_ROWS:
        raise DataError(
            f"{path}: table {table} has more than {MAX_INPUT_ROWS:,} rows, the most one input "
            "may have; split the study into several logs"
        )
    return df


def read_log_trials(path: Path) -> pd.DataFrame:
    """Read a confocal trial log's answered trials from its base tables, bounded.

    Returns the columns of the log's ``tidy_trials`` view that the analysis uses: ``subject,
    session, object, condition, level, window, pixels, recognized, response, score, rater,
    rt_s, part, trial_index`` and, from schema 2 on, ``simulated, observer``; one row per
    answered trial with a primary score (its latest), ordered by session and trial.

    Raises
    ------
    DataError
        Not a trial log (:func:`identify_log`), larger than the bounds, or unreadable; one line
        naming the file.
    """
    check_input_size(path)
    con = open_log(path)
    try:
        identify_log(con, path)
        have = {r[1] for r in con.execute("PRAGMA table_info(sessions)")}
        s_cols = _COLUMNS["sessions"] + (("observer",) if "observer" in have else ())
        sessions = _table(con, path, "sessions", s_cols)
        schedule = _table(con, path, "schedule", _COLUMNS["schedule"])
        trials = _table(con, path, "trials", _COLUMNS["trials"])
        scores = _table(con, path, "scores", _COLUMNS["scores"])
    except sqlite3.OperationalError as exc:
        if "interrupted" in str(exc):
            raise DataError(
                f"{path}: reading it took more than {MAX_STEPS:,} SQLite steps, far more than "
                "a trial log of the allowed size needs; not read"
            ) from None
        raise DataError(f"{path}: cannot read SQLite trial log ({_line(exc)})") from None
    except (sqlite3.DatabaseError, pd.errors.DatabaseError) as exc:
        raise DataError(f"{path}: cannot read SQLite trial log ({_line(exc)})") from None
    finally:
        con.close()
    try:
        return _join(sessions, schedule, trials, scores)
    except (pd.errors.MergeError, TypeError, ValueError, KeyError) as exc:
        # a real log's keys are unique and typed (primary keys); a hand-made file's may not be
        raise DataError(
            f"{path}: trial log tables do not fit together (a repeated session or trial key, or "
            f"a key of the wrong type: {_line(exc)})"
        ) from None


def _join(sessions, schedule, trials, scores) -> pd.DataFrame:
    """Do the ``tidy_trials`` view's join here: trials with their session, schedule row and score.

    The score is the latest primary score; trials without one are left out, as the view's inner
    join does.
    """
    key = ["session_id", "trial_index"]
    primary = scores[scores["is_primary"] == 1]
    latest = primary.loc[primary.groupby(key, sort=False)["score_id"].idxmax()]
    df = trials.merge(sessions, on="session_id", how="inner", validate="many_to_one")
    df = df.merge(schedule, on=key, how="inner", validate="many_to_one")
    df = df.merge(latest[[*key, "score", "recognized", "rater"]], on=key, how="inner")
    df = df.sort_values(key, kind="stable").rename(columns={"session_id": "session"})
    cols = ["subject", "session", "object", "condition", "level", "window", "pixels"]
    cols += ["recognized", "response", "score", "rater", "rt_s", "part", "trial_index"]
    out = df[cols].reset_index(drop=True)
    if "observer" in df.columns:
        observer = df["observer"].reset_index(drop=True)
        out["simulated"] = observer.notna().astype(int)
        out["observer"] = observer.fillna("human")
    return out
