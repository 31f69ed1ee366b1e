"""Read-only queries of an open trial log: sessions, schedule, trials, scores, events, locks.

:class:`LogQueries` holds them; :class:`~experiment.log.triallog.TrialLog` inherits them, so a
log opened ``readonly=True`` (``session status``, ``session export``, a reader beside a running
session) answers every query below and refuses every write.
"""

from __future__ import annotations

import json
import sqlite3
from typing import Any

from experiment.log.errors import TrialLogError
from experiment.log.schema import SCHEDULE_COLUMNS
from experiment.trials import Schedule, Trial
from stimuli.flagnames import param

__all__ = ["LogQueries"]


class LogQueries:
    """The read-only queries of a trial log, on its open connection.

    Mixed into :class:`~experiment.log.triallog.TrialLog`, which opens ``_con`` (rows as
    :class:`sqlite3.Row`) and sets ``path``.
    """

    path: str
    _con: sqlite3.Connection

    def _reopen_after_write(self) -> bool:
        """Reopen a read-only connection that may have read the file while a writer changed it.

        Return whether it was reopened (then the query is run again). None here.
        """
        return False

    def _fetch(self, sql: str, params: tuple | dict = ()) -> list[sqlite3.Row]:
        """Run a read query; once more on a fresh connection if the file changed under it."""
        try:
            return self._con.execute(sql, params).fetchall()
        except sqlite3.OperationalError:
            raise
        except sqlite3.DatabaseError:
            if not self._reopen_after_write():
                raise
            return self._con.execute(sql, params).fetchall()

    def schema_version(self) -> int:
        """Return the highest applied migration number (0 for an empty file)."""
        try:
            row = self._fetch("SELECT max(version) FROM schema_migrations")[0]
        except sqlite3.OperationalError:
            return 0
        return int(row[0] or 0)

    def execute(self, sql: str, params: tuple | dict = ()) -> list[sqlite3.Row]:
        """Run a read query and return all rows (for status, export and tests)."""
        try:
            return self._fetch(sql, params)
        except sqlite3.DatabaseError as exc:
            raise TrialLogError(f"{self.path}: query failed ({exc})") from None

    def session(self, session_id: int) -> dict[str, Any]:
        """Return one ``sessions`` row as a dict."""
        rows = self.execute("SELECT * FROM sessions WHERE session_id = ?", (session_id,))
        if not rows:
            raise TrialLogError(f"{self.path}: no session {session_id}")
        return dict(rows[0])

    def sessions(self) -> list[dict[str, Any]]:
        """Return all ``sessions`` rows, oldest first."""
        return [dict(r) for r in self.execute("SELECT * FROM sessions ORDER BY session_id")]

    def unfinished_session(self, subject: str) -> dict[str, Any] | None:
        """Return the subject's latest ``open`` session, or None."""
        rows = self.execute(
            "SELECT * FROM sessions WHERE subject = ? AND status = 'open' "
            "ORDER BY session_id DESC LIMIT 1",
            (subject,),
        )
        return dict(rows[0]) if rows else None

    def new_session_reason(self, session_id: int) -> str | None:
        """Return the reason a session was started as a further session (None for a first)."""
        rows = self.execute(
            "SELECT note FROM events WHERE session_id = ? AND kind = 'new_session' "
            "ORDER BY event_id LIMIT 1",
            (session_id,),
        )
        return rows[0][0] if rows else None

    def session_progress(self, session_id: int) -> tuple[int, int]:
        """Return ``(answered, planned)`` trials of a recognition or an active-search session."""
        planned = self.planned_count(session_id)
        if planned:
            return self.answered_count(session_id), planned
        try:
            plans = self._fetch(
                "SELECT payload FROM active_events WHERE session_id = ? AND kind = 'plan' "
                "ORDER BY seq LIMIT 1",
                (session_id,),
            )
            if not plans:
                return 0, 0
            plan = plans[0]
            answered = self._fetch(
                "SELECT count(DISTINCT trial) FROM active_events "
                "WHERE session_id = ? AND kind = 'answer'",
                (session_id,),
            )[0][0]
        except sqlite3.OperationalError:  # a log from before active search
            return 0, 0
        return int(answered), len(json.loads(plan[0]).get("trials", []))

    def session_to_open(
        self, subject: str, *, new_session: str | None = None
    ) -> tuple[str, dict[str, Any] | None]:
        """Decide what running a subject's session does now; reads only.

        Parameters
        ----------
        subject : str
        new_session : str, optional
            The operator's reason for a further session (``--new-session REASON``). The reason
            names that session: the same command again resumes it or reports it complete.

        Returns
        -------
        (str, dict or None)
            ``("resume", row)``: the subject's unfinished session; ``("complete", row)``: the
            subject's session is complete (the latest one, or the one started with this
            reason) and nothing is to be run; ``("new", None)``: start a session.

        Raises
        ------
        TrialLogError
            ``new_session`` is given while another unfinished session exists.
        """
        open_row = self.unfinished_session(subject)
        if open_row is not None:
            sid = int(open_row["session_id"])
            if new_session is None or new_session == self.new_session_reason(sid):
                return "resume", open_row
            answered, planned = self.session_progress(sid)
            raise TrialLogError(
                f"{self.path}: subject {subject} has unfinished session {sid} ({answered}/"
                f"{planned} trials answered); finish it first: run the command without "
                f"{param('new_session')} to resume it"
            )
        done = self.execute(
            "SELECT * FROM sessions WHERE subject = ? AND status = 'completed' "
            "ORDER BY session_id DESC",
            (subject,),
        )
        if not done:
            return "new", None
        if new_session is None:
            return "complete", dict(done[0])
        for row in done:
            if self.new_session_reason(int(row["session_id"])) == new_session:
                return "complete", dict(row)
        return "new", None

    def complete_message(self, row: dict[str, Any]) -> str:
        """Return the line that reports a completed session: subject, date, trials answered."""
        sid = int(row["session_id"])
        answered, planned = self.session_progress(sid)
        day = (row.get("ended_at") or row.get("started_at") or "")[:10]
        reason = self.new_session_reason(sid)
        return (
            f"subject {row['subject']}: session {sid} is complete (ended {day} UTC, "
            f"{answered}/{planned} trials answered"
            + (f"; new session: {reason}" if reason else "")
            + f"); nothing was run or written. To run {row['subject']} again, add "
            "--new-session REASON"
        )

    # -- schedule and trials -------------------------------------------------------------------

    def read_schedule(self, session_id: int) -> Schedule:
        """Return the saved schedule of a session."""
        rows = self.execute(
            f"SELECT {', '.join(SCHEDULE_COLUMNS)} FROM schedule WHERE session_id = ? "
            "ORDER BY trial_index",
            (session_id,),
        )
        trials = []
        for r in rows:
            d = dict(r)
            d["index"] = d.pop("trial_index")
            trials.append(Trial.from_dict(d))
        return Schedule(trials)

    def viewings(self, session_id: int, trial_index: int) -> int:
        """Return how many onsets of a trial are logged (0 if never shown, or before schema 4)."""
        return int(
            self.execute(
                "SELECT count(*) FROM viewings WHERE session_id = ? AND trial_index = ?",
                (session_id, trial_index),
            )[0][0]
        )

    def last_committed_trial(self, session_id: int) -> int | None:
        """Return the highest answered ``trial_index`` of a session (None if none)."""
        row = self.execute(
            "SELECT max(trial_index) FROM trials WHERE session_id = ?", (session_id,)
        )[0]
        return None if row[0] is None else int(row[0])

    def answered_count(self, session_id: int) -> int:
        """Return the number of answered trials of a session."""
        return int(
            self.execute("SELECT count(*) FROM trials WHERE session_id = ?", (session_id,))[0][0]
        )

    def planned_count(self, session_id: int) -> int:
        """Return the number of planned trials of a session."""
        return int(
            self.execute("SELECT count(*) FROM schedule WHERE session_id = ?", (session_id,))[0][0]
        )

    def tidy_trials(self) -> list[dict[str, Any]]:
        """Return the ``tidy_trials`` view as a list of dicts (columns :data:`TIDY_COLUMNS`)."""
        return [dict(r) for r in self.execute("SELECT * FROM tidy_trials")]

    def latest_scores(self, rater: str) -> dict[tuple[int, int], str]:
        """Return ``{(session_id, trial_index): score}``: each trial's latest score by ``rater``."""
        rows = self.execute(
            "SELECT session_id, trial_index, score FROM scores WHERE rater = ? ORDER BY score_id",
            (rater,),
        )
        return {(r[0], r[1]): r[2] for r in rows}

    # -- events and locks ---------------------------------------------------------------------

    def events(self, session_id: int | None = None) -> list[dict[str, Any]]:
        """Return events (of one session, or all), oldest first."""
        if session_id is None:
            return [dict(r) for r in self.execute("SELECT * FROM events ORDER BY event_id")]
        return [
            dict(r)
            for r in self.execute(
                "SELECT * FROM events WHERE session_id = ? ORDER BY event_id", (session_id,)
            )
        ]

    def locks(self) -> list[dict[str, Any]]:
        """Return the current lock rows."""
        return [dict(r) for r in self.execute("SELECT * FROM locks ORDER BY session_id")]
