"""Participant metadata and the Psych-DS export of a trial log (issue 15, point 2).

``confocal session export study.sqlite --out DATASET`` writes a Psych-DS 1.x dataset::

    DATASET/
      dataset_description.json   schema.org Dataset: name, description, variableMeasured, ...
      participants.tsv           one row per subject: participant_id, simulated, observer and
                                 the metadata entered with ``session run --participant``
      data/
        study-<name>_subject-<id>_session-<n>_data.csv   one file per session
      documentation/
        sessions.json            provenance per session: protocol and stimulus-set sha256,
                                 seed, software version, monitor profile (no host paths)

File names follow Psych-DS's keyword rule (``key-value`` pairs joined by ``_``, keys lower-case
letters, values letters and digits, ending ``_data.csv``); subject codes and study names are
reduced to their letters and digits there (the ``subject`` column keeps the code as logged).
A second export into the same folder *merges*: keys a person added to
``dataset_description.json`` (authors, licence, a better description) are kept, the generated
ones refreshed; rows of ``participants.tsv`` and data files of other sessions are kept.

Columns of each data file (``COLUMN_DESCRIPTIONS`` is the data dictionary, copied into
``variableMeasured``):

=====================  ==========================================================================
``operator_rt_s``      the *operator's* first keystroke after stimulus onset, seconds: not the
                       subject's response time (nobody times the spoken answer here)
``date``               when the trial was recorded, UTC, ISO 8601
``frame_rate_hz``      the subject screen's measured refresh rate during the trial
``stimulus_file``      the image shown, relative to the stimulus set, and its ``stimulus_sha256``
``simulated``          1 if a simulated observer answered (``observer`` names it), else 0
=====================  ==========================================================================
"""

from __future__ import annotations

import csv
import io
import json
import re
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError

__all__ = [
    "COLUMN_DESCRIPTIONS",
    "EXPORT_COLUMNS",
    "DATAFILE_RE",
    "ParticipantError",
    "parse_participant",
    "keyword_value",
    "datafile_name",
    "export_dataset",
]

#: The data dictionary: every exported column and what it holds (units in the name, H8).
COLUMN_DESCRIPTIONS: dict[str, str] = {
    "subject": "Subject code as logged.",
    "session": "Session id in the trial log.",
    "trial_index": "Position in the subject's saved schedule, 0-based.",
    "part": "training or main (analyse main only).",
    "block": "Block number in the schedule.",
    "object": "Object id (objects.csv of the stimulus set).",
    "object_name": "Object name (the correct answer).",
    "condition": "cluttered, decluttered or photo (training only).",
    "level": "Resolution level, 1 = fewest pixels (12x8) ... 8 = full 492x327.",
    "window": "Compression window side, pixels.",
    "pixels": "Pixels of the stimulus (width x height).",
    "response": "The subject's words as typed by the operator ('' for a pass).",
    "score": "named, use, shape, wrong or pass (latest score of the primary rater).",
    "rater": "Who gave that score.",
    "recognized": "1 if the latest score of the primary rater counts as recognised, else 0.",
    "operator_rt_s": (
        "Seconds from stimulus onset to the operator's first keystroke (not the subject's "
        "response time)."
    ),
    "date": "When the trial was recorded (UTC, ISO 8601).",
    "frame_rate_hz": "Measured refresh rate of the subject's screen during the trial, Hz.",
    "onset_s": "Stimulus onset on the session clock, seconds.",
    "dropped_frames": "Frames dropped while the stimulus was shown.",
    "stimulus_file": "The image shown, relative to the stimulus set folder.",
    "stimulus_sha256": "SHA-256 of the image file shown.",
    "simulated": "1 if a simulated observer answered (no person), else 0.",
    "observer": "The simulated observer's name, or 'human'.",
    "viewings": "Times the stimulus was shown (each onset is logged when the frame is shown); 0 "
    "for trials logged before onsets were recorded.",
    "repeat_viewing": "1 if the subject saw this stimulus more than once (a crash between onset "
    "and answer, then a resume that showed it again), else 0.",
    "voice_rt_s": "Seconds from stimulus onset to the subject's voice onset, detected in the "
    "recorded answer (experiment.audio.voice; blank without a recording or without speech).",
    "audio_file": "The recorded spoken answer, relative to the trial log's folder (blank when "
    "not recorded).",
    "audio_sha256": "SHA-256 of the recorded answer's file.",
}

#: Columns of every data file, in order.
EXPORT_COLUMNS: tuple[str, ...] = tuple(COLUMN_DESCRIPTIONS)

#: Psych-DS 1.x data file names (schema ``Datafile.fileRegex``), anchored.
DATAFILE_RE = re.compile(r"^([a-z]+-[a-zA-Z0-9]+)(_[a-z]+-[a-zA-Z0-9]+)*_data\.csv$")

_KEY_RE = re.compile(r"^[a-z][a-z0-9_]*$")

#: schema.org/Psych-DS keys this export writes; on re-export these are refreshed, every other
#: key in an existing dataset_description.json is kept as the person wrote it.
_GENERATED_KEYS = ("@context", "@type", "schemaVersion", "variableMeasured", "dateModified")

_SQL = """
SELECT s.subject AS subject, t.session_id AS session, t.trial_index AS trial_index,
       p.part AS part, p.block AS block, t.object AS object, p.object_name AS object_name,
       t.condition AS condition, t.level AS level, p.window AS window, t.pixels AS pixels,
       t.response AS response, v.score AS score, v.rater AS rater, v.recognized AS recognized,
       t.rt_s AS operator_rt_s, t.recorded_at AS date, t.refresh_hz AS frame_rate_hz,
       t.onset_s AS onset_s, t.dropped_frames AS dropped_frames, p.path AS stimulus_file,
       t.stimulus_sha256 AS stimulus_sha256, v.simulated AS simulated, v.observer AS observer,
       v.viewings AS viewings, v.repeat_viewing AS repeat_viewing,
       a.voice_rt_s AS voice_rt_s, a.path AS audio_file, a.sha256 AS audio_sha256
FROM trials t
JOIN sessions s ON s.session_id = t.session_id
JOIN schedule p ON p.session_id = t.session_id AND p.trial_index = t.trial_index
JOIN tidy_trials v ON v.session = t.session_id AND v.trial_index = t.trial_index
LEFT JOIN audio a ON a.session_id = t.session_id AND a.trial_index = t.trial_index
ORDER BY t.session_id, t.trial_index
"""


class ParticipantError(ConfocalError):
    """Participant metadata is malformed (one line naming the key)."""


def parse_participant(text: str) -> dict[str, str | float]:
    """Parse ``--participant`` metadata: ``key=value`` pairs separated by commas.

    Keys are lower-case identifiers (``age``, ``sex``, ``acuity_logmar``, ``consent``); values
    are text without tabs or newlines, except ``age``, which must be a number of years in
    [0, 130].

    Examples
    --------
    >>> parse_participant("age=31, sex=F,acuity=20/200")
    {'age': 31.0, 'sex': 'F', 'acuity': '20/200'}

    Raises
    ------
    ParticipantError
        A pair without ``=``, a bad or repeated key, an empty value or a bad age.
    """
    out: dict[str, str | float] = {}
    for item in str(text).split(","):
        if not item.strip():
            continue
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep:
            raise ParticipantError(f"--participant must be KEY=VALUE[,KEY=VALUE...], got {item!r}")
        if not _KEY_RE.match(key) or key == "participant_id":
            raise ParticipantError(
                f"--participant key must be lower-case letters, digits and _ (not "
                f"participant_id), got {key!r}"
            )
        if key in out:
            raise ParticipantError(f"--participant key {key!r} is given twice")
        if not value or any(c in value for c in "\t\n\r"):
            raise ParticipantError(
                f"--participant {key} must be a non-empty value without tabs, got {value!r}"
            )
        if key == "age":
            try:
                age = float(value)
            except ValueError:
                raise ParticipantError(
                    f"--participant age must be a number of years, got {value!r}"
                ) from None
            if not 0 <= age <= 130:
                raise ParticipantError(f"--participant age must be in [0, 130], got {value!r}")
            out[key] = age
        else:
            out[key] = value
    if not out:
        raise ParticipantError(f"--participant needs at least one KEY=VALUE, got {text!r}")
    return out


def keyword_value(text: str) -> str:
    """Return ``text`` reduced to letters and digits, as a Psych-DS keyword value must be.

    Examples
    --------
    >>> keyword_value("S-01_b")
    'S01b'
    """
    value = re.sub(r"[^a-zA-Z0-9]", "", str(text))
    if not value:
        raise ValueError(f"text must contain a letter or digit for a file name, got {text!r}")
    return value


def datafile_name(study: str, subject: str, session: int) -> str:
    """Return ``study-<study>_subject-<subject>_session-<n>_data.csv``."""
    return (
        f"study-{keyword_value(study)}_subject-{keyword_value(subject)}_"
        f"session-{int(session)}_data.csv"
    )


def _csv_text(rows: list[dict[str, Any]], columns: tuple[str, ...]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: "" if r[k] is None else r[k] for k in columns})
    return buf.getvalue()


def _write(path: Path, text: str) -> None:
    from stimuli.io import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _tsv_value(v: Any) -> str:
    if v is None or v == "":
        return "n/a"
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return str(v).replace("\t", " ").replace("\n", " ")


def _read_tsv(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def _participants(sessions: list[dict[str, Any]], old: list[dict[str, str]]) -> str:
    rows: dict[str, dict[str, str]] = {r["participant_id"]: dict(r) for r in old}
    for s in sessions:  # oldest first: a later session's metadata wins
        meta = json.loads(s["participant_json"]) if s.get("participant_json") else {}
        row = rows.setdefault(s["subject"], {"participant_id": s["subject"]})
        row["simulated"] = "1" if s.get("observer") else "0"
        row["observer"] = s.get("observer") or "human"
        row.update({k: _tsv_value(v) for k, v in meta.items()})
    columns = ["participant_id", "simulated", "observer"]
    for r in rows.values():
        columns += [k for k in r if k not in columns]
    lines = ["\t".join(columns)]
    for pid in sorted(rows):
        lines.append("\t".join(_tsv_value(rows[pid].get(c)) for c in columns))
    return "\n".join(lines) + "\n"


def _session_record(s: dict[str, Any], data_file: str) -> dict[str, Any]:
    keep = (
        "session_id",
        "subject",
        "protocol_name",
        "protocol_sha256",
        "protocol_file_sha256",
        "stimset_manifest_sha256",
        "seed",
        "primary_rater",
        "software_version",
        "git_commit",
        "started_at",
        "ended_at",
        "status",
        "observer",
    )
    rec = {k: s.get(k) for k in keep}
    rec["simulated"] = bool(s.get("observer"))
    rec["observer_params"] = json.loads(s["observer_params"]) if s.get("observer_params") else None
    rec["display"] = json.loads(s["display_json"])
    monitor = json.loads(s["monitor_json"]) if s.get("monitor_json") else None
    if monitor is not None:  # the profile's file name only: no host paths in a shared dataset
        monitor["path"] = Path(monitor.get("path", "")).name
    rec["monitor"] = monitor
    rec["data_file"] = data_file
    return rec


def export_dataset(data: str | Path, out_dir: str | Path, *, study: str | None = None) -> dict:
    """Write (or update) a Psych-DS dataset folder from a trial log.

    Parameters
    ----------
    data : str or Path
        The study's SQLite trial log (opened read-only).
    out_dir : str or Path
        The dataset folder (created if missing; an existing one is merged into).
    study : str, optional
        Study name for the ``study-`` keyword (letters and digits are kept); default: the trial
        log's file name without extension.

    Returns
    -------
    dict
        ``{"files": [data file paths], "sessions": n, "simulated_sessions": [ids]}``.

    Raises
    ------
    TrialLogError
        The trial log is missing or unreadable.
    ValueError
        ``study`` has no letter or digit.
    """
    from experiment.triallog import TrialLog, TrialLogError

    data = Path(data)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise TrialLogError(f"--out {out}: exists and is not a folder (a dataset is a folder)")
    study = keyword_value(study if study is not None else data.stem)
    from experiment.triallog import MIGRATIONS

    with TrialLog(data, readonly=True) as log:
        old = log.schema_version() < max(m[0] for m in MIGRATIONS)
    if old:  # an older log is upgraded in place first: migrations only add tables and columns
        with TrialLog(data):
            pass
    with TrialLog(data, readonly=True) as log:
        rows = [dict(r) for r in log.execute(_SQL)]
        sessions = log.sessions()
    by_session: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_session.setdefault(int(r["session"]), []).append(r)
    files, records = [], []
    for s in sessions:
        sid = int(s["session_id"])
        name = datafile_name(study, s["subject"], sid)
        records.append(_session_record(s, f"data/{name}" if sid in by_session else None))
        if sid in by_session:
            files.append((out / "data" / name, _csv_text(by_session[sid], EXPORT_COLUMNS)))
    simulated = [int(s["session_id"]) for s in sessions if s.get("observer")]

    desc_path = out / "dataset_description.json"
    old: dict[str, Any] = {}
    if desc_path.is_file():
        try:
            old = json.loads(desc_path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise TrialLogError(
                f"{desc_path}: existing dataset_description.json is not valid JSON ({exc}); "
                "fix or remove it, nothing was written"
            ) from None
        if not isinstance(old, dict):
            raise TrialLogError(f"{desc_path}: existing dataset_description.json is not an object")
    now = datetime.now(UTC).isoformat(timespec="seconds")
    sim_note = (
        " Simulated sessions (no person answered): "
        + ", ".join(
            f"{s['session_id']} ({s['subject']}, {s['observer']})"
            for s in sessions
            if s.get("observer")
        )  # fmt: skip
        + "."
        if simulated
        else ""
    )
    generated: dict[str, Any] = {
        "@context": "https://schema.org/",
        "@type": "Dataset",
        "name": f"Object recognition with compressed, cluttered and de-cluttered images ({study})",
        "description": (
            "Trials exported from a confocal trial log (Jung et al. 2015 paradigm): one file per "
            "session, one row per answered trial; 'recognized' from the primary rater's latest "
            "score." + sim_note
        ),
        "schemaVersion": "Psych-DS 1.0.0",
        "dateCreated": now,
        "dateModified": now,
        "keywords": ["psychophysics", "object recognition", "visual prosthesis"]
        + (["simulated data"] if simulated else []),
        "variableMeasured": [
            {"@type": "PropertyValue", "name": c, "description": d}
            for c, d in COLUMN_DESCRIPTIONS.items()
        ],
    }
    desc = dict(old)
    for key, value in generated.items():
        if key in _GENERATED_KEYS or key not in desc:
            desc[key] = value
    if simulated and "simulated data" not in desc.get("keywords", []):
        desc["keywords"] = [*desc.get("keywords", []), "simulated data"]
    old_vars = [v for v in old.get("variableMeasured", []) if isinstance(v, dict)]
    ours = {c for c in COLUMN_DESCRIPTIONS}
    desc["variableMeasured"] = generated["variableMeasured"] + [
        v for v in old_vars if v.get("name") not in ours
    ]

    sessions_path = out / "documentation" / "sessions.json"
    old_records = []
    if sessions_path.is_file():
        try:
            old_records = json.loads(sessions_path.read_text(encoding="utf-8")).get("sessions", [])
        except (json.JSONDecodeError, AttributeError, UnicodeDecodeError):
            old_records = []
    mine = {(r["subject"], r["session_id"]) for r in records}
    merged_records = [
        r for r in old_records if (r.get("subject"), r.get("session_id")) not in mine
    ] + records
    participants = _participants(sessions, _read_tsv(out / "participants.tsv"))

    # everything is built; now write, all files or none (a full disk leaves the old dataset)
    from stimuli.io import staged_folder

    with staged_folder(out, what="the dataset") as tmp:
        for path, text in files:
            _write(tmp / path.relative_to(out), text)
        _write(tmp / "participants.tsv", participants)
        _write(
            tmp / sessions_path.relative_to(out),
            json.dumps({"trial_log": data.name, "sessions": merged_records}, indent=2) + "\n",
        )
        _write(tmp / desc_path.relative_to(out), json.dumps(desc, indent=2) + "\n")
    return {
        "files": [str(p) for p, _ in files],
        "sessions": len(sessions),
        "simulated_sessions": simulated,
    }
