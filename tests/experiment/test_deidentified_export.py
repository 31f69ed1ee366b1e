"""``session export`` shares no identifying participant field, no wall-clock time, and never merges
two subject codes into one file name."""

from __future__ import annotations

import csv
import dataclasses
import json
import re
from datetime import date, timedelta

import pytest

from experiment.data.psychds import (
    ParticipantError,
    SubjectCollision,
    check_subject_collisions,
    identifying_reason,
    parse_dates,
)
from experiment.log import TrialLog
from tests.experiment.conftest import (
    confocal,
    headless_run_args,
    make_study,
    run_and_export,
)


@pytest.fixture()
def study(tmp_path):
    return make_study(tmp_path, (1, 8), n_main=2, training=None)


def read(path, delimiter=","):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f, delimiter=delimiter))


@pytest.mark.parametrize(
    "text",
    [
        "name=Ann Smith",
        "first_name=Ann",
        "surname=Smith",
        "email=ann@example.org",
        "contact=ann@example.org",
        "phone=+44 20 7946 0958",
        "note=020 7946 0958",
        "dob=1970-01-02",
        "born=02/01/1970",
        "birth_year=1970",
        "address=1 High Street",
        "zip=02134",
        "mrn=12345",
    ],
)
def test_identifying_participant_fields_are_refused_at_session_run(study, capsys, text):
    stim, proto, db = study
    code, _, err = confocal(
        headless_run_args(stim, proto, db, "S01", "--participant", text), capsys
    )
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert text.split("=")[0] in err and "--allow-identifying" in err
    assert not db.exists(), "nothing written"


@pytest.mark.parametrize(
    "text", ["age=31", "sex=F", "acuity=20/200", "acuity_logmar=1.2", "consent=C7", "group=A"]
)
def test_documented_fields_are_not_identifying(text):
    key, value = text.split("=")
    assert identifying_reason(key, value) is None


def test_identifying_fields_stay_in_the_log_unless_asked(study, tmp_path, capsys):
    stim, proto, db = study
    meta = "age=31,email=ann@example.org,dob=1970-01-02,favourite=tea"
    code, _, err = confocal(headless_run_args(stim, proto, db, "S01", "--participant", meta,
                                "--allow-identifying"), capsys)  # fmt: skip
    assert code == 0, err
    with TrialLog(db, readonly=True) as log:
        stored = json.loads(log.sessions()[0]["participant_json"])
    assert stored["email"] == "ann@example.org", "kept in the log"
    out = tmp_path / "dataset"
    code, stdout, err = confocal(["session", "export", db, "--out", out], capsys)
    assert code == 0, err
    assert "left out identifying participant field(s) dob, email" in stdout
    assert "undocumented participant column(s) favourite" in stdout
    text = "".join(p.read_text() for p in out.rglob("*") if p.is_file())
    assert "ann@example.org" not in text and "1970-01-02" not in text
    (row,) = read(out / "participants.tsv", "\t")
    assert row["age"] == "31" and row["favourite"] == "tea" and "email" not in row
    doc = json.loads((out / "documentation" / "participants.json").read_text())
    assert doc["favourite"]["Undocumented"] is True and "Undocumented" not in doc["age"]
    # asked explicitly: exported
    out2 = tmp_path / "full"
    code, _, err = confocal(["session", "export", db, "--out", out2, "--include-identifying"],
                            capsys)  # fmt: skip
    assert code == 0, err
    (row,) = read(out2 / "participants.tsv", "\t")
    assert row["email"] == "ann@example.org"


def test_export_has_no_wall_clock_time(study, tmp_path, capsys):
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    with TrialLog(db, readonly=True) as log:
        started = log.sessions()[0]["started_at"]
        stamps = [r[0] for r in log.execute("SELECT recorded_at FROM trials")]
    day = date.fromisoformat(started[:10])
    clock = re.compile(r"\d{2}:\d{2}:\d{2}")
    for rule, want in (("day", day.isoformat()), ("shift:-400", (day - timedelta(400)).isoformat()),
                       ("none", "")):  # fmt: skip
        out = tmp_path / rule.replace(":", "")
        code, _, err = confocal(["session", "export", db, "--out", out, "--dates", rule], capsys)
        assert code == 0, err
        (data,) = (out / "data").glob("*_data.csv")
        rows = read(data)
        assert {r["date"] for r in rows} == {want}
        times = [float(r["time_s"]) for r in rows]
        assert all(0 <= t < 600 for t in times) and times == sorted(times)
        for p in out.rglob("*"):
            if p.is_file():
                text = p.read_text()
                for stamp in [started, *stamps]:
                    assert stamp not in text, (p.name, stamp)
        rec = json.loads((out / "documentation" / "sessions.json").read_text())["sessions"][0]
        assert "started_at" not in rec and rec["date"] == (want or None)
        for p in (data, out / "documentation" / "sessions.json"):
            assert not clock.search(p.read_text()), p.name
        desc = (out / "dataset_description.json").read_text()
        assert "400" not in desc, "the shift itself is not recorded"


@pytest.mark.parametrize("text", ["week", "shift", "shift:x", "shift:1.5", ""])
def test_bad_dates_rule(study, tmp_path, capsys, text):
    with pytest.raises(ParticipantError, match="--dates must be day, shift:N"):
        parse_dates(text)
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    code, _, err = confocal(["session", "export", db, "--out", tmp_path / "o", "--dates", text],
                            capsys)  # fmt: skip
    assert code == 2 and "--dates" in err and not (tmp_path / "o").exists()


def test_colliding_subject_codes_are_refused_at_run(study, capsys):
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S_01"), capsys)[0] == 0
    before = db.read_bytes()
    for other in ("S-01", "S01", "s01"):
        code, _, err = confocal(headless_run_args(stim, proto, db, other), capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert "'S_01'" in err and f"'{other}'" in err and "subject-" in err
    assert db.read_bytes() == before
    code = confocal(headless_run_args(stim, proto, db, "S_01"), capsys)[0]
    assert code == 0, "the same code is fine"


def test_colliding_subject_codes_are_refused_at_export(study, tmp_path, capsys):
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S_01"), capsys)[0] == 0
    import sqlite3

    con = sqlite3.connect(db)  # a second code, as in a log written before run refused it
    row = con.execute("SELECT * FROM sessions").fetchone()
    cols = [d[0] for d in con.execute("SELECT * FROM sessions").description]
    rec = dict(zip(cols, row, strict=True))
    rec.pop("session_id")
    rec["subject"] = "S-01"
    con.execute(f"INSERT INTO sessions ({', '.join(rec)}) VALUES ({', '.join('?' * len(rec))})",
                tuple(rec.values()))  # fmt: skip
    con.commit()
    con.close()
    out = tmp_path / "dataset"
    code, _, err = confocal(["session", "export", db, "--out", out], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "'S_01'" in err and "'S-01'" in err and "subject-S01" in err
    assert not out.exists(), "nothing written"


def test_collision_with_a_subject_already_in_the_dataset(study, tmp_path, capsys):
    stim, proto, db = study
    out = tmp_path / "dataset"
    run_and_export(study, out, capsys)
    db2 = tmp_path / "site2.sqlite"
    assert confocal(headless_run_args(stim, proto, db2, "S-01"), capsys)[0] == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    code, _, err = confocal(["session", "export", db2, "--out", out], capsys)
    assert code == 2 and "'S01'" in err and "'S-01'" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


def test_collision_check():
    check_subject_collisions(["S01", "S02", "S01"])
    with pytest.raises(SubjectCollision, match=r"subjects 'S01' and 's01'"):
        check_subject_collisions(["S01", "s01"])
    with pytest.raises(SubjectCollision, match="no letter or digit"):
        check_subject_collisions(["__"])


def test_participants_tsv_is_formula_safe(study, tmp_path, capsys):
    stim, proto, db = study
    code, _, err = confocal(headless_run_args(stim, proto, db, "S01", "--participant",
                                "group=+cmd|calc,site=-A"), capsys)  # fmt: skip
    assert code == 0, err
    out = tmp_path / "dataset"
    assert confocal(["session", "export", db, "--out", out], capsys)[0] == 0
    raw = (out / "participants.tsv").read_text()
    assert "\t'+cmd|calc" in raw and "\t'-A" in raw
    # a second export merges the rows it reads back: still escaped once, not twice
    assert confocal(["session", "export", db, "--out", out], capsys)[0] == 0
    (row,) = read(out / "participants.tsv", "\t")
    assert row["group"] == "'+cmd|calc" and row["site"] == "'-A"


# -- what the description, the answers and a person's own files may hold -----------------------


def _log_with_answers(folder, subject, answers):
    """A trial log of ``subject``'s session whose trials are answered with ``answers`` in turn."""
    from experiment.clock import FakeClock
    from experiment.interfaces import Answer, FlipRecord
    from experiment.protocol import load_protocol
    from experiment.session.engine import Session
    from experiment.session.plan import plan_session
    from experiment.session.stimset import StimulusSet

    stim, proto, db = make_study(folder, (1, 8), n_main=2, training=None)
    clock = FakeClock(0.0)
    with TrialLog(db) as log:
        plan = plan_session(load_protocol(proto), StimulusSet.load(stim), "S01", log=log, seed=1)
        # the code as a log made before the subject-code rule holds it: past the plan's check
        s = Session.open_planned(log, dataclasses.replace(plan, subject=subject), clock=clock)
        with s:
            i = 0
            while (trial := s.next_trial()) is not None:
                clock.advance(1.0)
                s.record(trial, Answer(answers[i % len(answers)], "named", "operator", rt_s=0.5),
                         FlipRecord(onset_s=0.0, offset_s=1.0))  # fmt: skip
                i += 1
    return db


@pytest.mark.parametrize("rule", ["day", "shift:-400", "none"])
def test_description_dates_follow_the_dates_rule(study, tmp_path, capsys, rule):
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    out = tmp_path / "dataset"
    code, _, err = confocal(["session", "export", db, "--out", out, "--dates", rule], capsys)
    assert code == 0, err
    desc = json.loads((out / "dataset_description.json").read_text())
    today = date.today()  # UTC and local differ by at most a day
    near = {(today + timedelta(d)).isoformat() for d in (-1, 0, 1)}
    if rule == "none":
        assert "dateCreated" not in desc and "dateModified" not in desc
    else:
        shift = parse_dates(rule)[1]
        near = {(date.fromisoformat(d) + timedelta(shift)).isoformat() for d in near}
        assert desc["dateCreated"] in near and desc["dateModified"] in near, desc
    text = (out / "dataset_description.json").read_text()
    assert not re.search(r"\d{2}:\d{2}", text), "no time of day"


def test_a_time_of_day_left_by_an_older_export_is_not_kept(study, tmp_path, capsys):
    out = tmp_path / "dataset"
    run_and_export(study, out, capsys)
    desc_path = out / "dataset_description.json"
    desc = json.loads(desc_path.read_text())
    desc["dateCreated"] = "2020-01-02T03:04:05+00:00"
    desc_path.write_text(json.dumps(desc))
    assert confocal(["session", "export", study[2], "--out", out], capsys)[0] == 0
    assert "03:04:05" not in desc_path.read_text()


def test_answers_that_look_like_contact_details_are_warned(tmp_path, capsys):
    db = _log_with_answers(tmp_path, "S01", ["cup", "write to ann@example.org", "cup",
                                             "call 020 7946 0958"])  # fmt: skip
    out = tmp_path / "dataset"
    code, stdout, err = confocal(["session", "export", db, "--out", out], capsys)
    assert code == 0, err
    (line,) = [x for x in err.splitlines() if "typed answer" in x]
    assert line.startswith("warning: ") and "e-mail" in line and "phone" in line
    assert "session 1 trial 1 " in line and "session 1 trial 3 " in line
    assert "trial 0 " not in line and "trial 2 " not in line


def test_plain_answers_give_no_warning(tmp_path, capsys):
    db = _log_with_answers(tmp_path, "S01", ["cup", "a red cup", "3 cups", "1,-2"])
    code, _, err = confocal(["session", "export", db, "--out", tmp_path / "d"], capsys)
    assert code == 0 and "warning" not in err, err


@pytest.mark.parametrize(
    ("text", "found"),
    [("ann@example.org", "e-mail"), ("me: a.b@c.co.uk ok", "e-mail"), ("020 7946 0958", "phone"),
     ("+1 (555) 010-9999", "phone"), ("cup", None), ("20/200", None), ("12 cups", None),
     ("version 1.2.3", None), ("", None)],
)  # fmt: skip
def test_identifying_answer(text, found):
    from experiment.data.psychds import identifying_answer

    reason = identifying_answer(text)
    assert (reason is None) if found is None else (found in reason)


def test_subject_codes_logged_before_the_rule_are_warned(tmp_path, capsys):
    db = _log_with_answers(tmp_path, "ann@example.org", ["cup"])
    code, _, err = confocal(["session", "export", db, "--out", tmp_path / "d"], capsys)
    assert code == 0, err
    assert "warning: subject code(s) 'ann@example.org'" in err


def test_a_persons_readme_changes_and_license_do_not_block_the_next_export(study, tmp_path, capsys):
    from experiment.outputs import read_manifest

    out = tmp_path / "dataset"
    run_and_export(study, out, capsys)
    mine = {"README": "About this study\n", "CHANGES": "1.0 first\n", "LICENSE.md": "CC-BY\n"}
    for name, text in mine.items():
        (out / name).write_text(text)
    code, _, err = confocal(["session", "export", study[2], "--out", out], capsys)
    assert code == 0, err
    assert {n: (out / n).read_text() for n in mine} == mine, "kept as the person wrote them"
    assert not set(mine) & set(read_manifest(out)["files"]), "never listed as the export's"
    assert confocal(["session", "export", study[2], "--out", out], capsys)[0] == 0
    # any other file of a person's is still refused, naming it
    (out / "notes.txt").write_text("mine\n")
    code, _, err = confocal(["session", "export", study[2], "--out", out], capsys)
    assert code == 2 and "notes.txt" in err and len(err.strip().splitlines()) == 1
