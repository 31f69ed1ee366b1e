"""Simulated sessions are named in the report and results.json, and not pooled with human ones
unless asked for."""

from __future__ import annotations

import dataclasses
import json

import pytest

from analysis.data import read_trials
from analysis.errors import DataError
from analysis.pipeline import AnalysisResult
from analysis.report import render_markdown

from .conftest import lab_and_pilot_csv


@pytest.fixture()
def two_files(tmp_path, small_trials):
    """S1 labelled human (simulated = 0) and S2 labelled simulated, in two CSV files."""
    human = {"simulated": 0, "observer": "human"}
    sim = {"simulated": 1, "observer": "logistic", "session": 7}
    return lab_and_pilot_csv(small_trials, tmp_path, human, sim)


def test_mixed_files_refused_unless_asked(two_files):
    a, b = two_files
    with pytest.raises(DataError, match=r"refusing to pool simulated session\(s\) pilot\.csv "
                       r"session 7 \(.*, logistic\) with human session\(s\) lab\.csv"):  # fmt: skip
        read_trials([a, b])
    assert read_trials([b]).simulated_sessions[0].startswith("pilot.csv session 7 (")
    assert read_trials([a]).simulated_sessions == ()
    table = read_trials([a, b], include_simulated=True)
    assert len(table.simulated_sessions) == 1


def test_unlabelled_files_count_as_human(small_csv):
    assert read_trials([small_csv]).simulated_sessions == ()


def test_report_and_results_name_the_simulated_sessions(small_result):
    labels = ("pilot.sqlite session 2 (S02, logistic)",)
    r = dataclasses.replace(small_result, simulated_sessions=labels)
    assert r.results_json()["simulated_sessions"] == list(labels)
    md = render_markdown(r, figures=False)
    assert "**Simulated data**" in md and labels[0] in md
    assert "Simulated data" not in render_markdown(small_result, figures=False)
    back = AnalysisResult.from_dict(json.loads(json.dumps(r.to_dict())))
    assert back.simulated_sessions == labels


def test_cli_include_simulated_writes_the_label(two_files, tmp_path, capsys):
    from experiment import cli

    a, b = two_files
    out = tmp_path / "rep"
    with pytest.raises(SystemExit) as exc:
        cli.main(["analyze", str(a), str(b), "--out", str(out), "--include-simulated",
                  "--no-figures", "--by", "none", "--seed", "1"])  # fmt: skip
    assert exc.value.code in (0, None)
    assert "SIMULATED (no person answered): pilot.csv session 7" in capsys.readouterr().out
    results = json.loads((out / "results.json").read_text())
    assert results["simulated_sessions"][0].startswith("pilot.csv session 7")
