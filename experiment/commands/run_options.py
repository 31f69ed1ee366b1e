"""The command-line options and checks that ``session run`` and ``active run`` share.

Both commands run one subject's session in the study's trial log: the same ``--subject``,
``--data``, ``--new-session`` and ``--take-over-lock``, the same subject's-screen options
(``--presenter``, ``--screen``, ``--fullscreen/--window``, ``--skip-timing-check``), and the same
read-only report of a subject whose session is complete (:func:`report_if_complete`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from experiment.errors import ConfocalError

__all__ = [
    "PRESENTERS",
    "DataOption",
    "FullscreenOption",
    "NewSessionOption",
    "PresenterOption",
    "ScreenOption",
    "SkipTimingCheckOption",
    "SubjectOption",
    "TakeOverLockOption",
    "check_presenter",
    "confirm_take_over",
    "report_if_complete",
]

#: The subject's screens: a window in its own process, GL rendering into memory, or none.
PRESENTERS: tuple[str, ...] = ("process", "offscreen", "none")

SubjectOption = Annotated[str, typer.Option("--subject", help="Subject code, e.g. S01.")]
DataOption = Annotated[Path, typer.Option("--data", "-d", help="The study's SQLite trial log.")]
NewSessionOption = Annotated[
    str | None,
    typer.Option(
        "--new-session",
        metavar="REASON",
        help="Start a further session for a subject whose session is complete; the reason is "
        'logged, e.g. --new-session "re-test after new glasses". Without it a complete '
        "subject's session is reported, not run again.",
    ),
]
TakeOverLockOption = Annotated[
    str | None,
    typer.Option(
        "--take-over-lock",
        metavar="REASON",
        help="Resume a subject's unfinished session whose lock names another host (this "
        "machine was renamed: a laptop on another network, a new container) after making sure "
        "no program there runs it; asks to confirm on a terminal, and logs who took it over "
        'and why, e.g. --take-over-lock "laptop renamed on the clinic network". A session '
        "open in a live process on this host is still refused.",
    ),
]
ScreenOption = Annotated[
    int | None, typer.Option("--screen", min=0, help="Screen index of the subject's window.")
]
FullscreenOption = Annotated[
    bool, typer.Option("--fullscreen/--window", help="Subject's window full screen or windowed.")
]
PresenterOption = Annotated[
    str,
    typer.Option(
        "--presenter",
        envvar="CONFOCAL_PRESENTER",
        help="process (a window, in its own process), offscreen (no window: GL renders into "
        "memory), or none.",
    ),
]
SkipTimingCheckOption = Annotated[
    bool,
    typer.Option(
        "--skip-timing-check",
        help="Start even if the frame-timing self-test fails (the choice is logged).",
    ),
]


def check_presenter(presenter: str) -> None:
    """Refuse a ``--presenter`` that is not one of :data:`PRESENTERS`.

    Raises
    ------
    ConfocalError
        Naming ``--presenter``, the choices and the value given.
    """
    if presenter not in PRESENTERS:
        raise ConfocalError(
            f"--presenter must be one of {', '.join(PRESENTERS)}; got {presenter!r}"
        )


def confirm_take_over(data: Path, subject: str, reason: str | None) -> None:
    """Check a ``--take-over-lock`` reason; on a terminal, show the lock and ask to confirm.

    Reads only. Nothing is asked when ``reason`` is None, the log or the subject's unfinished
    session does not exist, or it has no lock; without a terminal (stdin or stdout not a tty)
    the option alone is the operator's confirmation.

    Raises
    ------
    TrialLogError
        A blank or multi-line reason.
    ConfocalError
        The operator did not confirm (nothing was changed).
    """
    import sys

    from experiment.log import TrialLog
    from experiment.log.locks import check_take_over_reason
    from stimuli.flagnames import cli_flags

    with cli_flags():  # the library names the parameter; the command line its flag
        check_take_over_reason(reason)
    if reason is None or not data.is_file() or data.stat().st_size == 0:
        return
    with TrialLog(data, readonly=True) as log:
        row = log.unfinished_session(subject)
        if row is None:
            return
        held = [r for r in log.locks() if r["session_id"] == row["session_id"]]
    if not held or not (sys.stdin.isatty() and sys.stdout.isatty()):
        return
    lock = held[0]
    typer.echo(
        f"session {row['session_id']} of {subject} is locked by pid {lock['pid']} on host "
        f"{lock['host']} since {lock['acquired_at']}. Take it over only if no program on "
        f"{lock['host']} runs it any more; reason: {reason}"
    )
    if not typer.confirm("Take over the lock?", default=False):
        raise ConfocalError("--take-over-lock: not confirmed; nothing was changed")


def report_if_complete(data: Path, subject: str, new_session: str | None) -> bool:
    """Print that SUBJECT's session is complete and return True, or return False; reads only.

    Opens the log read-only (nothing is written, migrated or checkpointed), so running a
    completed subject's command again -- the recovery after a crash -- changes nothing. False
    when the subject has an unfinished session, no session, or ``new_session`` asks for one.

    Raises
    ------
    TrialLogError
        The file is not a trial log, or ``new_session`` is given while another session of
        the subject is unfinished.
    """
    from experiment.log import TrialLog

    if not data.exists() or (data.is_file() and data.stat().st_size == 0):
        return False
    with TrialLog(data, readonly=True) as log:
        decision, row = log.session_to_open(subject, new_session=new_session)
        if decision != "complete":
            return False
        typer.echo(log.complete_message(row))
    return True
