"""The operators' console layout, shared by the recognition and the active-search consoles.

Trial panel and stimulus preview on top; timer, suggested score, status and the subject's words
at the bottom, the key footer last (:func:`console_layout`, styled by :data:`CONSOLE_CSS`). The
input line, the status and the key footer keep fixed rows at the bottom; the trial panel and the
preview share what is left, so nothing is clipped from 80x24 upward. :class:`TrialConsole` is the
Textual app both consoles build on.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from textual.app import App, ComposeResult
from textual.containers import Horizontal, Vertical
from textual.css.query import NoMatches
from textual.widgets import Footer, Input, Static

__all__ = [
    "PREVIEW_COLS",
    "CONSOLE_CSS",
    "console_layout",
    "preview_text",
    "progress_line",
    "TrialConsole",
]

#: Preview width in terminal cells (ours: fits an 80-column terminal beside the trial panel).
PREVIEW_COLS = 48


def preview_text(image: np.ndarray, cols: int = PREVIEW_COLS) -> str:
    """Return a text preview of a stimulus with half-block characters (two image rows per line).

    Nearest-neighbour sampling at ``cols`` characters wide, aspect kept; values >= 0.5 are lit.
    """
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 3:  # a colour training photo: its luminance (Rec. 709)
        img = img[..., :3] @ np.array([0.2125, 0.7154, 0.0721], np.float32)
    rows_px, cols_px = img.shape
    cols = max(1, min(cols, cols_px))
    # Terminal cells are about twice as tall as wide; two image rows per cell keeps the aspect.
    rows = max(2, int(round(cols * rows_px / cols_px)) // 2 * 2)
    r = ((2 * np.arange(rows) + 1) * rows_px) // (2 * rows)
    c = ((2 * np.arange(cols) + 1) * cols_px) // (2 * cols)
    lit = img[np.ix_(r, c)] >= 0.5
    glyph = {(True, True): "\u2588", (True, False): "\u2580", (False, True): "\u2584"}
    lines = []
    for top, bottom in zip(lit[0::2], lit[1::2], strict=True):
        lines.append(
            "".join(glyph.get((bool(a), bool(b)), " ") for a, b in zip(top, bottom, strict=True))
        )
    return "\n".join(lines)


#: Layout of an operator's console: trial panel and preview on top; timer, suggested score,
#: status and the response line at the bottom (:func:`console_layout`).
CONSOLE_CSS = """
#top { height: 1fr; overflow: hidden; }
#trial { width: 1fr; min-width: 30; padding: 0 1; }
#preview { width: auto; border: solid $accent; padding: 0 1; }
#bottom { height: auto; }
#timer { padding: 0 1; height: 1; }
#suggest { padding: 0 1; height: 1; color: $success; }
#status { padding: 0 1; height: 2; }
"""


def console_layout(*bottom_extra: Any) -> ComposeResult:
    """Yield an operator console's widgets (styled by :data:`CONSOLE_CSS`) for ``compose``.

    ``bottom_extra`` widgets go below the response line (the static study's note line).
    """
    with Horizontal(id="top"):
        yield Static(id="trial")
        yield Static(id="preview")
    with Vertical(id="bottom"):
        yield Static(id="timer")
        yield Static(id="suggest")
        yield Static(id="status")
        yield Input(placeholder="the subject's words", id="response")
        yield from bottom_extra
    footer = Footer()
    footer.compact = True  # a reactive since textual 0.63 (the keyword came later)
    yield footer


def progress_line(subject: Any, answered: int, total: int) -> str:
    """Return the trial panel's first line: the subject and how many trials are answered."""
    return f"subject [b]{subject}[/b]   answered {answered} of {total}"


class TrialConsole(App):
    """An operator's console on :func:`console_layout`: writes to its panels and lines.

    Subclasses add the keys (:func:`experiment.console.keys.score_bindings` first) and what a
    trial is.
    """

    CSS = CONSOLE_CSS

    ENABLE_COMMAND_PALETTE = False

    def compose(self) -> ComposeResult:
        """Lay out the console's panes (a Textual hook)."""
        yield from console_layout()

    def _status(self, text: str) -> None:
        self.query_one("#status", Static).update(text)

    def _show_panel(self, text: str) -> None:
        self.query_one("#trial", Static).update(text)

    def _show_preview(self, preview: Any) -> None:
        self.query_one("#preview", Static).update(preview)

    def _show_timer(self, text: str) -> None:
        # The clock ticks on a timer, which can fire once more while the app shuts down and its
        # panes are already gone: then there is nothing to update.
        try:
            timer = self.query_one("#timer", Static)
        except NoMatches:
            return
        timer.update(text)

    def _show_suggestion(self, score: str | None) -> None:
        self.query_one("#suggest", Static).update("" if score is None else f"suggested: {score}")

    def _clear_answer(self) -> None:
        """Empty the response line and the suggestion once an answer is scored."""
        self.query_one("#response", Input).value = ""
        self._show_suggestion(None)
