"""The trial log's file on disk: identified before any write, and created whole.

Identity: a trial log says what it is in SQLite's header, ``PRAGMA application_id`` =
:data:`schema.APPLICATION_ID` (set when the file is created, and by a migration on logs made before
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
"""

from __future__ import annotations

import os
import shutil
import sqlite3
import stat
import tempfile
import uuid
from pathlib import Path

from experiment.log import schema
from experiment.log.errors import TrialLogError

__all__ = ["SIDE_SUFFIXES", "identify_log_file", "check_writable", "create_log_file"]

#: The first bytes of every SQLite 3 database file.
_SQLITE_MAGIC = b"SQLite format 3\x00"
#: Files SQLite keeps beside a database while it is written.
SIDE_SUFFIXES = ("-wal", "-shm", "-journal")
#: Tables every confocal trial log has (migration 1).
_CORE_TABLES = ("sessions", "schedule", "trials", "scores", "events", "locks")


def identify_log_file(path: str | Path) -> str:
    """Decide, reading only, whether ``path`` may be opened as a confocal trial log.

    Nothing is written, created or renamed: the header is read as bytes; a header without our
    :data:`schema.APPLICATION_ID` (a log made before it was set, or not ours) is checked through an
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
        beside = [f"{p.name}{s}" for s in SIDE_SUFFIXES if Path(f"{p}{s}").exists()]
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
    if app_id == schema.APPLICATION_ID:
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
    if app_id == schema.APPLICATION_ID:
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
    if first is None or first[0] != schema.MIGRATIONS[0][1]:
        return "its schema_migrations rows are not confocal's migrations"
    missing = [t for t in _CORE_TABLES if t not in tables]
    if missing:
        return f"no {missing[0]} table"
    return None


def check_writable(p: Path) -> None:
    """Refuse, before anything is written, a log file or folder that may not be written.

    Raises
    ------
    TrialLogError
        ``p`` is read-only, or its folder is missing or read-only (SQLite writes its ``-wal``
        and ``-shm`` files there).
    """
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


def create_log_file(p: Path) -> None:
    """Make a new, empty trial log at ``p``: built under a temporary name, then linked in.

    The file gets :data:`schema.APPLICATION_ID`, the WAL header and every migration before it
    has its name, so a crash leaves either no file or a whole empty trial log (at worst a temporary
    ``.*.new`` file beside it). A 0-byte file at ``p`` (see :func:`identify_log_file`) is
    renamed over whole.
    """
    tmp = p.with_name(f".{p.name}.{uuid.uuid4().hex}.new")
    try:
        try:
            con = sqlite3.connect(tmp, isolation_level=None)
            try:
                con.execute(f"PRAGMA application_id = {schema.APPLICATION_ID}")
                con.execute("PRAGMA journal_mode = WAL")
                con.execute("BEGIN IMMEDIATE")
                con.execute(schema.MIGRATIONS_TABLE)
                for version, name, sql in schema.MIGRATIONS:
                    schema.apply_migration(con, version, name, sql)
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
        for suffix in ("", *SIDE_SUFFIXES):
            Path(f"{tmp}{suffix}").unlink(missing_ok=True)


def _fsync_dir(folder: Path) -> None:
    """Flush a folder's entries (a new name) to disk; best effort."""
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
