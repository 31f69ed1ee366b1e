"""Shared helpers of the experiment tests: a small study on disk, a small answered log, the CLI.

Import the helpers by name (``from tests.experiment.conftest import make_study``); the fixtures
below are found by pytest.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from experiment.clock import FakeClock
from experiment.interfaces import Answer, FlipRecord
from experiment.log import TrialLog
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set


def protocol_toml(
    levels: tuple[int, ...],
    *,
    name: str = "small",
    conditions: tuple[str, ...] = ("cluttered", "decluttered"),
    training: tuple[int, str] | None = (8, "photo"),
    settings: str = "",
    main_settings: str = "",
) -> str:
    """Return a recognition protocol: a training block of one trial, then the main block.

    Parameters
    ----------
    levels : tuple of int
        The main block's resolution levels.
    training : (level, condition) or None
        The training block's one level and condition; None for no training block.
    settings, main_settings : str
        Extra TOML lines for ``[protocol]`` and for the main block.
    """
    lines = ["[protocol]", f'name = "{name}"', *settings.splitlines()]
    if training is not None:
        level, condition = training
        lines += ["", "[[blocks]]", 'part = "training"', 'objects = "training"']
        lines += [f"levels = [{level}]", f'conditions = ["{condition}"]']
    lines += ["", "[[blocks]]", 'part = "main"', 'objects = "main"', f"levels = {list(levels)}"]
    lines += [f"conditions = {json.dumps(list(conditions))}", *main_settings.splitlines()]
    return "\n".join(lines) + "\n"


def make_study(
    folder: Path,
    levels: tuple[int, ...],
    *,
    n_main: int = 3,
    n_training: int = 1,
    **protocol: object,
) -> tuple[Path, Path, Path]:
    """Write a stimulus set and a protocol (:func:`protocol_toml`) into ``folder``.

    The set has every level the protocol shows. Returns ``(stimulus folder, protocol file,
    trial log path)``; the log does not exist yet.
    """
    training = protocol.get("training", (8, "photo"))
    shown = sorted(set(levels) | ({training[0]} if training else set()))  # type: ignore[index]
    stim = make_stimulus_set(folder / "stim", n_main=n_main, n_training=n_training, levels=shown)
    proto = folder / f"{protocol.get('name', 'small')}.toml"
    proto.write_text(protocol_toml(levels, **protocol))  # type: ignore[arg-type]
    return stim, proto, folder / "study.sqlite"


def make_answered_log(
    folder: Path, levels: tuple[int, ...] = (1, 8), *, n_main: int = 2, n_training: int = 2
) -> Path:
    """Write a trial log with one person's session (S01), every trial answered 'named'.

    Answers are ``word INDEX`` from the ``operator``, 0.5 s each, on a fake clock. Returns the
    log's path.
    """
    stim, proto, db = make_study(folder, levels, n_main=n_main, n_training=n_training)
    clock = FakeClock(0.0)
    with TrialLog(db) as log:
        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S01", seed=1,
                         clock=clock)  # fmt: skip
        with s:
            while (trial := s.next_trial()) is not None:
                clock.advance(1.0)
                s.record(trial, Answer(f"word {trial.index}", "named", "operator", rt_s=0.5),
                         FlipRecord(onset_s=0.0, offset_s=1.0))  # fmt: skip
    return db


def confocal(args: list, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run ``confocal ARGS`` in-process; return (exit code, stdout, stderr)."""
    from experiment import cli

    with pytest.raises(SystemExit) as exc:
        cli.main([str(a) for a in args])
    out = capsys.readouterr()
    return exc.value.code, out.out, out.err


def session_run_args(stim: Path, proto: Path, db: Path, subject: str = "S01", *extra) -> list:
    """Return the arguments of ``confocal session run`` for a study made by :func:`make_study`."""
    return ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", subject,
            "--data", db, *extra]  # fmt: skip
