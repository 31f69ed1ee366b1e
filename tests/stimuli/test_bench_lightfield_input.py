"""The light-field benchmark refuses a capture folder it cannot read in one line, exit status 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_missing_capture_is_one_line_and_exit_2(tmp_path) -> None:
    """``--capture`` naming no light field: one line naming the option and the folder."""
    missing = tmp_path / "no_such_capture"
    run = subprocess.run(
        [
            sys.executable,
            str(REPO / "benchmarks" / "bench_lightfield.py"),
            "--capture",
            str(missing),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert lines[0].startswith("--capture:") and str(missing) in lines[0]
    assert "Traceback" not in run.stderr
