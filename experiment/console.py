"""The operator's console: a Textual app that runs a session trial by trial (issue 6).

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

import contextlib
import json
import logging
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.containers import Horizontal, Vertical
from textual.widgets import Footer, Input, Static

from experiment.clock import Clock, PerfCounterClock
from experiment.errors import ConfocalError
from experiment.interfaces import Answer, Display, FlipRecord, combine_flips

__all__ = [
    "SCORE_KEYS",
    "CONSOLE_CSS",
    "console_layout",
    "OperatorConsole",
    "ScoringApp",
    "ConsoleResult",
    "preview_text",
    "make_display",
    "run_console",
    "session_log_path",
    "logs_to_file",
]

logger = logging.getLogger(__name__)

#: Function keys of the five scores (Jung et al. 2015, Sec. 3.2: name, use, shape/features, pass;
#: "wrong" is the engine's score for a wrong name).
SCORE_KEYS: dict[str, str] = {
    "f1": "named",
    "f2": "use",
    "f3": "shape",
    "f4": "wrong",
    "f5": "pass",
}

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


class OperatorConsole(App):
    """The operator's Textual app; drives ``session`` and the subject's ``display``.

    Parameters
    ----------
    session : experiment.session.Session
    display : Display
        The subject's screen (``RemoteDisplay``, ``Presenter`` or a headless twin).
    clock : Clock or None
        Clock for response times and the onset timer; the session's clock by default. It must
        share its time base with the display's flips (``perf_counter`` does across processes).
    rater : str
        Rater name stored with the operator's scores.
    recorder : experiment.audio.TrialAudio or None
        Records each trial's spoken answer (issue 15); None: no recording.
    audio_note : str
        Shown once at start (e.g. why there is no recording).
    """

    # Responsive layout (issue 15): the input line, the status and the key footer keep fixed
    # rows at the bottom; the trial panel and the preview share what is left, and the preview is
    # re-drawn to fit it (see _fit_preview), so nothing is clipped from 80x24 upward.
    CSS = CONSOLE_CSS + "#note { display: none; }\n"

    ENABLE_COMMAND_PALETTE = False

    # Short labels so that the whole footer fits in 80 columns; F9 is named in the status line
    # when the presenter stops, the only time it is needed.
    BINDINGS = [
        *(Binding(k, f"score('{s}')", s, priority=True) for k, s in SCORE_KEYS.items()),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("f6", "note", "note", priority=True),
        Binding("f8", "pause", "pause", priority=True),
        Binding("f9", "restart_presenter", "restart presenter", show=False, priority=True),
        Binding("ctrl+q", "save_quit", "quit", priority=True),
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
        yield from console_layout(
            Input(placeholder="note for the log (Enter saves, Esc cancels)", id="note")
        )

    def on_resize(self) -> None:
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
        self.query_one("#preview", Static).update(Text(preview_text(self._preview_image, cols)))

    def on_mount(self) -> None:
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

    def _status(self, text: str) -> None:
        self.query_one("#status", Static).update(text)

    def _update_trial_panel(self) -> None:
        a, n = self.session.progress()
        t = self.trial if self.trial is not None else self.session.next_trial()
        lines = [f"subject [b]{self.session.subject}[/b]   answered {a} of {n}"]
        if t is not None:
            lines += [
                f"part {t.part}   block {t.block}   trial {t.index + 1} of {n}",
                f"object [b]{t.object_name}[/b] ({t.object})",
                f"level {t.level} (window {t.window} px, {t.pixels} px)   condition {t.condition}",
            ]
        lines.append(f"state: {self.state}")
        self.query_one("#trial", Static).update("\n".join(lines))

    def _set_state(self, state: str) -> None:
        self.state = state
        self._update_trial_panel()

    def _tick(self) -> None:
        if self.state == "trial" and self.onset is not None:
            el = self.clock.now_s() - self.onset.onset_s
            wait = self.trial.pass_allowed_after_s - el
            tail = f"pass allowed in {wait:.0f} s" if wait > 0 else "pass allowed"
            self.query_one("#timer", Static).update(f"since onset {el:.1f} s   {tail}")
        else:
            self.query_one("#timer", Static).update("")
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
        self.session.mark_shown(trial, onset)  # durable before any answer (issue 10)
        self._audio("start", trial, onset.onset_s)
        self.first_key_s = None
        response = self.query_one("#response", Input)
        response.value = ""
        response.focus()
        self._set_state("trial")
        self.query_one("#suggest", Static).update("")
        self._status("Type the subject's words; F1-F5 scores, Enter takes the suggestion.")

    def on_input_changed(self, event: Input.Changed) -> None:
        if event.input.id != "response" or self.state not in ("trial", "rescoring"):
            return
        if self.state == "trial" and self.first_key_s is None and event.value:
            self.first_key_s = self.clock.now_s()
        self.query_one("#suggest", Static).update(
            f"suggested: {self.session.suggest_score(self.trial, event.value.strip())}"
        )

    def on_input_submitted(self, event: Input.Submitted) -> None:
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
        self.query_one("#response", Input).value = ""
        self.query_one("#suggest", Static).update("")
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


class ScoringApp(App):
    """A second rater's walk through logged responses, blind to every other rater's scores.

    Shows each answered trial's object (the right answer), condition, level and the logged words;
    F1..F5 appends a score by ``rater`` to the log (never the first rater's score, never the
    suggestion). Ctrl+Z steps back to the previous trial: the score given next is appended and,
    being this rater's latest, replaces the undone one (scores are never deleted). A progress
    line shows how many are scored and left. Returns the number of trials scored.

    Parameters
    ----------
    log : experiment.triallog.TrialLog
    rater : str
    pending : list of dict
        Trials to score, from :func:`experiment.presentation.cli.pending_for_rater`.
    """

    BINDINGS = [
        *(Binding(k, f"score('{s}')", s, priority=True) for k, s in SCORE_KEYS.items()),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("f7", "replay", "replay voice", priority=True),
        Binding("ctrl+q", "done", "save & quit", priority=True),
    ]

    #: Plays a recording and returns "" or why not (tests replace it).
    player: Any = None

    def action_replay(self) -> None:
        """Play the current trial's recorded answer, if there is one (issue 15)."""
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
        yield Static(id="item")
        yield Static(id="status")
        yield Footer()

    def on_mount(self) -> None:
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


def make_display(
    geometry: Any,
    presenter: str,
    *,
    screen: int | None = None,
    fullscreen: bool = True,
    skip_timing_check: bool = False,
    clock: Clock | None = None,
    **kwargs: Any,
) -> Any:
    """Open the subject's display: ``'process'`` (a window in a presenter process),
    ``'offscreen'`` (an in-process EGL presenter) or ``'none'`` (headless twin).
    """
    if presenter == "process":
        from experiment.presentation.process import RemoteDisplay

        phos = kwargs.pop("phosphenes", None)
        if phos is not None and not isinstance(phos, dict):
            from dataclasses import asdict

            phos = asdict(phos)
        return RemoteDisplay(
            geometry,
            mode="window",
            screen=screen,
            fullscreen=fullscreen,
            skip_timing_check=skip_timing_check,
            phosphenes=phos,
            **kwargs,
        )
    if presenter == "offscreen":
        from experiment.presentation.presenter import Presenter

        return Presenter.offscreen(geometry, clock=clock, **kwargs)
    if presenter == "none":
        from experiment.presentation.displays import NullDisplay

        return NullDisplay(clock)
    raise ValueError(f"presenter must be 'process', 'offscreen' or 'none', got {presenter!r}")


def _open_recorder(session: Any, record_audio: bool, microphone: Any) -> tuple[Any, str]:
    """Return ``(recorder or None, note for the operator)``; log what happened once."""
    if not record_audio and microphone is None:
        return None, ""
    from experiment.audio import TrialAudio, open_microphone

    why = ""
    if microphone is None:
        microphone, why = open_microphone(session.clock)
    if microphone is not None:
        try:
            recorder = TrialAudio(session, microphone)
        except (ImportError, ValueError) as exc:
            microphone.close()
            why = " ".join(str(exc).split())
        else:
            session.log_event(
                "audio",
                json.dumps(
                    {
                        "device": getattr(microphone, "device_name", "?"),
                        "samplerate_hz": microphone.samplerate_hz,
                    }
                ),
            )
            return recorder, ""
    session.log_event("audio_unavailable", why)
    logger.warning("recording the answers is off: %s", why)
    return None, f"[b]Recording off[/b]: {why}. The session runs without audio."


def session_log_path(session: Any) -> Path | None:
    """Return the session log file beside the trial log (``study.sqlite`` -> ``study.log``).

    ``None`` for an in-memory trial log.
    """
    db = str(getattr(getattr(session, "log", None), "path", ":memory:"))
    return None if db == ":memory:" else Path(db).with_suffix(".log")


@contextlib.contextmanager
def logs_to_file(path: str | Path | None, *, prefix: str = "") -> Iterator[None]:
    """Send every log record (moderngl-window's included) to ``path`` instead of the terminal.

    While the console owns the terminal, a log line written there would tear its screen. Handlers
    that write to stdout or stderr are detached from every logger, a file handler (append, level
    INFO) is put on the root logger, and everything is put back on exit. ``path=None`` only
    silences the terminal.

    Parameters
    ----------
    path : str or Path or None
        The session log file.
    prefix : str
        Written after the time stamp on every line (e.g. ``"session 3"``).
    """
    root = logging.getLogger()
    terminal = (sys.stderr, sys.stdout, sys.__stderr__, sys.__stdout__)
    moved: list[tuple[logging.Logger, logging.Handler]] = []
    loggers = [root, *(logging.getLogger(n) for n in list(logging.root.manager.loggerDict))]
    for lg in loggers:
        for h in list(lg.handlers):
            if (
                isinstance(h, logging.StreamHandler)
                and not isinstance(h, logging.FileHandler)
                and getattr(h, "stream", None) in terminal
            ):
                lg.removeHandler(h)
                moved.append((lg, h))
    handler: logging.Handler = (
        logging.NullHandler() if path is None else logging.FileHandler(path, encoding="utf-8")
    )
    tag = f" {prefix}" if prefix else ""
    handler.setFormatter(logging.Formatter(f"%(asctime)s{tag} %(name)s %(levelname)s: %(message)s"))
    old_level = root.level
    root.setLevel(min(old_level, logging.INFO) if old_level else logging.INFO)
    root.addHandler(handler)
    try:
        yield
    finally:
        root.removeHandler(handler)
        handler.close()
        root.setLevel(old_level)
        for lg, h in moved:
            lg.addHandler(h)


def run_console(
    session: Any,
    *,
    screen: int | None = None,
    fullscreen: bool = True,
    presenter: str = "process",
    skip_timing_check: bool = False,
    rater: str = "operator",
    display: Display | None = None,
    record_audio: bool = False,
    microphone: Any = None,
    **presenter_options: Any,
) -> ConsoleResult:
    """Run the operator console for ``session`` until the operator quits; return what happened.

    Parameters
    ----------
    session : experiment.session.Session
        An open session (new or resumed); it is closed (lock released) on return.
    screen : int or None
        Screen index of the subject's window.
    fullscreen : bool
    presenter : {'process', 'offscreen', 'none'}
        How the subject's screen is drawn (see :func:`make_display`).
    skip_timing_check : bool
        Start even if the presenter's frame-timing self-test fails; the choice is logged (H12).
    rater : str
    display : Display or None
        Use this display instead of opening one.
    record_audio : bool
        Record each trial's spoken answer (:mod:`experiment.audio`). Without the ``audio`` extra
        or a microphone the session runs without, and says so once (console and log event).
    microphone : experiment.audio.Microphone or None
        Use this input (a test twin) instead of opening the default one.
    **presenter_options
        ``integer_scale``, ``phosphenes`` (passed to the presenter). A protocol with a
        ``[display] implant`` gets that implant's phosphenes unless ``phosphenes`` is given.

    Notes
    -----
    While the console runs, log lines (ours, and moderngl-window's in the presenter process) go
    to the session log file :func:`session_log_path`, not the terminal.

    Raises
    ------
    ConfocalError
        The subject's screen cannot be opened (one line; nothing is shown).
    """
    from experiment.presentation.presenter import ScreenGeometry

    log_path = session_log_path(session)
    if presenter == "process" and log_path is not None:
        presenter_options.setdefault("stderr_path", log_path)
    layout = session.protocol.display.implant_layout
    if layout is not None and presenter_options.get("phosphenes") is None:
        # Session.image_for resamples each stimulus to the implant's grid; the presenter draws
        # the grid as its phosphenes at its field of view, as ``confocal present --implant``.
        from experiment.presentation.implant import phosphene_spec

        presenter_options["phosphenes"] = phosphene_spec(layout)
    if display is None:
        try:
            geometry = ScreenGeometry.from_display_spec(session.protocol.display)
            display = make_display(
                geometry,
                presenter,
                screen=screen,
                fullscreen=fullscreen,
                skip_timing_check=skip_timing_check,
                clock=session.clock,
                **presenter_options,
            )
        except (ConfocalError, ValueError) as exc:
            session.log_event("presenter_failed", " ".join(str(exc).split()))
            session.close()
            if isinstance(exc, ConfocalError):
                raise
            raise ConfocalError(f"subject's display: {exc}") from None
    recorder = None
    try:
        info = getattr(display, "info", None) or {"presenter": presenter}
        session.log_event("display", json.dumps(info, sort_keys=True, default=str))
        if skip_timing_check:
            session.log_event("timing_check", "skipped by the operator (--skip-timing-check)")
        recorder, audio_note = _open_recorder(session, record_audio, microphone)
        app = OperatorConsole(
            session, display, rater=rater, recorder=recorder, audio_note=audio_note
        )
        with logs_to_file(log_path, prefix=f"session {session.session_id}"):
            result = app.run()
    finally:
        try:
            display.close()
            if recorder is not None:
                recorder.close()
        finally:
            session.close()
    if result is None:
        a, n = session.progress()
        result = ConsoleResult(answered=a, total=n, finished=a >= n)
    return result
