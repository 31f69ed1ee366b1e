"""What the subject's screen raises when it cannot open or draw."""

from __future__ import annotations

from experiment.errors import ConfocalError

__all__ = ["PresenterError"]


class PresenterError(ConfocalError):
    """The presenter cannot open or draw (no OpenGL context, wrong screen mode, closed window)."""
