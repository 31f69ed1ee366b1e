"""The viewer's event log: every input event and displayed state, appended to SQLite.

One table, ``viewer_events``, in any SQLite file: a standalone ``confocal view --log FILE`` or a
session's trial log (the active-search task writes it beside ``trials``). Rows are
never updated or deleted (triggers), each :meth:`ViewerEventLog.append` is its own committed
transaction (crash-safe: after a kill every appended event is there), and ``seq`` numbers the
events of one ``session_id`` from 0 so a resumed run continues where the last committed event
left off.

Schema (version :data:`SCHEMA_VERSION`, recorded in ``viewer_events_schema``)
------------------------------------------------------------------------------
==============  =========  ===============================================================
column          type       meaning
==============  =========  ===============================================================
event_id        INTEGER    row id (file order)
session_id      INTEGER    the trial log's session, 0 for a standalone viewer
seq             INTEGER    0, 1, 2, ... within ``session_id``; ``UNIQUE(session_id, seq)``
t_s             REAL       the caller's monotonic clock, seconds (session clock in a study)
kind            TEXT       ``key``, ``wheel``, ``drag``, ``click``, ``state``, ... (lower case)
payload_json    TEXT       a JSON object (the event's fields, or the displayed state)
recorded_at     TEXT       UTC wall-clock time, ISO 8601 (provenance, not timing)
==============  =========  ===============================================================
"""

from __future__ import annotations

import json
import re
import sqlite3
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError
from experiment.interfaces import ClosesOnExit
from stimuli.resources import finite_number

__all__ = ["SCHEMA_VERSION", "ViewerEvent", "ViewerEventLogError", "ViewerEventLog"]

#: Version of the ``viewer_events`` table; a file with a newer one is refused.
SCHEMA_VERSION = 1

_KIND_RE = re.compile(r"^[a-z][a-z0-9_.]*$")

_SCHEMA: tuple[str, ...] = (
    """CREATE TABLE IF NOT EXISTS viewer_events_schema (
    version INTEGER PRIMARY KEY, applied_at TEXT NOT NULL)""",
    """CREATE TABLE IF NOT EXISTS viewer_events (
    event_id INTEGER PRIMARY KEY,
    session_id INTEGER NOT NULL DEFAULT 0,
    seq INTEGER NOT NULL CHECK (seq >= 0),
    t_s REAL NOT NULL,
    kind TEXT NOT NULL,
    payload_json TEXT NOT NULL,
    recorded_at TEXT NOT NULL,
    UNIQUE (session_id, seq))""",
    "CREATE INDEX IF NOT EXISTS viewer_events_kind ON viewer_events(session_id, kind)",
    """CREATE TRIGGER IF NOT EXISTS viewer_events_no_update BEFORE UPDATE ON viewer_events
    BEGIN SELECT RAISE(ABORT, 'viewer events are append-only'); END""",
    """CREATE TRIGGER IF NOT EXISTS viewer_events_no_delete BEFORE DELETE ON viewer_events
    BEGIN SELECT RAISE(ABORT, 'viewer events are append-only'); END""",
)


class ViewerEventLogError(ConfocalError):
    """The event log cannot be opened or written, or an event is malformed."""


def _check_ours(path: Path) -> None:
    """Refuse, reading only, a file that is neither new, a viewer log nor a confocal trial log.

    ``--log`` appends tables to an existing file, so another program's SQLite file (or any other
    file) must be refused before anything is written to it, leaving it byte-identical.
    """
    from experiment.log import TrialLogError, identify_log_file

    try:
        identify_log_file(path)  # "new" or "trial log", or it raises
        return
    except TrialLogError as exc:
        refusal = str(exc)
    try:  # a viewer log of an earlier run holds only the viewer's own tables
        uri = f"{path.resolve().as_uri()}?mode=ro"
        if not Path(f"{path}-wal").exists():  # no writer has it open: read the file as it is
            uri += "&immutable=1"
        con = sqlite3.connect(uri, uri=True)
        try:
            tables = {
                r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")
            }
        finally:
            con.close()
    except sqlite3.DatabaseError:
        tables = set()
    if tables and tables <= {"viewer_events", "viewer_events_schema", "sqlite_sequence"}:
        return
    raise ViewerEventLogError(refusal)


@dataclass(frozen=True)
class ViewerEvent:
    """One logged event, as read back from the table.

    Attributes
    ----------
    seq : int
        Position within the session's events, from 0.
    t_s : float
        Time on the caller's monotonic clock, seconds.
    kind : str
        Event kind (lower-case identifier).
    payload : dict
        The event's fields, decoded from JSON.
    session_id : int
        The trial log's session, 0 for a standalone viewer.
    recorded_at : str
        UTC wall-clock time of the write, ISO 8601.
    """

    seq: int
    t_s: float
    kind: str
    payload: dict[str, Any] = field(default_factory=dict)
    session_id: int = 0
    recorded_at: str = ""


def _json_default(obj: Any) -> Any:
    # numpy scalars and arrays, tuples inside dataclasses' asdict, Paths: plain JSON values
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, set | frozenset):
        return sorted(obj)
    raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")


class ViewerEventLog(ClosesOnExit):
    """An append-only SQLite table of viewer events (input events and displayed states).

    Parameters
    ----------
    target : str, Path or sqlite3.Connection
        An SQLite file (created if missing; may be a session's trial log), ``":memory:"``
        (the test twin), or an open connection to share (e.g. the trial log's) in autocommit
        mode (``isolation_level=None``).
    session_id : int
        The trial log's session the events belong to; 0 for a standalone viewer.

    Raises
    ------
    ViewerEventLogError
        The file is not writable, not SQLite, or has a newer ``viewer_events`` schema.

    Examples
    --------
    >>> log = ViewerEventLog(":memory:")
    >>> log.append(0.25, "key", {"key": "page_down"})
    0
    >>> [(e.kind, e.payload) for e in log.events()]
    [('key', {'key': 'page_down'})]
    """

    def __init__(
        self, target: str | Path | sqlite3.Connection = ":memory:", *, session_id: int = 0
    ) -> None:
        if isinstance(session_id, bool) or not isinstance(session_id, int) or session_id < 0:
            raise ViewerEventLogError(f"session_id must be an int >= 0, got {session_id!r}")
        self.session_id = session_id
        self._owned = not isinstance(target, sqlite3.Connection)
        if isinstance(target, sqlite3.Connection):
            self.path = "<shared connection>"
            self._con = target
        else:
            self.path = str(target)
            if self.path != ":memory:":
                parent = Path(self.path).resolve().parent
                if not parent.is_dir():
                    raise ViewerEventLogError(f"{self.path}: folder {parent} does not exist")
                _check_ours(Path(self.path))
            try:
                self._con = sqlite3.connect(self.path, isolation_level=None, timeout=10.0)
                if self.path != ":memory:":
                    self._con.execute("PRAGMA journal_mode = WAL")
                self._con.execute("PRAGMA synchronous = FULL")
            except sqlite3.DatabaseError as exc:
                raise ViewerEventLogError(f"{self.path}: cannot open as SQLite ({exc})") from None
        try:
            # statement by statement: executescript would COMMIT a shared connection's
            # outer transaction
            for stmt in _SCHEMA:
                self._con.execute(stmt)
            row = self._con.execute("SELECT max(version) FROM viewer_events_schema").fetchone()
            if row[0] is None:
                self._con.execute(
                    "INSERT INTO viewer_events_schema (version, applied_at) VALUES (?, ?)",
                    (SCHEMA_VERSION, _utc_now()),
                )
            elif row[0] > SCHEMA_VERSION:
                raise ViewerEventLogError(
                    f"{self.path}: viewer_events schema {row[0]} is newer than this software "
                    f"knows ({SCHEMA_VERSION}); upgrade confocal"
                )
            self._next = self._con.execute(
                "SELECT coalesce(max(seq) + 1, 0) FROM viewer_events WHERE session_id = ?",
                (session_id,),
            ).fetchone()[0]
        except sqlite3.DatabaseError as exc:
            self.close()
            raise ViewerEventLogError(
                f"{self.path}: cannot create the viewer_events table ({exc})"
            ) from None

    @property
    def next_seq(self) -> int:
        """Return the ``seq`` the next appended event gets (the count of this session's events)."""
        return self._next

    def append(self, t: float, kind: str, payload: dict[str, Any] | None = None) -> int:
        """Append one event and commit it; return its ``seq``.

        Parameters
        ----------
        t : float
            Time on the caller's monotonic clock, seconds; finite.
        kind : str
            Lower-case identifier (``key``, ``wheel``, ``drag``, ``click``, ``state``, ...).
        payload : dict, optional
            JSON-serialisable fields (numpy scalars and arrays are converted).

        Raises
        ------
        ViewerEventLogError
            ``t`` not finite, ``kind`` not an identifier, ``payload`` not a JSON object, or the
            write failed.
        """
        t_s = finite_number(t, "t", expected="a number of seconds", error=ViewerEventLogError)
        if not isinstance(kind, str) or not _KIND_RE.match(kind):
            raise ViewerEventLogError(
                f"kind must be a lower-case identifier like 'key' or 'state', got {kind!r}"
            )
        payload = {} if payload is None else payload
        if not isinstance(payload, dict):
            raise ViewerEventLogError(f"payload must be a dict, got {type(payload).__name__}")
        try:
            text = json.dumps(payload, default=_json_default, sort_keys=True, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ViewerEventLogError(f"payload of {kind!r} event is not JSON: {exc}") from None
        seq = self._next
        try:
            self._con.execute(
                "INSERT INTO viewer_events "
                "(session_id, seq, t_s, kind, payload_json, recorded_at) VALUES (?,?,?,?,?,?)",
                (self.session_id, seq, t_s, kind, text, _utc_now()),
            )
        except sqlite3.DatabaseError as exc:
            raise ViewerEventLogError(f"{self.path}: cannot append event ({exc})") from None
        self._next = seq + 1
        return seq

    def events(self, *, kind: str | None = None) -> list[ViewerEvent]:
        """Return this session's events in ``seq`` order, optionally only those of one kind."""
        sql = (
            "SELECT seq, t_s, kind, payload_json, session_id, recorded_at FROM viewer_events "
            "WHERE session_id = ?"
        )
        params: tuple[Any, ...] = (self.session_id,)
        if kind is not None:
            sql += " AND kind = ?"
            params += (kind,)
        rows = self._con.execute(sql + " ORDER BY seq", params).fetchall()
        return [
            ViewerEvent(
                seq=r[0],
                t_s=r[1],
                kind=r[2],
                payload=json.loads(r[3]),
                session_id=r[4],
                recorded_at=r[5],
            )
            for r in rows
        ]

    def close(self) -> None:
        """Close the file (a shared connection is left open for its owner)."""
        if self._owned and getattr(self, "_con", None) is not None:
            self._con.close()
            self._con = None  # type: ignore[assignment]


def _utc_now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")
