"""Write a trial table into a real (empty) confocal trial log, for tests that read SQLite input.

The analysis reads only files that identify as confocal trial logs, from their base tables; a
test that wants its own trials in SQLite form writes them here: one session per subject (or per
``session`` value), each row a scheduled, answered trial with one primary score.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pandas as pd

__all__ = ["write_trial_log"]


def write_trial_log(path: Path, trials: pd.DataFrame) -> Path:
    """Write ``trials`` (``subject, object, condition, pixels, recognized`` and optionally
    ``part``, ``level``, ``session``, ``response``) as a confocal trial log at ``path``."""
    from experiment.log import TrialLog

    TrialLog(path).close()  # the real schema, application id and migrations
    con = sqlite3.connect(path)
    sessions: dict[tuple, int] = {}
    next_index: dict[int, int] = {}
    for r in trials.to_dict("records"):
        key = (r["subject"], r.get("session", 1))
        if key not in sessions:
            cur = con.execute(
                "INSERT INTO sessions (subject, protocol_name, protocol_sha256, protocol_json, "
                "display_json, stimset_path, stimset_manifest_sha256, seed, primary_rater, "
                "started_at, status) VALUES (?, 'test', '0', '{}', '{}', '.', '0', '1', "
                "'operator', '2024-01-01T00:00:00+00:00', 'completed')",
                (str(r["subject"]),),
            )
            sessions[key] = cur.lastrowid
        sid = sessions[key]
        i = next_index.get(sid, 0)
        next_index[sid] = i + 1
        level = int(r.get("level", 1))
        con.execute(
            "INSERT INTO schedule VALUES (?, ?, ?, 0, ?, ?, ?, ?, 40, ?, 'x.png', '0', 0, 0, 0)",
            (sid, i, r.get("part", "main"), str(r["object"]), str(r["object"]),
             r["condition"], level, r["pixels"]),
        )  # fmt: skip
        con.execute(
            "INSERT INTO trials (session_id, trial_index, object, condition, level, pixels, "
            "stimulus_sha256, response, rt_s, recorded_at) VALUES (?, ?, ?, ?, ?, ?, '0', ?, "
            "1.0, '2024-01-01T00:00:01+00:00')",
            (sid, i, str(r["object"]), r["condition"], level, r["pixels"],
             str(r.get("response", ""))),
        )  # fmt: skip
        con.execute(
            "INSERT INTO scores (session_id, trial_index, score, recognized, rater, is_primary, "
            "scored_at) VALUES (?, ?, ?, ?, 'operator', 1, '2024-01-01T00:00:02+00:00')",
            (sid, i, "named" if int(r["recognized"]) else "wrong", int(r["recognized"])),
        )
    con.commit()
    con.close()
    return path
