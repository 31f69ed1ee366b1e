"""The operator's console for an active-search session with a person searching.

The subject sits at the subject's screen (a presenter process with input on) and drives the
search with its keyboard and mouse; the operator, at this terminal, sees what the subject sees
(the implant's view as text), where they are (depth, plane, zoom), the target (for the
operator only) and the time, types the subject's words and scores them, as in the recognition
study (:mod:`experiment.console.recognition`), on the same layout
(:mod:`experiment.console.layout`). What happens in a trial is described in
:mod:`experiment.active.live`.

Keys
----
========  ====================================================================================
Enter     before a trial: show the implant's view and start the trial; during one: score with
          the suggested score
F1..F5    score named / use / shape / wrong / pass
Ctrl+Q    save and quit: every scored trial is committed; a trial on screen but not scored is
          restarted (a new attempt) when the session resumes
Ctrl+C    the same as Ctrl+Q (a terminal's stop key; the console takes it as a key)
========  ====================================================================================
"""

from __future__ import annotations

from typing import Any

from textual.binding import Binding
from textual.widgets import Input

from experiment.active.live import LiveSearch
from experiment.console.keys import score_bindings
from experiment.console.layout import TrialConsole, preview_text, progress_line

__all__ = ["ActiveConsole", "run_active_console"]

#: Width of the implant-view preview in terminal cells (ours: two per cell of the paper's
#: 35-column grid).
PREVIEW_COLS: int = 70

#: How often the console applies the subject's inputs and checks the time limit, seconds (ours:
#: 30 ms keeps a key's effect within two frames at 60 Hz on top of the render time).
POLL_S: float = 0.03


class ActiveConsole(TrialConsole):
    """The operator's Textual app for a person's active search.

    Parameters
    ----------
    live : LiveSearch
    """

    BINDINGS = [
        *score_bindings(),
        Binding("ctrl+q", "save_quit", "quit", priority=True),
        Binding("ctrl+c", "save_quit", "quit", show=False, priority=True),
    ]

    def __init__(self, live: LiveSearch) -> None:
        super().__init__()
        self.live = live
        self.finished = False
        self._shown_state: Any = None

    # -- start --------------------------------------------------------------------------------

    def on_mount(self) -> None:
        """Set the title and start polling the search when the app starts (a Textual hook)."""
        s = self.live.session
        self.title = f"confocal: active search, session {s.session_id}, subject {s.subject}"
        self.set_interval(POLL_S, self.poll)
        if self.live.cue() is None:
            self._finish()
        else:
            a, n = s.progress()
            self._status(f"{a} of {n} trials answered. The subject sees the cue; Enter starts.")
        self._panel()
        self.query_one("#response", Input).focus()

    # -- display ------------------------------------------------------------------------------

    def _panel(self) -> None:
        live, s = self.live, self.live.session
        a, n = s.progress()
        lines = [progress_line(s.subject, a, n)]
        t = live.trial
        if t is not None:
            lines += [
                f"trial {t.index + 1} of {n}   condition {t.condition}",
                f"target [b]{t.target}[/b] (operator only)",
            ]
        if live.running and s.state is not None:
            st = s.state
            depth_m = s.scene.depth_m(st.disparity_px)
            where = f"depth {st.disparity_px:.3g} px/view"
            if depth_m is not None:
                where += f" ({depth_m:.2f} m)"
            plane = "-" if st.plane is None else f"{st.plane + 1} of {len(s.planes_px)}"
            zoom = "none" if st.zoom is None else "x,y,w,h " + ",".join(map(str, st.zoom))
            lines += [where, f"plane {plane}   zoom {zoom}"]
            if live.answered:
                lines.append("[b]the subject pressed Enter[/b]: type the words, then score")
        self._show_panel("\n".join(lines))
        if live.running and s.view is not None:
            self._show_preview(preview_text(s.view.grid, PREVIEW_COLS))
        else:
            self._show_preview("")

    def poll(self) -> None:
        """Apply the subject's inputs, check the time limit, refresh the panel."""
        live = self.live
        try:
            rows = live.pump()
            rows += live.tick()
        except Exception as exc:  # noqa: BLE001 - the presenter may have died
            self._status(f"subject's screen: {' '.join(str(exc).split())}; Ctrl+Q saves and quits")
            return
        if any(r["kind"] == "score" for r in rows):
            self._after_score("time limit: scored pass (auto)")
            return
        el = live.elapsed_s()
        limit = live.session.task.time_limit_s
        self._show_timer("" if el is None else f"since onset {el:.1f} s of {limit:g} s")
        key = (live.running, live.answered, live.session.state)
        if rows or key != self._shown_state:
            self._shown_state = key
            self._panel()

    # -- operator input -----------------------------------------------------------------------

    def on_input_changed(self, event: Input.Changed) -> None:
        """Show the score suggested for the answer typed so far (a Textual hook)."""
        if self.live.running:
            self._show_suggestion(self.live.suggest(event.value))

    def on_input_submitted(self, event: Input.Submitted) -> None:
        """Take the typed answer on Enter, or leave once the session is over (a Textual hook)."""
        if self.finished:
            self.exit()
        elif not self.live.running:
            self.live.begin()
            self._status("Searching. Type the subject's words; F1-F5 scores, Enter the suggestion.")
            self._panel()
        else:
            self.action_score(self.live.suggest(event.value))

    def action_score(self, score: str) -> None:
        """Score the running trial (F1-F5, or Enter for the suggestion)."""
        if not self.live.running:
            self._status("No trial is running: Enter starts the next one.")
            return
        box = self.query_one("#response", Input)
        self.live.score(box.value, score)
        self._after_score(f"scored {score}")

    def _after_score(self, what: str) -> None:
        self._clear_answer()
        if self.live.cue() is None:
            self._finish()
        else:
            self._status(f"{what}. The subject sees the next cue; Enter starts it.")
        self._panel()

    def _finish(self) -> None:
        self.finished = True
        a, n = self.live.session.progress()
        self._status(f"Session finished: {a} of {n} trials answered. Enter or Ctrl+Q closes.")

    def action_save_quit(self) -> None:
        """Quit; committed trials are saved, an unscored trial restarts on resume."""
        self.exit()


def run_active_console(live: LiveSearch) -> tuple[int, int]:
    """Run the console until the operator quits; return ``(answered, total)`` trials."""
    ActiveConsole(live).run()
    return live.session.progress()
