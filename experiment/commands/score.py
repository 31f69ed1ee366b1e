"""The second rater's command: ``confocal score``.

``confocal score study.sqlite --rater B`` lets a second rater walk through the logged responses
and score them, blind to the first rater's scores; each score is appended to the log.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from experiment.errors import ConfocalError
from stimuli.resources import MAX_ID_CHARS

__all__ = ["register", "pending_for_rater"]


def pending_for_rater(
    log, rater: str, *, session_id: int | None = None, include_training: bool = False
) -> list[dict]:
    """Return the answered trials ``rater`` has not scored yet (oldest first), without any scores.

    Each dict has ``session_id, subject, trial_index, part, object, object_name, condition,
    level, response``: what a blind second rater needs, and nothing about the first rater's
    scores. Only main-part trials unless ``include_training`` (training answers are not
    analysed, so agreement on them is rarely needed).
    """
    sql = (
        "SELECT t.session_id, s.subject, t.trial_index, p.part, t.object, p.object_name, "
        "t.condition, "
        "t.level, t.response FROM trials t "
        "JOIN sessions s ON s.session_id = t.session_id "
        "JOIN schedule p ON p.session_id = t.session_id AND p.trial_index = t.trial_index "
        "WHERE NOT EXISTS (SELECT 1 FROM scores q WHERE q.session_id = t.session_id "
        "AND q.trial_index = t.trial_index AND q.rater = ?)"
    )
    params: list = [rater]
    if session_id is not None:
        sql += " AND t.session_id = ?"
        params.append(session_id)
    if not include_training:
        sql += " AND p.part = 'main'"
    sql += " ORDER BY t.session_id, t.trial_index"
    return [dict(r) for r in log.execute(sql, tuple(params))]


def register(app: typer.Typer) -> None:
    """Add ``score`` to the root ``confocal`` app."""

    def _isatty(f) -> bool:
        try:
            return f is not None and f.isatty()
        except (AttributeError, ValueError):  # replaced or closed stream
            return False

    @app.command("score")
    def score(
        log_path: Annotated[Path, typer.Argument(help="The study's trial log (SQLite).")],
        rater: Annotated[str, typer.Option(help="Your rater name (not the operator's).")],
        session_id: Annotated[int | None, typer.Option("--session", help="Only this one.")] = None,
        include_training: Annotated[
            bool,
            typer.Option(
                "--include-training", help="Score training trials too (main only by default)."
            ),
        ] = False,
    ) -> None:
        """Score logged responses as a second rater, blind to the first rater's scores."""
        from experiment.log import TrialLog

        if not log_path.is_file():
            raise ConfocalError(f"{log_path}: trial log not found")
        if not rater.strip() or rater != rater.strip():
            raise ConfocalError(f"--rater must be a name without surrounding spaces, got {rater!r}")
        if len(rater) > MAX_ID_CHARS:
            raise ConfocalError(
                f"--rater must be at most {MAX_ID_CHARS} characters, got {len(rater)} "
                f"({rater[:20]!r}...)"
            )
        with TrialLog(log_path, readonly=True) as ro:  # check before the log is opened to write
            ids = [s["session_id"] for s in ro.sessions()]
            if session_id is not None and session_id not in ids:
                raise ConfocalError(
                    f"{log_path}: --session {session_id} does not exist; expected one of "
                    f"{', '.join(map(str, ids)) or '(no sessions yet)'}"
                )
            to_score = pending_for_rater(
                ro, rater, session_id=session_id, include_training=include_training
            )
        # Scoring is interactive: without a terminal (a pipe, cron, a CI job) the screen would
        # wait forever for keys that never come.
        no_tty = [n for n, f in (("stdin", sys.stdin), ("stdout", sys.stdout)) if not _isatty(f)]
        if to_score and no_tty:
            raise ConfocalError(
                f"score: {' and '.join(no_tty)} {'is' if len(no_tty) == 1 else 'are'} not a "
                f"terminal; {len(to_score)} trial(s) wait for {rater!r}: run 'confocal score' "
                "in an interactive terminal"
            )
        with TrialLog(log_path) as log:
            pending = pending_for_rater(
                log, rater, session_id=session_id, include_training=include_training
            )
            if not pending:
                answered = log.execute("SELECT COUNT(*) AS n FROM trials")[0]["n"]
                left_training = (
                    0
                    if include_training
                    else len(
                        pending_for_rater(log, rater, session_id=session_id, include_training=True)
                    )
                )
                typer.echo(
                    "nothing to score: the log has no answered trials yet"
                    if not answered
                    else f"nothing to score: every answered main trial has a score by {rater!r}"
                    + (
                        f" ({left_training} training trial(s) left: --include-training)"
                        if left_training
                        else ""
                    )
                )
                return
            typer.echo(
                f"{len(pending)} {'' if include_training else 'main '}trial(s) to score",
                err=True,
            )
            from experiment.console import ScoringApp

            done = ScoringApp(log, rater, pending).run() or 0
            typer.echo(f"{done} trial(s) scored by {rater!r}; {len(pending) - done} left")
