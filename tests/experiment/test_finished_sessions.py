"""A finished session is not run again by accident; ``--new-session REASON`` starts another.

Running a completed subject's command again (the README's recovery after a crash, e.g. a kill
after the session was committed complete but before "complete" was printed) reports the session
and exits 0 without changing a byte of the log.
"""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path

import pytest

from experiment import cli
from experiment.log import TrialLog
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml

PROTOCOL = protocol_toml((1, 2), name="tiny", training=None)
N_TRIALS = 2 * 2 * 2

ACTIVE = """
[protocol]
name = "tiny_active"
pass_allowed_after_s = 0.0

[task]
type = "active_search"
scene = "synthetic:three_plane"
targets = ["tree"]
conditions = ["decluttered"]
grid_px = [12, 15]
scene_shape_px = [96, 120]
n_planes = 20
time_limit_s = 40.0
scene_grid = [3, 3]
"""


def confocal(args, capsys):
    with pytest.raises(SystemExit) as exc, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        cli.main([str(a) for a in args])
    out = capsys.readouterr()
    return exc.value.code, out.out, out.err


def files(folder: Path) -> dict[str, str]:
    """Every file beside the log, with its sha256 (a new -wal or -shm shows up too)."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir()}


@pytest.fixture()
def study(tmp_path):
    stim = make_stimulus_set(tmp_path / "stim", n_main=2, n_training=1, levels=(1, 2))
    proto = tmp_path / "tiny.toml"
    proto.write_text(PROTOCOL)
    (tmp_path / "data").mkdir()
    return stim, proto, tmp_path / "data" / "study.sqlite"


def run_args(stim, proto, db, subject="S01", *extra):
    return ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", subject,
            "--data", db, "--headless", "--seed", "3", *extra]  # fmt: skip


def test_completed_session_is_reported_not_run_again(study, capsys):
    stim, proto, db = study
    code, out, _ = confocal(run_args(stim, proto, db), capsys)
    assert code == 0 and "complete" in out
    before = files(db.parent)
    code, out, err = confocal(run_args(stim, proto, db), capsys)  # the same command again
    assert code == 0, err
    assert "session 1 is complete (ended 20" in out and f"{N_TRIALS}/{N_TRIALS} trials" in out
    assert "--new-session" in out
    assert files(db.parent) == before, "nothing written"
    with TrialLog(db, readonly=True) as log:
        assert len(log.sessions()) == 1


def test_new_session_needs_a_reason_and_logs_it(study, capsys):
    stim, proto, db = study
    assert confocal(run_args(stim, proto, db), capsys)[0] == 0
    before = files(db.parent)
    code, _, err = confocal(run_args(stim, proto, db, "S01", "--new-session", "  "), capsys)
    assert code == 2 and "--new-session needs the reason" in err
    assert files(db.parent) == before
    reason = "re-test after new glasses"
    code, out, _ = confocal(run_args(stim, proto, db, "S01", "--new-session", reason), capsys)
    assert code == 0 and "session 2 (S01)" in out
    with TrialLog(db, readonly=True) as log:
        assert [s["status"] for s in log.sessions()] == ["completed", "completed"]
        assert log.new_session_reason(2) == reason and log.new_session_reason(1) is None
    # the same command again reports session 2; it never starts a third
    before = files(db.parent)
    code, out, _ = confocal(run_args(stim, proto, db, "S01", "--new-session", reason), capsys)
    assert code == 0 and "session 2 is complete" in out and reason in out
    assert files(db.parent) == before


def test_new_session_while_one_is_unfinished_is_refused(study, capsys):
    stim, proto, db = study
    from experiment.protocol import load_protocol
    from experiment.session.engine import Session
    from experiment.session.stimset import StimulusSet

    with TrialLog(db) as log:
        Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=3).close()
    before = files(db.parent)
    code, _, err = confocal(run_args(stim, proto, db, "S01", "--new-session", "again"), capsys)
    assert code == 2 and "unfinished session 1 (0/8 trials answered)" in err
    assert files(db.parent) == before


def test_status_shows_complete_and_incomplete_subjects(study, capsys):
    stim, proto, db = study
    assert confocal(run_args(stim, proto, db, "S01"), capsys)[0] == 0
    from experiment.protocol import load_protocol
    from experiment.session.engine import Session
    from experiment.session.stimset import StimulusSet

    with TrialLog(db) as log:
        Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S02").close()
    code, out, _ = confocal(["session", "status", db], capsys)
    assert code == 0
    assert "subject S01      complete (session 1, ended 20" in out
    assert "subject S02      INCOMPLETE (session 2; run the same command to resume, 0/8" in out
    code, out, _ = confocal(["session", "status", db, "--json"], capsys)
    subjects = {s["subject"]: s for s in json.loads(out)["subjects"]}
    assert subjects["S01"]["complete"] and not subjects["S02"]["complete"]


def test_active_run_completed_is_reported_and_status_counts_it(tmp_path, capsys):
    proto = tmp_path / "active.toml"
    proto.write_text(ACTIVE)
    db = tmp_path / "data" / "active.sqlite"
    db.parent.mkdir()
    argv = ["active", "run", proto, "--data", db, "--subject", "A1", "--seed", "2"]
    code, out, err = confocal(argv, capsys)
    assert code == 0, err
    before = files(db.parent)
    code, out, _ = confocal(argv, capsys)
    assert code == 0 and "session 1 is complete" in out and "1/1 trials answered" in out
    assert files(db.parent) == before, "nothing written"
    code, out, _ = confocal(["session", "status", db], capsys)
    assert "1/1" in out and "subject A1       complete" in out
    code, out, _ = confocal([*argv, "--new-session", "second scene order"], capsys)
    assert code == 0
    with TrialLog(db, readonly=True) as log:
        assert len(log.sessions()) == 2 and log.new_session_reason(2) == "second scene order"
