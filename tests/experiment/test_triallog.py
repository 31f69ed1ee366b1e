"""The SQLite trial log: schema, durability, append-only rules, locks, bad files (H16, H22)."""

from __future__ import annotations

import hashlib
import os
import socket
import sqlite3
import subprocess
import sys

import pytest

from experiment.clock import FakeClock
from experiment.interfaces import Answer, FlipRecord
from experiment.log import (
    MIGRATIONS,
    TIDY_COLUMNS,
    SessionLocked,
    TrialLog,
    TrialLogError,
    faults,
    schema,
)
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml

PROTOCOL = protocol_toml((1, 2), name="tiny", training=(2, "decluttered"))


@pytest.fixture(scope="module")
def stimset(tmp_path_factory):
    return StimulusSet.load(
        make_stimulus_set(tmp_path_factory.mktemp("set"), n_main=3, n_training=1, levels=(1, 2))
    )


@pytest.fixture(scope="module")
def protocol(tmp_path_factory):
    p = tmp_path_factory.mktemp("proto") / "tiny.toml"
    p.write_text(PROTOCOL)
    return load_protocol(p)


class Scripted:
    """A deterministic responder: scores cycle through all five scores."""

    SCORES = ("named", "use", "shape", "wrong", "pass")

    def respond(self, trial, image):
        score = self.SCORES[trial.index % 5]
        return Answer(f"answer {trial.index}", score, "operator", 1.0 + trial.index)


def run_scripted(log, protocol, stimset, subject="S01", n=None):
    clock = FakeClock()
    s = Session.open(log, protocol, stimset, subject, seed=7, clock=clock)
    resp = Scripted()
    for _ in range(n if n is not None else len(s.schedule)):
        t = s.next_trial()
        img = s.image_for(t)
        a = resp.respond(t, img)
        clock.advance(1.0)
        s.record(t, a, FlipRecord(onset_s=clock.now_s(), offset_s=clock.now_s() + 0.5))
    return s


def test_wal_full_and_numbered_migrations(tmp_path):
    path = tmp_path / "study.sqlite"
    with TrialLog(path) as log:
        assert log.execute("PRAGMA journal_mode")[0][0] == "wal"
        assert log.execute("PRAGMA synchronous")[0][0] == 2  # FULL
        rows = log.execute("SELECT version, name FROM schema_migrations ORDER BY version")
        assert [tuple(r) for r in rows] == [(v, n) for v, n, _ in MIGRATIONS]
    with TrialLog(path) as log:  # reopening applies nothing twice
        assert log.execute("SELECT count(*) FROM schema_migrations")[0][0] == len(MIGRATIONS)
        assert log.schema_version() == MIGRATIONS[-1][0]


#: sha256 of each released migration's SQL, whitespace-normalised (runs of blanks made one
#: space). A released migration is never edited, so that every existing log migrates exactly as
#: before; a change of schema is a new migration, appended.
RELEASED_MIGRATION_SQL_SHA256 = {
    1: "70ba9b4ba922bfeffe74899969a7ac7e0711dcb1a34c226574c4f57d99a19c8b",
    2: "3e602d161a53b9800ebbfde2fb665cd7b3b706cb48b7ac306ef51df43f1fbfab",
    3: "3772af95847b46255b1f624e55ebcaf890e21c27f371660001ca110d40de811f",
    4: "99f4a3f6f704334e455170cacd132fd025a40a87790532f5c889b7c9e837535b",
    5: "20b37a2c24e2d422ef77ca795b8030938f3c7ea928d83c77e57d065751a347c9",
    6: "42d8159020a9c05d6931d0db640e0ec7621c25f2c8d65cd728815f94adf04766",
}


def test_released_migrations_run_the_sql_they_always_ran():
    versions = [v for v, _, _ in MIGRATIONS]
    assert versions == sorted(set(versions)), "migration numbers are unique and ascending"
    assert set(RELEASED_MIGRATION_SQL_SHA256) <= set(versions), "a released migration was removed"
    for version, name, sql in MIGRATIONS:
        if version in RELEASED_MIGRATION_SQL_SHA256:
            digest = hashlib.sha256(" ".join(sql.split()).encode()).hexdigest()
            assert digest == RELEASED_MIGRATION_SQL_SHA256[version], (
                f"migration {version} ({name}) was edited; append a new migration instead"
            )


def test_tidy_view_has_the_contract_columns(tmp_path, protocol, stimset):
    with TrialLog(tmp_path / "s.sqlite") as log:
        run_scripted(log, protocol, stimset, n=3).close()
        cur = log._con.execute("SELECT * FROM tidy_trials")
        assert tuple(d[0] for d in cur.description) == TIDY_COLUMNS
        rows = log.tidy_trials()
        assert [r["trial_index"] for r in rows] == [0, 1, 2]
        assert [r["recognized"] for r in rows] == [1, 1, 0]  # named, use, shape
        assert rows[0]["subject"] == "S01" and rows[0]["part"] == "training"


def test_unique_trial_index_refuses_a_duplicate(tmp_path, protocol, stimset):
    with TrialLog(tmp_path / "s.sqlite") as log:
        s = run_scripted(log, protocol, stimset, n=1)
        t0 = s.schedule[0]
        with pytest.raises(TrialLogError, match="cannot record trial 0 of session 1"):
            log.record(s.session_id, t0, FlipRecord(0.0), Answer("x", "named", "operator"), True)
        assert log.answered_count(s.session_id) == 1
        assert log.execute("SELECT count(*) FROM scores")[0][0] == 1, "rolled back whole"


def test_atomic_rolls_back_and_nests(tmp_path):
    with TrialLog(tmp_path / "s.sqlite") as log:
        with pytest.raises(RuntimeError):
            with log.atomic():
                log.add_event(None, "note", "a")
                raise RuntimeError("boom")
        assert log.events() == []
        with log.atomic():
            log.add_event(None, "note", "outer")
            with pytest.raises(RuntimeError):
                with log.atomic():
                    log.add_event(None, "note", "inner")
                    raise RuntimeError("boom")
        assert [e["note"] for e in log.events()] == ["outer"]


def test_trials_and_scores_are_append_only(tmp_path, protocol, stimset):
    with TrialLog(tmp_path / "s.sqlite") as log:
        run_scripted(log, protocol, stimset, n=2).close()
        for sql in (
            "UPDATE scores SET score = 'named'",
            "DELETE FROM scores",
            "UPDATE trials SET response = 'x'",
            "DELETE FROM trials",
            "UPDATE schedule SET level = 3",
        ):
            with pytest.raises(sqlite3.DatabaseError, match="append-only|fixed once written"):
                with log.atomic() as con:
                    con.execute(sql)


def test_rescore_appends_and_the_view_uses_the_latest_primary_score(tmp_path, protocol, stimset):
    with TrialLog(tmp_path / "s.sqlite") as log:
        s = run_scripted(log, protocol, stimset, n=3)
        s.rescore(2, "named", "operator")  # operator corrects shape -> named
        s.rescore(0, "wrong", "B")  # a second rater disagrees; not primary
        rows = {r["trial_index"]: r for r in log.tidy_trials()}
        assert (rows[2]["score"], rows[2]["recognized"]) == ("named", 1)
        assert (rows[0]["score"], rows[0]["rater"]) == ("named", "operator")
        assert log.execute("SELECT count(*) FROM scores")[0][0] == 5
        with pytest.raises(TrialLogError, match="trial 5 of session 1 has no answer"):
            s.rescore(5, "named", "B")
        with pytest.raises(ValueError, match="score must be one of"):
            log.add_score(1, 0, "great", True, "B")
        with pytest.raises(ValueError, match="rater must be a non-empty string"):
            s.rescore(0, "named", "")


def test_memory_and_sqlite_logs_give_identical_rows(tmp_path, protocol, stimset):
    """H22: the same scripted session through the :memory: twin and the file."""
    dumps = []
    for path in (":memory:", tmp_path / "s.sqlite"):
        with TrialLog(path) as log:
            run_scripted(log, protocol, stimset).close()
            trials = [
                {k: r[k] for k in r.keys() if k not in ("recorded_at", "trial_id")}
                for r in log.execute("SELECT * FROM trials ORDER BY trial_index")
            ]
            dumps.append(
                (
                    log.tidy_trials(),
                    trials,
                    [dict(r) for r in log.execute("SELECT * FROM schedule ORDER BY trial_index")],
                )
            )
    assert dumps[0] == dumps[1]
    assert len(dumps[0][0]) == 1 + 3 * 2 * 2  # training + main trials


def test_reader_opens_read_only_while_a_session_writes(tmp_path, protocol, stimset):
    path = tmp_path / "s.sqlite"
    with TrialLog(path) as log:
        s = run_scripted(log, protocol, stimset, n=2)
        reader = TrialLog(path, readonly=True)
        assert len(reader.tidy_trials()) == 2
        t = s.next_trial()
        s.record(t, Answer("x", "pass", "operator"), FlipRecord(1.0))
        assert len(reader.tidy_trials()) == 3
        with pytest.raises(TrialLogError, match="opened read-only; cannot write"):
            reader.add_event(1, "note")
        reader.close()
        s.close()


def test_corrupt_file_is_refused_and_left_alone(tmp_path):
    path = tmp_path / "study.sqlite"
    garbage = b"this is not a database" * 100
    path.write_bytes(garbage)
    with pytest.raises(TrialLogError, match=r"study\.sqlite: not a readable SQLite trial log"):
        TrialLog(path)
    with pytest.raises(TrialLogError, match=r"not a readable SQLite trial log"):
        TrialLog(path, readonly=True)
    assert path.read_bytes() == garbage


def test_foreign_sqlite_file_is_refused(tmp_path):
    path = tmp_path / "other.sqlite"
    con = sqlite3.connect(path)
    con.execute("CREATE TABLE x (a)")
    con.commit()
    con.close()
    with pytest.raises(TrialLogError, match="not a confocal trial log"):
        TrialLog(path)


def test_read_only_file_and_folder_are_refused_and_left_alone(tmp_path, protocol, stimset):
    path = tmp_path / "study.sqlite"
    with TrialLog(path) as log:
        run_scripted(log, protocol, stimset, n=2).close()
    before = path.read_bytes()
    path.chmod(0o444)
    try:
        with pytest.raises(TrialLogError, match=r"study\.sqlite: trial log is read-only"):
            TrialLog(path)
        assert path.read_bytes() == before
        with TrialLog(path, readonly=True) as ro:  # reading still works
            assert len(ro.tidy_trials()) == 2
    finally:
        path.chmod(0o644)
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        with pytest.raises(TrialLogError, match=r"folder .*ro is read-only"):
            TrialLog(folder / "new.sqlite")
    finally:
        folder.chmod(0o755)
    with pytest.raises(TrialLogError, match="does not exist"):
        TrialLog(tmp_path / "missing" / "x.sqlite")
    with pytest.raises(TrialLogError, match="trial log not found"):
        TrialLog(tmp_path / "absent.sqlite", readonly=True)


def test_newer_schema_is_refused(tmp_path):
    path = tmp_path / "s.sqlite"
    with TrialLog(path) as log, log.atomic() as con:
        con.execute("INSERT INTO schema_migrations VALUES (99, 'future', 'x')")
    with pytest.raises(TrialLogError, match="schema version 99 is newer"):
        TrialLog(path)


def test_second_opener_in_the_same_process_is_refused(tmp_path, protocol, stimset):
    path = tmp_path / "s.sqlite"
    with TrialLog(path) as a, TrialLog(path) as b:
        s = run_scripted(a, protocol, stimset, n=1)
        with pytest.raises(SessionLocked, match=r"session 1 is already open in another process"):
            b.acquire_lock(s.session_id)
        s.close()
        assert b.acquire_lock(s.session_id) is None  # released cleanly: not stale
        b.release_lock(s.session_id)


def test_stale_lock_of_a_dead_process_is_taken_over(tmp_path, protocol, stimset):
    path = tmp_path / "s.sqlite"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    dead_pid = int(dead.stdout)
    with TrialLog(path) as log:
        s = run_scripted(log, protocol, stimset, n=1)
        s.close()
        with log.atomic() as con:
            con.execute(
                "INSERT INTO locks VALUES (?, ?, ?, NULL, 'x', 'then')",
                (s.session_id, dead_pid, socket.gethostname()),
            )
        stale = log.acquire_lock(s.session_id)
        assert stale is not None and stale["pid"] == dead_pid
        assert [r["pid"] for r in log.locks()] == [os.getpid()]


def test_lock_held_on_another_host_is_refused(tmp_path, protocol, stimset):
    path = tmp_path / "s.sqlite"
    with TrialLog(path) as log:
        s = run_scripted(log, protocol, stimset, n=1)
        s.close()
        with log.atomic() as con:
            con.execute(
                "INSERT INTO locks VALUES (?, 1, 'elsewhere', NULL, 'x', 'then')", (s.session_id,)
            )
        with pytest.raises(SessionLocked, match="open on host elsewhere"):
            log.acquire_lock(s.session_id)


def test_misc_errors(tmp_path):
    with TrialLog(tmp_path / "s.sqlite") as log:
        with pytest.raises(ValueError, match="kind must be a non-empty string"):
            log.add_event(None, "")
        with pytest.raises(ValueError, match="unknown sessions column 'colour'"):
            log.create_session(colour="red")
        with pytest.raises(TrialLogError, match="no session 42"):
            log.session(42)
        with pytest.raises(TrialLogError, match="query failed"):
            log.execute("SELECT nope FROM nothing")


def test_an_older_log_is_upgraded_in_place_and_keeps_its_trials(
    tmp_path, protocol, stimset, monkeypatch
):
    """A schema-1 log is upgraded in place: old trials have 0 logged viewings, new ones >= 1."""
    db = tmp_path / "old.sqlite"
    monkeypatch.setattr(schema, "MIGRATIONS", MIGRATIONS[:-1])  # before the viewings migration
    with TrialLog(db) as log:
        s = Session.open(log, protocol, stimset, "S01", seed=3, clock=FakeClock())
        t0 = s.next_trial()
        with log.atomic() as con:  # a trial as schema 1 recorded it (no onset table yet)
            con.execute(
                "INSERT INTO trials (session_id, trial_index, object, condition, level, pixels, "
                "stimulus_sha256, response, recorded_at) VALUES (?, 0, ?, ?, ?, ?, ?, 'x', 'now')",
                (s.session_id, t0.object, t0.condition, t0.level, t0.pixels, t0.sha256),
            )
            con.execute(
                "INSERT INTO scores (session_id, trial_index, score, recognized, rater, "
                "is_primary, scored_at) VALUES (?, 0, 'named', 1, 'operator', 1, 'now')",
                (s.session_id,),
            )
        s.close()
        assert log.schema_version() == MIGRATIONS[-2][0]
    monkeypatch.setattr(schema, "MIGRATIONS", MIGRATIONS)
    with TrialLog(db) as log:
        assert log.schema_version() == MIGRATIONS[-1][0]
        s = Session.open(log, protocol, stimset, "S01", clock=FakeClock())
        t1 = s.next_trial()
        assert t1.index == 1
        assert s.mark_shown(t1, FlipRecord(1.0)) == 1
        assert s.mark_shown(t1, FlipRecord(2.0)) == 2  # shown again before it was answered
        s.record(t1, Answer("mug", "named", "operator"), FlipRecord(2.0, 3.0))
        rows = log.tidy_trials()
        assert [(r["trial_index"], r["viewings"], r["repeat_viewing"]) for r in rows] == [
            (0, 0, 0),
            (1, 2, 1),
        ]
        assert tuple(rows[0]) == TIDY_COLUMNS
        kinds = [e["kind"] for e in log.events(s.session_id)]
        assert kinds.count("repeat_viewing") == 1
        s.close()
    with pytest.raises(sqlite3.IntegrityError, match="viewings are append-only"):
        con = sqlite3.connect(db)
        try:
            con.execute("DELETE FROM viewings")
        finally:
            con.close()


def test_fault_spec_is_checked():
    for bad in ("commit", "commit@0=exit", "nowhere@1=exit", "commit@1=explode"):
        with pytest.raises(ValueError, match="CONFOCAL_FAULT must look like STEP@N=exit|enospc"):
            faults.parse_fault(bad)
    assert faults.parse_fault("") is None
    assert faults.parse_fault("record.trial@3=exit") == ("record.trial", 3, "exit")


def test_disk_full_rolls_back_and_says_so(tmp_path, protocol, stimset, monkeypatch):
    db = tmp_path / "full.sqlite"
    with TrialLog(db) as log:
        s = Session.open(log, protocol, stimset, "S01", seed=3, clock=FakeClock())
        t0 = s.next_trial()
        monkeypatch.setattr(faults, "_fault_spec", ("record.score", 1, "enospc"))
        monkeypatch.setattr(faults, "_fault_hits", {})
        with pytest.raises(TrialLogError, match="disk is full .*rolled back.*run the same"):
            s.record(t0, Answer("mug", "named", "operator"), FlipRecord(0.0, 1.0))
        monkeypatch.setattr(faults, "_fault_spec", None)
        assert log.answered_count(s.session_id) == 0, "the half-written trial was rolled back"
        assert log.viewings(s.session_id, 0) == 0
        s.record(t0, Answer("mug", "named", "operator"), FlipRecord(0.0, 1.0))
        assert log.answered_count(s.session_id) == 1
        s.close()
