"""Hostile and mistaken analysis input is identified, bounded and refused with one line.

A trial log is identified (application id, confocal's schema_migrations) before it is read, and
read from its base tables -- never through a view the file brings, which may recurse without end
-- within bounds on bytes, rows, value length and SQLite steps. The same trial twice and a pixel
count no display can show are refused.
"""

from __future__ import annotations

import shutil
import sqlite3

import pandas as pd
import pytest

import analysis.data as data
import analysis.logreader as logreader
from analysis.data import read_trial_file, read_trials
from analysis.errors import DataError
from analysis.logreader import read_log_trials
from tests.conftest import make_scored_study, run_cli

#: A view that counts without end: reading it reads until memory runs out.
ENDLESS = (
    "CREATE VIEW tidy_trials AS WITH RECURSIVE r(n) AS (SELECT 1 UNION ALL SELECT n + 1 FROM r) "
    "SELECT 's' AS subject, 1 AS session, 'o' AS object, 'cluttered' AS condition, 1 AS level, "
    "40 AS window, n AS pixels, 1 AS recognized, 'x' AS response, 'named' AS score, "
    "'operator' AS rater, 1.0 AS rt_s, 'main' AS part, n AS trial_index FROM r"
)
#: The same view, stopped at 200,000 rows (a test that old code must finish, and fail).
LONG = ENDLESS + " LIMIT 200000"


@pytest.fixture(scope="module")
def real_log(tmp_path_factory):
    """A headless session's log, some trials re-scored (the latest primary score counts)."""
    return make_scored_study(tmp_path_factory.mktemp("study"))[2]


def _copy(src, dst):
    shutil.copyfile(src, dst)
    return dst


def _tidy_view(path):
    con = sqlite3.connect(path)
    try:
        return pd.read_sql_query("SELECT * FROM tidy_trials", con)
    finally:
        con.close()


def test_base_tables_give_what_the_logs_own_view_gives(real_log):
    """An independent check: the log's tidy_trials view (SQLite's join) against the join here."""
    mine = read_log_trials(real_log)
    view = _tidy_view(real_log)[list(mine.columns)]
    assert len(mine) == len(view) > 0
    pd.testing.assert_frame_equal(mine, view, check_dtype=False)


def test_an_endless_view_in_another_programs_file_is_never_run(tmp_path, capsys):
    p = tmp_path / "evil.sqlite"
    con = sqlite3.connect(p)
    con.execute(ENDLESS)
    con.commit()
    con.close()
    assert p.stat().st_size <= 8192
    with pytest.raises(DataError, match=r"evil\.sqlite: not a confocal trial log"):
        read_trial_file(p)
    assert run_cli(["analyze", p, "--out", tmp_path / "rep", "--no-figures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "evil.sqlite" in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "rep").exists()


@pytest.mark.parametrize("view", [LONG, ENDLESS], ids=["long", "endless"])
def test_a_trial_logs_own_view_is_not_read(real_log, tmp_path, view):
    """A log with confocal's id and tables whose tidy_trials view was replaced: the base tables
    are read, and give the real trials."""
    p = _copy(real_log, tmp_path / "swapped.sqlite")
    con = sqlite3.connect(p)
    con.execute("DROP VIEW tidy_trials")
    con.execute(view)
    con.commit()
    con.close()
    df, _ = read_trial_file(p)
    assert len(df) == len(read_log_trials(real_log)) < 1000


def test_a_base_table_that_is_a_view_is_refused(real_log, tmp_path):
    p = _copy(real_log, tmp_path / "viewed.sqlite")
    con = sqlite3.connect(p)
    con.execute("ALTER TABLE scores RENAME TO scores_real")
    con.execute("CREATE VIEW scores AS SELECT * FROM scores_real")
    con.commit()
    con.close()
    with pytest.raises(DataError, match=r"viewed\.sqlite: .*scores table is a view"):
        read_trial_file(p)


def test_another_programs_application_id_is_refused(tmp_path):
    p = tmp_path / "theirs.sqlite"
    con = sqlite3.connect(p)
    con.execute("PRAGMA application_id = 1234")
    con.execute("CREATE TABLE x (a)")
    con.commit()
    con.close()
    with pytest.raises(DataError, match=r"theirs\.sqlite: an SQLite file of another program"):
        read_trial_file(p)


def test_rows_bytes_values_and_steps_are_bounded(real_log, tmp_path, monkeypatch):
    n = len(read_log_trials(real_log))
    monkeypatch.setattr(logreader, "MAX_INPUT_ROWS", n - 1)
    with pytest.raises(DataError, match=rf"study\.sqlite: table \w+ has more than {n - 1} rows"):
        read_trial_file(real_log)
    monkeypatch.undo()
    monkeypatch.setattr(logreader, "MAX_INPUT_BYTES", 1000)
    with pytest.raises(DataError, match=r"study\.sqlite: .* GiB is larger than"):
        read_trial_file(real_log)
    monkeypatch.undo()
    monkeypatch.setattr(logreader, "MAX_STEPS", 1)
    monkeypatch.setattr(logreader, "_STEP", 1)
    with pytest.raises(DataError, match=r"study\.sqlite: reading it took more than 1 SQLite"):
        read_trial_file(real_log)
    monkeypatch.undo()
    p = _copy(real_log, tmp_path / "long_answer.sqlite")
    con = sqlite3.connect(p)
    con.execute(
        "INSERT INTO trials (session_id, trial_index, object, condition, level, pixels, "
        "stimulus_sha256, response, recorded_at) VALUES (1, 9999, 'o', 'cluttered', 1, 96, '0', "
        "?, 'x')",
        ("w" * (2 << 20),),
    )
    con.commit()
    con.close()
    with pytest.raises(DataError, match=r"long_answer\.sqlite: cannot read .*too big"):
        read_trial_file(p)


def test_csv_rows_and_bytes_are_bounded(tmp_path, monkeypatch):
    p = tmp_path / "t.csv"
    p.write_text("subject,object,condition,pixels,recognized\n" + "s1,1,cluttered,96,0\n" * 5)
    monkeypatch.setattr(data, "MAX_INPUT_ROWS", 4)
    with pytest.raises(DataError, match=r"t\.csv: more than 4 rows"):
        read_trial_file(p)
    monkeypatch.undo()
    monkeypatch.setattr(logreader, "MAX_INPUT_BYTES", 10)
    with pytest.raises(DataError, match=r"t\.csv: .* GiB is larger than"):
        read_trial_file(p)


def test_parquet_rows_are_bounded_from_its_footer(tmp_path, monkeypatch):
    pytest.importorskip("pyarrow")
    p = tmp_path / "t.parquet"
    pd.DataFrame(
        {"subject": ["s1"] * 5, "object": ["1"] * 5, "condition": ["cluttered"] * 5,
         "pixels": [96] * 5, "recognized": [0] * 5}
    ).to_parquet(p)  # fmt: skip
    assert len(read_trial_file(p)[0]) == 5
    monkeypatch.setattr(data, "MAX_INPUT_ROWS", 4)
    with pytest.raises(DataError, match=r"t\.parquet: more than 4 rows"):
        read_trial_file(p)


TRIALS = (
    "subject,session,trial_index,object,condition,pixels,recognized\n"
    "s1,1,0,1,cluttered,96,0\n"
    "s1,1,1,1,decluttered,950,1\n"
    "s1,1,2,2,cluttered,3290,1\n"
)


def test_a_repeated_trial_is_refused(tmp_path, capsys):
    p = tmp_path / "t.csv"
    p.write_text(TRIALS + "s1,1,1,1,decluttered,950,1\n")
    with pytest.raises(DataError, match=r"t\.csv: the same trial \(subject s1, session 1, "):
        read_trials([p])
    assert run_cli(["analyze", p, "--out", tmp_path / "rep", "--no-figures"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "t.csv" in err[0] and "trial_index 1" in err[0]


def test_a_file_given_twice_or_copied_is_refused(real_log, tmp_path):
    with pytest.raises(DataError, match=r"study\.sqlite: given twice"):
        read_trials([real_log, real_log])
    copy = _copy(real_log, tmp_path / "copy.sqlite")
    with pytest.raises(DataError, match=r"the same trial .* in .*study\.sqlite and .*copy\.sqlite"):
        read_trials([real_log, copy])


def test_sessions_and_trials_that_differ_are_pooled(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text(TRIALS)
    b.write_text(TRIALS.replace("s1,1,", "s1,2,"))
    assert len(read_trials([a, b]).trials) == 6


@pytest.mark.parametrize("value", ["1e308", "2e9"])
def test_pixels_no_display_can_show_are_refused(tmp_path, value):
    p = tmp_path / "t.csv"
    p.write_text(TRIALS.replace("3290", value))
    with pytest.raises(DataError, match=r"t\.csv: column 'pixels' must be at most 1e\+09.*row 3"):
        read_trial_file(p)


@pytest.mark.parametrize("value", ["inf", "nan", "0", "-96"])
def test_pixels_not_positive_or_not_finite_are_refused(tmp_path, value):
    p = tmp_path / "t.csv"
    p.write_text(TRIALS.replace("3290", value))
    with pytest.raises(DataError, match=r"t\.csv: column 'pixels' .*row 3"):
        read_trial_file(p)
