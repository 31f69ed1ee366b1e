"""A person searching: the subject's inputs drive an :class:`ActiveSession`, the operator scores.

:class:`LiveSearch` is the GL-free, UI-free core of a human active-search session; the operator
console (:mod:`experiment.console.active`) and tests drive it. Its display is the subject's
screen with input on: a presenter process started with ``inputs=True``
(:class:`experiment.presentation.process.RemoteDisplay`), an offscreen
:class:`~experiment.presentation.presenter.Presenter`, or the headless
:class:`~experiment.presentation.displays.NullDisplay` in tests. Each must offer
``show_text``, ``show_stimulus``, ``clear`` and ``poll_inputs``.

One trial
---------
1. :meth:`LiveSearch.cue`: the subject's screen shows the cue ("Find the tree"); the operator
   starts the trial when the subject is ready (:meth:`LiveSearch.begin`): the implant's view at
   the nearest end of the depth range appears and the clock of the trial starts.
2. The subject searches with the keys of :data:`INPUT_ACTIONS` (arrow keys or wheel: depth;
   PageUp/PageDown: previous/next detected plane; drag a box: zoom; Escape: un-zoom). Each
   input is logged with the presenter's time stamp, then the state it shows, and the implant's
   new view is drawn (:meth:`LiveSearch.handle`).
3. The subject presses Enter and names the object aloud. That time is the answer time; inputs
   after it are not applied (nor logged) until the operator scores.
4. The operator types the words and scores (:meth:`LiveSearch.score`); the answer and score are
   committed in one transaction. Without Enter, the answer time is when the operator scores.
   At the task's time limit the trial ends as a pass (:meth:`LiveSearch.tick`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

from experiment.active.adapter import MIN_ZOOM_PX  # a smaller drag is a click, not a zoom
from experiment.active.session import ActiveSession, auto_scorer
from experiment.active.task import ActiveTrial
from experiment.viewer.state import KEYMAP

__all__ = ["INPUT_ACTIONS", "LiveSearch", "zoom_box_px"]

logger = logging.getLogger(__name__)

#: Subject inputs (as the presenter names them) and the actions they send. The viewer's keys
#: (:data:`experiment.viewer.state.KEYMAP`) plus the mouse wheel; ``drag`` sends ``zoom``.
INPUT_ACTIONS: dict[str, str] = {**KEYMAP, "WheelUp": "depth_near", "WheelDown": "depth_far"}


def zoom_box_px(
    fraction_box: Any, shape_px: tuple[int, int], zoom: tuple[int, int, int, int] | None
) -> tuple[int, int, int, int] | None:
    """Map a drag on the shown implant view to a zoom box in view pixels (None: too small).

    Parameters
    ----------
    fraction_box : [x0, y0, x1, y1]
        The drag as fractions of the shown image (top-left origin, each in [0, 1]).
    shape_px : (rows, cols)
        The light field's view size.
    zoom : (x, y, w, h) or None
        The zoom box now shown: the image covers that region of the view, else the whole view.

    Examples
    --------
    >>> zoom_box_px([0.25, 0.5, 0.75, 1.0], (100, 200), None)
    (50, 50, 100, 50)
    >>> zoom_box_px([0.0, 0.0, 0.5, 0.5], (100, 200), (50, 50, 100, 50))
    (50, 50, 50, 25)
    """
    try:
        fx0, fy0, fx1, fy1 = (min(max(float(v), 0.0), 1.0) for v in fraction_box)
    except (TypeError, ValueError):
        return None
    rows, cols = shape_px
    zx, zy, zw, zh = zoom if zoom is not None else (0, 0, cols, rows)
    x0, x1 = round(zx + min(fx0, fx1) * zw), round(zx + max(fx0, fx1) * zw)
    y0, y1 = round(zy + min(fy0, fy1) * zh), round(zy + max(fy0, fy1) * zh)
    x0, y0 = max(0, x0), max(0, y0)
    x1, y1 = min(cols, x1), min(rows, y1)
    if x1 - x0 < MIN_ZOOM_PX or y1 - y0 < MIN_ZOOM_PX:
        return None
    return int(x0), int(y0), int(x1 - x0), int(y1 - y0)


@dataclass
class _Trial:
    trial: ActiveTrial
    answered_at_s: float | None = None
    answer_key: str | None = None


class LiveSearch:
    """Drive an active-search session from a person's inputs and an operator's scores.

    Parameters
    ----------
    session : ActiveSession
        An open session (new or resumed).
    display : the subject's screen with input (see the module docstring).
    rater : str
        Rater name stored with the operator's scores.
    """

    def __init__(self, session: ActiveSession, display: Any, *, rater: str = "operator") -> None:
        if not isinstance(rater, str) or not rater.strip():
            raise ValueError(f"rater must be a non-empty string, got {rater!r}")
        self.session = session
        self.display = display
        self.rater = rater
        self._trial: _Trial | None = None
        self.ignored_inputs = 0

    # -- state --------------------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """Whether a trial is on screen (begun, not yet scored)."""
        return self._trial is not None

    @property
    def answered(self) -> bool:
        """Whether the subject has pressed the answer key in the running trial."""
        return self._trial is not None and self._trial.answered_at_s is not None

    @property
    def trial(self) -> ActiveTrial | None:
        """The running trial, else the next one (None when the session is finished)."""
        return self._trial.trial if self._trial is not None else self.session.next_trial()

    def cue_text(self, trial: ActiveTrial | None = None) -> str:
        """Return the text shown to the subject before a trial."""
        t = trial or self.trial
        if t is None:
            return "The session is finished. Thank you."
        return (
            f"Find the {t.target}.\n\nArrow keys or wheel: depth.  PageUp / PageDown: planes.\n"
            "Drag a box: zoom.  Esc: un-zoom.  Enter: you know what it is."
        )

    # -- the trial ----------------------------------------------------------------------------

    def cue(self) -> ActiveTrial | None:
        """Show the next trial's cue on the subject's screen; return that trial (None: done)."""
        t = self.session.next_trial()
        self.display.show_text(self.cue_text(t))
        return t

    def begin(self) -> list[dict]:
        """Start the next trial: log its onset and first state, show the implant's view."""
        if self._trial is not None:
            raise ValueError("a trial is running; score it first")
        self.display.poll_inputs()  # keys pressed while the cue was up are not part of a trial
        trial, rows = self.session.start_trial("person")
        self._trial = _Trial(trial)
        self.display.show_stimulus(self.session.view.grid)
        return rows

    def handle(self, event: dict[str, Any]) -> list[dict]:
        """Apply one subject input (a presenter ``input`` event); return the rows logged."""
        if self._trial is None or self._trial.answered_at_s is not None:
            self.ignored_inputs += 1
            return []
        key = str(event.get("key", ""))
        t_s = event.get("t_s")
        if key == "drag":
            s = self.session.state
            box = zoom_box_px(event.get("box"), self.session.scene.shape_px, s.zoom)
            if box is None or not self.session.task.zoom_allowed:
                self.ignored_inputs += 1
                return []
            rows = self.session.press("drag", "zoom", box=box, t_s=t_s)
        else:
            action = INPUT_ACTIONS.get(key)
            if action is None:
                self.ignored_inputs += 1
                return []
            if action in ("answer", "pass"):
                self._trial.answered_at_s = (
                    float(t_s) if t_s is not None else self.session.clock.now_s()
                )
                self._trial.answer_key = key
                return []
            rows = self.session.press(key, action, t_s=t_s)
        if any(r["kind"] == "state" for r in rows):
            self.display.show_stimulus(self.session.view.grid)
        return rows

    def pump(self) -> list[dict]:
        """Apply every input the display has queued; return the rows logged."""
        out: list[dict] = []
        for ev in self.display.poll_inputs():
            out += self.handle(ev)
        return out

    def elapsed_s(self) -> float | None:
        """Seconds since the running trial's onset (None without one)."""
        return self.session.elapsed_s() if self._trial is not None else None

    def suggest(self, response: str) -> str:
        """Return the score the console suggests for ``response`` (the static study's rule)."""
        t = self.trial
        if t is None:
            return "pass"
        return auto_scorer(t, response, self.session.task.targets, self.session.object_infos)[0]

    def score(self, response: str, score: str) -> list[dict]:
        """Commit the running trial's answer with the operator's score; clear the screen."""
        if self._trial is None:
            raise ValueError("no trial is running")
        tr = self._trial
        key = tr.answer_key or "operator"
        rows = self.session.answer(
            response, key=key, score=score, rater=self.rater, t_s=tr.answered_at_s
        )
        self._trial = None
        self.display.clear()
        return rows

    def tick(self) -> list[dict]:
        """End the running trial as a pass at the task's time limit (unless already answered)."""
        tr = self._trial
        if tr is None or tr.answered_at_s is not None:
            return []
        limit = self.session.task.time_limit_s
        if self.session.elapsed_s() < limit:
            return []
        t_s = self.session.onset_s + limit
        rows = self.session.answer("", key="timeout", score="pass", rater="auto", t_s=t_s)
        self._trial = None
        self.display.clear()
        return rows
