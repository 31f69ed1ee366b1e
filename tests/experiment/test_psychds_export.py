"""``confocal session export`` writes a valid Psych-DS 1.x dataset.

:func:`check_psychds` below is an independent check of the Psych-DS 1.x rules that apply to this
export (schema objects ``dataset_description``, ``Datafile``, ``columnsMatchMetadata`` and the CSV
errors ``CSVHeaderMissing``, ``CSVHeaderRepeated``, ``CSVHeaderLengthMismatch``); the file-name
pattern is the schema's ``Datafile.fileRegex``, written out here again rather than imported.
"""

from __future__ import annotations

import csv
import hashlib
import json
import re
from datetime import datetime
from pathlib import Path

import pytest

from experiment.data.psychds import (
    ParticipantError,
    datafile_name,
    keyword_value,
    parse_participant,
)
from experiment.log import TrialLog
from tests.experiment.conftest import (
    confocal,
    headless_run_args,
    make_study,
    run_and_export,
)

#: Psych-DS 1.x schema, objects/files/Datafile: fileRegex.
FILE_REGEX = re.compile(r"([a-z]+-[a-zA-Z0-9]+)(_[a-z]+-[a-zA-Z0-9]+)*_data\.csv")


def check_psychds(root: Path) -> list[str]:
    """Return the Psych-DS 1.x rule violations of dataset folder ``root`` (empty: valid)."""
    errors = []
    desc_path = root / "dataset_description.json"
    if not desc_path.is_file():
        return ["MISSING_DATASET_DESCRIPTION"]
    try:
        desc = json.loads(desc_path.read_text(encoding="utf-8"))
    except json.JSONDecodeError:
        return ["JSON_INVALID"]
    if "schema.org" not in str(desc.get("@context", "")):
        errors.append("INCORRECT_DATASET_TYPE: @context must be schema.org")
    if desc.get("@type") != "Dataset":
        errors.append("INCORRECT_DATASET_TYPE: @type must be Dataset")
    for key in ("name", "description"):
        if not isinstance(desc.get(key), str) or not desc[key].strip():
            errors.append(f"MISSING_REQUIRED_FIELD: {key}")
    variables = desc.get("variableMeasured")
    if not isinstance(variables, list) or not variables:
        errors.append("MISSING_REQUIRED_FIELD: variableMeasured")
        variables = []
    names = {v if isinstance(v, str) else v.get("name") for v in variables}
    data = root / "data"
    if not data.is_dir():
        return [*errors, "MISSING_DATA_DIRECTORY"]
    files = sorted(p for p in data.rglob("*") if p.is_file())
    if not any(FILE_REGEX.fullmatch(p.name) for p in files):
        errors.append("MISSING_DATAFILE")
    seen_columns = set()
    for p in files:
        if not FILE_REGEX.fullmatch(p.name):
            errors.append(f"FILENAME_KEYWORD_FORMATTING_ERROR: {p.name}")
            continue
        keys = [kv.split("-")[0] for kv in p.name[: -len("_data.csv")].split("_")]
        if len(keys) != len(set(keys)):
            errors.append(f"FILENAME_KEYWORD_DUPLICATE: {p.name}")
        with open(p, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        if not rows or not rows[0]:
            errors.append(f"CSV_HEADER_MISSING: {p.name}")
            continue
        header = rows[0]
        if len(header) != len(set(header)):
            errors.append(f"CSV_HEADER_REPEATED: {p.name}")
        if any(len(r) != len(header) for r in rows[1:]):
            errors.append(f"CSV_HEADER_LENGTH_MISMATCH: {p.name}")
        for col in header:
            seen_columns.add(col)
            if col not in names:
                errors.append(f"CSV_COLUMN_MISSING_FROM_METADATA: {col} in {p.name}")
    for name in sorted(names - seen_columns):
        errors.append(f"VARIABLE_MISSING_FROM_CSV_COLUMNS: {name}")
    return errors


def strings(obj):
    if isinstance(obj, str):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from strings(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from strings(v)


@pytest.fixture()
def study(tmp_path):
    return make_study(tmp_path, (1, 8), n_main=2)


def test_export_is_a_valid_psychds_dataset(study, tmp_path, capsys):
    stim, proto, db = study
    args = headless_run_args(stim, proto, db, "S-01", "--participant", "age=31,sex=F,consent=C7")
    assert confocal(args, capsys)[0] == 0
    assert confocal(headless_run_args(stim, proto, db, "S02"), capsys)[0] == 0
    out = tmp_path / "dataset"
    code, stdout, err = confocal(["session", "export", db, "--out", out, "--study", "pilot-1"],
                                 capsys)  # fmt: skip
    assert code == 0, err
    assert check_psychds(out) == []
    assert sorted(p.name for p in (out / "data").iterdir()) == [
        "study-pilot1_subject-S01_session-1_data.csv",
        "study-pilot1_subject-S02_session-2_data.csv",
    ]
    # no host paths anywhere in the metadata a lab would share
    for meta in (out / "dataset_description.json", out / "documentation" / "sessions.json"):
        for s in strings(json.loads(meta.read_text())):
            assert str(tmp_path) not in s and not s.startswith("/"), (meta.name, s)
    with open(out / "data" / "study-pilot1_subject-S01_session-1_data.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert "rt_s" not in rows[0] and "operator_rt_s" in rows[0]
    assert {r["subject"] for r in rows} == {"S-01"}, "the code as logged"
    for r in rows:
        datetime.fromisoformat(r["date"])
        image = stim / r["stimulus_file"]
        assert hashlib.sha256(image.read_bytes()).hexdigest() == r["stimulus_sha256"]
        assert r["simulated"] == "1" and r["observer"] == "logistic"
    with TrialLog(db, readonly=True) as log:
        n_trials = log.answered_count(1)
    assert len(rows) == n_trials
    with open(out / "participants.tsv", newline="") as f:
        part = list(csv.DictReader(f, delimiter="\t"))
    assert part[0] == {"participant_id": "S-01", "simulated": "1", "observer": "logistic",
                       "age": "31", "sex": "F", "consent": "C7"}  # fmt: skip
    assert part[1]["participant_id"] == "S02" and part[1]["age"] == "n/a"


def test_reexport_merges_instead_of_overwriting(study, tmp_path, capsys):
    stim, proto, db = study
    out = tmp_path / "dataset"
    run_and_export(study, out, capsys)
    desc_path = out / "dataset_description.json"
    desc = json.loads(desc_path.read_text())
    created = desc["dateCreated"]
    desc["name"] = "Our lab's replication"
    desc["author"] = [{"@type": "Person", "name": "A. Researcher"}]
    desc["variableMeasured"].append({"@type": "PropertyValue", "name": "extra_note",
                                     "description": "added by hand"})  # fmt: skip
    desc_path.write_text(json.dumps(desc))
    # a second site's log exported into the same folder
    db2 = tmp_path / "site2.sqlite"
    assert confocal(headless_run_args(stim, proto, db2, "S09"), capsys)[0] == 0
    assert confocal(["session", "export", db2, "--out", out], capsys)[0] == 0
    again = json.loads(desc_path.read_text())
    assert again["name"] == "Our lab's replication" and again["author"] == desc["author"]
    assert again["dateCreated"] == created
    assert "extra_note" in {v["name"] for v in again["variableMeasured"]}
    assert sorted(p.name for p in (out / "data").iterdir()) == [
        "study-site2_subject-S09_session-1_data.csv",
        "study-study_subject-S01_session-1_data.csv",
    ]
    with open(out / "participants.tsv", newline="") as f:
        assert [r["participant_id"] for r in csv.DictReader(f, delimiter="\t")] == ["S01", "S09"]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("age", "must be KEY=VALUE"),
        ("Age=3", "key must be lower-case"),
        ("participant_id=x", "not participant_id"),
        ("age=old", "age must be a number"),
        ("age=200", r"age must be in \[0, 130\]"),
        ("sex=F,sex=M", "given twice"),
        ("sex=", "non-empty value"),
        (",", "at least one"),
    ],
)
def test_bad_participant_metadata(study, capsys, text, match):
    with pytest.raises(ParticipantError, match=match):
        parse_participant(text)
    stim, proto, db = study
    code, _, err = confocal(
        headless_run_args(stim, proto, db, "S01", "--participant", text), capsys
    )
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert not db.exists(), "nothing written"


def test_names():
    meta = parse_participant("age=31.5, acuity_logmar=1.3")
    assert meta == {"age": 31.5, "acuity_logmar": "1.3"}
    assert keyword_value("S_01-b") == "S01b"
    assert FILE_REGEX.fullmatch(datafile_name("jung 2015", "S01", 3))
    with pytest.raises(ValueError, match="must contain a letter or digit"):
        keyword_value("__")


def test_export_refuses_a_file_as_folder(study, tmp_path, capsys):
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    target = tmp_path / "x.csv"
    target.write_text("keep")
    code, _, err = confocal(["session", "export", db, "--out", target], capsys)
    assert code == 2 and "not a folder" in err and target.read_text() == "keep"


def test_export_reads_the_logs_tables_not_a_view_in_the_file(tmp_path, capsys):
    """A log whose tidy_trials view was replaced (here: every trial 'named' by 'evil', and
    200,000 rows of it) is exported from its tables, as the untouched log is."""
    import shutil
    import sqlite3

    stim, proto, db = make_study(tmp_path, (1, 8), n_main=2, training=None)
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    swapped = _swap_view(tmp_path / "swapped.sqlite", db, shutil, sqlite3)
    texts = []
    for log, out in ((db, tmp_path / "a"), (swapped, tmp_path / "b")):
        code, _, err = confocal(["session", "export", log, "--out", out, "--study", "s"], capsys)
        assert code == 0, err
        (data,) = (out / "data").glob("*_data.csv")
        texts.append(data.read_text())
    assert texts[0] == texts[1] and "evil" not in texts[1]


def _swap_view(dst, src, shutil, sqlite3):
    shutil.copyfile(src, dst)
    con = sqlite3.connect(dst)
    con.execute("DROP VIEW tidy_trials")
    con.execute(
        "CREATE VIEW tidy_trials AS WITH RECURSIVE r(n) AS (SELECT 0 UNION ALL SELECT n + 1 "
        "FROM r LIMIT 200000) SELECT 'S01' AS subject, 1 AS session, n AS trial_index, "
        "'named' AS score, 'evil' AS rater, 1 AS recognized, 0 AS simulated, 'human' AS observer, "
        "0 AS viewings, 0 AS repeat_viewing FROM r"
    )
    con.commit()
    con.close()
    return dst
