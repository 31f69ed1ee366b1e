"""The one reader of the git commit that stimulus sets, trial logs and calibrations record."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from stimuli.software import git_commit

ROOT = Path(__file__).resolve().parents[2]


def test_git_commit_is_the_checked_out_commit() -> None:
    """Compared with git's own answer for the work tree (skipped outside a checkout)."""
    r = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    if r.returncode != 0:
        pytest.skip("not a git checkout")
    assert git_commit() == r.stdout.strip()
    assert git_commit(ROOT) == r.stdout.strip()
    assert re.fullmatch(r"[0-9a-f]{40}", git_commit())


def test_git_commit_outside_a_work_tree_is_none(tmp_path: Path) -> None:
    """A folder in no work tree (an installed wheel) records no commit, and nothing raises."""
    inside = subprocess.run(["git", "-C", str(tmp_path), "rev-parse"], capture_output=True)
    if inside.returncode == 0:
        pytest.skip(f"{tmp_path} is inside a git work tree")
    assert git_commit(tmp_path) is None
    assert git_commit(tmp_path / "missing") is None


def test_session_and_set_records_use_the_one_reader(monkeypatch: pytest.MonkeyPatch) -> None:
    """The sessions row and stimulus_set.json take the commit from this reader, and no other
    module of the project runs git itself."""
    from experiment.session import lifecycle
    from stimuli.stimset import provenance

    monkeypatch.setattr(lifecycle, "git_commit", lambda: "f" * 40)
    assert lifecycle.software_provenance()["git_commit"] == "f" * 40
    assert provenance.git_commit is git_commit
    runs_git = [
        str(p.relative_to(ROOT))
        for folder in ("stimuli", "experiment", "analysis", "benchmarks")
        for p in (ROOT / folder).rglob("*.py")
        if "rev-parse" in p.read_text(encoding="utf-8") and p.name != "software.py"
    ]
    assert not runs_git, f"git read outside stimuli/software.py: {runs_git}"
