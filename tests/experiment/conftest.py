"""Shared helpers of the experiment tests: a small study on disk, a small answered log, the CLI,
a small session for the operator console.

Import the helpers by name (``from tests.experiment.conftest import make_study``); the fixtures
below are found by pytest.
"""

from __future__ import annotations

import csv
import hashlib
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from experiment.clock import FakeClock
from experiment.interfaces import Answer, FlipRecord
from experiment.log import TrialLog
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import MANIFEST_COLUMNS, StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml


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


def confocal_process(*args: object, timeout: float = 300, **run: object):
    """Run ``confocal ARGS`` in a new Python process; return its ``CompletedProcess`` (text).

    Extra keywords (``env``) go to :func:`subprocess.run`.
    """
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    return subprocess.run(
        [sys.executable, "-c", code, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        **run,  # type: ignore[arg-type]
    )


def viewer_model(**fields: object):
    """Return a small ``ViewerModel``: a 100x150 view, disparities -5..15 px in 0.2 px steps."""
    from experiment.viewer.state import ViewerModel

    return ViewerModel(
        shape_px=(100, 150),
        disparity_range_px=(-5.0, 15.0),
        step_px=0.2,
        **fields,  # type: ignore[arg-type]
    )


def session_run_args(stim: Path, proto: Path, db: Path, subject: str = "S01", *extra) -> list:
    """Return the arguments of ``confocal session run`` for a study made by :func:`make_study`."""
    return ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", subject,
            "--data", db, *extra]  # fmt: skip


def headless_run_args(stim: Path, proto: Path, db: Path, subject: str, *extra) -> list:
    """Like :func:`session_run_args`, for a headless run (a simulated observer) with seed 2."""
    return session_run_args(stim, proto, db, subject, "--headless", "--seed", "2", *extra)


def run_and_export(study: tuple[Path, Path, Path], out: Path, capsys) -> None:
    """Run S01's headless session of ``study`` (:func:`make_study`'s paths), then export the
    log to the psych-DS folder ``out``; both must succeed."""
    stim, proto, db = study
    assert confocal(headless_run_args(stim, proto, db, "S01"), capsys)[0] == 0
    assert confocal(["session", "export", db, "--out", out], capsys)[0] == 0


#: The operator-console tests' protocol: one level, two conditions, the paper's display.
CONSOLE_PROTOCOL = """
[protocol]
name = "mini"
pass_allowed_after_s = 60.0
[display]
screen_width_px = 1280
screen_height_px = 1024
screen_width_cm = 37.98
viewing_distance_cm = 80.0
image_width_cm = 14.6
image_height_cm = 9.7
border_rgb = [0, 0, 255]
border_width_px = 6
background_rgb = [0, 0, 0]
[[blocks]]
part = "main"
objects = "main"
levels = [1]
conditions = ["cluttered", "decluttered"]
"""


def make_console_stimset(
    root: Path, shape_px: tuple[int, int] = (8, 12), window_px: int = 40
) -> Path:
    """Write two objects x two conditions x level 1 (random binary PNGs of ``shape_px`` rows x
    cols, compressed at ``window_px``), with manifest and objects; return ``root``."""
    root.mkdir(parents=True)
    objs = [("o1", "cup", "mug", "drinking", "main"), ("o2", "stapler", "", "stapling", "main")]
    with open(root / "objects.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["object", "name", "synonyms", "uses", "role"])
        w.writerows(objs)
    rng = np.random.default_rng(0)
    rows_px, cols_px = shape_px
    rows = []
    for o, *_ in objs:
        for cond in ("cluttered", "decluttered"):
            p = root / f"{o}_{cond}_1.png"
            Image.fromarray((rng.random(shape_px) < 0.3).astype(np.uint8) * 255).save(p)
            sha = hashlib.sha256(p.read_bytes()).hexdigest()
            rows.append([o, "main", cond, 1, window_px, cols_px, rows_px, rows_px * cols_px,
                         p.name, sha])  # fmt: skip
    with open(root / "manifest.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(MANIFEST_COLUMNS)
        w.writerows(rows)
    return root


@contextmanager
def console_session(
    folder: Path, *, shape_px: tuple[int, int] = (8, 12), window_px: int = 40
) -> Iterator[tuple[Session, FakeClock, TrialLog]]:
    """Open S01's session (seed 7, a fake clock at 1000 s) of :data:`CONSOLE_PROTOCOL` on
    :func:`make_console_stimset` in ``folder``; yield ``(session, clock, log)``, then close them."""
    stimset = StimulusSet.load(make_console_stimset(folder / "set", shape_px, window_px))
    (folder / "mini.toml").write_text(CONSOLE_PROTOCOL)
    clock = FakeClock(1000.0)
    log = TrialLog(folder / "study.sqlite")
    session = Session.open(
        log, load_protocol(folder / "mini.toml"), stimset, "S01", seed=7, clock=clock
    )
    try:
        yield session, clock, log
    finally:
        session.close()
        log.close()
