"""Append-only SQLite storage of an active-search session's events (table ``active_events``).

Every input event and every displayed state of an active-search trial is one row, stamped with
the session clock and committed before the next one is produced (crash-safe: WAL,
``synchronous=FULL``, one transaction per row; the answer and its score share one). Rows are
numbered by ``seq`` (0, 1, 2, ... per session; ``UNIQUE(session_id, seq)``), so a lost or
duplicated event is detectable.

Payloads (JSON objects) by kind
-------------------------------
=====================  ===========================================================================
``plan``               ``trials``: list of ``{index, target, condition, repetition, scene}``
                       (+ ``layout``, ``scene_seed`` for a randomised scene); ``task``: the
                       ``[task]`` table; ``scenes``: per fixed scene ``{sha256, planes_px``
                       (detected planes, px per view step, nearest first), ``depth_step_px``,
                       ``scan_px`` ([nearest, farthest] disparity of the scan),
                       ``objects_px}``; ``counterbalance``: ``{scheme, subject_index,
                       condition_order}``. With one fixed scene also ``scene_sha256``,
                       ``planes_px``, ``depth_step_px``, ``scan_px``, ``objects_px`` at top
                       level. Trial NULL.
``trial_start``        ``target``, ``condition``, ``cue`` (text shown), ``searcher``, ``scene``,
                       ``scene_sha256``, ``planes_px``, ``depth_step_px``, ``objects_px``
                       (target -> true disparity, where known); a randomised scene adds
                       ``layout`` ({object: {x_frac, depth_m}}) and ``scene_seed``: the trial
                       is rebuilt exactly from them.
``key``                ``key`` (the key or input pressed), ``action`` (``depth_near``,
                       ``depth_far``, ``plane_next``, ``plane_prev``, ``zoom``, ``unzoom``,
                       ``answer``, ``pass``), ``box`` ([x, y, w, h], zoom only).
``state``              the displayed state: ``depth_px`` (the viewer state's ``disparity_px``;
                       the log keeps its field name), ``depth_m`` (or null), ``plane`` (index
                       of the detected plane shown, or null), ``zoom`` ([x, y, w, h] or null),
                       ``grid_px``, ``on_cells`` (implant cells on), ``implant`` (hex of the
                       packed grid bits).
``answer``             ``response`` (the subject's words), ``rt_s`` (from trial onset).
``score``              ``score``, ``recognized``, ``rater``, ``primary`` (bool).
``attempt_abandoned``  ``reason``: a resumed session restarts the trial whose attempt was cut.
=====================  ===========================================================================

A trial is *committed* when its ``answer`` row exists (written with its first ``score`` in one
transaction). Resume continues at the first uncommitted trial with ``attempt + 1``.
"""

from __future__ import annotations

import json
import sqlite3
from typing import Any

from experiment.log import TrialLog, TrialLogError, utc_now

__all__ = ["ActiveEventLog", "EVENT_KINDS"]

#: Kinds of ``active_events`` rows (see the module docstring for their payloads).
EVENT_KINDS: tuple[str, ...] = (
    "plan",
    "trial_start",
    "key",
    "state",
    "answer",
    "score",
    "attempt_abandoned",
)


class ActiveEventLog:
    """The ``active_events`` rows of one session in an open :class:`TrialLog`.

    Parameters
    ----------
    log : TrialLog
        Opened writable (migrated to a schema with ``active_events``).
    session_id : int
    """

    def __init__(self, log: TrialLog, session_id: int) -> None:
        self.log = log
        self.session_id = int(session_id)
        row = log.execute(
            "SELECT max(seq) FROM active_events WHERE session_id = ?", (self.session_id,)
        )[0]
        self._next_seq = 0 if row[0] is None else int(row[0]) + 1

    @property
    def next_seq(self) -> int:
        """Sequence number the next appended event gets."""
        return self._next_seq

    def append(
        self,
        kind: str,
        payload: dict[str, Any],
        t_s: float,
        *,
        trial: int | None = None,
        attempt: int = 0,
    ) -> int:
        """Append one event in its own durable transaction; return its ``seq``.

        Raises
        ------
        ValueError
            Unknown ``kind``, a payload that is not a JSON object, or a non-finite time.
        TrialLogError
            The row could not be written (e.g. a second writer took the same ``seq``).
        """
        with self.log.atomic():
            return self._insert(kind, payload, t_s, trial, attempt)

    def append_many(
        self, rows: list[tuple[str, dict[str, Any], float]], *, trial: int, attempt: int
    ) -> list[int]:
        """Append several events of one trial in one transaction (the answer and its score)."""
        with self.log.atomic():
            return [self._insert(k, p, t, trial, attempt) for k, p, t in rows]

    def _insert(
        self, kind: str, payload: dict[str, Any], t_s: float, trial: int | None, attempt: int
    ) -> int:
        if kind not in EVENT_KINDS:
            raise ValueError(f"kind must be one of {', '.join(EVENT_KINDS)}, got {kind!r}")
        if not isinstance(payload, dict):
            raise ValueError(f"payload must be a dict, got {type(payload).__name__}")
        t = float(t_s)
        if t != t or t in (float("inf"), float("-inf")):
            raise ValueError(f"t_s must be finite, got {t_s!r}")
        text = json.dumps(payload, sort_keys=True, allow_nan=False)
        seq = self._next_seq
        try:
            self.log._con.execute(  # noqa: SLF001 - same package family: the log's connection
                "INSERT INTO active_events (session_id, trial, attempt, seq, t_s, kind, payload, "
                "recorded_at) VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                (self.session_id, trial, int(attempt), seq, t, kind, text, utc_now()),
            )
        except sqlite3.IntegrityError as exc:
            raise TrialLogError(
                f"{self.log.path}: cannot append active event {seq} of session "
                f"{self.session_id} ({exc})"
            ) from None
        self._next_seq += 1
        return seq

    def rows(self) -> list[dict[str, Any]]:
        """Return the session's events in ``seq`` order, payloads decoded."""
        out = []
        for r in self.log.execute(
            "SELECT trial, attempt, seq, t_s, kind, payload FROM active_events "
            "WHERE session_id = ? ORDER BY seq",
            (self.session_id,),
        ):
            d = dict(r)
            d["payload"] = json.loads(d["payload"])
            out.append(d)
        return out

    def plan(self) -> dict[str, Any] | None:
        """Return the ``plan`` payload (None before it is written)."""
        r = self.log.execute(
            "SELECT payload FROM active_events WHERE session_id = ? AND kind = 'plan' "
            "ORDER BY seq LIMIT 1",
            (self.session_id,),
        )
        return json.loads(r[0][0]) if r else None

    def committed_trials(self) -> set[int]:
        """Return the trial indices that have an ``answer`` row."""
        return {
            int(r[0])
            for r in self.log.execute(
                "SELECT DISTINCT trial FROM active_events WHERE session_id = ? AND kind = 'answer'",
                (self.session_id,),
            )
        }

    def attempts(self, trial: int) -> int:
        """Return how many attempts of ``trial`` were started."""
        r = self.log.execute(
            "SELECT count(*) FROM active_events WHERE session_id = ? AND trial = ? "
            "AND kind = 'trial_start'",
            (self.session_id, int(trial)),
        )
        return int(r[0][0])

    def last_t_s(self) -> float | None:
        """Return the clock time of the latest event (None when there is none)."""
        r = self.log.execute(
            "SELECT t_s FROM active_events WHERE session_id = ? ORDER BY seq DESC LIMIT 1",
            (self.session_id,),
        )
        return float(r[0][0]) if r else None
