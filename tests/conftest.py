"""Shared fixtures and helpers: the real-data folder (``CONFOCAL_DATA``), the repository root, a
small recognition protocol, the CLI run in-process, a small scored study and the inputs the
commands are fed in the command-table tests.

Import the helpers by name (``from tests.conftest import protocol_toml, run_cli``).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def _data_root() -> Path:
    return Path(os.environ.get("CONFOCAL_DATA", REPO_ROOT.parent / "shared" / "data")).resolve()


@pytest.fixture(scope="session")
def repo_root() -> Path:
    """The repository root."""
    return REPO_ROOT


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The real-data folder; tests that use it are skipped when it is absent."""
    root = _data_root()
    if not root.is_dir():
        pytest.skip(f"real data not found at {root} (set CONFOCAL_DATA to the shared data folder)")
    return root


def require_data(data_dir: Path, *parts: str) -> Path:
    """Return ``data_dir / parts``, skipping the test with a reason when it is missing."""
    p = data_dir.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"real data file {p} not found (set CONFOCAL_DATA)")
    return p


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


def run_cli(argv: list) -> int:
    """Run ``confocal ARGV`` in-process (arguments made strings); return its exit status."""
    from experiment import cli

    try:
        cli.main([str(a) for a in argv])
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def make_scored_study(root: Path) -> tuple[Path, Path, Path]:
    """Write a stimulus set, the main-block-only protocol ``tiny.toml`` and the log of one
    headless session (S01, seed 1) into ``root``, some trials scored 'named' so that an analysis
    can run; return ``(stimulus folder, protocol file, log)``."""
    from experiment.log import TrialLog
    from experiment.testing import make_stimulus_set

    stim = make_stimulus_set(root / "stim", n_main=3, n_training=1, levels=(1, 2))
    proto = root / "tiny.toml"
    proto.write_text(protocol_toml((1, 2), name="tiny", training=None))
    db = root / "study.sqlite"
    run = ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01"]
    assert run_cli([*run, "--data", db, "--headless", "--seed", "1"]) == 0
    with TrialLog(db) as log:
        for r in log.tidy_trials():
            if r["trial_index"] % 3 != 1 if r["level"] == 2 else r["trial_index"] % 3 == 0:
                log.add_score(r["session"], r["trial_index"], "named", True, r["rater"])
    return stim, proto, db


@dataclass(frozen=True)
class StudyInputs:
    """The inputs of every command, written by :func:`make_study_inputs` under ``root``."""

    root: Path
    stim: Path  # a stimulus set
    proto: Path  # its protocol
    db: Path  # the log of one scored session
    pairs: Path  # a PAIRS folder of synthetic photo pairs
    lf: Path  # a small light field (.npz)


def make_study_inputs(root: Path, *synth_options: str) -> StudyInputs:
    """Write a scored study (:func:`make_scored_study`), a PAIRS folder made by ``confocal stimuli
    synth SYNTH_OPTIONS`` and a 40x32 light field into ``root``; return their paths."""
    stim, proto, db = make_scored_study(root)
    pairs = root / "pairs"
    assert run_cli(["stimuli", "synth", *synth_options, "--out", pairs]) == 0
    lf = root / "lf.npz"
    assert run_cli(["lightfield", "synth", "--size", "40x32", "--out", lf]) == 0
    return StudyInputs(root, stim, proto, db, pairs, lf)
