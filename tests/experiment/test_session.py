"""Session API: create, record, resume, refuse mismatches and changed stimuli, headless run."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from experiment.clock import FakeClock
from experiment.data.subjects import SubjectCodeError
from experiment.interfaces import Answer, FlipRecord
from experiment.log import ResumeMismatch, SessionComplete, SessionLocked, TrialLog
from experiment.presentation.displays import NullDisplay
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet, StimulusSetError
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml

PROTOCOL = protocol_toml(
    (1, 2, 3),
    name="tiny",
    settings="pass_allowed_after_s = 30.0",
    main_settings="break_every_blocks = 2",
)


@pytest.fixture()
def stim_dir(tmp_path):
    return make_stimulus_set(tmp_path / "stim", n_main=3, n_training=1, levels=(1, 2, 3, 8))


@pytest.fixture()
def stimset(stim_dir):
    return StimulusSet.load(stim_dir)


@pytest.fixture()
def protocol(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(PROTOCOL)
    return load_protocol(p)


@pytest.fixture()
def log(tmp_path):
    with TrialLog(tmp_path / "study.sqlite") as lg:
        yield lg


class Scripted:
    """Answers every trial with ``score``; advances a fake clock by the response time."""

    def __init__(self, clock, score="named", rt_s=2.0, stop_at=None):
        self.clock, self.score, self.rt_s, self.stop_at = clock, score, rt_s, stop_at

    def respond(self, trial, image):
        if self.stop_at is not None and trial.index == self.stop_at:
            raise KeyboardInterrupt
        self.clock.advance(self.rt_s)
        return Answer(trial.object_name, self.score, "operator", self.rt_s)


def answer_next(session, score="named"):
    t = session.next_trial()
    session.record(t, Answer("x", score, "operator", 1.0), FlipRecord(onset_s=0.0))
    return t


def test_new_session_records_provenance(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01", seed=5)
    row = log.session(s.session_id)
    assert row["subject"] == "S01" and row["status"] == "open"
    assert row["protocol_sha256"] == protocol.content_sha256()
    assert row["protocol_file_sha256"] == protocol.source_sha256
    assert row["stimset_manifest_sha256"] == stimset.manifest_sha256
    assert row["seed"] == "5" and s.seed == 5
    assert json.loads(row["display_json"]) == protocol.display.to_dict()
    assert row["software_version"] and row["machine"]
    assert s.progress() == (0, 1 + 3 * 3 * 2)
    assert s.next_trial().index == 0
    assert log.planned_count(s.session_id) == len(s.schedule), "schedule written before trial 1"


def test_record_only_the_next_trial_and_known_scores(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01", seed=5)
    with pytest.raises(ValueError, match=r"next unanswered trial \(index 0\), got index 3"):
        s.record(s.schedule[3], Answer("x", "named", "operator"), FlipRecord(0.0))
    with pytest.raises(ValueError, match="answer.score must be one of"):
        s.record(s.schedule[0], Answer("x", "good", "operator"), FlipRecord(0.0))
    answer_next(s)
    assert s.progress()[0] == 1 and s.next_trial().index == 1


def test_resume_after_clean_close_continues_the_same_schedule(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01")
    for _ in range(4):
        answer_next(s)
    schedule = s.schedule
    s.close()
    r = Session.open(log, protocol, stimset, "S01")
    assert r.session_id == s.session_id and r.seed == s.seed
    assert r.schedule == schedule
    assert r.next_trial().index == 4 and r.progress() == (4, len(schedule))
    kinds = [e["kind"] for e in log.events(r.session_id)]
    assert kinds == ["open", "close", "resume"], "a clean close is not a crash"
    r.close()


def test_crash_detected_at_restart_is_logged(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01")
    answer_next(s)
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    with log.atomic() as con:  # the lock row a killed process leaves behind
        con.execute("UPDATE locks SET pid = ?, token = 'gone'", (int(dead.stdout),))
    r = Session.open(log, protocol, stimset, "S01")
    events = log.events(r.session_id)
    crash = [e for e in events if e["kind"] == "crash"]
    assert len(crash) == 1
    assert "ended without closing; 1 of 19 trials were committed" in crash[0]["note"]
    assert r.next_trial().index == 1


def test_the_same_session_cannot_be_opened_twice(tmp_path, protocol, stimset):
    path = tmp_path / "s.sqlite"
    with TrialLog(path) as a, TrialLog(path) as b:
        s = Session.open(a, protocol, stimset, "S01")
        with pytest.raises(SessionLocked, match="already open in another process"):
            Session.open(b, protocol, stimset, "S01")
        s.close()
        Session.open(b, protocol, stimset, "S01").close()


def test_resume_refuses_another_protocol_seed_or_stimulus_set(tmp_path, log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01", seed=7)
    s.close()
    other = tmp_path / "other.toml"
    other.write_text(PROTOCOL.replace("levels = [1, 2, 3]", "levels = [1, 2]"))
    with pytest.raises(ResumeMismatch, match=r"S01 has unfinished session 1 with protocol 'tiny'"):
        Session.open(log, load_protocol(other), stimset, "S01")
    with pytest.raises(ResumeMismatch, match=r"with seed 7, not 8; omit `seed`"):
        Session.open(log, protocol, stimset, "S01", seed=8)
    other_set = StimulusSet.load(
        make_stimulus_set(tmp_path / "s2", n_main=3, n_training=1, levels=(1, 2, 3, 8), rng=99)
    )
    with pytest.raises(ResumeMismatch, match="manifest.csv differs"):
        Session.open(log, protocol, other_set, "S01")
    Session.open(log, protocol, stimset, "S01", seed=7).close()  # the stored seed is fine


def test_changed_stimulus_file_refuses_to_start_naming_it(log, protocol, stim_dir):
    stimset = StimulusSet.load(stim_dir)
    target = stim_dir / stimset.get("obj02", "cluttered", 2).path
    target.write_bytes(target.read_bytes() + b"\0")
    with pytest.raises(StimulusSetError, match=r"obj02_cluttered_L2\.png: stimulus file changed"):
        Session.open(log, protocol, stimset, "S01")
    assert log.sessions() == [], "nothing is created when the check fails"
    target.unlink()
    with pytest.raises(
        StimulusSetError, match=r"obj02_cluttered_L2\.png: stimulus file is missing"
    ):
        Session.open(log, protocol, stimset, "S01")


def test_changed_file_refuses_resume_and_image_for(log, protocol, stim_dir):
    stimset = StimulusSet.load(stim_dir)
    s = Session.open(log, protocol, stimset, "S01")
    t = s.schedule[5]
    (stim_dir / t.path).write_bytes((stim_dir / t.path).read_bytes() + b"\0")
    with pytest.raises(StimulusSetError, match="changed during the session"):
        s.image_for(t)
    s.close()
    with pytest.raises(StimulusSetError, match="stimulus file changed"):
        Session.open(log, protocol, stimset, "S01")


def test_image_for_types(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01")
    photo = s.image_for(s.schedule[0])
    edge = s.image_for(s.schedule[1])
    assert s.schedule[0].condition == "photo" and photo.dtype == np.float32
    assert edge.dtype == bool
    t = s.schedule[1]
    assert edge.shape == (
        stimset.get(t.object, t.condition, t.level).height,
        stimset.get(t.object, t.condition, t.level).width,
    )


def test_headless_run_records_everything_with_breaks_and_timing(log, protocol, stimset):
    clock = FakeClock(100.0)
    s = Session.open(log, protocol, stimset, "S01", clock=clock)
    display = NullDisplay(clock)
    seen = []
    s.run(display, Scripted(clock, rt_s=2.5), progress=lambda a, n: seen.append((a, n)))
    n = len(s.schedule)
    assert seen == [(i, n) for i in range(1, n + 1)]
    assert s.finished and s.next_trial() is None
    assert log.session(s.session_id)["status"] == "completed"
    assert len(display.shown) == n
    rows = log.execute("SELECT onset_s, offset_s, rt_s FROM trials ORDER BY trial_index")
    assert all(r["offset_s"] - r["onset_s"] == pytest.approx(2.5) for r in rows)
    kinds = [e["kind"] for e in log.events(s.session_id)]
    assert kinds.count("break") == 2  # 6 main blocks, break before blocks 3 and 5
    assert "complete" in kinds
    assert display.texts.count("Break") == 2
    assert display.texts[-1].startswith("The session is complete")
    with pytest.raises(ValueError, match="is finished"):
        s.record(s.schedule[0], Answer("x", "named", "operator"), FlipRecord(0.0))
    s.close()
    with pytest.raises(SessionComplete, match=r"session 1 is complete .*--new-session"):
        Session.open(log, protocol, stimset, "S01")  # a completed session is not run again
    assert len(log.sessions()) == 1
    nxt = Session.open(log, protocol, stimset, "S01", new_session="re-test")
    assert nxt.session_id == s.session_id + 1, "a completed session is not resumed"
    assert log.new_session_reason(nxt.session_id) == "re-test"


def test_interrupt_logs_abort_and_keeps_answers(log, protocol, stimset):
    clock = FakeClock()
    s = Session.open(log, protocol, stimset, "S01", clock=clock)
    with pytest.raises(KeyboardInterrupt):
        s.run(NullDisplay(clock), Scripted(clock, stop_at=6))
    assert s.progress()[0] == 6
    assert [e["kind"] for e in log.events(s.session_id)][-1] == "abort"
    s.log_event("note", "subject needed a rest")
    assert log.events(s.session_id)[-1]["note"] == "subject needed a rest"


def test_seeds_give_subject_orders(log, protocol, stimset):
    a = Session.open(log, protocol, stimset, "A")
    b = Session.open(log, protocol, stimset, "B")
    assert a.seed != b.seed
    c = Session.open(log, protocol, stimset, "C", seed=a.seed)
    assert c.schedule == a.schedule
    orders = {
        tuple(t.object for t in Session.open(log, protocol, stimset, f"X{i}").schedule)
        for i in range(6)
    }
    assert len(orders) > 1


def test_suggest_score_and_rescore(log, protocol, stimset):
    s = Session.open(log, protocol, stimset, "S01")
    t = s.next_trial()
    name = t.object_name
    assert s.suggest_score(t, name.upper() + "S") == "named"
    assert s.suggest_score(t, "") == "pass"
    answer_next(s, "shape")
    s.rescore(t.index, "use", "operator", note="heard 'for cutting'")
    assert log.tidy_trials()[0]["score"] == "use"


def test_bad_arguments(log, protocol, stimset):
    with pytest.raises(SubjectCodeError, match="`subject` ' ' is empty"):  # as session run
        Session.open(log, protocol, stimset, " ")
    with pytest.raises(ValueError, match="subject must be a non-empty string"):
        Session.open(log, protocol, stimset, None)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        Session.open(log, protocol, stimset, "S01", seed=-1)
    with pytest.raises(ValueError, match="hold_s must be >= 0"):
        NullDisplay(hold_s=-1)
    with pytest.raises(ValueError, match="image must be 2-D"):
        NullDisplay().show_stimulus(np.zeros((2, 2, 2)))


def test_stimulus_set_reader_errors(tmp_path, stim_dir):
    from experiment.session.stimset import StimulusSet as SS

    with pytest.raises(StimulusSetError, match="stimulus set folder not found"):
        SS.load(tmp_path / "none")
    (stim_dir / "stimulus_set.json").write_text("{")
    with pytest.raises(StimulusSetError, match=r"stimulus_set\.json: not valid JSON"):
        SS.load(stim_dir)
    (stim_dir / "stimulus_set.json").write_text("{}")
    objects = (stim_dir / "objects.csv").read_text().splitlines()
    (stim_dir / "objects.csv").write_text("\n".join(objects[:-1]) + "\n")
    with pytest.raises(StimulusSetError, match=r"object 'obj04' of the manifest is not listed"):
        SS.load(stim_dir)
    (stim_dir / "objects.csv").write_text("\n".join(objects) + "\n")
    manifest = (stim_dir / "manifest.csv").read_text()
    lines = manifest.splitlines()
    parts = lines[1].split(",")
    parts[3] = "high"
    (stim_dir / "manifest.csv").write_text("\n".join([lines[0], ",".join(parts), *lines[2:]]))
    with pytest.raises(StimulusSetError, match=r"line 2: level/window/width/height/pixels must"):
        SS.load(stim_dir)
    (stim_dir / "manifest.csv").write_text(lines[0] + "\n")
    with pytest.raises(StimulusSetError, match="no stimuli listed"):
        SS.load(stim_dir)
    (stim_dir / "manifest.csv").write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(StimulusSetError, match="not a readable CSV file|missing column"):
        SS.load(stim_dir)
    (stim_dir / "manifest.csv").write_text(manifest)
    s = SS.load(stim_dir)
    assert s.verify() == len(s.records)
    with pytest.raises(
        StimulusSetError, match="no stimulus for object 'obj01', condition 'photo', level 1"
    ):
        s.get("obj01", "photo", 1)
    (stim_dir / s.records[0].path).unlink()
    with pytest.raises(StimulusSetError, match="listed in manifest.csv is missing"):
        s.verify()
    (stim_dir / s.records[1].path).write_bytes(b"x")
    with pytest.raises(StimulusSetError, match="stimulus file changed"):
        s.verify(s.records[1:2])
