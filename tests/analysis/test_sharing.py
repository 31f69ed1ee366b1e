"""Provenance survives a spreadsheet: simulated rows stay apart, escaped cells read back."""

from __future__ import annotations

import pytest

from analysis.data import read_trials
from analysis.errors import DataError
from analysis.tables import escape_frame

from .conftest import lab_and_pilot_csv


@pytest.fixture()
def human_and_sim(tmp_path, small_trials):
    """Two files with no simulated/observer columns; only the rater says who answered."""
    human = {"rater": "console"}
    return lab_and_pilot_csv(small_trials, tmp_path, human, {"rater": "sim:logistic", "session": 4})


def test_rater_marks_simulated_rows_when_the_columns_were_dropped(human_and_sim):
    a, b = human_and_sim
    with pytest.raises(DataError, match=r"refusing to pool simulated session\(s\) pilot\.csv "
                       r"session 4 \(.*, logistic\) with human session\(s\) lab\.csv"):  # fmt: skip
        read_trials([a, b])
    table = read_trials([b])
    assert set(table.trials["simulated"]) == {1} and set(table.trials["observer"]) == {"logistic"}
    assert read_trials([a]).simulated_sessions == ()


def test_one_file_mixing_people_and_simulated_rows_is_refused(human_and_sim, tmp_path):
    import pandas as pd

    a, b = human_and_sim
    both = tmp_path / "both.csv"
    pd.concat([pd.read_csv(a), pd.read_csv(b)]).to_csv(both, index=False)
    with pytest.raises(DataError, match="refusing to pool simulated"):
        read_trials([both])


def test_observer_column_alone_marks_simulated(tmp_path, small_trials):
    t = small_trials.copy()
    t["observer"] = "human"
    t.loc[t.index[: len(t) // 2], "observer"] = "model"
    t.to_csv(tmp_path / "t.csv", index=False)
    with pytest.raises(DataError, match="refusing to pool simulated"):
        read_trials([tmp_path / "t.csv"])


def test_analysis_reads_an_escaped_trial_table(tmp_path, small_trials):
    hostile = '=HYPERLINK("http://x","cup")'
    t = small_trials.copy()
    t["response"] = hostile
    escape_frame(t).to_csv(tmp_path / "t.csv", index=False)
    assert "'" + hostile.replace('"', '""') in (tmp_path / "t.csv").read_text()
    assert set(read_trials([tmp_path / "t.csv"]).trials["response"]) == {hostile}
