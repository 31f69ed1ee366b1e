"""The operator's console for the recognition study: a Textual app that runs it trial by trial.

The operator sees the subject, part, block, trial k of n, the object (the right answer, for the
operator only), level and condition, a preview of the stimulus, the time since onset and when a
pass is allowed; types the subject's words; and scores them with a key. The subject's screen is a
:class:`~experiment.interfaces.Display`: by default the presenter process
(:class:`experiment.presentation.process.RemoteDisplay`), in tests a headless twin.

Keys
----
======== =====================================================================================
Enter    during a trial: score with the suggested score; after scoring: start the next trial
F1..F5   score named / use / shape / wrong / pass (a pass only after ``pass_allowed_after_s``)
Ctrl+Z   undo the last score (until the next trial starts)
F6       write a note into the log
F8       pause / resume (a pause asked for during a trial starts once it is scored)
F9       restart the presenter after it died
Ctrl+Q   save and quit: every answered trial is already committed; the session resumes later at
         the next unanswered trial (a trial on screen but not scored is shown again)
Ctrl+C   the same as Ctrl+Q (a terminal's stop key; the console takes it as a key)
======== =====================================================================================

Undo, and why nothing logged is ever lost
-----------------------------------------
A score is committed the moment it is given (one transaction with the typed response and the flip
times), before anything else happens, so a crash never loses an answer. The stimulus is removed at
that moment too. Until the operator starts the next trial, Ctrl+Z re-opens scoring of that trial
with its response in the input line: the new score is *appended* as a re-score by the same rater
(``Session.rescore``; the primary, latest score is what ``tidy_trials`` reports), and the earlier
row stays in the log. If the operator also edits the words, the corrected text goes into the
re-score's note and a ``response_corrected`` event; the original ``trials.response`` row is never
changed (the log is append-only).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding
from textual.widgets import Input

from experiment.clock import Clock, PerfCounterClock
from experiment.console.keys import score_bindings
from experiment.console.layout import (
    CONSOLE_CSS,
    PREVIEW_COLS,
    TrialConsole,
    console_layout,
    preview_text,
    progress_line,
)
from experiment.interfaces import Answer, Display, FlipRecord, combine_flips

__all__ = ["OperatorConsole", "ConsoleResult"]


@dataclass
class ConsoleResult:
    """What happened in one console run.

    Parameters
    ----------
    answered : int
        Trials answered in the session so far (all runs).
    total : int
        Trials planned.
    finished : bool
        Whether the session is complete.
    recorded : list of int
        Trial indices recorded in this run.
    """

    answered: int = 0
    total: int = 0
    finished: bool = False
    recorded: list[int] = field(default_factory=list)


class OperatorConsole(TrialConsole):
    """The operator's Textual app; drives ``session`` and the subject's ``display``.

    Parameters
    ----------
    session : experiment.session.engine.Session
    display : Display
        The subject's screen (``RemoteDisplay``, ``Presenter`` or a headless twin).
    clock : Clock or None
        Clock for response times and the onset timer; the session's clock by default. It must
        share its time base with the display's flips (``perf_counter`` does across processes).
    rater : str
        Rater name stored with the operator's scores.
    recorder : experiment.audio.TrialAudio or None
        Records each trial's spoken answer; None: no recording.
    audio_note : str
        Shown once at start (e.g. why there is no recording).
    """

    # The shared layout (experiment.console.layout) with the preview re-drawn to fit what the
    # trial panel leaves (see _fit_preview); the note line is hidden until F6 opens it.
    CSS = CONSOLE_CSS + "#note { display: none; }\n"

    # Short labels so that the whole footer fits in 80 columns; F9 is named in the status line
    # when the presenter stops, the only time it is needed.
    BINDINGS = [
        *score_bindings(),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("f6", "note", "note", priority=True),
        Binding("f8", "pause", "pause", priority=True),
        Binding("f9", "restart_presenter", "restart presenter", show=False, priority=True),
        Binding("ctrl+q", "save_quit", "quit", priority=True),
        Binding("ctrl+c", "save_quit", "quit", show=False, priority=True),
    ]

    def __init__(
        self,
        session: Any,
        display: Display,
        *,
        clock: Clock | None = None,
        rater: str = "operator",
        recorder: Any = None,
        audio_note: str = "",
    ) -> None:
        super().__init__()
        self.recorder = recorder
        self.audio_note = audio_note
        self.session = session
        self.subject_display = display
        self.clock = clock or getattr(session, "clock", None) or PerfCounterClock()
        self.rater = rater
        self.result = ConsoleResult()
        self.state = "ready"  # ready | trial | scored | rescoring | paused | down | finished
        self.trial: Any = None
        self.onset: FlipRecord | None = None
        self.first_key_s: float | None = None
        self.last: dict[str, Any] | None = None
        self.pause_requested = False
        self._paused_from = "ready"
        self._down_from = "ready"
        self._shown_part: str | None = None
        self._breaks_shown: set[int] = set()
        self._preview_image: np.ndarray | None = None

    # -- layout -----------------------------------------------------------------------------------

    def compose(self) -> ComposeResult:
        """Lay out the console's panes and the note field (a Textual hook)."""
        yield from console_layout(
            Input(placeholder="note for the log (Enter saves, Esc cancels)", id="note")
        )

    def on_resize(self) -> None:
        """Fit the stimulus preview to the new size (a Textual hook)."""
        self.call_after_refresh(self._fit_preview)

    def _fit_preview(self) -> None:
        """Draw the preview as large as the space beside the trial panel allows."""
        if self._preview_image is None:
            return
        top = self.query_one("#top").size
        trial_min = 30
        # preview border (2) and padding (2) around the text
        max_cols = max(4, min(2 * PREVIEW_COLS, top.width - trial_min - 4))
        max_lines = max(1, top.height - 2)
        rows_px, cols_px = self._preview_image.shape[:2]
        cols = max_cols
        while cols > 4 and (cols * rows_px / cols_px) / 2 > max_lines:
            cols -= 1
        self._show_preview(Text(preview_text(self._preview_image, cols)))

    def on_mount(self) -> None:
        """Set the title, start the clock tick and show the first trial (a Textual hook)."""
        self.title = f"confocal: session {self.session.session_id}, subject {self.session.subject}"
        self.set_interval(0.25, self._tick)
        self._update_trial_panel()
        a, n = self.session.progress()
        self._safe(self.subject_display.show_text, self._instructions.wait)
        if self.session.next_trial() is None:
            self._finish()
        else:
            note = f"{self.audio_note}\n" if self.audio_note else ""
            self._status(
                f"{note}{a} of {n} trials answered. Press Enter to show the next stimulus."
            )
        self.query_one("#response", Input).focus()

    # -- helpers ----------------------------------------------------------------------------------

    @property
    def _instructions(self) -> Any:
        """The protocol's instruction screens (``[instructions]``)."""
        from experiment.protocol import InstructionsSpec

        return getattr(self.session.protocol, "instructions", None) or InstructionsSpec()

    def _update_trial_panel(self) -> None:
        a, n = self.session.progress()
        t = self.trial if self.trial is not None else self.session.next_trial()
        lines = [progress_line(self.session.subject, a, n)]
        if t is not None:
            lines += [
                f"part {t.part}   block {t.block}   trial {t.index + 1} of {n}",
                f"object [b]{t.object_name}[/b] ({t.object})",
                f"level {t.level} (window {t.window} px, {t.pixels} px)   condition {t.condition}",
            ]
        lines.append(f"state: {self.state}")
        self._show_panel("\n".join(lines))

    def _set_state(self, state: str) -> None:
        self.state = state
        self._update_trial_panel()

    def _tick(self) -> None:
        if self.state == "trial" and self.onset is not None:
            el = self.clock.now_s() - self.onset.onset_s
            wait = self.trial.pass_allowed_after_s - el
            tail = f"pass allowed in {wait:.0f} s" if wait > 0 else "pass allowed"
            self._show_timer(f"since onset {el:.1f} s   {tail}")
        else:
            self._show_timer("")
        alive = getattr(self.subject_display, "alive", True)
        if not alive and self.state not in ("down", "finished"):
            self._presenter_down("the presenter process is not running")

    def _safe(self, fn: Any, *args: Any) -> Any:
        """Call a display method; on a dead presenter switch to the 'down' state and return None."""
        from experiment.presentation.process import PresenterDied

        try:
            return fn(*args)
        except PresenterDied as exc:
            self._presenter_down(str(exc))
            return None

    def _audio(self, what: str, *args: Any) -> Any:
        """Drive the recorder; a failing recorder is switched off, the session goes on."""
        if self.recorder is None:
            return None
        try:
            return getattr(self.recorder, what)(*args)
        except Exception as exc:  # a sound-card or disk error must not stop the session
            why = " ".join(str(exc).split()) or type(exc).__name__
            self.session.log_event("audio_failed", why)
            self.recorder = None
            self.notify(f"Recording stopped: {why}", severity="error")
            return None

    def _presenter_down(self, why: str) -> None:
        if self.state == "down":
            return
        self._down_from = self.state
        self.session.log_event("presenter_died", why)
        self._set_state("down")
        self._status(f"[b red]PRESENTER STOPPED[/]: {why}. Press F9 to restart it.")

    # -- trials -----------------------------------------------------------------------------------

    def _start_next_trial(self) -> None:
        trial = self.session.next_trial()
        if trial is None:
            self._finish()
            return
        announce = None
        if trial.part != self._shown_part:
            self._shown_part = trial.part
            announce = self._instructions.for_part(trial.part)
        elif trial.break_before and trial.index not in self._breaks_shown:
            self._breaks_shown.add(trial.index)
            self.session.log_event("break", f"before trial {trial.index}")
            announce = self._instructions.rest
        if announce is not None:
            self._safe(self.subject_display.show_text, announce)
            title = announce.strip().splitlines()[0]
            self._status(f"'{title}' is on the subject's screen. Press Enter to continue.")
            return
        self.trial = trial
        image = self.session.image_for(trial)
        self._preview_image = np.asarray(image)
        self._fit_preview()
        onset = self._safe(self.subject_display.show_stimulus, image)
        if onset is None:
            return
        self.onset = onset
        self.session.mark_shown(trial, onset)  # durable before any answer
        self._audio("start", trial, onset.onset_s)
        self.first_key_s = None
        response = self.query_one("#response", Input)
        response.value = ""
        response.focus()
        self._set_state("trial")
        self._show_suggestion(None)
        self._status("Type the subject's words; F1-F5 scores, Enter takes the suggestion.")

    def on_input_changed(self, event: Input.Changed) -> None:
        """Time the first key of an answer and show its suggested score (a Textual hook)."""
        if event.input.id != "response" or self.state not in ("trial", "rescoring"):
            return
        if self.state == "trial" and self.first_key_s is None and event.value:
            self.first_key_s = self.clock.now_s()
        self._show_suggestion(self.session.suggest_score(self.trial, event.value.strip()))

    def on_input_submitted(self, event: Input.Submitted) -> None:
        """Save a note, or take the typed answer, on Enter (a Textual hook)."""
        if event.input.id == "note":
            self._save_note(event.value)
            return
        if self.state in ("trial", "rescoring"):
            self.action_score(self.session.suggest_score(self.trial, event.value.strip()))
        elif self.state in ("ready", "scored"):
            if event.value.strip():
                why = (
                    "the trial is already scored"
                    if self.state == "scored"
                    else "no stimulus is on the subject's screen yet"
                )
                self._status(f"Clear the input line ({why}), then Enter.")
                return
            self._start_next_trial()

    def action_score(self, score: str) -> None:
        """Score the current trial (or re-score it after an undo)."""
        if self.state == "rescoring":
            self._rescore(score)
            return
        in_trial = self.state == "trial" or (self.state == "down" and self._down_from == "trial")
        if not in_trial or self.trial is None:
            return
        trial = self.trial
        now = self.clock.now_s()
        elapsed = now - self.onset.onset_s
        if score == "pass" and elapsed < trial.pass_allowed_after_s:
            self._status(
                f"A pass is allowed {trial.pass_allowed_after_s:g} s after onset "
                f"({trial.pass_allowed_after_s - elapsed:.0f} s left)."
            )
            return
        response = self.query_one("#response", Input).value.strip()
        offset = self._safe(self.subject_display.clear)
        if offset is None:
            self.session.log_event(
                "offset_unknown", f"trial {trial.index}: the presenter died before the offset"
            )
        flip = combine_flips(self.onset, offset)
        rt = (self.first_key_s if self.first_key_s is not None else now) - self.onset.onset_s
        self.session.record(trial, Answer(response, score, self.rater, rt_s=rt), flip)
        audio = self._audio("finish", trial)
        self.result.recorded.append(trial.index)
        self.last = {
            "index": trial.index,
            "response": response,
            "score": score,
            "part": trial.part,
            "trial": trial,
        }
        self._clear_answer()
        self.trial = None
        if self.state == "down":  # the presenter died during clear(); the answer is saved
            self._down_from = "scored"
            return
        self._set_state("scored")
        voice = ""
        if audio is not None:
            voice = (
                " No voice found in the recording."
                if audio.voice_rt_s is None
                else f" Voice onset {audio.voice_rt_s:.2f} s."
            )
        self._status(
            f"Recorded trial {trial.index + 1}: {response!r} -> {score}.{voice} "
            "Ctrl+Z changes it; Enter starts the next trial."
        )
        if self.pause_requested:
            self.pause_requested = False
            self.action_pause()

    def action_undo(self) -> None:
        """Re-open scoring of the last trial (only before the next trial starts)."""
        if self.state != "scored" or self.last is None:
            self._status("Nothing to undo: undo works until the next trial starts.")
            return
        self.trial = self.last["trial"]
        self._set_state("rescoring")
        response = self.query_one("#response", Input)
        response.value = self.last["response"]
        response.cursor_position = len(response.value)
        response.focus()
        self._status(
            f"Re-scoring trial {self.last['index'] + 1} (was {self.last['score']}; kept in the "
            "log). F1-F5 or Enter gives the new score."
        )

    def _rescore(self, score: str) -> None:
        last = self.last
        response = self.query_one("#response", Input).value.strip()
        note = "undo by operator"
        if response != last["response"]:
            note += f"; corrected response: {response!r}"
            self.session.log_event(
                "response_corrected",
                json.dumps(
                    {"trial_index": last["index"], "was": last["response"], "now": response}
                ),
            )
        self.session.rescore(last["index"], score, self.rater, note=note)
        last.update(score=score, response=response)
        self.trial = None
        self.query_one("#response", Input).value = ""
        self._set_state("scored")
        self._status(
            f"Re-scored trial {last['index'] + 1} -> {score}. Ctrl+Z changes it again; Enter "
            "starts the next trial."
        )

    # -- pause, notes, presenter, quit ------------------------------------------------------------

    def action_pause(self) -> None:
        """Pause between trials (requested during a trial, it starts once the trial is scored)."""
        if self.state == "paused":
            self.session.log_event("resume", "")
            self._safe(self.subject_display.clear)
            self._set_state(self._paused_from)
            self._status("Resumed. Enter starts the next trial.")
            return
        if self.state in ("trial", "rescoring"):
            self.pause_requested = True
            self._status("Pause requested: it starts once this trial is scored.")
            return
        if self.state not in ("ready", "scored"):
            return
        self._paused_from = self.state
        self.session.log_event("pause", "")
        self._safe(self.subject_display.show_text, self._instructions.pause)
        self._set_state("paused")
        self._status("Paused. F8 resumes.")

    def action_note(self) -> None:
        """Open the note line."""
        note = self.query_one("#note", Input)
        # the note line takes the input line's place, so the layout keeps its height
        self.query_one("#response", Input).styles.display = "none"
        note.styles.display = "block"
        note.value = ""
        note.focus()

    def _save_note(self, text: str) -> None:
        if text.strip():
            self.session.log_event("note", text.strip())
            self._status(f"Note saved: {text.strip()!r}")
        note = self.query_one("#note", Input)
        note.value = ""
        note.styles.display = "none"
        response = self.query_one("#response", Input)
        response.styles.display = "block"
        response.focus()

    def action_restart_presenter(self) -> None:
        """Restart the presenter process after it died, and carry on where the session was."""
        if self.state != "down":
            self._status("The presenter is running.")
            return
        start = getattr(self.subject_display, "start", None)
        if start is None:
            self._status("This display cannot be restarted; quit (Ctrl+Q) and run again.")
            return
        from experiment.presentation.process import PresenterDied

        try:
            start()
        except PresenterDied as exc:
            self._status(f"[b red]Restart failed[/]: {exc}. F9 tries again.")
            return
        self.session.log_event(
            "presenter_restart", json.dumps(getattr(self.subject_display, "info", {}))
        )
        back = self._down_from
        if back == "trial" and self.trial is not None:
            self.session.log_event(
                "trial_reshown", f"trial {self.trial.index}: shown again after a presenter restart"
            )
            self._set_state("ready")
            self.trial = None
            self._start_next_trial()
            return
        self._safe(self.subject_display.show_text, self._instructions.wait)
        self._set_state(back if back in ("ready", "scored") else "ready")
        self._status("Presenter restarted. Enter starts the next trial.")

    def _finish(self) -> None:
        self._safe(self.subject_display.show_text, self._instructions.end)
        self._set_state("finished")
        self._status("Session complete. Ctrl+Q closes the console.")

    def action_save_quit(self) -> None:
        """Save and quit: log where the session stops, release it and close the subject's screen."""
        if self.state == "trial" or (self.state == "down" and self._down_from == "trial"):
            self.session.log_event(
                "abort", f"quit during trial {self.trial.index}; it is shown again on resume"
            )
            self._audio("discard")
            self._safe(self.subject_display.clear)
        a, n = self.session.progress()
        self.result.answered, self.result.total = a, n
        self.result.finished = a >= n
        self.exit(self.result)
