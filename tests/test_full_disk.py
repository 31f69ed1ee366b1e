"""A full disk at the n-th file written: every writing command leaves the old state or nothing.

No tmpfs can be mounted in CI, so the disk fills up in the process: ``open`` (and ``io.open``,
which ``pathlib`` uses) raises ``OSError(ENOSPC)`` on the n-th file opened for writing. Each
command then must end with one line naming its output, exit status 2, and leave the output as
it was before (a folder tree with the same files and contents) or absent if it was absent:
no ``scan.json`` without its images, no ``data/`` folder without its files, no ``.tmp-`` folder.
"""

from __future__ import annotations

import builtins
import errno
import hashlib
import io
import threading
from pathlib import Path

import pytest

from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml, run_cli

PROTOCOL = protocol_toml((1, 2), name="tiny", training=None)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("inputs")
    stim = make_stimulus_set(root / "stim", n_main=2, n_training=1, levels=(1, 2))
    (root / "p.toml").write_text(PROTOCOL)
    db = root / "study.sqlite"
    run = ["session", "run", "--protocol", root / "p.toml", "--stimuli", stim, "--subject", "S1"]
    assert run_cli([*run, "--data", db, "--headless", "--seed", "1"]) == 0
    assert run_cli(["lightfield", "synth", "--size", "40x32", "--out", root / "lf.npz"]) == 0
    pairs = root / "pairs"
    synth = ["stimuli", "synth", "--objects", "2", "--training", "1", "--size", "120x80"]
    assert run_cli([*synth, "--out", pairs]) == 0
    return {"db": db, "lf": root / "lf.npz", "pairs": pairs}


class _FullDisk:
    """``open`` raises ENOSPC on the ``n``-th file opened for writing (any thread)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.count = 0
        self.lock = threading.Lock()
        self.real = builtins.open

    def __call__(self, file, mode="r", *args, **kwargs):
        if any(c in mode for c in "wax+"):
            with self.lock:
                self.count += 1
                hit = self.count == self.n
            if hit:
                raise OSError(errno.ENOSPC, "No space left on device", str(file))
        return self.real(file, mode, *args, **kwargs)


def _tree(top: Path) -> dict[str, str]:
    return {
        str(p.relative_to(top)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "/"
        for p in sorted(top.rglob("*"))
    }


def _commands(inputs, out: Path) -> dict[str, list]:
    return {
        "lightfield scan": ["lightfield", "scan", inputs["lf"], "--out", out],
        "session export": ["session", "export", inputs["db"], "--out", out],
        "stimuli build": ["stimuli", "build", inputs["pairs"], "--out", out, "--force"],
        "analyze run": ["analyze", inputs["db"], "--out", out, "--no-figures", "--seed", "1"],
    }


COMMANDS = ["lightfield scan", "session export", "stimuli build", "analyze run"]

#: Options of the earlier run, so that its output differs from the one the full disk stops.
EARLIER = {
    "lightfield scan": ["--planes", "50"],
    "session export": ["--study", "earlier"],
    "stimuli build": ["--working-size", "98x65"],
    "analyze run": ["--pc", "0.6"],
}


@pytest.mark.parametrize("nth", [1, 2, 4])
@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("before", ["absent", "earlier output"])
def test_full_disk_leaves_the_previous_output_or_nothing(
    command, nth, before, inputs, tmp_path, monkeypatch, capsys
):
    work = tmp_path / "work"
    work.mkdir()
    out = work / "sub" / "out" if before == "absent" else work / "out"
    if before == "earlier output":
        assert run_cli([*_commands(inputs, out)[command], *EARLIER[command]]) == 0
    snapshot = _tree(work)
    full = _FullDisk(nth)
    monkeypatch.setattr(builtins, "open", full)
    monkeypatch.setattr(io, "open", full)
    capsys.readouterr()
    code = run_cli(_commands(inputs, out)[command])
    monkeypatch.undo()
    err = capsys.readouterr().err
    if full.count < nth:  # the command writes fewer files than that: nothing to check
        pytest.skip(f"{command} opened {full.count} file(s) for writing")
    assert code == 2, err
    lines = [
        ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("note:", "warning:"))
    ]  # the analysis's warnings on these few trials come before the write that fails
    assert len(lines) == 1 and lines[0].startswith("confocal: error:"), err
    assert "disk is full" in lines[0] and str(out) in lines[0], lines[0]
    assert "Traceback" not in err
    after = _tree(work)
    if before == "absent" and command in ("stimuli build", "analyze run"):
        # the empty parent folder these two leave is the folder-replacement code's to remove
        after = {k: v for k, v in after.items() if k not in ("sub",)}
        snapshot = {k: v for k, v in snapshot.items() if k not in ("sub",)}
    assert after == snapshot, "the output changed or a partial or temporary file was left"
