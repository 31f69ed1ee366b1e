"""A second rater's console: scores logged responses, blind to every other rater's scores."""

from __future__ import annotations

import json
from typing import Any

from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.widgets import Footer, Static

from experiment.console.keys import score_bindings

__all__ = ["ScoringApp"]


class ScoringApp(App):
    """A second rater's walk through logged responses, blind to every other rater's scores.

    Shows each answered trial's object (the right answer), condition, level and the logged words;
    F1..F5 appends a score by ``rater`` to the log (never the first rater's score, never the
    suggestion). Ctrl+Z steps back to the previous trial: the score given next is appended and,
    being this rater's latest, replaces the undone one (scores are never deleted). A progress
    line shows how many are scored and left. Returns the number of trials scored.

    Parameters
    ----------
    log : experiment.log.TrialLog
    rater : str
    pending : list of dict
        Trials to score, from :func:`experiment.commands.score.pending_for_rater`.
    """

    BINDINGS = [
        *score_bindings(),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("f7", "replay", "replay voice", priority=True),
        Binding("ctrl+q", "done", "save & quit", priority=True),
        Binding("ctrl+c", "done", "save & quit", show=False, priority=True),
    ]

    #: Plays a recording and returns "" or why not (tests replace it).
    player: Any = None

    def action_replay(self) -> None:
        """Play the current trial's recorded answer, if there is one."""
        from experiment.audio.playback import play, recording_for

        if self.position >= len(self.pending):
            return
        t = self.pending[self.position]
        path = recording_for(self.trial_log, t["session_id"], t["trial_index"])
        why = "no recording of this answer" if path is None else (self.player or play)(path)
        self.query_one("#status", Static).update(why or f"playing {path.name}")

    def __init__(self, log: Any, rater: str, pending: list[dict[str, Any]]) -> None:
        super().__init__()
        self.trial_log = log
        self.rater = rater
        self.pending = list(pending)
        self.position = 0
        self._recognized: dict[int, Any] = {}
        self._undone: dict[int, str] = {}
        self._last_scores: dict[int, str] = {}

    def compose(self) -> ComposeResult:
        """Lay out the item, the status line and the key footer (a Textual hook)."""
        yield Static(id="item")
        yield Static(id="status")
        yield Footer()

    def on_mount(self) -> None:
        """Set the title and show the first item (a Textual hook)."""
        self.title = f"confocal score: rater {self.rater}"
        self._show()

    def progress_text(self) -> str:
        """Return the progress line: scored, left and a 20-cell bar."""
        n = len(self.pending)
        done = min(self.position, n)
        cells = round(20 * done / n) if n else 20
        return (
            f"scored {done} of {n}, {n - done} left  "
            + "\u2588" * cells
            + "\u2591" * (20 - cells)
            + f"  {100 * done / n if n else 100:.0f} %"
        )

    def _show(self) -> None:
        from rich.markup import escape

        progress = self.progress_text()
        if self.position >= len(self.pending):
            self.query_one("#item", Static).update(
                f"All {len(self.pending)} responses are scored.\n\n"
                "Ctrl+Z undoes the last score; Ctrl+Q quits (every score is saved)."
            )
            self.query_one("#status", Static).update(progress)
            return
        t = self.pending[self.position]
        redo = self.position in self._undone
        self.query_one("#item", Static).update(
            f"{self.position + 1} of {len(self.pending)}   session {t['session_id']} "
            f"(subject {escape(str(t['subject']))}), trial {t['trial_index'] + 1}\n"
            f"object: [b]{escape(str(t['object_name']))}[/b] ({escape(str(t['object']))}), "
            f"{t['condition']}, level {t['level']}\n\n"
            f"response: [b]{escape(repr(t['response']))}[/b]"
            + (
                f"\n\nundone: you gave {self._undone[self.position]}; score it again"
                if redo
                else ""
            )
        )
        self.query_one("#status", Static).update(
            f"{progress}\nF1 named  F2 use  F3 shape  F4 wrong  F5 pass  Ctrl+Z undo"
        )

    def _is_recognized(self, session_id: int, score: str) -> bool:
        if session_id not in self._recognized:
            from experiment.protocol import ProtocolSpec

            row = self.trial_log.execute(
                "SELECT protocol_json FROM sessions WHERE session_id = ?", (session_id,)
            )[0]
            self._recognized[session_id] = ProtocolSpec.from_dict(json.loads(row[0])).scoring
        return self._recognized[session_id].is_recognized(score)

    def action_score(self, score: str) -> None:
        """Append this rater's score for the current trial and move on."""
        if self.position >= len(self.pending):
            return
        t = self.pending[self.position]
        undone = self._undone.pop(self.position, None)
        self.trial_log.add_score(
            t["session_id"],
            t["trial_index"],
            score,
            self._is_recognized(t["session_id"], score),
            self.rater,
            note="blind re-score" + (f" (replaces this rater's undone {undone})" if undone else ""),
        )
        self._last_scores[self.position] = score
        self.position += 1
        self._show()

    def action_undo(self) -> None:
        """Step back to the previous trial; its next score replaces the undone one."""
        if self.position == 0:
            self.notify("nothing to undo")
            return
        self.position -= 1
        self._undone[self.position] = self._last_scores.get(self.position, "a score")
        self._show()

    def action_done(self) -> None:
        """Quit; every score given is already saved."""
        self.exit(self.position)
