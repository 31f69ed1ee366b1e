"""Foreign files are only read: the trial log is identified (application_id, schema) before a write.

Every refused file, and its folder, is byte-identical afterwards: same names, sizes, mtimes and
contents, no ``-wal``/``-shm``/``-journal`` created beside it.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sqlite3

import pytest

from experiment import cli
from experiment.log import APPLICATION_ID, MIGRATIONS, TrialLog, TrialLogError
from tests.experiment.conftest import make_study


def snapshot(folder):
    out = {}
    for p in sorted(folder.iterdir()):
        st = p.lstat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else ""
        out[p.name] = (p.is_dir(), st.st_size, st.st_mtime_ns, digest)
    return out, folder.stat().st_mtime_ns


def other_program_with_schema_migrations(path):
    """Another program's database that has its own ``schema_migrations`` and ``sessions``."""
    con = sqlite3.connect(path)
    con.executescript(
        """
        CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, name TEXT NOT NULL,
                                        applied_at TEXT NOT NULL);
        INSERT INTO schema_migrations VALUES (1, 'create users', '2020-01-01');
        CREATE TABLE sessions (id INTEGER PRIMARY KEY, user TEXT);
        CREATE TABLE users (id INTEGER PRIMARY KEY, name TEXT);
        """
    )
    con.commit()
    con.close()
    return path


def other_program_with_application_id(path):
    con = sqlite3.connect(path)
    con.execute("PRAGMA application_id = 0x12345678")
    con.execute("CREATE TABLE things (x)")
    con.commit()
    con.close()
    return path


def empty_sqlite_database(path):
    con = sqlite3.connect(path)
    con.execute("PRAGMA user_version = 3")  # a valid database file with no tables
    con.commit()
    con.close()
    return path


def text_file(path):
    path.write_text("name,age\nAda,36\n")
    return path


def empty_with_journal(path):
    path.write_bytes(b"")
    (path.parent / f"{path.name}-journal").write_bytes(b"\0" * 512)
    return path


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (other_program_with_schema_migrations, "not a confocal trial log .*schema_migrations"),
        (other_program_with_application_id, r"another program \(application_id 0x12345678\)"),
        (empty_sqlite_database, "not a confocal trial log .*no tables"),
        (text_file, "not an SQLite file"),
        (empty_with_journal, "empty file with other.sqlite-journal beside it"),
    ],
)
def test_foreign_file_is_refused_before_any_write(tmp_path, make, match):
    folder = tmp_path / "data"
    folder.mkdir()
    path = make(folder / "other.sqlite")
    before = snapshot(folder)
    for readonly in (False, True):
        with pytest.raises(TrialLogError, match=match) as exc:
            TrialLog(path, readonly=readonly)
        assert str(path) in str(exc.value)
        assert snapshot(folder) == before, "the file and its folder are unchanged"


def test_session_run_on_another_programs_file_exits_2_and_changes_nothing(tmp_path, capsys):
    stim, proto, _ = make_study(
        tmp_path, (1,), n_main=2, name="tiny", conditions=("cluttered",), training=None
    )
    folder = tmp_path / "data"
    folder.mkdir()
    other = other_program_with_schema_migrations(folder / "other.sqlite")
    before = snapshot(folder)
    for argv in (
        ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01",
         "--data", other, "--headless"],
        ["active", "run", "active_search", "--data", other, "--subject", "S01"],
        ["score", other, "--rater", "B"],
    ):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            cli.main([str(a) for a in argv])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "other.sqlite" in err[0] and "not a confocal trial log" in err[0]
        assert snapshot(folder) == before


def test_a_folder_is_refused(tmp_path):
    folder = tmp_path / "log.sqlite"
    folder.mkdir()
    with pytest.raises(TrialLogError, match=r"log\.sqlite: a folder, not a trial log file"):
        TrialLog(folder)


def test_an_empty_file_becomes_a_new_log(tmp_path):
    """A 0-byte file holds nothing to harm: it is replaced whole by a new trial log."""
    path = tmp_path / "study.sqlite"
    path.write_bytes(b"")
    with TrialLog(path) as log:
        assert log.execute("PRAGMA application_id")[0][0] == APPLICATION_ID
        assert log.schema_version() == MIGRATIONS[-1][0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.sqlite"]


def test_a_new_log_says_it_is_ours_in_its_header(tmp_path):
    path = tmp_path / "study.sqlite"
    TrialLog(path).close()
    assert path.read_bytes()[68:72] == APPLICATION_ID.to_bytes(4, "big")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.sqlite"], "no temporary left"


def legacy_log(path):
    """A trial log made before the application id: id 0, without the id's migration."""
    TrialLog(path).close()
    con = sqlite3.connect(path)
    con.execute("PRAGMA application_id = 0")
    last = MIGRATIONS[-1][0]
    con.execute("DELETE FROM schema_migrations WHERE version = ?", (last,))
    con.commit()
    con.close()
    assert path.read_bytes()[68:72] == b"\0\0\0\0"
    return path


def test_an_existing_log_gets_the_id_on_its_first_write(tmp_path):
    path = legacy_log(tmp_path / "old.sqlite")
    with TrialLog(path, readonly=True) as ro:  # read: accepted, not changed
        assert ro.execute("PRAGMA application_id")[0][0] == 0
    with TrialLog(path) as log:
        assert log.execute("PRAGMA application_id")[0][0] == APPLICATION_ID
        assert log.schema_version() == MIGRATIONS[-1][0]
    assert path.read_bytes()[68:72] == APPLICATION_ID.to_bytes(4, "big")


def test_an_existing_log_killed_mid_write_is_recognised_from_its_wal(tmp_path):
    """Header id 0 and the newest pages only in the WAL (a killed run): read through a copy."""
    path = legacy_log(tmp_path / "old.sqlite")
    con = sqlite3.connect(path, isolation_level=None)
    con.execute("PRAGMA journal_mode = WAL")
    con.execute("PRAGMA wal_autocheckpoint = 0")
    con.execute(
        "INSERT INTO events (session_id, kind, note, at) VALUES (NULL, 'note', 'in wal', 'x')"
    )
    crashed = tmp_path / "crashed"
    crashed.mkdir()
    shutil.copy(path, crashed / "old.sqlite")  # as a SIGKILL would leave it
    shutil.copy(f"{path}-wal", crashed / "old.sqlite-wal")
    con.close()
    copy = crashed / "old.sqlite"
    assert copy.read_bytes()[68:72] == b"\0\0\0\0" and os.path.getsize(f"{copy}-wal") > 0
    with TrialLog(copy) as log:
        assert [e["note"] for e in log.events()] == ["in wal"]
        assert log.execute("PRAGMA application_id")[0][0] == APPLICATION_ID
