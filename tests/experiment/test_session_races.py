"""One session per subject whatever the timing; locks that end with the session; a WAL that fits.

- The same subject started twice at the same moment gets one session: deciding "resume or
  create" and creating are one ``BEGIN IMMEDIATE`` transaction. The in-process tests hold both
  starts at a barrier after their decision, so both decide "new" before either writes (the
  timing that gave two complete sessions); the forked tests race real commands.
- Completing a session drops its lock in the completing commit (a kill after it left a lock
  row, and ``session status`` said "OPEN in pid ..." for a completed subject).
- A lock naming another host (the machine was renamed) is taken over only with
  ``--take-over-lock REASON``, logged with who and why; a live holder on this host never.
- The write-ahead log stays near the log's own size over a long session.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from experiment.active.session import ActiveSession
from experiment.clock import FakeClock
from experiment.interfaces import Answer, FlipRecord
from experiment.log import SessionComplete, SessionLocked, TrialLog
from experiment.protocol import load_protocol
from experiment.session import lifecycle
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import run_cli
from tests.experiment.test_session import PROTOCOL


@pytest.fixture()
def study(tmp_path):
    stim = make_stimulus_set(tmp_path / "stim", n_main=3, n_training=1, levels=(1, 2, 3, 8))
    proto = tmp_path / "tiny.toml"
    proto.write_text(PROTOCOL)
    return stim, proto, tmp_path / "study.sqlite"


def small_protocol(folder: Path):
    """The kill test's active-search protocol (a small scene, 4 trials), written to ``folder``."""
    from experiment.kill_recovery import ACTIVE_PROTOCOL

    proto = folder / "active.toml"
    proto.write_text(ACTIVE_PROTOCOL)
    return load_protocol(proto)


def _dead_pid() -> int:
    out = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    return int(out.stdout)


def _answer_all(s: Session) -> None:
    while not s.finished:
        t = s.next_trial()
        s.record(t, Answer("x", "named", "operator", 1.0), FlipRecord(onset_s=0.0))


def _decide_together(monkeypatch) -> None:
    """Hold each thread after its first "resume or create" decision until the other has made
    its own: both decide before either writes."""
    barrier = threading.Barrier(2, timeout=20)
    real = lifecycle.session_to_resume
    first = threading.local()

    def decide(*args, **kwargs):
        out = real(*args, **kwargs)
        if not getattr(first, "done", False):
            first.done = True
            barrier.wait()
        return out

    monkeypatch.setattr(lifecycle, "session_to_resume", decide)
    # an engine that imported the function by name decides through it too
    monkeypatch.setattr("experiment.session.engine.session_to_resume", decide, raising=False)


def _start_twice(path: Path, open_session) -> list[str]:
    """Open the same subject's session from two threads at once; each one that opens runs it to
    the end. Return each thread's outcome (``ran`` or the error's text)."""
    outcomes: list[str] = []

    def start() -> None:
        with TrialLog(path) as log:
            try:
                s = open_session(log)
            except Exception as exc:  # noqa: BLE001 - the outcome is checked below
                outcomes.append(f"{type(exc).__name__}: {exc}")
                return
            try:
                s.run_to_end()
                outcomes.append("ran")
            finally:
                s.close()

    threads = [threading.Thread(target=start) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    return outcomes


def _one_run_and_one_refusal(outcomes: list[str]) -> None:
    """One start ran the session; the other was refused while it ran ("already open"), or
    reported it complete when the first had finished by the time it wrote."""
    assert len(outcomes) == 2 and outcomes.count("ran") == 1, outcomes
    (other,) = [o for o in outcomes if o != "ran"]
    assert other.startswith(("SessionLocked", "SessionComplete")), other
    if other.startswith("SessionLocked"):
        assert "already open in another process" in other


def _one_complete_session(path: Path, subject: str = "S01") -> None:
    with TrialLog(path, readonly=True) as log:
        rows = [s for s in log.sessions() if s["subject"] == subject]
        assert len(rows) == 1, f"{len(rows)} sessions of {subject}"
        assert rows[0]["status"] == "completed"
        answered, planned = log.session_progress(rows[0]["session_id"])
        assert answered == planned > 0
        assert log.locks() == []


def test_the_same_subject_started_twice_at_once_gets_one_session(study, monkeypatch) -> None:
    stim, proto, db = study
    spec, stimset = load_protocol(proto), StimulusSet.load(stim)
    _decide_together(monkeypatch)
    monkeypatch.setattr(Session, "run_to_end", _answer_all, raising=False)
    outcomes = _start_twice(db, lambda log: Session.open(log, spec, stimset, "S01", seed=3))
    _one_run_and_one_refusal(outcomes)
    _one_complete_session(db)


def test_the_same_subject_started_twice_at_once_in_active_search_gets_one_session(
    tmp_path, monkeypatch
) -> None:
    from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher

    spec = small_protocol(tmp_path)
    _decide_together(monkeypatch)

    def run_to_end(s: ActiveSession) -> None:
        s.run(SimulatedSearcher(EdgeRecogniser(s.scene, spec.task.grid_px, rng=1), "planes"))

    monkeypatch.setattr(ActiveSession, "run_to_end", run_to_end, raising=False)
    db = tmp_path / "active.sqlite"
    outcomes = _start_twice(
        db, lambda log: ActiveSession.open(log, spec, "S01", seed=1, clock=FakeClock())
    )
    _one_run_and_one_refusal(outcomes)
    _one_complete_session(db)


def test_a_session_completed_after_the_decision_to_resume_it_is_not_run_again(
    study, monkeypatch
) -> None:
    """Start B decides to resume the subject's unfinished session; before it locks the session,
    start A (which had it open) answers the last trial. B must report the session complete, not
    resume it (a resume after the completion, the second 'ran' of a race)."""
    stim, proto, db = study
    spec, stimset = load_protocol(proto), StimulusSet.load(stim)
    with TrialLog(db) as log:
        s = Session.open(log, spec, stimset, "S01", seed=3)
        for _ in range(len(s.schedule) - 1):
            t = s.next_trial()
            s.record(t, Answer("x", "named", "operator", 1.0), FlipRecord(onset_s=0.0))
        s.close()
    real = lifecycle.session_to_resume

    started = []

    def decide_then_a_finishes(*args, **kwargs):
        row = real(*args, **kwargs)
        if started:  # start A's own decision
            return row
        started.append(True)
        with TrialLog(db) as other:
            a = Session.open(other, spec, stimset, "S01")
            _answer_all(a)
            a.close()
        return row

    monkeypatch.setattr(lifecycle, "session_to_resume", decide_then_a_finishes)
    monkeypatch.setattr(
        "experiment.session.engine.session_to_resume", decide_then_a_finishes, raising=False
    )
    with TrialLog(db) as log, pytest.raises(SessionComplete, match="is complete"):
        Session.open(log, spec, stimset, "S01")
    with TrialLog(db, readonly=True) as log:
        kinds = [e["kind"] for e in log.events()]
        assert "resume" not in kinds[kinds.index("complete") :], kinds
        assert log.locks() == []


def test_forked_commands_started_at_once_make_one_session_each(tmp_path) -> None:
    """Real commands, released together from a barrier: two races of each command."""
    from experiment.session_races import run_session_races

    report = run_session_races(tmp_path, races=2)
    assert report.ok, "\n".join(report.lines())
    for kind in ("static", "active"):
        assert report.ran[kind] + report.reported_complete[kind] + report.refused[kind] == 4
        assert report.ran[kind] >= 2  # every subject's session ran (no start was lost)


# -- locks end with the session ------------------------------------------------------------------


def test_completing_a_session_drops_its_lock_in_the_completing_commit(study, tmp_path) -> None:
    stim, proto, db = study
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=1)
        _answer_all(s)
        # a SIGKILL here, after the completing commit and before close(), leaves this log
        assert log.locks() == []
    with TrialLog(db) as log:
        a = ActiveSession.open(log, small_protocol(tmp_path), "A01", seed=1, clock=FakeClock())
        from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher

        a.run(SimulatedSearcher(EdgeRecogniser(a.scene, a.task.grid_px, rng=1), "planes"))
        assert log.locks() == []


def test_status_does_not_call_a_completed_session_open(study, capsys) -> None:
    """A log written by an older version, killed after the completing commit, keeps a lock row:
    ``session status`` must not say the completed session is open."""
    stim, proto, db = study
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=1)
        _answer_all(s)
        with log.atomic() as con:  # the row such a run left behind
            con.execute(
                "INSERT OR REPLACE INTO locks "
                "(session_id, pid, host, proc_start, token, acquired_at) "
                "VALUES (?, ?, 'lab-pc', NULL, 'gone', '2026-01-01')",
                (s.session_id, _dead_pid()),
            )
    assert run_cli(["session", "status", db]) == 0
    out = capsys.readouterr().out
    assert "complete (session" in out
    assert "OPEN in pid" not in out


# -- a lock on a renamed host --------------------------------------------------------------------


def _run_args(stim, proto, db, *extra) -> list:
    return ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01",
            "--data", db, "--headless", "--observer", "logistic", "--seed", 7, *extra]  # fmt: skip


def _crash_on_old_host(log: TrialLog, session_id: int) -> None:
    """The lock row of a run killed on this machine under its old host name."""
    with log.atomic() as con:
        con.execute(
            "UPDATE locks SET host = 'old-laptop.local', pid = ?, token = 'gone' "
            "WHERE session_id = ?",
            (_dead_pid(), session_id),
        )


def test_a_lock_from_a_renamed_host_is_taken_over_only_with_a_reason(study, capsys) -> None:
    stim, proto, db = study
    with TrialLog(db) as log:
        s = Session.open(
            log,
            load_protocol(proto),
            StimulusSet.load(stim),
            "S01",
            seed=7,
            responder="sim:logistic",
        )
        for _ in range(3):
            t = s.next_trial()
            s.record(t, Answer("x", "named", "operator", 1.0), FlipRecord(onset_s=0.0))
        _crash_on_old_host(log, s.session_id)
    before = db.read_bytes()
    assert run_cli(_run_args(stim, proto, db)) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "open on host old-laptop.local" in err and "--take-over-lock REASON" in err
    assert db.read_bytes() == before
    reason = "laptop renamed on the clinic network"
    assert run_cli(_run_args(stim, proto, db, "--take-over-lock", reason)) == 0
    assert "trials answered - complete" in capsys.readouterr().out
    with TrialLog(db, readonly=True) as log:
        (taken,) = [e for e in log.events(s.session_id) if e["kind"] == "lock_taken_over"]
        assert reason in taken["note"] and "old-laptop.local" in taken["note"]
        assert f"pid {os.getpid()}" in taken["note"] and "user " in taken["note"]
        assert [e["kind"] for e in log.events(s.session_id)].count("crash") == 1
        assert log.session(s.session_id)["status"] == "completed"
        assert log.answered_count(s.session_id) == len(s.schedule)
        assert log.locks() == []


def test_active_run_takes_over_a_renamed_hosts_lock_with_a_reason(tmp_path, capsys) -> None:
    from experiment.kill_recovery import ACTIVE_PROTOCOL

    proto = tmp_path / "active.toml"
    proto.write_text(ACTIVE_PROTOCOL)
    db = tmp_path / "active.sqlite"
    with TrialLog(db) as log:
        a = ActiveSession.open(
            log, load_protocol(proto), "S01", seed=4, clock=FakeClock(), responder="sim:planes"
        )
        _crash_on_old_host(log, a.session_id)
    args = ["active", "run", proto, "--data", db, "--subject", "S01", "--seed", 4]
    assert run_cli(args) == 2
    assert "--take-over-lock REASON" in capsys.readouterr().err
    assert run_cli([*args, "--take-over-lock", "new container"]) == 0
    with TrialLog(db, readonly=True) as log:
        kinds = [e["kind"] for e in log.events(a.session_id)]
        assert "lock_taken_over" in kinds and "complete" in kinds
        assert log.locks() == []


def test_a_live_lock_on_this_host_is_never_taken_over(study) -> None:
    stim, proto, db = study
    spec, stimset = load_protocol(proto), StimulusSet.load(stim)
    with TrialLog(db) as a, TrialLog(db) as b:
        s = Session.open(a, spec, stimset, "S01", seed=1)
        with pytest.raises(SessionLocked, match="already open in another process"):
            Session.open(b, spec, stimset, "S01", take_over_lock="I am sure")
        s.close()


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_taking_over_asks_on_a_terminal_and_no_changes_nothing(study, monkeypatch) -> None:
    import typer

    from experiment.commands.run_options import confirm_take_over
    from experiment.errors import ConfocalError

    stim, proto, db = study
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=7)
        _crash_on_old_host(log, s.session_id)
    before = db.read_bytes()
    asked = []
    monkeypatch.setattr(sys, "stdin", _Terminal())
    monkeypatch.setattr(sys, "stdout", _Terminal())
    monkeypatch.setattr(typer, "confirm", lambda text, default: asked.append(text) or False)
    with pytest.raises(ConfocalError, match="--take-over-lock: not confirmed; nothing was changed"):
        confirm_take_over(db, "S01", "renamed")
    assert asked and "old-laptop.local" in sys.stdout.getvalue()
    assert db.read_bytes() == before
    monkeypatch.setattr(typer, "confirm", lambda text, default: True)
    confirm_take_over(db, "S01", "renamed")  # confirmed: the command goes on
    with pytest.raises(Exception, match="--take-over-lock needs the reason on one line"):
        confirm_take_over(db, "S01", "  ")


# -- the write-ahead log fits --------------------------------------------------------------------


def test_the_write_ahead_log_stays_near_the_logs_size_over_a_long_session(tmp_path) -> None:
    """122 trials, onset and answer committed for each: the WAL grew ~25 KB a trial (3.1 MB
    here) and was never shrunk; checkpointing keeps it within a few trials' commits."""
    from tests.experiment.test_crash_resume import N_PLANNED
    from tests.experiment.test_crash_resume import PROTOCOL as LONG

    stim = make_stimulus_set(tmp_path / "stim", n_main=5, n_training=1, levels=(1, 2, 3, 4))
    proto = tmp_path / "long.toml"
    proto.write_text(LONG)
    db = tmp_path / "long.sqlite"
    wal = Path(f"{db}-wal")
    sizes = []
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=1)
        while not s.finished:
            t = s.next_trial()
            s.mark_shown(t, FlipRecord(onset_s=0.0))
            s.record(t, Answer("x", "named", "operator", 1.0), FlipRecord(onset_s=0.0))
            sizes.append(wal.stat().st_size)
        db_size = db.stat().st_size
        s.close()
    assert len(sizes) == N_PLANNED
    assert max(sizes) <= 2 * db_size, f"WAL reached {max(sizes)} bytes, the log {db_size}"


def test_a_reader_opened_before_a_writer_started_still_reads(study) -> None:
    """``session run`` reads the log (is the subject complete?) before it writes; a second start
    of the same subject may begin writing the file meanwhile. A reader opened while no WAL
    existed read the file as unchanging and failed "database disk image is malformed"."""
    stim, proto, db = study
    spec, stimset = load_protocol(proto), StimulusSet.load(stim)
    TrialLog(db).close()
    with TrialLog(db, readonly=True) as reader:
        with TrialLog(db) as writer:
            for i in range(30):
                Session.open(writer, spec, stimset, f"S{i:02d}", seed=1).close()
        assert len(reader.sessions()) == 30


def test_status_tells_a_crashed_runs_lock_from_a_live_one(study, capsys) -> None:
    import json

    stim, proto, db = study
    spec, stimset = load_protocol(proto), StimulusSet.load(stim)
    with TrialLog(db) as log:
        live = Session.open(log, spec, stimset, "S01", seed=1)
        crashed = Session.open(log, spec, stimset, "S02", seed=1)
        with log.atomic() as con:
            con.execute(
                "UPDATE locks SET pid = ?, token = 'gone' WHERE session_id = ?",
                (_dead_pid(), crashed.session_id),
            )
        assert run_cli(["session", "status", db]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert f"OPEN in pid {os.getpid()}" in lines[0]
        assert "crashed in pid" in lines[1] and "run the same command to resume" in lines[1]
        assert run_cli(["session", "status", db, "--json"]) == 0
        rep = json.loads(capsys.readouterr().out)
        assert [s["lock"]["stale"] for s in rep["sessions"]] == [False, True]
        live.close()
