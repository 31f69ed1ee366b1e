"""Shared fixtures: the real-data folder (``CONFOCAL_DATA``) and the repository root."""

from __future__ import annotations

import os
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
