"""``confocal active run``: run (or resume) an active-search session headless.

With ``--searcher person`` a subject searches: the subject's screen opens (a presenter process
with keyboard and mouse input, on ``--screen``), and the operator's console runs in this
terminal (:mod:`experiment.console.active`): the operator starts each trial, sees the implant's
view and where the subject is in depth, types the subject's words and scores them.

With ``sim:planes`` or ``sim:ordered`` (:mod:`experiment.active.searcher`) the searcher is
simulated and its times run on a simulated clock; they are labelled simulated in the log
(``searcher`` of each ``trial_start``) and in ``confocal analyze``'s report. It searches
synthetic scenes and recorded light fields with a scene description (each target's plane and
box: :mod:`experiment.active.scenefile`).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer

from experiment.commands import run_options
from experiment.data.subjects import check_subject_code
from experiment.errors import ConfocalError
from stimuli.resources import MAX_ID_CHARS, MAX_SEED

__all__ = ["register", "active_app", "SEARCHERS", "subject_phosphenes"]

#: Searchers ``confocal active run`` can use: a person (a subject at the presenter window) or
#: a simulated one (headless).
SEARCHERS: tuple[str, ...] = ("sim:planes", "sim:ordered", "person")

active_app = typer.Typer(
    name="active",
    no_args_is_help=True,
    add_completion=False,
    help="Active search (Jung et al. 2015, Sec. 5): a subject drives the confocal viewer to "
    "find and name objects; every key and displayed state is logged.",
)


@active_app.command("run")
def run_command(
    protocol: Annotated[
        Path, typer.Argument(help='Protocol with \\[task] type = "active_search" (or its name).')
    ],
    data: run_options.DataOption,
    subject: run_options.SubjectOption,
    searcher: Annotated[
        str,
        typer.Option(
            "--searcher",
            help="person (a subject at the subject's screen; the operator scores here), or "
            "sim:planes / sim:ordered (simulated, headless).",
        ),
    ] = "sim:planes",
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, max=MAX_SEED, help="Root seed.")
    ] = None,
    screen: run_options.ScreenOption = None,
    fullscreen: run_options.FullscreenOption = True,
    presenter: run_options.PresenterOption = "process",
    skip_timing_check: run_options.SkipTimingCheckOption = False,
    rater: Annotated[
        str, typer.Option("--rater", help="person: rater name stored with the scores.")
    ] = "operator",
    new_session: run_options.NewSessionOption = None,
    take_over_lock: run_options.TakeOverLockOption = None,
    subject_index: Annotated[
        int | None,
        typer.Option(
            "--subject-index",
            min=0,
            max=MAX_SEED,
            help='counterbalance = "latin_square": the subject\'s position in the study '
            "(picks the condition order; default: the subject's position in this log's "
            "subjects). Saved in the plan.",
        ),
    ] = None,
) -> None:
    """Run or resume SUBJECT's active-search session: a person searches, or a simulated one.

    A subject whose session is complete is reported (exit 0, nothing written), not run again;
    ``--new-session REASON`` starts a further one.
    """
    from experiment.protocol import load_protocol
    from experiment.session.lifecycle import check_new_session_reason

    if searcher not in SEARCHERS:
        raise ConfocalError(f"--searcher must be one of {', '.join(SEARCHERS)}, got {searcher!r}")
    if not rater.strip():
        raise ConfocalError("--rater must not be blank")
    check_subject_code(subject)  # the one rule for what leaves the lab as a subject code
    if len(rater) > MAX_ID_CHARS:
        raise ConfocalError(
            f"--rater must be 1 to {MAX_ID_CHARS} characters, got {len(rater)} ({rater[:20]!r})"
        )
    run_options.check_presenter(presenter)
    spec = load_protocol(protocol)
    if spec.task is None:
        raise ConfocalError(
            f'{protocol}: not an active-search protocol (needs [task] type = "active_search")'
        )
    check_new_session_reason(new_session)
    from experiment.log.locks import check_take_over_reason

    check_take_over_reason(take_over_lock)
    if searcher == "person":
        screen_options = {
            "screen": screen,
            "fullscreen": fullscreen,
            "skip_timing_check": skip_timing_check,
        }
        _run_person(
            spec,
            data,
            subject,
            seed,
            presenter,
            screen_options,
            rater,
            new_session,
            subject_index,
            take_over_lock,
        )
        return
    _run_simulated(
        protocol, spec, data, subject, searcher, seed, new_session, subject_index, take_over_lock
    )


def subject_phosphenes(spec) -> dict | None:
    """Return the presenter's phosphene fields for a protocol with a ``[display] implant``.

    None without one; with one, the implant's view is drawn as its phosphenes at its field of view.
    """
    layout = spec.display.implant_layout
    if layout is None:
        return None
    from dataclasses import asdict

    from experiment.presentation.implant import phosphene_spec

    return asdict(phosphene_spec(layout))


@contextmanager
def _open_session(
    data, spec, subject, seed, new_session, subject_index, take_over_lock=None, **open_options
):
    """Open (or resume) SUBJECT's active-search session in the trial log DATA.

    Yield the log and the session, both closed on exit. ``take_over_lock``: the operator's
    reason to take over a lock held on another host (confirmed first on a terminal).
    ``open_options``: the searcher's ``responder`` and ``clock``.
    """
    from experiment.active.session import ActiveSession
    from experiment.log import SessionComplete, TrialLog

    run_options.confirm_take_over(data, subject, take_over_lock)
    with TrialLog(data) as log:
        try:
            session = ActiveSession.open(
                log,
                spec,
                subject,
                seed=seed,
                new_session=new_session,
                subject_index=subject_index,
                take_over_lock=take_over_lock,
                **open_options,
            )
        except SessionComplete as exc:  # completed by another process since the check
            typer.echo(str(exc))
            raise typer.Exit(0) from None
        try:
            yield log, session
        finally:
            session.close()


def _run_person(
    spec,
    data,
    subject,
    seed,
    presenter,
    screen_options,
    rater,
    new_session,
    subject_index=None,
    take_over_lock=None,
) -> None:
    """Run SUBJECT's session with a person searching.

    ``screen_options`` are the subject's window's ``screen``, ``fullscreen`` and
    ``skip_timing_check``.
    """
    import json
    import sys

    from experiment.active.live import LiveSearch
    from experiment.console import logs_to_file, session_log_path
    from experiment.console.active import run_active_console
    from experiment.presentation.presenter import ScreenGeometry
    from experiment.presentation.process import PresenterDied, RemoteDisplay

    if not (sys.stdin.isatty() and sys.stdout.isatty()):
        raise ConfocalError(
            "--searcher person runs the operator's console in this terminal; stdin and stdout "
            "must be a terminal"
        )
    if not data.parent.is_dir():
        raise ConfocalError(f"--data {data}: folder {data.parent} does not exist")
    geometry = ScreenGeometry.from_display_spec(spec.display)
    if run_options.report_if_complete(data, subject, new_session):
        return
    with _open_session(
        data, spec, subject, seed, new_session, subject_index, take_over_lock, responder="person"
    ) as (log, session):
        try:
            if presenter == "none":
                from experiment.presentation.displays import NullDisplay

                display = NullDisplay(session.clock)
            else:
                display = RemoteDisplay(
                    geometry,
                    mode="window" if presenter == "process" else "offscreen",
                    **screen_options,
                    inputs=True,
                    stderr_path=session_log_path(session),
                    phosphenes=subject_phosphenes(spec),
                )
        except PresenterDied as exc:
            log.add_event(session.session_id, "presenter_failed", str(exc), session.clock.now_s())
            raise ConfocalError(str(exc)) from None
        try:
            info = getattr(display, "info", None) or {"presenter": presenter}
            info = json.dumps(info, sort_keys=True, default=str)
            log.add_event(session.session_id, "display", info, session.clock.now_s())
            if screen_options["skip_timing_check"]:
                log.add_event(
                    session.session_id,
                    "timing_check",
                    "skipped by the operator (--skip-timing-check)",
                    session.clock.now_s(),
                )
            live = LiveSearch(session, display, rater=rater)
            with logs_to_file(session_log_path(session), prefix=f"session {session.session_id}"):
                done, total = run_active_console(live)
        finally:
            display.close()
    typer.echo(f"session of {subject}: {done} of {total} trials answered; log: {data}")


def _run_simulated(
    protocol,
    spec,
    data,
    subject,
    searcher,
    seed,
    new_session=None,
    subject_index=None,
    take_over_lock=None,
) -> None:
    from pathlib import Path

    from experiment.active.adapter import scene_objects
    from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher
    from experiment.clock import FakeClock

    base = None if spec.source_path is None else Path(spec.source_path).parent
    for name in spec.task.scenes:
        if scene_objects(name, base_dir=base) is None:
            raise ConfocalError(
                f"{protocol}: task.scene {name!r} is a light field without a scene description; "
                "the simulated searcher needs to know each target's plane and box (give a "
                ".toml scene description: see experiment/active/scenefile.py)"
            )
    if run_options.report_if_complete(data, subject, new_session):
        return
    with _open_session(
        data,
        spec,
        subject,
        seed,
        new_session,
        subject_index,
        take_over_lock,
        clock=FakeClock(),
        responder=searcher,
    ) as (_, session):
        rec = EdgeRecogniser(session.scene, spec.task.grid_px, rng=session.seed)
        sim = SimulatedSearcher(rec, searcher.split(":", 1)[1], rng=session.seed)
        for ev in session.iter_run(sim):
            if ev["kind"] == "answer":
                p = ev["payload"]
                typer.echo(
                    f"trial {ev['trial']}: answered {p['response'] or '(pass)'!r} after "
                    f"{p['rt_s']:.1f} s (simulated)"
                )
        done, total = session.progress()
    typer.echo(f"session of {subject}: {done} of {total} trials answered; log: {data}")


def register(app: typer.Typer) -> None:
    """Add the ``active`` group to the root app."""
    app.add_typer(active_app, name="active")
