"""The session room: one lifecycle and one set of run options for recognition and active search.

``experiment/session/`` holds the recognition session; :mod:`experiment.session.lifecycle` opens,
resumes, locks and closes a subject's session for it and for active search alike, and
:mod:`experiment.commands.run_options` declares the options ``session run`` and ``active run``
share.
"""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from experiment import cli
from experiment.active.session import ActiveSession
from experiment.clock import FakeClock
from experiment.log import TrialLog
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import REPO_ROOT
from tests.experiment.test_active import small_protocol
from tests.experiment.test_session import PROTOCOL

#: The options both commands take, declared once in experiment.commands.run_options.
SHARED_OPTIONS = (
    "subject",
    "data",
    "new_session",
    "take_over_lock",
    "presenter",
    "screen",
    "fullscreen",
    "skip_timing_check",
)


def test_trial_log_imports_without_the_session_engine() -> None:
    """The trial log reads the schedule module; the package must not pull the engine (which
    imports the trial log) in with it, or importing the trial log first fails half-way."""
    code = (
        "import sys, experiment.log; "
        "assert 'experiment.session.engine' not in sys.modules, sorted(sys.modules)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("old", ["session", "session_cli", "schedule", "scoring", "stimset"])
def test_no_module_is_left_at_the_old_flat_path(old: str) -> None:
    assert not (REPO_ROOT / "experiment" / f"{old}.py").exists()
    assert (REPO_ROOT / "experiment" / "session" / "__init__.py").is_file()


def _kill_lock(log: TrialLog) -> None:
    """Leave the lock row a killed process leaves behind (its pid no longer runs)."""
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    with log.atomic() as con:
        con.execute("UPDATE locks SET pid = ?, token = 'gone'", (int(dead.stdout),))


def _crash_note(log: TrialLog, session_id: int) -> str:
    (note,) = [e["note"] for e in log.events(session_id) if e["kind"] == "crash"]
    return note


def test_both_kinds_of_session_log_a_crash_alike(tmp_path) -> None:
    """A resume after a crash names the dead run's pid, host and start, for both kinds."""
    proto = tmp_path / "tiny.toml"
    proto.write_text(PROTOCOL)
    stim_dir = make_stimulus_set(tmp_path / "stim", n_main=3, n_training=1, levels=(1, 2, 3, 8))
    stim = StimulusSet.load(stim_dir)
    with TrialLog(tmp_path / "recognition.sqlite") as log:
        Session.open(log, load_protocol(proto), stim, "S01", seed=1)
        _kill_lock(log)
        s = Session.open(log, load_protocol(proto), stim, "S01")
        recognition = _crash_note(log, s.session_id)
        s.close()
    with TrialLog(tmp_path / "active.sqlite") as log:
        ActiveSession.open(log, small_protocol(), "S01", seed=1, clock=FakeClock())
        _kill_lock(log)
        a = ActiveSession.open(log, small_protocol(), "S01", clock=FakeClock())
        active = _crash_note(log, a.session_id)
        a.close()
    pattern = r"^previous run \(pid \d+ on .+, since .+\) ended without closing; "
    assert recognition.endswith("0 of 19 trials were committed")
    assert active.endswith("0 active-search trials were committed")
    for note in (recognition, active):
        assert re.match(pattern, note), note


def _run_params(name: str) -> dict:
    run = cli.load_subcommand(name).commands["run"]
    return {p.name: p for p in run.params}


def test_session_run_and_active_run_declare_the_shared_options_alike() -> None:
    session, active = _run_params("session"), _run_params("active")
    for name in SHARED_OPTIONS:
        a, b = session[name], active[name]
        assert (a.opts, a.secondary_opts, a.help, a.envvar, a.metavar) == (
            b.opts,
            b.secondary_opts,
            b.help,
            b.envvar,
            b.metavar,
        ), name


@pytest.mark.parametrize(
    "argv",
    [
        ["session", "run", "-p", "jung2015", "-s", "nowhere", "--subject", "S01"],
        ["active", "run", "active_search", "--data", "x.sqlite", "--subject", "S01"],
    ],
)
def test_a_bad_presenter_is_refused_alike(argv, tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--presenter", "projector"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.strip() == (
        "confocal: error: --presenter must be one of process, offscreen, none; got 'projector'"
    )
    assert not (tmp_path / "x.sqlite").exists()
