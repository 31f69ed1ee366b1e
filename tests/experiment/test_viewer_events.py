"""The viewer's SQLite event log: append-only, crash-safe, resumable, shareable."""

from __future__ import annotations

import sqlite3
import subprocess
import sys

import numpy as np
import pytest

from experiment.viewer.events import ViewerEventLog, ViewerEventLogError


def test_append_and_read_back_in_order(tmp_path) -> None:
    path = tmp_path / "ev.sqlite"
    sent = [
        (0.0, "key", {"key": "page_down"}),
        (0.5, "drag", {"box": [1, 2, 30, 40]}),
        (0.75, "state", {"depth_px": np.float32(1.5), "plane": np.int64(2)}),
    ]
    with ViewerEventLog(path) as log:
        seqs = [log.append(*e) for e in sent]
    assert seqs == [0, 1, 2]
    with ViewerEventLog(path) as log:
        got = log.events()
        assert [(e.t_s, e.kind) for e in got] == [(t, k) for t, k, _ in sent]
        assert got[2].payload == {"depth_px": 1.5, "plane": 2}
        assert [e.kind for e in log.events(kind="drag")] == ["drag"]
        # resume continues the numbering
        assert log.append(1.0, "key", {"key": "escape"}) == 3


def test_sessions_are_numbered_separately_and_rows_are_append_only(tmp_path) -> None:
    path = tmp_path / "ev.sqlite"
    a = ViewerEventLog(path, session_id=1)
    b = ViewerEventLog(path, session_id=2)
    a.append(0, "key")
    b.append(0, "key")
    a.append(1, "key")
    assert [e.seq for e in a.events()] == [0, 1] and [e.seq for e in b.events()] == [0]
    con = sqlite3.connect(path)
    with pytest.raises(sqlite3.DatabaseError, match="append-only"):
        con.execute("DELETE FROM viewer_events")
    with pytest.raises(sqlite3.DatabaseError, match="append-only"):
        con.execute("UPDATE viewer_events SET kind = 'x'")


def test_shared_connection_keeps_outer_transaction(tmp_path) -> None:
    con = sqlite3.connect(tmp_path / "s.sqlite", isolation_level=None)
    con.execute("CREATE TABLE other (x)")
    log = ViewerEventLog(con, session_id=3)
    con.execute("BEGIN")
    log.append(0.1, "state", {"plane": 0})
    con.execute("ROLLBACK")
    assert log.events() == []
    log.close()
    con.execute("SELECT 1")  # still open for its owner


def test_kill_mid_stream_keeps_every_committed_event(tmp_path) -> None:
    path = tmp_path / "ev.sqlite"
    code = (
        "import os, signal, sys\n"
        "from experiment.viewer.events import ViewerEventLog\n"
        f"log = ViewerEventLog({str(path)!r})\n"
        "for i in range(25):\n"
        "    log.append(i * 0.01, 'key', {'i': i})\n"
        "os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    r = subprocess.run([sys.executable, "-c", code])
    assert r.returncode == -9
    log = ViewerEventLog(path)
    assert [e.payload["i"] for e in log.events()] == list(range(25))
    assert log.next_seq == 25


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((float("nan"), "key", {}), "t must be finite"),
        (("soon", "key", {}), "t must be a number"),
        ((0.0, "Key Press", {}), "kind must be a lower-case identifier"),
        ((0.0, "key", [1]), "payload must be a dict"),
        ((0.0, "key", {"x": object()}), "not JSON"),
        ((0.0, "key", {"x": float("inf")}), "not JSON"),
    ],
)
def test_bad_events_are_refused(args, match) -> None:
    log = ViewerEventLog()
    with pytest.raises(ViewerEventLogError, match=match):
        log.append(*args)
    assert log.events() == []


def test_bad_targets_are_refused(tmp_path) -> None:
    with pytest.raises(ViewerEventLogError, match="does not exist"):
        ViewerEventLog(tmp_path / "no" / "ev.sqlite")
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"not a database at all" * 100)
    with pytest.raises(ViewerEventLogError, match="junk.sqlite"):
        ViewerEventLog(junk)
    with pytest.raises(ViewerEventLogError, match="session_id"):
        ViewerEventLog(session_id=-1)
    newer = tmp_path / "newer.sqlite"
    ViewerEventLog(newer).close()
    sqlite3.connect(newer, isolation_level=None).execute(
        "INSERT INTO viewer_events_schema VALUES (99, 'x')"
    )
    with pytest.raises(ViewerEventLogError, match="newer"):
        ViewerEventLog(newer)
