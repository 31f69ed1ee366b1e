"""A session's plan: every check of a session start made once, and its schedule built once.

:func:`plan_session` checks the subject code, the protocol, the stimulus set, the implant and
the memory a schedule needs, and builds the schedule (or, for a subject with an unfinished
session, reads the saved one back), before anything is written. The frozen
:class:`SessionPlan` it returns is what :meth:`experiment.session.engine.Session.open_planned`
opens; ``Session.open`` plans through it, and ``confocal session run`` plans first (so a refused
start writes nothing) and opens with that plan. A Python caller and the command line meet the
same checks and the same errors; the command line names its flags where the errors name
parameters.

References
----------
Jung et al. 2015, Sec. 3.2 (procedure).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from experiment.log import ResumeMismatch, TrialLog
from experiment.protocol import DisplaySpec, ProtocolError, ProtocolSpec
from experiment.session.lifecycle import (
    check_new_session_reason,
    check_subject_and_seed,
    stored_seed,
)
from experiment.session.schedule import (
    Schedule,
    build_schedule,
    planned_trials,
    subject_position,
)
from experiment.session.stimset import StimulusSet, StimulusSetError
from stimuli.flagnames import param

__all__ = [
    "BYTES_PER_TRIAL",
    "SessionPlan",
    "check_implant_fits",
    "check_resumable",
    "display_json",
    "child_rng",
    "plan_session",
    "verify_files",
]

#: Memory per planned trial, bytes: the Trial object, its schedule row and its index entries
#: (ours, rounded up; the check only has to catch absurd repetition counts before allocating).
BYTES_PER_TRIAL = 4096


def child_rng(seed: int, k: int) -> np.random.Generator:
    """Return the generator of child ``k`` of ``SeedSequence(seed)`` (0: the schedule)."""
    return np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(k + 1)[k])


@dataclass(frozen=True, eq=False)
class SessionPlan:
    """A checked session start (:func:`plan_session`): what to open, with its schedule.

    Parameters
    ----------
    protocol : ProtocolSpec
        The protocol, with the monitor profile's display when one was given.
    stimset : StimulusSet
    subject : str
        A subject code that follows the subject-code rule.
    seed : int
        The root seed: the given one, one drawn from the OS for a new session, or the unfinished
        session's stored seed.
    subject_index : int >= 0
        The subject's position among the log's subjects (the Latin square's row).
    schedule : Schedule
        The new session's schedule, or the unfinished session's saved one; every stimulus file
        checked against its sha256 and against the implant's grid.
    seed_given : bool
        Whether the caller gave the seed (a resume then checks it against the stored one).
    resumes : int or None
        The unfinished session this plan resumes (its id), or None for a new session.
    responder, observer : str or None
        Who answers (``"console"``, ``"sim:logistic"``); the simulated observer's name.
    observer_params, participant, monitor : dict or None
        Stored as JSON with a new session.
    new_session, take_over_lock : str or None
        The operator's reasons (a further session; taking over a lock held elsewhere).
    """

    protocol: ProtocolSpec
    stimset: StimulusSet
    subject: str
    seed: int
    subject_index: int
    schedule: Schedule
    seed_given: bool = False
    resumes: int | None = None
    responder: str | None = None
    observer: str | None = None
    observer_params: dict[str, Any] | None = None
    participant: dict[str, Any] | None = None
    monitor: dict[str, Any] | None = None
    new_session: str | None = None
    take_over_lock: str | None = None


def plan_session(
    protocol: ProtocolSpec | str | os.PathLike,
    stimset: StimulusSet | str | os.PathLike,
    subject: str,
    *,
    log: TrialLog | str | os.PathLike | None = None,
    seed: int | None = None,
    responder: str | None = None,
    observer: str | None = None,
    observer_params: dict | None = None,
    participant: dict | None = None,
    monitor: str | os.PathLike | dict | None = None,
    new_session: str | None = None,
    take_over_lock: str | None = None,
) -> SessionPlan:
    """Check a session start and build its schedule once; write nothing.

    Parameters
    ----------
    protocol : ProtocolSpec, or str or path-like
        The protocol, or a TOML file or shipped name (:func:`experiment.protocol.load_protocol`).
    stimset : StimulusSet, or str or path-like
        The stimulus set, or its folder.
    subject : str
        Subject code (``S01``), checked by :func:`experiment.data.subjects.check_subject_code`.
    log : TrialLog, or str or path-like, optional
        The study's trial log (a missing or empty file is a new study): read, never written, for
        the subject's position among its subjects and an unfinished session to resume.
    seed : int, optional
        Root seed of a new session (drawn from the OS if None); on resume None or the stored one.
    responder, observer, observer_params, participant, new_session, take_over_lock
        As :meth:`experiment.session.engine.Session.open`. A ``"sim:NAME"`` responder without
        ``observer`` names the observer ``NAME``.
    monitor : str, path-like or dict, optional
        A monitor profile (name or ``.toml`` file) whose values replace the protocol's display,
        or the record of one already applied to ``protocol`` (stored as JSON).

    Returns
    -------
    SessionPlan

    Raises
    ------
    SubjectCodeError
        A subject code the rule refuses.
    SubjectCollision
        A subject code an export could not tell from one already in the log.
    ValueError
        A bad seed.
    TrialLogError
        A blank or multi-line ``new_session`` or ``take_over_lock`` reason; a file that is not
        a trial log.
    ResumeMismatch
        A seed other than the unfinished session's.
    ProtocolError
        The protocol asks for objects or levels the set lacks, or its ``display.implant`` grid
        is finer than a planned stimulus.
    StimulusSetError
        A stimulus file is missing or its sha256 differs from the manifest.
    InputError
        Too little memory for the schedule.
    """
    from experiment.data.subjects import check_subject_code
    from experiment.log.locks import check_take_over_reason
    from stimuli.resources import check_memory

    if isinstance(subject, str):  # the subject-code rule first, as the command line says it
        check_subject_code(subject, option=param("subject"))
    check_subject_and_seed(subject, seed)
    check_new_session_reason(new_session)
    check_take_over_reason(take_over_lock)
    if observer is None and responder and responder.startswith("sim:"):
        observer = responder[4:]
    spec, monitor_record = _protocol(protocol, monitor)
    stims = stimset if isinstance(stimset, StimulusSet) else StimulusSet.load(stimset)
    n = planned_trials(spec, stims)  # every block checked against the set first
    check_memory(n * BYTES_PER_TRIAL, f"protocol {spec.name}")
    with _reading(log) as readable:
        if readable is not None:
            _check_subject_is_new_or_same(readable, subject)
        index = 0 if readable is None else subject_position(readable, subject)
        row = None
        if readable is not None:
            decision, row = readable.session_to_open(subject, new_session=new_session)
            row = row if decision == "resume" else None
        if row is not None:
            root_seed = check_resumable(readable, spec, stims, subject, row, seed, observer)
            schedule = readable.read_schedule(int(row["session_id"]))
        else:
            root_seed = int(seed) if seed is not None else int(np.random.SeedSequence().entropy)
            schedule = build_schedule(spec, stims, child_rng(root_seed, 0), subject_index=index)
    verify_files(stims, schedule)
    check_implant_fits(spec.display, stims, schedule)
    return SessionPlan(
        protocol=spec,
        stimset=stims,
        subject=subject,
        seed=root_seed,
        subject_index=index,
        schedule=schedule,
        seed_given=seed is not None,
        resumes=None if row is None else int(row["session_id"]),
        responder=responder,
        observer=observer,
        observer_params=observer_params,
        participant=participant,
        monitor=monitor_record,
        new_session=new_session,
        take_over_lock=take_over_lock,
    )


def display_json(display: DisplaySpec) -> str:
    """Return the display spec as the session row logs it (``sessions.display_json``).

    The spec's fields (:meth:`DisplaySpec.to_dict`), plus, when ``display.implant`` is set, the
    whole implant layout under ``implant_layout`` (:meth:`stimuli.implants.ImplantLayout.to_dict`),
    so that the log says what the subject saw even for a user's own layout file.
    """
    d = display.to_dict()
    if display.implant_layout is not None:
        d["implant_layout"] = display.implant_layout.to_dict()
    return json.dumps(d, sort_keys=True)


def check_resumable(
    log: TrialLog,
    protocol: ProtocolSpec,
    stimset: StimulusSet,
    subject: str,
    row: dict,
    seed: int | None,
    observer: str | None,
) -> int:
    """Check that an unfinished session ``row`` can be resumed as asked; return its stored seed.

    Raises
    ------
    ResumeMismatch
        It used another protocol (or display geometry), stimulus set, seed or observer.
    """
    sid = int(row["session_id"])
    same_display = row["display_json"] == display_json(protocol.display)
    if row["protocol_sha256"] != protocol.content_sha256() and not same_display:
        raise ResumeMismatch(
            f"{log.path}: subject {subject} has unfinished session {sid} with another "
            f"display geometry ({row['display_json']}); resume it with the same protocol "
            f"and {param('monitor')}"
        )
    if row["protocol_sha256"] != protocol.content_sha256():
        raise ResumeMismatch(
            f"{log.path}: subject {subject} has unfinished session {sid} with protocol "
            f"{row['protocol_name']!r} ({row['protocol_path']}); resume it with that "
            "protocol, unchanged"
        )
    if row["stimset_manifest_sha256"] != stimset.manifest_sha256:
        raise ResumeMismatch(
            f"{log.path}: subject {subject} has unfinished session {sid} with stimulus set "
            f"{row['stimset_path']} (manifest sha256 {row['stimset_manifest_sha256'][:12]}...);"
            f" {stimset.root}/manifest.csv differs"
        )
    stored = stored_seed(log, subject, row, seed)
    if (row.get("observer") or None) != observer:

        def who(o: str | None) -> str:
            return f"simulated observer {o!r}" if o else "a person"

        raise ResumeMismatch(
            f"{log.path}: subject {subject} has unfinished session {sid} answered by "
            f"{who(row.get('observer'))}, not {who(observer)}; use another subject code"
        )
    return stored


def _check_subject_is_new_or_same(log: TrialLog, subject: str) -> None:
    """Refuse a subject code that an export could not tell from one already in the log."""
    from experiment.data.psychds import SubjectCollision, keyword_value, subject_key

    try:
        key = subject_key(subject)
    except SubjectCollision as exc:
        raise SubjectCollision(f"{param('subject')}: {exc}") from None
    for other in sorted({s["subject"] for s in log.sessions()}):
        if other != subject and subject_key(other) == key:
            raise SubjectCollision(
                f"{param('subject')} {subject!r}: the log already has subject {other!r}, and both "
                f"would be exported as subject-{keyword_value(subject)}; use {other!r} or another "
                "code"
            )


def _protocol(
    protocol: ProtocolSpec | str | os.PathLike, monitor: str | os.PathLike | dict | None
) -> tuple[ProtocolSpec, dict | None]:
    """Return the protocol (with the monitor profile's display) and the monitor's record."""
    import dataclasses

    from experiment.protocol import load_protocol

    spec = protocol if isinstance(protocol, ProtocolSpec) else load_protocol(protocol)
    if monitor is None or isinstance(monitor, dict):
        return spec, monitor
    from experiment.data.monitors import apply_monitor, load_monitor

    profile, record = load_monitor(monitor)
    return dataclasses.replace(spec, display=apply_monitor(spec.display, profile)), record


class _reading:
    """``with _reading(log) as readable``: the log to read (read-only from a path), or None."""

    def __init__(self, log: TrialLog | str | os.PathLike | None) -> None:
        self.given = log
        self.opened: TrialLog | None = None

    def __enter__(self) -> TrialLog | None:
        if self.given is None or isinstance(self.given, TrialLog):
            return self.given
        path = Path(self.given)
        if not path.is_file() or path.stat().st_size == 0:
            return None
        self.opened = TrialLog(path, readonly=True)
        return self.opened

    def __exit__(self, *exc: object) -> None:
        if self.opened is not None:
            self.opened.close()


def check_implant_fits(display: DisplaySpec, stimset: StimulusSet, schedule: Schedule) -> None:
    """Refuse a schedule holding a stimulus coarser than the protocol's implant grid.

    Called by :func:`plan_session` (before the trial log is written), so a protocol whose
    ``[display] implant`` cannot show a planned level fails with one line and writes nothing.

    Raises
    ------
    ProtocolError
        Naming ``display.implant``, the grid, the stimulus and its level.
    """
    layout = display.implant_layout
    if layout is None:
        return
    from experiment.session.stimset import COLOUR_CONDITIONS
    from stimuli.errors import InputError
    from stimuli.io import image_shape_px

    seen: set[str] = set()
    for t in schedule.trials:
        if t.path in seen or t.condition in COLOUR_CONDITIONS:
            continue
        seen.add(t.path)
        try:
            rows, cols = image_shape_px(stimset.root / t.path)
        except InputError as exc:
            raise StimulusSetError(str(exc)) from None
        if layout.rows > rows or layout.cols > cols:
            raise ProtocolError(
                f"display.implant {display.implant!r}: its {layout.cols}x{layout.rows} grid is "
                f"finer than the {cols}x{rows} stimulus {t.path} ({t.condition}, level "
                f"{t.level}); plan only levels with at least as many pixels as the implant"
            )


def verify_files(stimset: StimulusSet, schedule: Schedule) -> None:
    """Check every stimulus file of the schedule against the sha256 it was planned with.

    Raises
    ------
    StimulusSetError
        A file is missing or its sha256 differs.
    """
    seen: dict[str, str] = {}
    for t in schedule.trials:
        seen.setdefault(t.path, t.sha256)
    for path, sha in seen.items():
        p = stimset.root / path
        if not p.is_file():
            raise StimulusSetError(f"{p}: stimulus file is missing; refusing to start")
        h = hashlib.sha256(p.read_bytes()).hexdigest()
        if h != sha:
            raise StimulusSetError(
                f"{p}: stimulus file changed: sha256 {h[:12]}... does not match manifest.csv "
                f"({sha[:12]}...); refusing to start"
            )
