"""Starting the recognition console: the subject's display, the answer recorder, the session log.

:func:`run_console` is what ``confocal session run`` calls; it opens the subject's screen
(:func:`make_display`), logs what was opened, and runs :class:`OperatorConsole` with log lines
sent to the session log (:func:`experiment.console.logfile.logs_to_file`).
"""

from __future__ import annotations

import json
import logging
from typing import Any

from experiment.clock import Clock
from experiment.console.logfile import logs_to_file, session_log_path
from experiment.console.recognition import ConsoleResult, OperatorConsole
from experiment.errors import ConfocalError
from experiment.interfaces import Display

__all__ = ["make_display", "run_console"]

logger = logging.getLogger(__name__)


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
    """Open the subject's display.

    ``'process'`` (a window in a presenter process), ``'offscreen'`` (an in-process EGL presenter)
    or ``'none'`` (headless twin).
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
    session : experiment.session.engine.Session
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
    from experiment.presentation.geometry import ScreenGeometry

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
