"""Active-search metrics (analysis/active.py) against a hand computation on a constructed log."""

from __future__ import annotations

import json
import sqlite3

import pandas as pd
import pytest

from analysis.active import (
    ActiveSearchResult,
    active_trials,
    add_active_results,
    analyze_active,
    has_active_events,
    only_active,
    read_active_events,
    summarize_active,
    write_active_report,
)
from analysis.errors import DataError

from .conftest import active_session


def _state(depth, zoom=None, plane=None):
    return {
        "depth_px": depth,
        "depth_m": None,
        "plane": plane,
        "zoom": zoom,
        "grid_px": [2, 2],
        "on_cells": 1,
        "implant": "80",
    }


def _score(score, recognized, t, *, rater="operator", primary=True):
    """A ``score`` event row for ``add``: the rater's verdict at ``t`` seconds."""
    payload = {"score": score, "recognized": recognized, "rater": rater, "primary": primary}
    return ("score", payload, t)


def _answered_at_once(start, t0, rt_s, *, key, action, response, score, recognized):
    """``add`` rows of a trial answered from its first view (depth 10) ``rt_s`` after ``t0``."""
    t = t0 + rt_s
    return [
        ("trial_start", start, t0),
        ("state", _state(10.0), t0),
        ("key", {"key": key, "action": action}, t),
        ("answer", {"response": response, "rt_s": rt_s, "state": _state(10.0)}, t),
        _score(score, recognized, t),
    ]


@pytest.fixture()
def db(tmp_path):
    """A hand-made log: 1 session, 3 trials; trial 1 crashed once and was resumed."""
    from experiment.active.eventlog import ActiveEventLog
    from experiment.log import TrialLog

    path = tmp_path / "hand.sqlite"
    log = TrialLog(path)
    ev = ActiveEventLog(log, active_session(log, "S07"))
    ev.append(
        "plan",
        {"trials": [], "objects_px": {"tree": 3.0, "pedestrian": 12.0}, "depth_step_px": 0.5},
        0.0,
    )

    def add(trial, attempt, rows):
        for kind, payload, t in rows:
            ev.append(kind, payload, t, trial=trial, attempt=attempt)

    start = {
        "target": "tree",
        "condition": "decluttered",
        "cue": "find the tree",
        "searcher": "sim:planes",
    }
    # trial 0, decluttered, tree: 10 -> 8 (zoom 3..5 s) -> 3.2; named at 6.5 s after onset 1.0
    add(
        0,
        0,
        [
            ("trial_start", start, 1.0),
            ("state", _state(10.0), 1.0),
            ("key", {"key": "PageDown", "action": "plane_next"}, 2.0),
            ("state", _state(8.0, plane=0), 2.0),
            ("key", {"key": "drag", "action": "zoom", "box": [0, 0, 4, 4]}, 4.0),
            ("state", _state(8.0, [0, 0, 4, 4], 0), 4.0),
            ("key", {"key": "Escape", "action": "unzoom"}, 6.0),
            ("state", _state(8.0, plane=0), 6.0),
            ("key", {"key": "Down", "action": "depth_far"}, 6.5),
            ("state", _state(3.2), 6.5),
            ("key", {"key": "Enter", "action": "answer"}, 7.5),
            ("answer", {"response": "tree", "rt_s": 6.5, "state": _state(3.2)}, 7.5),
            _score("named", True, 7.5),
        ],
    )
    # trial 1, decluttered, pedestrian: attempt 0 cut by a crash, attempt 1 passes after 4 s
    ped = {**start, "target": "pedestrian", "cue": "find the pedestrian"}
    add(
        1,
        0,
        [
            ("trial_start", ped, 8.0),
            ("state", _state(10.0), 8.0),
            ("key", {"key": "Down", "action": "depth_far"}, 9.0),
            ("state", _state(9.5), 9.0),
        ],
    )
    add(1, 0, [("attempt_abandoned", {"reason": "session resumed"}, 20.0)])
    passed = {"key": "Escape", "action": "pass", "response": "", "score": "pass"}
    add(1, 1, _answered_at_once(ped, 20.0, 4.0, **passed, recognized=False))
    # trial 2, cluttered, tree: named after 3 s, then re-scored by operator as 'use' and by
    # a second rater (not primary) as 'wrong'
    clut = {**start, "condition": "cluttered"}
    named = {"key": "Enter", "action": "answer", "response": "a tree", "score": "named"}
    add(2, 0, _answered_at_once(clut, 30.0, 3.0, **named, recognized=True))
    add(2, 0, [_score("use", True, 40.0), _score("wrong", False, 41.0, rater="B", primary=False)])
    log.close()
    return path


def test_per_trial_metrics_match_hand_computation(db) -> None:
    t = active_trials(read_active_events([db])).set_index("trial")
    assert list(t.index) == [0, 1, 2]
    r0 = t.loc[0]
    assert r0["rt_s"] == pytest.approx(6.5)  # 7.5 - 1.0
    assert r0["time_to_recognition_s"] == pytest.approx(6.5)
    assert r0["planes_visited"] == 3  # 10, 8, 3.2 (8 shown three times counts once)
    assert r0["detected_planes_visited"] == 1
    assert r0["depth_keys"] == 2 and r0["zooms"] == 1 and bool(r0["zoomed"])
    assert r0["zoom_time_s"] == pytest.approx(2.0)  # zoomed from 4.0 to 6.0
    assert bool(r0["at_target_plane"])  # |3.2 - 3.0| <= 0.5
    r1 = t.loc[1]
    assert r1["attempt"] == 1  # the crashed attempt is left out
    assert r1["rt_s"] == pytest.approx(4.0) and not r1["recognized"]
    assert r1["planes_visited"] == 1 and r1["depth_keys"] == 0  # attempt 0's key not counted
    assert r1["at_target_plane"] is not None and not r1["at_target_plane"]  # |10 - 12| > 0.5
    r2 = t.loc[2]
    assert r2["score"] == "use"  # latest primary score; rater B's is not primary
    assert r2["condition"] == "cluttered" and r2["rt_s"] == pytest.approx(3.0)


def test_condition_summary_matches_hand_computation(db) -> None:
    result, _ = analyze_active([db])
    d = result.conditions["decluttered"]
    assert (d.n_trials, d.n_recognized, d.recognition_rate) == (2, 1, 0.5)
    assert d.median_rt_recognised_only_s == pytest.approx(6.5)
    assert d.planes_visited_mean == pytest.approx((3 + 1) / 2)
    assert d.depth_keys_mean == pytest.approx(1.0)
    assert d.zoom_use_rate == pytest.approx(0.5) and d.zooms_mean == pytest.approx(0.5)
    assert d.zoom_time_mean_s == pytest.approx(1.0)
    assert d.at_target_plane_rate == pytest.approx(1.0)  # of recognised trials
    c = result.conditions["cluttered"]
    assert (c.n_trials, c.n_recognized) == (1, 1)
    assert c.mean_rt_recognised_only_s == pytest.approx(3.0)
    assert result.simulated is True and result.n_trials == 3
    assert ActiveSearchResult.from_dict(json.loads(json.dumps(result.to_dict()))) == result


def test_report_hook_and_active_only_report(db, tmp_path) -> None:
    assert has_active_events(db) and only_active([db])
    out = tmp_path / "rep"
    write_active_report([db], out)
    data = json.loads((out / "results.json").read_text())
    assert data["active_search"]["conditions"]["decluttered"]["n_recognized"] == 1
    assert "## Active search (SIMULATED searcher)" in (out / "report.md").read_text()
    assert (out / "active_trials.csv").read_text().count("\n") == 4
    # into an existing report: the key is added, the section appended, other keys kept
    other = tmp_path / "static"
    other.mkdir()
    (other / "results.json").write_text('{"n_trials": 7}')
    (other / "report.md").write_text("# Report\n\nstatic part\n")
    add_active_results([db], other)
    assert json.loads((other / "results.json").read_text())["n_trials"] == 7
    assert (other / "report.md").read_text().startswith("# Report\n\nstatic part\n\n## Active")


def test_active_only_report_folder_follows_the_umask(db, tmp_path) -> None:
    """The report folder gets the user's umask, as the study report's does, not a fixed 0755."""
    import os
    import stat

    old = os.umask(0o002)
    try:
        write_active_report([db], tmp_path / "rep")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "rep").stat().st_mode) == 0o775


def test_files_without_active_events(tmp_path) -> None:
    plain = tmp_path / "plain.sqlite"
    sqlite3.connect(plain).execute("CREATE TABLE x (a)").connection.commit()
    assert not has_active_events(plain) and not only_active([plain])
    assert analyze_active([plain]) is None
    csv = tmp_path / "t.csv"
    csv.write_text("a,b\n")
    assert not has_active_events(csv)
    with pytest.raises(DataError, match=r"plain.sqlite: not an active-search trial log"):
        read_active_events([plain])
    with pytest.raises(DataError, match=r"missing.sqlite: file not found"):
        read_active_events([tmp_path / "missing.sqlite"])
    with pytest.raises(DataError, match=r"no trial files given"):
        read_active_events([])
    with pytest.raises(DataError, match=r"no active-search events"):
        write_active_report([plain], tmp_path / "r")
    empty = active_trials(pd.DataFrame(columns=["source", "session", "trial", "kind"]))
    assert summarize_active(empty).n_trials == 0


def test_inconsistent_logs_are_refused(tmp_path) -> None:
    from experiment.active.eventlog import ActiveEventLog
    from experiment.log import TrialLog

    path = tmp_path / "bad.sqlite"
    log = TrialLog(path)
    ev = ActiveEventLog(log, active_session(log, "S01"))
    ev.append("answer", {"response": "x", "rt_s": 1.0, "state": _state(1.0)}, 1.0, trial=0)
    log.close()
    with pytest.raises(DataError, match=r"trial 0: answer without trial_start"):
        analyze_active([path])
    path2 = tmp_path / "bad2.sqlite"
    log = TrialLog(path2)
    ev = ActiveEventLog(log, active_session(log, "S01"))
    ev.append("trial_start", {"target": "tree", "condition": "cluttered"}, 0.0, trial=0)
    ev.append("answer", {"response": "x", "rt_s": 1.0, "state": _state(1.0)}, 1.0, trial=0)
    log.close()
    with pytest.raises(DataError, match=r"trial 0: answer without score"):
        analyze_active([path2])
    (tmp_path / "file").write_text("x")
    with pytest.raises(DataError, match=r"--out .*file exists and is not a folder"):
        write_active_report([path2], tmp_path / "file")


def test_confocal_analyze_on_an_active_only_log(db, tmp_path, capsys) -> None:
    """``confocal analyze LOG --out DIR`` reports the active-search metrics per condition."""
    from experiment import cli

    out = tmp_path / "rep"
    with pytest.raises(SystemExit) as exc:
        cli.main(["analyze", str(db), "--out", str(out)])
    assert exc.value.code in (0, None)
    text = capsys.readouterr().out
    assert "active search: 3 trials (SIMULATED searcher)" in text
    assert (
        "decluttered: 1/2 recognised, time to recognition (Kaplan-Meier, censored) median 6.5 s"
        in text
    )
    assert json.loads((out / "results.json").read_text())["active_search"]["n_trials"] == 3
