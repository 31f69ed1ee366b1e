"""The study's status, read from its trial log: sessions, subjects, progress, locks, agreement.

``confocal session status`` prints it (:mod:`experiment.commands.session`), as text or JSON.
"""

from __future__ import annotations

import itertools
from pathlib import Path

__all__ = ["status_report"]


def status_report(path: Path) -> dict:
    """Return the study's status: sessions, subjects, progress, next trial, locks, agreement.

    Parameters
    ----------
    path : Path
        The study's SQLite trial log (opened read-only).

    Returns
    -------
    dict
        ``{"sessions": [...], "subjects": [...], "raters": [...], "kappa": [...]}``; each
        session has ``answered``, ``planned``, ``left`` and ``next`` (the first unanswered trial
        or None; None for active search), ``new_session`` (the reason for a further
        session, or None) and ``lock`` (the process that has it open: ``pid``, ``host``,
        ``acquired_at`` and ``stale`` -- True when that process is gone, None when it runs on
        another host; None for a completed session, which no process holds); each subject has
        ``complete`` (its latest session is), that ``session``, ``sessions`` (how many),
        ``answered``, ``planned`` and ``ended_at``.
    """
    from experiment.log import TrialLog
    from experiment.log.locks import lock_is_stale
    from experiment.session.scoring import cohen_kappa

    with TrialLog(path, readonly=True) as log:
        locks = {r["session_id"]: r for r in log.locks()}
        out = []
        for s in log.sessions():
            sid = s["session_id"]
            answered, planned = log.session_progress(sid)  # recognition or active search
            nxt = log.execute(
                "SELECT trial_index, part, block, object, condition, level FROM schedule "
                "WHERE session_id = ? AND trial_index NOT IN "
                "(SELECT trial_index FROM trials WHERE session_id = ?) "
                "ORDER BY trial_index LIMIT 1",
                (sid, sid),
            )
            crashes = log.execute(
                "SELECT count(*) FROM events WHERE session_id = ? AND kind = 'crash'", (sid,)
            )[0][0]
            out.append(
                {
                    "session": sid,
                    "subject": s["subject"],
                    "protocol": s["protocol_name"],
                    "status": s["status"],
                    "answered": answered,
                    "planned": planned,
                    "left": planned - answered,
                    "next": dict(nxt[0]) if nxt else None,
                    "started_at": s["started_at"],
                    "ended_at": s["ended_at"],
                    "crashes": int(crashes),
                    "observer": s.get("observer"),
                    "new_session": log.new_session_reason(sid),
                    "lock": (
                        {k: locks[sid][k] for k in ("pid", "host", "acquired_at")}
                        | {"stale": lock_is_stale(dict(locks[sid]))}
                        # a completed session is open in no process: a row left by a run of
                        # an older version killed after the completion is not a lock
                        if sid in locks and s["status"] != "completed"
                        else None
                    ),
                }
            )
        raters = [r[0] for r in log.execute("SELECT DISTINCT rater FROM scores ORDER BY rater")]
        kappas = []
        for a, b in itertools.combinations(raters, 2):
            k = cohen_kappa(log, a, b)
            if k.n > 0:
                kappas.append(k.to_dict())
    subjects: dict[str, dict] = {}
    for s in out:  # oldest first: the last one seen is the subject's latest session
        subjects[s["subject"]] = {
            "subject": s["subject"],
            "complete": s["status"] == "completed",
            "session": s["session"],
            "sessions": subjects.get(s["subject"], {}).get("sessions", 0) + 1,
            "answered": s["answered"],
            "planned": s["planned"],
            "ended_at": s["ended_at"],
        }
    return {"sessions": out, "subjects": list(subjects.values()), "raters": raters, "kappa": kappas}
