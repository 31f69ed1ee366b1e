"""``plan_session``: a session start checked once and its schedule built once, for every caller.

A Python caller of ``Session.open`` and ``confocal session run`` meet the same checks; the library's
messages name the parameter (```subject```, ```new_session```), the command line its flag.
"""

from __future__ import annotations

import sys

import pytest

import experiment.session.schedule as schedule_module
from experiment.data.subjects import SubjectCodeError
from experiment.log import TrialLog, TrialLogError
from experiment.protocol import ProtocolError, load_protocol
from experiment.session.engine import Session
from experiment.session.plan import SessionPlan, plan_session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import run_cli
from tests.experiment.test_session_implant import write_protocol


@pytest.fixture(scope="module")
def stim_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("stim")
    return make_stimulus_set(root / "stim", n_main=2, n_training=1, levels=(3, 5, 8))


def _run(stim_dir, protocol, data, *more) -> list:
    return [
        "session", "run", "--protocol", protocol, "--stimuli", stim_dir, "--subject", "S01",
        "--data", data, "--headless", "--seed", "1", *more,
    ]  # fmt: skip


def test_a_session_run_builds_the_schedule_once(stim_dir, tmp_path, monkeypatch, capsys):
    """With an implant (whose fit is checked on the schedule), one schedule per start."""
    calls = []
    real = schedule_module.build_schedule

    def counting(*args, **kwargs):
        calls.append(args[0].name)
        return real(*args, **kwargs)

    for module in list(sys.modules.values()):  # wherever the function was imported by name
        if module is not None and getattr(module, "build_schedule", None) is real:
            monkeypatch.setattr(module, "build_schedule", counting)
    protocol = write_protocol(tmp_path / "p.toml")  # argus2: its fit is checked
    assert run_cli(_run(stim_dir, protocol, tmp_path / "s.sqlite")) == 0, capsys.readouterr()
    assert calls == ["implant"]
    with TrialLog(tmp_path / "s.sqlite", readonly=True) as log:
        assert len(log.read_schedule(1)) == 2 + 2 * 2 * 2


def test_the_plan_is_frozen_and_opens_its_schedule(stim_dir, tmp_path) -> None:
    protocol = load_protocol(write_protocol(tmp_path / "p.toml"))
    with TrialLog(tmp_path / "s.sqlite") as log:
        plan = plan_session(protocol, StimulusSet.load(stim_dir), "S01", log=log, seed=4)
        assert isinstance(plan, SessionPlan) and plan.resumes is None
        with pytest.raises(AttributeError):
            plan.seed = 5  # type: ignore[misc]
        session = Session.open_planned(log, plan)
        assert session.schedule is plan.schedule and session.seed == 4
        session.close()
        again = plan_session(protocol, StimulusSet.load(stim_dir), "S01", log=log)
    assert again.resumes == session.session_id and again.seed == 4
    assert [t.path for t in again.schedule] == [t.path for t in plan.schedule]


@pytest.mark.parametrize(
    "subject, new_session, error, python_says, cli_says",
    [
        ("Ann Smith", None, SubjectCodeError, "`subject` 'Ann Smith' holds a space", "--subject"),
        ("S01", " ", TrialLogError, "`new_session` needs the reason", "--new-session needs"),
    ],
)
def test_a_python_caller_gets_the_errors_of_the_command_line(
    stim_dir, tmp_path, capsys, subject, new_session, error, python_says, cli_says
) -> None:
    """The same check and message; the library names the parameter, the command its flag."""
    protocol = write_protocol(tmp_path / "p.toml", display="gamma = 1.0")
    with TrialLog(tmp_path / "py.sqlite") as log, pytest.raises(error) as caught:
        Session.open(
            log, load_protocol(protocol), StimulusSet.load(stim_dir), subject,
            seed=1, new_session=new_session,
        )  # fmt: skip
    assert python_says in str(caught.value) and "--" not in str(caught.value)
    argv = _run(stim_dir, protocol, tmp_path / "cli.sqlite")
    argv[argv.index("S01")] = subject
    if new_session is not None:
        argv += ["--new-session", new_session]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err
    assert cli_says in err and "`" not in err, err
    assert python_says.split("` ", 1)[1] in err  # the rest of the message is the library's


def test_an_implant_finer_than_a_level_is_refused_alike(stim_dir, tmp_path, capsys) -> None:
    protocol = write_protocol(tmp_path / "p.toml", levels="3, 8")  # level 3 is coarser
    with TrialLog(tmp_path / "py.sqlite") as log, pytest.raises(ProtocolError) as caught:
        Session.open(log, load_protocol(protocol), StimulusSet.load(stim_dir), "S01", seed=1)
    assert run_cli(_run(stim_dir, protocol, tmp_path / "cli.sqlite")) == 2
    err = capsys.readouterr().err
    assert str(caught.value) in err and not (tmp_path / "cli.sqlite").exists()
