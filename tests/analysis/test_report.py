"""Pipeline result, report text, figures (matplotlib only in analysis.figures), round trips."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from analysis.pipeline import AnalysisOptions, AnalysisResult, analyze, first_recognized
from analysis.report import FIGURE_NAMES, render_markdown, write_report


def test_result_roundtrip(small_result):
    d = json.loads(json.dumps(small_result.to_dict()))
    back = AnalysisResult.from_dict(d)
    assert back.results_json() == small_result.results_json()
    assert back.thresholds["cluttered"] == small_result.thresholds["cluttered"]


def test_results_json_is_strict_json(small_result):
    text = json.dumps(small_result.results_json(), allow_nan=False)
    r = json.loads(text)
    assert r["thresholds"]["decluttered"]["p50_pixels"] < r["thresholds"]["cluttered"]["p50_pixels"]


def test_pc_other_than_half(small_csv):
    from analysis.data import read_trials

    steps = list(
        analyze(read_trials([small_csv]), AnalysisOptions(pc=0.75, by_subject=False, seed=1))
    )
    r = steps[-1].result.results_json()
    done = [s.done for s in steps]
    assert done == sorted(done) and steps[-1].done == steps[-1].total == 3
    t = r["thresholds"]["cluttered"]
    assert t["pc"] == 0.75 and t["threshold"] > t["p50_pixels"]
    assert r["subject_thresholds"] == {}


def test_options_checked():
    with pytest.raises(ValueError, match=r"pc must be in \(0, 1\), got 1.2"):
        AnalysisOptions(pc=1.2)
    with pytest.raises(ValueError, match="pc must be above the guess rate 0.5, got 0.5"):
        AnalysisOptions(pc=0.5, guess=0.5)
    with pytest.raises(ValueError, match=r"lapse_prior must be two numbers > 0, got \(1.0, 0.0\)"):
        AnalysisOptions(lapse_prior=(1.0, 0.0))


def test_first_recognized():
    import pandas as pd

    t = pd.DataFrame(
        {
            "subject": ["a"] * 4,
            "object": ["1"] * 4,
            "condition": ["cluttered", "cluttered", "decluttered", "decluttered"],
            "pixels": [96.0, 950.0, 96.0, 950.0],
            "recognized": [0, 1, 0, 0],
        }
    )
    assert first_recognized(t) == {"a": {"1": {"cluttered": 950.0, "decluttered": None}}}


def test_markdown_mentions_training_exclusion(small_result):
    import dataclasses

    r = dataclasses.replace(small_result, n_training_excluded=12)
    text = render_markdown(r)
    assert "12 training trials" in text
    assert "| 1 |" in text  # first-recognised table row for object 1


def test_write_report_and_figures(tmp_path, small_result):
    out = write_report(small_result, tmp_path / "rep")
    for name in FIGURE_NAMES:
        for ext in ("png", "pdf"):
            assert (out / f"{name}.{ext}").stat().st_size > 1000
        assert not (out / f"{name}.svg").exists()  # SVG only when asked for
    assert json.loads((out / "results.json").read_text()) == small_result.results_json()


def test_matplotlib_only_in_figures():
    code = (
        "import sys, analysis.pipeline, analysis.report, analysis.cli, analysis.power\n"
        "print('matplotlib' in sys.modules)\n"
        "import analysis.figures\n"
        "print('matplotlib.pyplot' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_constants_agree_with_stimuli():
    from analysis import jung2015 as a
    from stimuli import jung2015 as s

    assert a.PIXEL_COUNTS == s.PIXEL_COUNTS
