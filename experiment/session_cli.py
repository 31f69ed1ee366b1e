"""Session commands (issue 5): command-line registration (filled in by that issue)."""

from __future__ import annotations

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root ``confocal`` app (none yet)."""
