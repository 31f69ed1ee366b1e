"""Readers: CSV, Parquet, SQLite trial logs, pooling, training exclusion, bad data."""

from __future__ import annotations

import sqlite3

import pandas as pd
import pytest

from analysis.data import object_order, read_trial_file, read_trials
from analysis.errors import DataError

GOOD = (
    "subject,object,condition,pixels,recognized\n"
    "s1,1,cluttered,96,0\n"
    "s1,1,decluttered,160884,1\n"
    "s1,2,cluttered,3290,1\n"
)


def _write(tmp_path, text, name="t.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_csv_is_read_and_normalised(tmp_path):
    p = _write(tmp_path, GOOD.replace("decluttered", "De-cluttered"))
    df, dropped = read_trial_file(p)
    assert dropped == 0
    assert list(df["condition"]) == ["cluttered", "decluttered", "cluttered"]
    assert df["pixels"].dtype == float and list(df["recognized"]) == [0, 1, 1]
    assert set(df["source"]) == {str(p)}


def test_pooling_and_training_exclusion(tmp_path):
    a = _write(tmp_path, GOOD, "a.csv")
    b = _write(
        tmp_path,
        "subject,object,condition,pixels,recognized,part,rt\n"
        "s2,1,photo,,0,training,1.5\n"
        "s2,1,cluttered,950,1,main,2.5\n",
        "b.csv",
    )
    t = read_trials([a, b])
    assert len(t.trials) == 4
    assert t.n_training_excluded == 1
    assert t.sources == (str(a), str(b))
    assert t.trials["rt_s"].dropna().tolist() == [2.5]


def test_training_only_file(tmp_path):
    p = _write(
        tmp_path,
        "subject,object,condition,pixels,recognized,part\ns1,1,photo,,1,training\n",
        "train.csv",
    )
    with pytest.raises(
        DataError, match=r"train\.csv: no main-part trials \(all 1 rows are training\)"
    ):
        read_trial_file(p)


def test_parquet(tmp_path):
    pytest.importorskip("pyarrow")
    df = pd.read_csv(_write(tmp_path, GOOD))
    p = tmp_path / "t.parquet"
    df.to_parquet(p)
    out, _ = read_trial_file(p)
    assert out["pixels"].tolist() == [96.0, 160884.0, 3290.0]


def _sqlite(path, with_view=True):
    con = sqlite3.connect(path)
    con.execute(
        "CREATE TABLE trials (subject TEXT, object TEXT, condition TEXT, pixels INTEGER, "
        "recognized INTEGER, part TEXT)"
    )
    con.executemany(
        "INSERT INTO trials VALUES (?,?,?,?,?,?)",
        [
            ("s1", "1", "cluttered", 96, 0, "main"),
            ("s1", "1", "decluttered", 950, 1, "main"),
            ("s1", "2", "cluttered", 96, 1, "training"),
        ],
    )
    if with_view:
        con.execute("CREATE VIEW tidy_trials AS SELECT * FROM trials")
    con.commit()
    con.close()


def test_trial_log_is_read_by_header_not_extension(tmp_path):
    from tests.analysis.trial_logs import write_trial_log

    rows = pd.DataFrame(
        {
            "subject": ["s1"] * 3,
            "object": ["1", "1", "2"],
            "condition": ["cluttered", "decluttered", "cluttered"],
            "pixels": [96, 950, 96],
            "recognized": [0, 1, 1],
            "part": ["main", "main", "training"],
        }
    )
    p = write_trial_log(tmp_path / "session.anything", rows)
    df, dropped = read_trial_file(p)
    assert len(df) == 2 and dropped == 1


@pytest.mark.parametrize("with_view", [True, False])
def test_sqlite_that_is_not_a_trial_log(tmp_path, with_view):
    """Another program's SQLite file is refused, whatever views it brings."""
    p = tmp_path / "other.db"
    _sqlite(p, with_view=with_view)
    with pytest.raises(DataError, match=r"other\.db: not a confocal trial log"):
        read_trial_file(p)


BAD = {
    "missing_column": (
        "subject,object,condition,recognized\ns1,1,cluttered,0\n",
        r"bad\.csv: missing required column\(s\) pixels",
    ),
    "empty_file": ("", r"bad\.csv: file is empty"),
    "header_only": ("subject,object,condition,pixels,recognized\n", r"bad\.csv: no trials"),
    "non_numeric_pixels": (
        GOOD.replace("3290", "lots"),
        r"bad\.csv: column 'pixels' must be numeric.*row 3 \(value 'lots'\)",
    ),
    "zero_pixels": (GOOD.replace("3290", "0"), r"bad\.csv: column 'pixels' must be > 0.*row 3"),
    "negative_pixels": (GOOD.replace("96", "-96"), r"column 'pixels' must be > 0.*row 1"),
    "nan_recognized": (
        GOOD.replace("3290,1", "3290,NaN"),
        r"bad\.csv: column 'recognized' has a missing value.*row 3",
    ),
    "empty_subject": (GOOD.replace("s1,2", ",2"), r"column 'subject' has a missing value.*row 3"),
    "recognized_not_binary": (
        GOOD.replace("3290,1", "3290,2"),
        r"column 'recognized' must be 0 or 1.*row 3",
    ),
    "unknown_condition": (
        GOOD.replace("s1,2,cluttered", "s1,2,blurred"),
        r"column 'condition' must be 'cluttered' or 'decluttered'.*'blurred'",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_data_is_one_clear_line(tmp_path, case):
    text, pattern = BAD[case]
    p = _write(tmp_path, text, "bad.csv")
    with pytest.raises(DataError, match=pattern) as exc:
        read_trials([p])
    assert "\n" not in str(exc.value)


def test_missing_file_and_no_files(tmp_path):
    with pytest.raises(DataError, match=r"nope\.csv: file not found"):
        read_trials([tmp_path / "nope.csv"])
    with pytest.raises(DataError, match="no trial files given"):
        read_trials([])


def test_object_order_is_natural():
    assert object_order(["10", "2", "1", "2"]) == ["1", "2", "10"]
    assert object_order(["b", "a", "3"]) == ["3", "a", "b"]
