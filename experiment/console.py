"""The operator's console: a Textual app that runs a session trial by trial (issue 6).

The operator sees the subject, part, block, trial k of n, the object (the right answer, for the
operator only), level and condition, a preview of the stimulus, the time since onset and when a
pass is allowed; types the subject's words; and scores them with a key. The subject's screen is a
:class:`~experiment.interfaces.Display`: by default the presenter process
(:class:`experiment.presenter_proc.RemoteDisplay`), in tests a headless twin.

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

import json
import logging
from dataclasses import dataclass, field
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
    "OperatorConsole",
    "ScoringApp",
    "ConsoleResult",
    "preview_text",
    "make_display",
    "run_console",
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
    """

    CSS = """
    #top { height: auto; }
    #trial { width: 1fr; padding: 0 1; }
    #preview { width: auto; border: solid $accent; padding: 0 1; }
    #timer { padding: 0 1; }
    #suggest { padding: 0 1; color: $success; }
    #status { padding: 0 1; min-height: 2; }
    #note { display: none; }
    """

    BINDINGS = [
        *(Binding(k, f"score('{s}')", s, priority=True) for k, s in SCORE_KEYS.items()),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("f6", "note", "note", priority=True),
        Binding("f8", "pause", "pause", priority=True),
        Binding("f9", "restart_presenter", "restart presenter", priority=True),
        Binding("ctrl+q", "save_quit", "save & quit", priority=True),
    ]

    def __init__(
        self, session: Any, display: Display, *, clock: Clock | None = None, rater: str = "operator"
    ) -> None:
        super().__init__()
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

    # -- layout -----------------------------------------------------------------------------------

    def compose(self) -> ComposeResult:
        with Horizontal(id="top"):
            yield Static(id="trial")
            yield Static(id="preview")
        with Vertical():
            yield Static(id="timer")
            yield Static(id="suggest")
            yield Static(id="status")
            yield Input(placeholder="the subject's words", id="response")
            yield Input(placeholder="note for the log (Enter saves, Esc cancels)", id="note")
        yield Footer()

    def on_mount(self) -> None:
        self.title = f"confocal: session {self.session.session_id}, subject {self.session.subject}"
        self.set_interval(0.25, self._tick)
        self._update_trial_panel()
        a, n = self.session.progress()
        self._safe(self.subject_display.show_text, "Please wait for the experimenter.")
        if self.session.next_trial() is None:
            self._finish()
        else:
            self._status(f"{a} of {n} trials answered. Press Enter to show the next stimulus.")
        self.query_one("#response", Input).focus()

    # -- helpers ----------------------------------------------------------------------------------

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
        from experiment.presenter_proc import PresenterDied

        try:
            return fn(*args)
        except PresenterDied as exc:
            self._presenter_down(str(exc))
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
            announce = f"{trial.part.capitalize()} part"
        elif trial.break_before and trial.index not in self._breaks_shown:
            self._breaks_shown.add(trial.index)
            self.session.log_event("break", f"before trial {trial.index}")
            announce = "Break"
        if announce is not None:
            self._safe(self.subject_display.show_text, announce)
            self._status(f"'{announce}' is on the subject's screen. Press Enter to continue.")
            return
        self.trial = trial
        image = self.session.image_for(trial)
        self.query_one("#preview", Static).update(Text(preview_text(image)))
        onset = self._safe(self.subject_display.show_stimulus, image)
        if onset is None:
            return
        self.onset = onset
        self.session.mark_shown(trial, onset)  # durable before any answer (issue 10)
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
        self._status(
            f"Recorded trial {trial.index + 1}: {response!r} -> {score}. "
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
        self._safe(self.subject_display.show_text, "Pause")
        self._set_state("paused")
        self._status("Paused. F8 resumes.")

    def action_note(self) -> None:
        """Open the note line."""
        note = self.query_one("#note", Input)
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
        self.query_one("#response", Input).focus()

    def action_restart_presenter(self) -> None:
        """Restart the presenter process after it died, and carry on where the session was."""
        if self.state != "down":
            self._status("The presenter is running.")
            return
        start = getattr(self.subject_display, "start", None)
        if start is None:
            self._status("This display cannot be restarted; quit (Ctrl+Q) and run again.")
            return
        from experiment.presenter_proc import PresenterDied

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
        self._safe(self.subject_display.show_text, "Please wait for the experimenter.")
        self._set_state(back if back in ("ready", "scored") else "ready")
        self._status("Presenter restarted. Enter starts the next trial.")

    def _finish(self) -> None:
        self._safe(self.subject_display.show_text, "The session is complete. Thank you.")
        self._set_state("finished")
        self._status("Session complete. Ctrl+Q closes the console.")

    def action_save_quit(self) -> None:
        """Save and quit: log where the session stops, release it and close the subject's screen."""
        if self.state == "trial" or (self.state == "down" and self._down_from == "trial"):
            self.session.log_event(
                "abort", f"quit during trial {self.trial.index}; it is shown again on resume"
            )
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
        Trials to score, from :func:`experiment.present_cli.pending_for_rater`.
    """

    BINDINGS = [
        *(Binding(k, f"score('{s}')", s, priority=True) for k, s in SCORE_KEYS.items()),
        Binding("ctrl+z", "undo", "undo", priority=True),
        Binding("ctrl+q", "done", "save & quit", priority=True),
    ]

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
        from experiment.presenter_proc import RemoteDisplay

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
        from experiment.presenter import Presenter

        return Presenter.offscreen(geometry, clock=clock, **kwargs)
    if presenter == "none":
        from experiment.displays import NullDisplay

        return NullDisplay(clock)
    raise ValueError(f"presenter must be 'process', 'offscreen' or 'none', got {presenter!r}")


def run_console(
    session: Any,
    *,
    screen: int | None = None,
    fullscreen: bool = True,
    presenter: str = "process",
    skip_timing_check: bool = False,
    rater: str = "operator",
    display: Display | None = None,
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
    **presenter_options
        ``integer_scale``, ``phosphenes`` (passed to the presenter).

    Raises
    ------
    ConfocalError
        The subject's screen cannot be opened (one line; nothing is shown).
    """
    from experiment.presenter import ScreenGeometry

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
    try:
        info = getattr(display, "info", None) or {"presenter": presenter}
        session.log_event("display", json.dumps(info, sort_keys=True, default=str))
        if skip_timing_check:
            session.log_event("timing_check", "skipped by the operator (--skip-timing-check)")
        app = OperatorConsole(session, display, rater=rater)
        result = app.run()
    finally:
        try:
            display.close()
        finally:
            session.close()
    if result is None:
        a, n = session.progress()
        result = ConsoleResult(answered=a, total=n, finished=a >= n)
    return result
