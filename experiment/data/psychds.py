"""Participant metadata and the Psych-DS export of a trial log, safe to share.

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
        participants.json        what each participants.tsv column means; columns that are not
                                 in :data:`PARTICIPANT_FIELDS` are flagged "undocumented"

File names follow Psych-DS's keyword rule (``key-value`` pairs joined by ``_``, keys lower-case
letters, values letters and digits, ending ``_data.csv``); subject codes and study names are
reduced to their letters and digits there (the ``subject`` column keeps the code as logged).
A second export into the same folder *merges*: keys a person added to
``dataset_description.json`` (authors, licence, a better description) are kept, the generated
ones refreshed; rows of ``participants.tsv`` and data files of other sessions are kept, and so
are Psych-DS's optional ``README``, ``CHANGES`` and ``LICENSE`` files a person adds
(:func:`is_optional_file`). The trials are read from the log's tables (the join of its
``tidy_trials`` view written out here), never through a view in the file.

What is and is not identifying:

* ``--participant`` takes the non-identifying fields of :data:`PARTICIPANT_FIELDS` (age, sex,
  gender, handedness, acuity, implant, eye, condition, group, consent code, ...). A field that
  looks identifying (:func:`identifying_reason`: a key such as ``name``, ``email``, ``phone``,
  ``address``, ``zip``, ``dob``, ``birth``, ``ssn``, ``mrn``; a value with an ``@``, a phone
  number or a full date) is refused unless ``session run --allow-identifying`` is given; even
  then it stays in the trial log and is exported only with ``session export
  --include-identifying``. Other keys (not documented, not identifying-looking) are kept and
  exported, and flagged as undocumented in ``documentation/participants.json`` and in the
  export's output, so that someone checks them before the dataset is shared.
* No wall-clock time is exported: each trial's ``time_s`` counts seconds from its session's
  start, and ``date`` is the session's day (``--dates day``), that day shifted by a number of
  days the exporter chooses (``--dates shift:N``; the shift itself is written nowhere), or
  blank (``--dates none``). ``sessions.json`` likewise has each session's ``date`` and
  ``duration_s`` instead of its start and end times, and ``dataset_description.json``'s
  ``dateCreated``/``dateModified`` are the export's day under the same rule (or left out).
* Subject codes are exported as logged; ``session run`` and ``active run`` accept only codes
  that follow :mod:`experiment.data.subjects` (no e-mail, phone number, date, name, path or
  control character). A log's codes from before that rule are named in the export's warning.
  Two codes that reduce to the same file-name keyword (``S_01``, ``S-01``, ``S01``, ``s01``)
  are refused, at export and when ``session run`` would add the second to a log.
* Typed answers are exported as typed; the export names the trials whose answer looks like an
  e-mail address or a phone number (:func:`identifying_answer`) so that someone checks them.
* Every text cell of the CSV/TSV files is formula-safe (``stimuli/tables.py``).

Columns of each data file (``COLUMN_DESCRIPTIONS`` is the data dictionary, copied into
``variableMeasured``):

=====================  ==========================================================================
``operator_rt_s``      the *operator's* first keystroke after stimulus onset, seconds: not the
                       subject's response time (nobody times the spoken answer here)
``date``               the session's day (UTC, ISO 8601), shifted or blank (``--dates``)
``time_s``             seconds from the session's start to when the trial was recorded
``frame_rate_hz``      the subject screen's measured refresh rate during the trial
``stimulus_file``      the image shown, relative to the stimulus set, and its ``stimulus_sha256``
``simulated``          1 if a simulated observer answered (``observer`` names it), else 0
=====================  ==========================================================================
"""

from __future__ import annotations

import csv
import json
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from experiment.data.identifying import identifying_answer, identifying_value
from experiment.data.subjects import subject_code_problem
from experiment.errors import ConfocalError
from stimuli.tables import table_text, unescape_row

__all__ = [
    "COLUMN_DESCRIPTIONS",
    "EXPORT_COLUMNS",
    "DATAFILE_RE",
    "PARTICIPANT_FIELDS",
    "ParticipantError",
    "SubjectCollision",
    "parse_participant",
    "identifying_reason",
    "identifying_value",
    "identifying_answer",
    "OPTIONAL_FILES",
    "is_optional_file",
    "identifying_fields",
    "check_not_identifying",
    "parse_dates",
    "subject_key",
    "check_subject_collisions",
    "keyword_value",
    "datafile_name",
    "export_dataset",
]

#: The documented, non-identifying participant fields (``--participant`` keys) and what they
#: hold. Ours: what vision-rehabilitation and prosthesis studies report about a participant
#: without naming them. Other keys are accepted unless they look identifying, and are flagged
#: as undocumented in the export.
PARTICIPANT_FIELDS: dict[str, str] = {
    "age": "Age, years (a number in [0, 130]).",
    "sex": "Sex as recorded by the study (e.g. F, M, X).",
    "gender": "Gender as stated by the participant.",
    "handedness": "L, R or ambidextrous.",
    "acuity": "Visual acuity as measured (e.g. 20/200).",
    "acuity_logmar": "Visual acuity, logMAR.",
    "acuity_eye": "Eye the acuity was measured in.",
    "implant": "Implant or prosthesis type (none for sighted participants).",
    "implant_years": "Years since implantation.",
    "eye": "Eye(s) tested: left, right or both.",
    "condition": "Participant condition (e.g. sighted, low vision, implanted).",
    "group": "Study group or arm.",
    "diagnosis": "Diagnosis category (e.g. RP, AMD), not free text.",
    "consent": "Consent form code or version (not a signature or a name).",
    "site": "Study site code.",
}

#: Key words that make a ``--participant`` key identifying (matched as ``_``-separated words of
#: the key, or anywhere in it for the longer ones).
_IDENTIFYING_WORDS = frozenset(
    "name first last surname firstname lastname fullname initials email mail phone tel "
    "telephone mobile cell fax address street city zip zipcode postcode postal dob birth "
    "birthday birthdate ssn mrn nhs passport".split()
)
_IDENTIFYING_PARTS = ("name", "mail", "phone", "address", "street", "postcode", "zipcode", "birth")

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
    "date": "The session's day (UTC, ISO 8601 date); shifted by a fixed number of days, or "
    "blank, as the exporter chose (no wall-clock time is exported).",
    "time_s": "Seconds from the session's start to when the trial was recorded.",
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
_ISO_DAY = re.compile(r"\d{4}-\d{2}-\d{2}")

#: Psych-DS's optional files at a dataset's top level, which a person may add to an exported
#: dataset (with or without an extension): kept by every later export, never listed as its own.
OPTIONAL_FILES: tuple[str, ...] = ("README", "CHANGES", "LICENSE")

#: schema.org/Psych-DS keys this export writes; on re-export these are refreshed, every other
#: key in an existing dataset_description.json is kept as the person wrote it.
_GENERATED_KEYS = ("@context", "@type", "schemaVersion", "variableMeasured", "dateModified")

#: How the description states the ``--dates`` rule (never the shift itself).
_DATES_NOTE = {
    "day": "the session's day",
    "shift": "the session's day shifted by a fixed number of days (not recorded here)",
    "none": "left blank",
}

#: The trials of every session, from the log's tables (the join of its ``tidy_trials`` view,
#: written out: a view in the file is never what the export reads).
_SQL = """
SELECT s.subject AS subject, t.session_id AS session, t.trial_index AS trial_index,
       p.part AS part, p.block AS block, t.object AS object, p.object_name AS object_name,
       t.condition AS condition, t.level AS level, p.window AS window, t.pixels AS pixels,
       t.response AS response, sc.score AS score, sc.rater AS rater, sc.recognized AS recognized,
       t.rt_s AS operator_rt_s, s.started_at AS date, t.recorded_at AS time_s,
       t.refresh_hz AS frame_rate_hz,
       t.onset_s AS onset_s, t.dropped_frames AS dropped_frames, p.path AS stimulus_file,
       t.stimulus_sha256 AS stimulus_sha256,
       CASE WHEN s.observer IS NULL THEN 0 ELSE 1 END AS simulated,
       COALESCE(s.observer, 'human') AS observer,
       (SELECT count(*) FROM viewings w
        WHERE w.session_id = t.session_id AND w.trial_index = t.trial_index) AS viewings,
       (SELECT count(*) > 1 FROM viewings w
        WHERE w.session_id = t.session_id AND w.trial_index = t.trial_index) AS repeat_viewing,
       a.voice_rt_s AS voice_rt_s, a.path AS audio_file, a.sha256 AS audio_sha256
FROM trials t
JOIN sessions s ON s.session_id = t.session_id
JOIN schedule p ON p.session_id = t.session_id AND p.trial_index = t.trial_index
JOIN scores sc ON sc.score_id = (
    SELECT max(q.score_id) FROM scores q
    WHERE q.session_id = t.session_id AND q.trial_index = t.trial_index AND q.is_primary = 1)
LEFT JOIN audio a ON a.session_id = t.session_id AND a.trial_index = t.trial_index
ORDER BY t.session_id, t.trial_index
"""


class ParticipantError(ConfocalError):
    """Participant metadata is malformed or identifying (one line naming the key)."""


class SubjectCollision(ConfocalError):
    """Two subject codes would be exported as one subject (one line naming both)."""


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
    return table_text(rows, columns)


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
        return [unescape_row(r) for r in csv.DictReader(f, delimiter="\t")]


def _participants(
    sessions: list[dict[str, Any]], old: list[dict[str, str]], include_identifying: bool
) -> tuple[str, list[str], list[str]]:
    """Return participants.tsv's text, the identifying keys left out and the columns."""
    rows: dict[str, dict[str, str]] = {r["participant_id"]: dict(r) for r in old}
    left_out: list[str] = []
    for s in sessions:  # oldest first: a later session's metadata wins
        meta = json.loads(s["participant_json"]) if s.get("participant_json") else {}
        if not include_identifying:
            for k in identifying_fields(meta):
                meta.pop(k)
                left_out.append(k)
        row = rows.setdefault(s["subject"], {"participant_id": s["subject"]})
        row["simulated"] = "1" if s.get("observer") else "0"
        row["observer"] = s.get("observer") or "human"
        row.update({k: _tsv_value(v) for k, v in meta.items()})
    columns = ["participant_id", "simulated", "observer"]
    for r in rows.values():
        columns += [k for k in r if k not in columns]
    text = table_text(
        [{c: _tsv_value(rows[pid].get(c)) for c in columns} for pid in sorted(rows)],
        columns,
        delimiter="\t",
    )
    return text, sorted(set(left_out)), columns


def _participants_json(columns: list[str]) -> dict[str, Any]:
    """``documentation/participants.json``: each participants.tsv column and what it holds."""
    fixed = {
        "participant_id": "Subject code as logged.",
        "simulated": "1 if a simulated observer answered (no person), else 0.",
        "observer": "The simulated observer's name, or 'human'.",
    }
    out: dict[str, Any] = {}
    for c in columns:
        if c in fixed or c in PARTICIPANT_FIELDS:
            out[c] = {"Description": fixed.get(c) or PARTICIPANT_FIELDS[c]}
        else:
            out[c] = {
                "Description": "Undocumented: entered with session run --participant, not one "
                "of the documented fields; check that it identifies nobody before sharing.",
                "Undocumented": True,
            }
    return out


def _no_host_paths(value: Any) -> Any:
    """``value`` with every absolute path (a string) replaced by its file name."""
    if isinstance(value, dict):
        return {k: _no_host_paths(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_no_host_paths(v) for v in value]
    if isinstance(value, str) and (value.startswith("/") or re.match(r"[A-Za-z]:[\\/]", value)):
        return Path(value).name
    return value


def _session_record(
    s: dict[str, Any], data_file: str | None, dates: tuple[str, int]
) -> dict[str, Any]:
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
        "status",
        "observer",
    )
    rec = {k: s.get(k) for k in keep}
    rec["simulated"] = bool(s.get("observer"))
    rec["date"] = _day(s.get("started_at"), dates) or None
    rec["duration_s"] = _seconds_between(s.get("started_at"), s.get("ended_at"))
    params = json.loads(s["observer_params"]) if s.get("observer_params") else None
    rec["observer_params"] = _no_host_paths(params)  # e.g. the exemplar's knowledge folder
    rec["display"] = json.loads(s["display_json"])
    monitor = json.loads(s["monitor_json"]) if s.get("monitor_json") else None
    if monitor is not None:  # the profile's file name only: no host paths in a shared dataset
        monitor["path"] = Path(monitor.get("path", "")).name
    rec["monitor"] = monitor
    rec["data_file"] = data_file
    return rec


def export_dataset(
    data: str | Path,
    out_dir: str | Path,
    *,
    study: str | None = None,
    dates: str = "day",
    include_identifying: bool = False,
) -> dict:
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
    dates : str
        How the session's day is exported (:func:`parse_dates`): ``day``, ``shift:N`` or
        ``none``. Times are always seconds from the session's start.
    include_identifying : bool
        Export participant fields that look identifying (:func:`identifying_reason`); without
        it they stay in the trial log only.

    Returns
    -------
    dict
        ``{"files": [data file paths], "sessions": n, "simulated_sessions": [ids],
        "identifying_left_out": [keys], "undocumented": [participants.tsv columns],
        "identifying_answers": ["session S trial T (why)"], "subject_codes_to_check":
        [codes that break the subject-code rule]}``.

    Raises
    ------
    TrialLogError
        The trial log is missing or unreadable.
    ParticipantError
        ``dates`` is not one of the forms above.
    SubjectCollision
        Two subject codes (in the log, or one in the log and one already in the dataset)
        would be exported as one subject; nothing is written.
    ValueError
        ``study`` has no letter or digit.
    """
    from experiment.log import TrialLog, TrialLogError

    data = Path(data)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise TrialLogError(f"--out {out}: exists and is not a folder (a dataset is a folder)")
    study = keyword_value(study if study is not None else data.stem)
    rule = parse_dates(dates)
    from experiment.log.schema import latest_version

    with TrialLog(data, readonly=True) as log:
        old = log.schema_version() < latest_version()
    if old:  # an older log is upgraded in place first: migrations only add tables and columns
        with TrialLog(data):
            pass
    with TrialLog(data, readonly=True) as log:
        rows = [dict(r) for r in log.execute(_SQL)]
        sessions = log.sessions()
    check_subject_collisions([s["subject"] for s in sessions])
    old_participants = _read_tsv(out / "participants.tsv")
    check_subject_collisions(
        [r["participant_id"] for r in old_participants if r.get("participant_id")]
        + [s["subject"] for s in sessions],
        where=f"{out / 'participants.tsv'} and the trial log",
    )
    for r in rows:  # no wall-clock time leaves the lab: the day (or not), seconds from start
        r["time_s"] = _seconds_between(r["date"], r["time_s"])
        r["date"] = _day(r["date"], rule)
    by_session: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_session.setdefault(int(r["session"]), []).append(r)
    files, records = [], []
    for s in sessions:
        sid = int(s["session_id"])
        name = datafile_name(study, s["subject"], sid)
        records.append(_session_record(s, f"data/{name}" if sid in by_session else None, rule))
        if sid in by_session:
            files.append((out / "data" / name, _csv_text(by_session[sid], EXPORT_COLUMNS)))
    simulated = [int(s["session_id"]) for s in sessions if s.get("observer")]
    answers = [  # typed answers leave the lab as they were typed: say which to check
        f"session {r['session']} trial {r['trial_index']} ({reason})"
        for r in rows
        if (reason := identifying_answer(r.get("response"))) is not None
    ]
    codes = sorted({s["subject"] for s in sessions if subject_code_problem(s["subject"])})

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
    # the export's own date follows --dates as the sessions' days do: no time of day, shifted
    # by the same days, or none at all
    export_day = _day(datetime.now(UTC).isoformat(), rule) or None
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
            "score. No wall-clock times: 'time_s' counts from each session's start; 'date' is "
            + _DATES_NOTE[rule[0]]
            + "."
            + sim_note
        ),
        "schemaVersion": "Psych-DS 1.0.0",
        "dateCreated": export_day,
        "dateModified": export_day,
        "keywords": ["psychophysics", "object recognition", "visual prosthesis"]
        + (["simulated data"] if simulated else []),
        "variableMeasured": [
            {"@type": "PropertyValue", "name": c, "description": d}
            for c, d in COLUMN_DESCRIPTIONS.items()
        ],
    }
    desc = dict(old)
    if not _ISO_DAY.fullmatch(str(desc.get("dateCreated", ""))):
        desc.pop("dateCreated", None)  # a time of day (an older export's): not kept
    for key, value in generated.items():
        if key in _GENERATED_KEYS or key not in desc:
            desc[key] = value
    if export_day is None:  # --dates none: no date of any kind
        desc.pop("dateCreated", None)
        desc.pop("dateModified", None)
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
    participants, left_out, columns = _participants(sessions, old_participants, include_identifying)
    part_doc = _participants_json(columns)
    undocumented = [c for c, d in part_doc.items() if d.get("Undocumented")]

    # everything is built; now write, all files or none (a full disk leaves the old dataset)
    from stimuli.io import staged_folder

    with staged_folder(out, what="the dataset", merge=True) as tmp:
        for path, text in files:
            _write(tmp / path.relative_to(out), text)
        _write(tmp / "participants.tsv", participants)
        _write(tmp / "documentation" / "participants.json", json.dumps(part_doc, indent=2) + "\n")
        _write(
            tmp / sessions_path.relative_to(out),
            json.dumps({"trial_log": data.name, "sessions": merged_records}, indent=2) + "\n",
        )
        _write(tmp / desc_path.relative_to(out), json.dumps(desc, indent=2) + "\n")
    return {
        "files": [str(p) for p, _ in files],
        "sessions": len(sessions),
        "simulated_sessions": simulated,
        "identifying_left_out": left_out,
        "undocumented": undocumented,
        "identifying_answers": answers,
        "subject_codes_to_check": codes,
    }


def identifying_reason(key: str, value: object) -> str | None:
    """Return why a participant field looks identifying, or None when it does not.

    Examples
    --------
    >>> identifying_reason("first_name", "Ann")
    "the key 'first_name' names a person or a way to reach them"
    >>> identifying_reason("acuity", "20/200") is None
    True
    """
    words = set(str(key).lower().split("_"))
    if words & _IDENTIFYING_WORDS or any(p in str(key).lower() for p in _IDENTIFYING_PARTS):
        return f"the key {key!r} names a person or a way to reach them"
    reason = identifying_value(value)
    return None if reason is None else f"the value of {key!r} {reason}"


def is_optional_file(relpath: str) -> bool:
    """Return whether ``relpath`` (relative to a dataset) is one of Psych-DS's optional files.

    ``README``, ``CHANGES`` or ``LICENSE`` at the top level, bare or with ``.md``, ``.txt`` or
    ``.rst``: a person may add them to an exported dataset, and a later export keeps them.

    Examples
    --------
    >>> is_optional_file("README.md"), is_optional_file("data/README")
    (True, False)
    """
    name = str(relpath)
    stem, dot, ext = name.partition(".")
    return "/" not in name and stem in OPTIONAL_FILES and (not dot or ext in ("md", "txt", "rst"))


def identifying_fields(meta: dict[str, object]) -> dict[str, str]:
    """Return ``{key: reason}`` for the fields of ``meta`` that look identifying."""
    out = {}
    for k, v in meta.items():
        reason = identifying_reason(k, v)
        if reason is not None:
            out[k] = reason
    return out


def check_not_identifying(meta: dict[str, object]) -> None:
    """Refuse participant metadata with an identifying-looking field (one line, the first).

    Raises
    ------
    ParticipantError
        Names the field, why, and the way out (``--allow-identifying``).
    """
    found = identifying_fields(meta)
    if found:
        key, reason = next(iter(found.items()))
        raise ParticipantError(
            f"--participant {key}: {reason}; leave it out (participants.tsv is shared), or pass "
            "--allow-identifying to keep it in the trial log only (exported only with "
            "session export --include-identifying)"
        )


def parse_dates(text: str) -> tuple[str, int]:
    """Parse ``--dates``: ``day``, ``shift:N`` (N whole days, may be negative) or ``none``.

    Returns
    -------
    tuple of (str, int)
        ``("day", 0)``, ``("shift", N)`` or ``("none", 0)``.

    Examples
    --------
    >>> parse_dates("shift:-30")
    ('shift', -30)
    """
    t = str(text).strip().lower()
    if t in ("day", "none"):
        return t, 0
    kind, sep, n = t.partition(":")
    if kind == "shift" and sep and re.fullmatch(r"[+-]?\d{1,6}", n.strip()):
        return "shift", int(n)
    raise ParticipantError(f"--dates must be day, shift:N (N whole days) or none, got {text!r}")


def subject_key(subject: str) -> str:
    """Return the key under which two subject codes are one subject in an export.

    The code reduced to letters and digits (:func:`keyword_value`, as in the data file names),
    lower-cased: ``S_01``, ``S-01`` and ``s01`` are one file on a case-insensitive disk.

    Raises
    ------
    SubjectCollision
        The code has no letter or digit.
    """
    try:
        return keyword_value(subject).lower()
    except ValueError:
        raise SubjectCollision(
            f"subject {subject!r} has no letter or digit, so it cannot name a data file"
        ) from None


def check_subject_collisions(subjects: list[str], where: str = "the trial log") -> None:
    """Refuse distinct subject codes that would be exported as one (one line naming both).

    Raises
    ------
    SubjectCollision
    """
    seen: dict[str, str] = {}
    for s in subjects:
        key = subject_key(s)
        other = seen.setdefault(key, s)
        if other != s:
            raise SubjectCollision(
                f"subjects {other!r} and {s!r} in {where} would both be exported as "
                f"subject-{keyword_value(s)} (one participant, one file name); nothing was "
                "written"
            )


def _day(stamp: str | None, rule: tuple[str, int]) -> str:
    if not stamp or rule[0] == "none":
        return ""
    day = datetime.fromisoformat(stamp).astimezone(UTC).date()
    return (day + timedelta(days=rule[1])).isoformat()


def _seconds_between(start: str | None, end: str | None) -> float | None:
    if not start or not end:
        return None
    return round((datetime.fromisoformat(end) - datetime.fromisoformat(start)).total_seconds(), 3)
