"""``confocal demo``: simulated observers labelled as such, the paper's numbers beside them, the
in-memory trial log saved whole, and a run end to end."""

from __future__ import annotations

import json
import shutil
import sqlite3
from pathlib import Path

import pytest

from experiment import cli
from experiment.demos.study import (
    PAPER_RESULTS,
    DemoResult,
    run_demo,
    simulated_section,
    summary_lines,
)
from experiment.errors import ConfocalError
from experiment.log import TrialLog
from experiment.observers import PAPER_OR_BACKGROUND, PAPER_OR_PER_LOG10_PX, PAPER_X50_CLUTTERED_PX


def test_paper_results_are_the_papers():
    # Jung et al. 2015, Sec. 3.2.2 (Results): Weibull 50 % thresholds 8,695 px cluttered and
    # 3,532 px de-cluttered; OR background 5.6; OR per log10 pixels 74.5.
    assert PAPER_RESULTS["x50_cluttered_px"] == 8695 == PAPER_X50_CLUTTERED_PX
    assert PAPER_RESULTS["x50_decluttered_px"] == 3532
    assert round(PAPER_RESULTS["threshold_ratio"], 2) == 2.46
    assert PAPER_RESULTS["or_background"] == 5.6 == PAPER_OR_BACKGROUND
    assert PAPER_RESULTS["or_per_log10_px"] == 74.5 == PAPER_OR_PER_LOG10_PX


def _fake_demo(tmp_path) -> DemoResult:
    """A DemoResult shaped like a real run's (values made up; only the wording is tested)."""
    results = {
        "n_trials": 1920,
        "n_recognized": 1000,
        "thresholds": {
            "cluttered": {
                "p50_pixels": 1234.0,
                "ci95": [1000.0, 1500.0],
                "mle_p50_pixels": 1230.0,
                "converged": True,
            },
            "decluttered": {
                "p50_pixels": 321.0,
                "ci95": [300.0, 350.0],
                "mle_p50_pixels": 320.0,
                "converged": True,
            },
        },
        "logistic": {
            "odds_ratios": {
                "background": {"or": 9.87, "ci95": [8.0, 12.0]},
                "log10_pixels": {"or": 43.21, "ci95": [30.0, 60.0]},
            }
        },
    }
    obs = {
        "observer": "exemplar",
        "model": "HOG exemplar matcher",
        "params": {"blur_deg": 0.1, "cell_deg": 0.6, "noise_sd": 0.02},
        "criterion": 0.02,
        "knowledge": {
            "root": "/k",
            "categories": ["cup", "mug"],
            "exemplars": [{}, {}],
            "synth": {"seed": 5},
        },
    }
    paths = {"report": tmp_path / "report", "data": tmp_path / "study.sqlite"}
    return DemoResult(tmp_path, paths, results, {}, [obs, {**obs, "criterion": 0.03}])


def test_console_and_report_say_simulated_and_print_the_paper_beside(tmp_path):
    demo = _fake_demo(tmp_path)
    lines = summary_lines(demo)
    assert lines[0].startswith("SIMULATED DATA")
    assert lines[1].startswith("simulated observer: exemplar") and "seed 5" in lines[1]
    assert "criterion set in each subject's training phase: 0.0200-0.0300" in lines[1]
    text = "\n".join(lines)
    assert "1,234 px" in text and "paper: 8,695 px" in text
    assert "321 px" in text and "paper: 3,532 px" in text
    assert "3.84-fold   paper: 2.46" in text  # 1234 / 321
    assert "9.87" in text and "paper: 5.6" in text and "43.21" in text and "paper: 74.5" in text
    section = simulated_section(demo)
    assert "## Simulated observers" in section
    assert "not from people" in section and "simulated observer: exemplar" in section
    assert "| 50% threshold, cluttered | 1,234 px | 8,695 px |" in section
    assert "| 50% threshold, de-cluttered | 321 px | 3,532 px |" in section
    assert "| threshold ratio (cluttered / de-cluttered) | 3.84 | 2.46 |" in section
    assert "| odds ratio per log10 px | 43.2 | 74.5 |" in section


def test_calibrated_observer_says_in_one_sentence_what_it_is_and_how_far_from_the_paper(
    tmp_path,
):
    demo = _fake_demo(tmp_path)
    p = {"blur_deg": 0.05, "noise_sd": 0.1, "criterion": 1.42, "lapse": 0.02}
    demo.observers = [{**demo.observers[0], "observer": "calibrated", "params": p}]
    line = summary_lines(demo)[1]
    assert line.startswith("simulated observer: calibrated") and "seed 5" in line
    assert "fitted to the paper's cluttered condition only" in line
    # 1,234 / 8,695 = 0.14x; 321 / 3,532 = 0.091x; ratio 1234 / 321 = 3.84
    assert "cluttered 1,234 px (0.14x the paper's)" in line
    assert "de-cluttered 321 px (0.091x the paper's)" in line
    assert "ratio 3.84 against 2.46" in line
    assert "\n" not in line and "WARNING" not in "\n".join(summary_lines(demo))
    assert line + "." in simulated_section(demo)
    # knowledge pooled from several renderings: the sentence names them all
    k = {**demo.observers[0]["knowledge"], "synth": {"seed": [6, 7, 8]}}
    demo.observers = [{**demo.observers[0], "knowledge": k}]
    assert "from 3 other renderings (seeds 6, 7, 8)" in summary_lines(demo)[1]
    assert "don't know" not in summary_lines(demo)[1]  # no open-set rate logged: none claimed
    # the open-set rate from the calibration, as logged by the observer
    demo.observers = [{**demo.observers[0], "calibration": {"unknown_kinds_passed": 0.91}}]
    assert summary_lines(demo)[1].endswith(
        'against 2.46 and says "don\'t know" to 91% of images of kinds it does not know'
    )
    assert "sampling" not in line  # not logged: not claimed
    demo.observers = [{**demo.observers[0], "params": {**p, "samples_per_deg": 30.0}}]
    assert "limits: retinal sampling 30/deg, blur 0.05 deg" in summary_lines(demo)[1]
    assert "already named" not in line  # no priming logged: none claimed
    demo.observers = [{**demo.observers[0], "params": {**p, "priming": 0.6}}]
    assert "criterion 1.42 (0.6 lower for kinds already named)" in summary_lines(demo)[1]


def test_logistic_observer_is_named_as_the_papers_model(tmp_path):
    demo = _fake_demo(tmp_path)
    demo.observers = [{"observer": "logistic", "params": {}}]
    assert "paper's own fitted logistic model" in summary_lines(demo)[1]


def test_save_copy_writes_the_whole_log(tmp_path):
    log = TrialLog(":memory:")
    log.add_event(None, "note", "first")
    log.add_event(None, "observer", json.dumps({"observer": "x"}))
    log.save_copy(tmp_path / "copy.sqlite")
    copy = TrialLog(tmp_path / "copy.sqlite", readonly=True)
    try:
        strip = [{k: e[k] for k in ("kind", "note")} for e in log.events()]
        assert [{k: e[k] for k in ("kind", "note")} for e in copy.events()] == strip
        assert copy.schema_version() == log.schema_version()
    finally:
        copy.close()
        log.close()
    assert [p.name for p in tmp_path.iterdir()] == ["copy.sqlite"]  # no temporary left


def test_knowledge_seed_must_differ_from_the_seed(tmp_path, capsys):
    with pytest.raises(ConfocalError, match=r"`knowledge_seed` must be .* other than `seed` \(3\)"):
        run_demo(tmp_path / "d", seed=3, knowledge_seed=3, show_progress=False)
    assert not (tmp_path / "d").exists()
    with pytest.raises(SystemExit) as exc:
        cli.main(["demo", "--out", str(tmp_path / "d"), "--seed", "1", "--knowledge-seed", "1"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--knowledge-seed" in err and len(err.strip().splitlines()) == 1


def test_no_pooled_knowledge_rendering_may_be_the_test_seed(tmp_path):
    """The calibrated observer knows renderings --knowledge-seed .. + 7: seed 3 is among 1-8."""
    with pytest.raises(ConfocalError, match=r"8 rendering\(s\) .* other than `seed` \(3\), got 1"):
        run_demo(tmp_path / "d", seed=3, knowledge_seed=1, show_progress=False)
    assert not (tmp_path / "d").exists()
    # the uncalibrated exemplar observer knows one rendering: seed 1 is not 3
    with pytest.raises(ConfocalError, match=r"1 rendering\(s\) .* other than `seed` \(2\), got 2"):
        run_demo(tmp_path / "e", seed=2, knowledge_seed=2, observer="exemplar", show_progress=False)


@pytest.fixture(scope="module")
def demo_two_subjects(tmp_path_factory) -> Path:
    """One ``confocal demo --subjects 2`` (seed 0), shared by the end-to-end checks below: a demo
    takes minutes on two cores. Written by the command into a fresh folder beside a user's
    file, which it leaves alone."""
    root = tmp_path_factory.mktemp("demo")
    (root / "notes.txt").write_text("mine")
    with pytest.raises(SystemExit) as exc:
        cli.main(["demo", "--out", str(root / "d"), "--subjects", "2"])
    assert exc.value.code in (0, None)
    assert sorted(p.name for p in root.iterdir()) == ["d", "notes.txt"]
    assert (root / "notes.txt").read_text() == "mine"
    return root / "d"


@pytest.mark.slow
def test_demo_logs_and_reports_its_simulated_observers(demo_two_subjects):
    """Two simulated subjects end to end: each session's observer is in the trial log, none of
    its exemplars is a stimulus, and report.md and demo.json say the data are simulated."""
    out = demo_two_subjects
    con = sqlite3.connect(f"file:{out / 'study.sqlite'}?mode=ro", uri=True)
    try:
        events = con.execute(
            "SELECT session_id, note FROM events WHERE kind = 'observer' ORDER BY session_id"
        ).fetchall()
        responders = {r[0] for r in con.execute("SELECT responder FROM sessions")}
        labels = set(con.execute("SELECT DISTINCT simulated, observer FROM tidy_trials"))
        params = [json.loads(r[0]) for r in con.execute("SELECT observer_params FROM sessions")]
        n = con.execute("SELECT COUNT(*) FROM tidy_trials WHERE part = 'main'").fetchone()[0]
    finally:
        con.close()
    assert n == 2 * 320 and responders == {"sim:calibrated"}
    assert labels == {(1, "calibrated")}  # the sessions table labels them simulated
    # the calibrated observer knows eight renderings of each kind (seeds 1-8), pooled
    folders = [str(out / "knowledge" / f"seed{k}" / "stimuli") for k in range(1, 9)]
    assert all(p["knowledge"] == folders for p in params)
    assert [sid for sid, _ in events] == [1, 2]
    manifest = (out / "stimuli" / "manifest.csv").read_text()
    for _, note in events:
        d = json.loads(note)
        assert d["observer"] == "calibrated" and d["simulated"] is True
        assert d["params"]["knowledge"] == folders
        assert d["knowledge"]["synth"]["seed"] == list(range(1, 9))
        assert len(d["knowledge"]["categories"]) == 23
        for e in d["knowledge"]["exemplars"]:
            assert e["file_sha256"] not in manifest
    report = (out / "report" / "report.md").read_text()
    assert "## Simulated observers" in report and "8,695 px" in report
    summary = json.loads((out / "demo.json").read_text())
    assert summary["simulated"] is True and summary["knowledge_seed"] == 1
    assert summary["knowledge_seeds"] == list(range(1, 9))
    assert summary["observers"][0]["observer"] == "calibrated"


@pytest.mark.slow
def test_demo_runs_twice_into_the_same_folder_and_keeps_a_users_file_beside_it(
    demo_two_subjects, tmp_path, monkeypatch, capsys
):
    """`confocal demo` into a folder it wrote before: refused without --force, replaced with it
    (only its own files), refused when a user's file is inside. The earlier run is the shared
    one, copied here (its manifest holds relative paths only, so the copy is the demo's own)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    shutil.copytree(demo_two_subjects, tmp_path / "d")
    argv = ["demo", "--out", str(tmp_path / "d"), "--subjects", "1"]
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code == 2 and "--force" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--force"])
    assert exc.value.code in (0, None), capsys.readouterr().err
    assert (tmp_path / "d" / "report" / "report.md").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "notes.txt"]
    con = sqlite3.connect(f"file:{tmp_path / 'd' / 'study.sqlite'}?mode=ro", uri=True)
    try:  # replaced, not added to: the second run's one subject only
        assert con.execute("SELECT COUNT(*) FROM sessions").fetchone()[0] == 1
    finally:
        con.close()
    (tmp_path / "d" / "mine.txt").write_text("mine")
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--force"])
    assert exc.value.code == 2 and "did not write: mine.txt" in capsys.readouterr().err
    assert (tmp_path / "d" / "mine.txt").read_text() == "mine"
