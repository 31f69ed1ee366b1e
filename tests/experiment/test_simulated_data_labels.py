"""Simulated data is labelled everywhere.

The observer and its parameters are stored per session (migration 2, back-filled for older
logs); ``tidy_trials`` says ``simulated`` and ``observer``; ``confocal analyze`` refuses to pool
simulated with human sessions unless ``--include-simulated``; ``session status`` marks them.
"""

from __future__ import annotations

import json
import sqlite3

import pytest

from experiment.log import MIGRATIONS, TIDY_COLUMNS, ResumeMismatch, TrialLog, schema
from experiment.observers import make_observer
from experiment.presentation.displays import NullDisplay
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from tests.experiment.conftest import confocal, make_study, session_run_args


@pytest.fixture()
def study(tmp_path):
    return make_study(tmp_path, (1, 2, 8), training=None)


def human_session(stim, proto, db, subject="S01"):
    """A session opened as a person's (console); answers come from a scripted responder.

    The scripted answers are scored by an operator (rater ``operator``), as a person's are: a
    rater ``sim:...`` would mark the rows simulated wherever they go.
    """
    stimset = StimulusSet.load(stim)
    scripted = make_observer("logistic", stimset, subject, rng=0)
    scripted.rater = "operator"
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), stimset, subject, seed=3, responder="console")
        with s:
            s.run(NullDisplay(), scripted)


def headless(stim, proto, db, subject, *extra):
    return session_run_args(stim, proto, db, subject, "--headless", "--seed", "5", *extra)


def test_observer_and_params_stored_and_in_tidy_trials(study, capsys):
    stim, proto, db = study
    human_session(stim, proto, db)
    code, _, err = confocal(
        headless(stim, proto, db, "S02", "--observer-param", "lapse=0.03"), capsys
    )
    assert code == 0, err
    with TrialLog(db, readonly=True) as log:
        s1, s2 = log.sessions()
        assert s1["observer"] is None and s1["observer_params"] is None
        assert s2["observer"] == "logistic"
        params = json.loads(s2["observer_params"])
        assert params["lapse"] == 0.03 and len(params) > 1, "the effective parameters, all"
        rows = log.tidy_trials()
    assert tuple(rows[0]) == TIDY_COLUMNS
    assert {(r["subject"], r["simulated"], r["observer"]) for r in rows} == {
        ("S01", 0, "human"),
        ("S02", 1, "logistic"),
    }
    code, out, _ = confocal(["session", "status", db], capsys)
    lines = out.splitlines()
    assert "SIMULATED (logistic)" in lines[1] and "SIMULATED" not in lines[0]


def test_migration_back_fills_an_old_log(tmp_path, monkeypatch):
    db = tmp_path / "old.sqlite"
    monkeypatch.setattr(schema, "MIGRATIONS", MIGRATIONS[:1])
    with TrialLog(db) as log:
        common = dict(protocol_name="p", protocol_sha256="x", protocol_json="{}",
                      display_json="{}", stimset_path="s", stimset_manifest_sha256="y", seed="1",
                      primary_rater="operator")  # fmt: skip
        log.create_session(subject="S01", responder="console", **common)
        log.create_session(subject="S02", responder="sim:model", **common)
        assert log.schema_version() == 1
    monkeypatch.setattr(schema, "MIGRATIONS", MIGRATIONS)
    with TrialLog(db) as log:
        assert log.schema_version() == MIGRATIONS[-1][0] >= 2
        assert [s["observer"] for s in log.sessions()] == [None, "model"]
    con = sqlite3.connect(db)
    cols = [r[1] for r in con.execute("PRAGMA table_info(tidy_trials)")]
    con.close()
    assert tuple(cols) == TIDY_COLUMNS


def test_a_person_cannot_resume_a_simulated_session(study):
    stim, proto, db = study
    stimset = StimulusSet.load(stim)
    with TrialLog(db) as log:
        Session.open(log, load_protocol(proto), stimset, "S03", seed=1,
                     responder="sim:logistic").close()  # fmt: skip
        n_events = len(log.events())
        with pytest.raises(ResumeMismatch, match="by simulated observer 'logistic', not a"):
            Session.open(log, load_protocol(proto), stimset, "S03", responder="console")
        assert len(log.events()) == n_events, "nothing written"


def test_analyze_refuses_to_pool_simulated_with_human(study, tmp_path, capsys):
    stim, proto, db = study
    human_session(stim, proto, db)
    assert confocal(headless(stim, proto, db, "S02", "--observer", "model"), capsys)[0] == 0
    out_dir = tmp_path / "report"
    code, _, err = confocal(["analyze", db, "--out", out_dir], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "simulated session(s) study.sqlite session 2 (S02, model)" in lines[0]
    assert "human session(s) study.sqlite session 1 (S01)" in lines[0]
    assert "--include-simulated" in lines[0]
    assert not out_dir.exists(), "nothing written"

    from analysis.data import read_trials

    table = read_trials([db], include_simulated=True)
    assert table.simulated_sessions == ("study.sqlite session 2 (S02, model)",)
    assert set(table.trials["subject"]) == {"S01", "S02"}
