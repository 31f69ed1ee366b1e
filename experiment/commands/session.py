"""``confocal session``: run a session, show a study's status, export its trials.

::

    confocal session run --protocol jung2015 --stimuli STIM_DIR --subject S01 --data study.sqlite
    confocal session run ... --headless --observer logistic --seed 1 --data pilot.sqlite
    confocal session run ... --participant age=31,sex=F --monitor lab_lcd
    confocal session status study.sqlite
    confocal session export study.sqlite --out dataset [--dates day|shift:N|none]

What the export leaves out (identifying participant fields, wall-clock times) is described in
:mod:`experiment.data.psychds`.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from pathlib import Path
from typing import Annotated

import typer

from experiment.commands.run_options import (
    DataOption,
    FullscreenOption,
    NewSessionOption,
    PresenterOption,
    ScreenOption,
    SkipTimingCheckOption,
    SubjectOption,
    TakeOverLockOption,
    check_presenter,
    confirm_take_over,
    report_if_complete,
)
from experiment.errors import ConfocalError
from stimuli.cli import seed_option
from stimuli.resources import finite_option

__all__ = [
    "register",
    "run_command",
    "status_command",
    "export_command",
]

logger = logging.getLogger(__name__)

#: Longest headless hold, seconds (ours: one day; longer is a typo, and inf overflows sleep()).
_MAX_HOLD_S = 86400.0
session_app = typer.Typer(
    name="session",
    help="Run recognition sessions and inspect or export the study's trial log.",
    no_args_is_help=True,
)


class _Progress:
    def __init__(self, every: int) -> None:
        self.every = every

    def __call__(self, answered: int, total: int) -> None:
        if self.every and (answered % self.every == 0 or answered == total):
            typer.echo(f"trial {answered}/{total}")


@session_app.command("run")
def run_command(
    protocol: Annotated[
        str,
        typer.Option("--protocol", "-p", help="Protocol TOML file, or a shipped name (jung2015)."),
    ],
    stimuli: Annotated[Path, typer.Option("--stimuli", "-s", help="Stimulus set folder.")],
    subject: SubjectOption,
    data: DataOption = Path("study.sqlite"),
    observer: Annotated[
        str | None,
        typer.Option(
            "--observer",
            help="Simulated observer for --headless: logistic, model or exemplar "
            "(exemplar needs --observer-param knowledge=FOLDER).",
        ),
    ] = None,
    headless: Annotated[
        bool,
        typer.Option("--headless", help="No screen: a simulated observer answers (dry runs, CI)."),
    ] = False,
    observer_param: Annotated[
        list[str] | None,
        typer.Option(
            "--observer-param",
            help="Simulated observer parameter KEY=VALUE (repeatable), e.g. lapse=0.02.",
        ),
    ] = None,
    seed: Annotated[
        int | None, seed_option("Root seed of a new session (drawn if omitted).")
    ] = None,
    hold_s: Annotated[
        float,
        typer.Option(
            "--hold-s",
            callback=finite_option(0.0, _MAX_HOLD_S),
            help="Headless: seconds each stimulus stays shown.",
        ),
    ] = 0.0,
    progress_every: Annotated[
        int,
        typer.Option("--progress-every", min=0, help="Print 'trial i/n' every n trials."),
    ] = 0,
    screen: ScreenOption = None,
    fullscreen: FullscreenOption = True,
    presenter: PresenterOption = "process",
    skip_timing_check: SkipTimingCheckOption = False,
    integer_scale: Annotated[
        bool,
        typer.Option("--integer-scale", help="Magnify stimuli by a whole number of pixels."),
    ] = False,
    participant: Annotated[
        str | None,
        typer.Option(
            "--participant",
            help="Participant metadata KEY=VALUE,... for participants.tsv, e.g. "
            "age=31,sex=F,acuity_logmar=1.2,consent=C17 (stored in the log); identifying "
            "fields (name, email, phone, date of birth, ...) are refused.",
        ),
    ] = None,
    allow_identifying: Annotated[
        bool,
        typer.Option(
            "--allow-identifying",
            help="Keep identifying --participant fields in the trial log; they are exported "
            "only with session export --include-identifying.",
        ),
    ] = False,
    monitor: Annotated[
        str | None,
        typer.Option(
            "--monitor",
            help="Monitor profile (a name in protocols/monitors or a .toml file): its width, "
            "distance, resolution and gamma replace the protocol's.",
        ),
    ] = None,
    record_audio: Annotated[
        bool,
        typer.Option(
            "--record-audio",
            help="Record each spoken answer beside the log and find its voice onset "
            "(needs the 'audio' extra and a microphone; without them the session runs silent).",
        ),
    ] = False,
    new_session: NewSessionOption = None,
    take_over_lock: TakeOverLockOption = None,
) -> None:
    """Run (or resume) a subject's session: console and presenter, or headless simulation.

    A subject whose session is complete is reported (exit 0, nothing written), not run again;
    ``--new-session REASON`` starts a further one.
    """
    from experiment.log import SessionComplete, TrialLog
    from experiment.observers import OBSERVERS, describe_observer, make_observer
    from experiment.presentation.displays import NullDisplay
    from experiment.session.engine import Session
    from experiment.session.plan import plan_session

    check_presenter(presenter)
    if observer is not None and not headless:
        raise ConfocalError("--observer needs --headless (a simulated subject has no screen)")
    if headless:
        observer = observer or "logistic"
        if observer not in OBSERVERS:
            raise ConfocalError(
                f"--observer must be one of {', '.join(sorted(OBSERVERS))}, got {observer!r}"
            )
    params = _parse_params(observer_param or [])
    if params and not headless:
        raise ConfocalError("--observer-param needs --headless")
    run_console = None
    if not headless:
        try:
            from experiment.console import run_console
        except ImportError as exc:
            raise ConfocalError(
                f"the operator console is unavailable ({exc}); use --headless --observer NAME "
                "for a simulated session"
            ) from None
    if data.is_dir():
        raise ConfocalError(f"--data {data} is a folder; expected the study's .sqlite file")
    meta = None
    if participant is not None:
        from experiment.data.psychds import check_not_identifying, parse_participant

        meta = parse_participant(participant)
        if not allow_identifying:
            check_not_identifying(meta)
    # the whole plan (subject, protocol, set, implant, memory, schedule) is checked once, before
    # the trial log is created or touched
    plan = plan_session(
        protocol,
        stimuli,
        subject,
        log=data,
        seed=seed,
        responder=f"sim:{observer}" if headless else "console",
        observer=observer if headless else None,
        participant=meta,
        monitor=monitor,
        new_session=new_session,
        take_over_lock=take_over_lock,
    )
    stimset = plan.stimset
    effective_params = None
    if headless:
        try:  # check the parameters before anything is written
            probe = make_observer(observer, stimset, subject, rng=0, **params)
        except (TypeError, ValueError) as exc:
            raise ConfocalError(f"--observer-param: {exc}") from None
        effective_params = _params_dict(getattr(probe, "params", None), params)
        plan = dataclasses.replace(plan, observer_params=effective_params)
    if report_if_complete(data, subject, new_session):
        return
    confirm_take_over(data, subject, take_over_lock)
    log = TrialLog(data)
    try:
        try:
            session = Session.open_planned(log, plan)
        except SessionComplete as exc:  # completed by another process since the check above
            typer.echo(str(exc))
            return
        try:
            if headless:
                responder = make_observer(
                    observer, stimset, subject, rng=session.child_rng(1), **params
                )
                session.log_event("observer", json.dumps(describe_observer(responder)))
                session.run(
                    NullDisplay(hold_s=hold_s), responder, progress=_Progress(progress_every)
                )
            else:
                run_console(
                    session,
                    screen=screen,
                    fullscreen=fullscreen,
                    presenter=presenter,
                    skip_timing_check=skip_timing_check,
                    integer_scale=integer_scale,
                    record_audio=record_audio,
                )
            answered, total = session.progress()
            typer.echo(
                f"session {session.session_id} ({subject}): {answered}/{total} trials answered"
                f"{' - complete' if answered == total else ''}; log {data}"
            )
        finally:
            session.close()
    finally:
        log.close()


def _params_dict(spec: object, given: dict[str, object]) -> dict[str, object]:
    """Return the observer's effective parameters (its params dataclass), else those given."""
    import dataclasses

    if spec is not None and dataclasses.is_dataclass(spec):
        return json.loads(json.dumps(dataclasses.asdict(spec), default=str))
    return dict(given)


def _parse_params(items: list[str]) -> dict[str, object]:
    out: dict[str, object] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfocalError(f"--observer-param must be KEY=VALUE, got {item!r}")
        try:
            out[key.strip()] = json.loads(value)
        except json.JSONDecodeError:
            out[key.strip()] = value
        if isinstance(out[key.strip()], list):
            out[key.strip()] = tuple(out[key.strip()])
    return out


@session_app.command("status")
def status_command(
    data: Annotated[Path, typer.Argument(help="The study's SQLite trial log.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")] = False,
) -> None:
    """Show subjects, progress, what is left, open locks and rater agreement (Cohen's kappa)."""
    from experiment.session.status import status_report

    rep = status_report(data)
    if as_json:
        typer.echo(json.dumps(rep, indent=2))
        return
    if not rep["sessions"]:
        typer.echo(f"{data}: no sessions yet")
    for s in rep["sessions"]:
        line = (
            f"session {s['session']:>3}  {s['subject']:<8} {s['protocol']:<12} "
            f"{s['status']:<9} {s['answered']:>4}/{s['planned']:<4} left {s['left']:>4}"
        )
        if s["next"]:
            n = s["next"]
            line += (
                f"  next: #{n['trial_index']} {n['part']} block {n['block']} "
                f"level {n['level']} {n['condition']}"
            )
        if s["observer"]:
            line += f"  SIMULATED ({s['observer']})"
        if s["crashes"]:
            line += f"  crashes recovered: {s['crashes']}"
        if s["lock"] and s["lock"]["stale"]:
            line += f"  crashed in pid {s['lock']['pid']} (run the same command to resume)"
        elif s["lock"]:
            line += f"  OPEN in pid {s['lock']['pid']} on {s['lock']['host']}"
        if s["new_session"]:
            line += f"  new session: {s['new_session']}"
        typer.echo(line)
    for sub in rep["subjects"]:
        if sub["complete"]:
            state = f"complete (session {sub['session']}, ended {(sub['ended_at'] or '')[:10]}"
        else:
            state = f"INCOMPLETE (session {sub['session']}; run the same command to resume"
        typer.echo(
            f"subject {sub['subject']:<8} {state}, {sub['answered']}/{sub['planned']} trials "
            f"answered; {sub['sessions']} session(s))"
        )
    from experiment.session.scoring import KAPPA_MIN_TRIALS

    for k in rep["kappa"]:
        kv = "nan" if k["kappa"] is None or math.isnan(k["kappa"]) else f"{k['kappa']:.3f}"
        ci = (
            ""
            if k.get("ci95_low") is None or math.isnan(k["ci95_low"])
            else f" (95% CI {k['ci95_low']:.3f} to {k['ci95_high']:.3f})"
        )
        if not ci and 0 < k["n"] < KAPPA_MIN_TRIALS:
            ci = f" (no 95% CI: too few trials, fewer than {KAPPA_MIN_TRIALS})"
        typer.echo(
            f"agreement {k['rater_a']} vs {k['rater_b']}: Cohen's kappa {kv}{ci} on {k['n']} "
            f"trials (observed {k['observed']:.3f}, chance {k['expected']:.3f})"
        )


@session_app.command("export")
def export_command(
    data: Annotated[Path, typer.Argument(help="The study's SQLite trial log.")],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Dataset folder (created, or merged into).")
    ],
    study: Annotated[
        str | None,
        typer.Option("--study", help="Study name in the file names (default: the log's name)."),
    ] = None,
    dates: Annotated[
        str,
        typer.Option(
            "--dates",
            help="The session day in the data: day, shift:N (moved by N days, the shift is "
            "not recorded) or none (blank). Times are always seconds from the session start.",
        ),
    ] = "day",
    include_identifying: Annotated[
        bool,
        typer.Option(
            "--include-identifying",
            help="Also export participant fields that look identifying (kept in the log by "
            "session run --allow-identifying).",
        ),
    ] = False,
) -> None:
    """Write a Psych-DS dataset: data/ (one CSV per session), participants.tsv, description."""
    from experiment.data.psychds import export_dataset
    from stimuli.errors import InputError

    try:
        info = export_dataset(
            data, out, study=study, dates=dates, include_identifying=include_identifying
        )
    except InputError:  # the disk filled up while writing; the message names --out
        raise
    except ValueError as exc:
        raise ConfocalError(f"--study: {exc}") from None
    sim = info["simulated_sessions"]
    typer.echo(
        f"wrote {out}: {len(info['files'])} data file(s) in {out / 'data'}, participants.tsv, "
        "dataset_description.json"
        + (f"; simulated session(s): {', '.join(map(str, sim))}" if sim else "")
    )
    if info["identifying_left_out"]:
        typer.echo(
            "left out identifying participant field(s) "
            f"{', '.join(info['identifying_left_out'])} (kept in the log; "
            "--include-identifying exports them)"
        )
    if info["undocumented"]:
        typer.echo(
            f"undocumented participant column(s) {', '.join(info['undocumented'])}: check they "
            "identify nobody before sharing (documentation/participants.json)"
        )
    if info["identifying_answers"]:
        found = info["identifying_answers"]
        typer.echo(
            f"warning: {len(found)} typed answer(s) look like contact details: "
            f"{'; '.join(found[:5])}{' ...' if len(found) > 5 else ''}; answers are exported as "
            "typed: check them before sharing",
            err=True,
        )
    if info["subject_codes_to_check"]:
        typer.echo(
            "warning: subject code(s) "
            f"{', '.join(map(repr, info['subject_codes_to_check']))} break the subject-code "
            "rule (logged before it was checked): check they name nobody before sharing",
            err=True,
        )


def register(app: typer.Typer) -> None:
    """Add the ``session`` command group to the root ``confocal`` app."""
    app.add_typer(session_app, name="session")
