"""``confocal view --log`` writes only into a new file, a viewer log or a confocal trial log."""

from __future__ import annotations

import hashlib
import sqlite3

import pytest

from experiment.viewer.events import ViewerEventLog, ViewerEventLogError


def _digest(folder):
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_another_programs_database_is_refused_and_left_untouched(tmp_path):
    other = tmp_path / "theirs.sqlite"
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE customers (id INTEGER, name TEXT)")
    con.execute("INSERT INTO customers VALUES (1, 'Ada')")
    con.commit()
    con.close()
    before = _digest(tmp_path)
    with pytest.raises(ViewerEventLogError, match="theirs.sqlite"):
        ViewerEventLog(other)
    assert _digest(tmp_path) == before, "the file and its folder are unchanged, no -wal/-shm"


def test_a_text_file_is_refused(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    with pytest.raises(ViewerEventLogError, match="notes.txt"):
        ViewerEventLog(notes)
    assert notes.read_text() == "my notes\n"


def test_a_viewer_log_of_an_earlier_run_is_appended_to(tmp_path):
    path = tmp_path / "view.sqlite"
    log = ViewerEventLog(path)
    log.close()
    ViewerEventLog(path).close()  # opened again: accepted


def test_a_trial_log_is_accepted(tmp_path):
    from experiment.log import TrialLog

    path = tmp_path / "study.sqlite"
    TrialLog(path).close()
    ViewerEventLog(path).close()
