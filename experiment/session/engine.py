"""A session: one subject's position in a saved schedule, with durable recording and resume.

:meth:`Session.open` creates a session (draws the schedule from the stored seed and writes it
whole) or resumes the subject's unfinished one (reads the saved schedule back); either way every
stimulus file is checked against its sha256 first and the session is locked against a second
process. :meth:`Session.run` is the headless loop (a display and a responder); the operator
console drives the same methods (:meth:`next_trial`, :meth:`record`, ...) itself.

References
----------
Jung et al. 2015, Sec. 3.2 (procedure).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable

import numpy as np

from experiment.clock import Clock, PerfCounterClock
from experiment.interfaces import Answer, Display, FlipRecord, Responder, combine_flips
from experiment.log import TrialLog
from experiment.protocol import ProtocolSpec
from experiment.session.lifecycle import (
    LoggedSession,
    create_session,
    open_or_create,
    reopen,
)
from experiment.session.plan import (
    SessionPlan,
    check_implant_fits,
    check_resumable,
    child_rng,
    display_json,
    plan_session,
    verify_files,
)
from experiment.session.schedule import (
    Schedule,
    Trial,
    build_schedule,
    counterbalance_record,
    subject_position,
)
from experiment.session.scoring import check_rater, check_score, suggest_score
from experiment.session.stimset import StimulusSet, StimulusSetError
from experiment.signals import Stopped

__all__ = ["Session", "Trial", "check_implant_fits", "display_json"]


class Session(LoggedSession):
    """One subject's session in a trial log. Create with :meth:`open`.

    Attributes
    ----------
    session_id : int
    subject : str
    protocol : ProtocolSpec
    stimset : StimulusSet
    seed : int
        The stored root seed; the schedule uses child 0 of ``SeedSequence(seed)``, simulated
        observers child 1 (:meth:`child_rng`).
    schedule : Schedule
        The saved schedule.
    log : TrialLog
    clock : Clock
    """

    def __init__(
        self,
        log: TrialLog,
        protocol: ProtocolSpec,
        stimset: StimulusSet,
        subject: str,
        session_id: int,
        seed: int,
        schedule: Schedule,
        clock: Clock,
    ) -> None:
        self.log = log
        self.protocol = protocol
        self.stimset = stimset
        self.subject = subject
        self.session_id = session_id
        self.seed = seed
        self.schedule = schedule
        self.clock = clock
        last = log.last_committed_trial(session_id)
        self._next = 0 if last is None else last + 1

    # -- creation and resume ------------------------------------------------------------------

    @classmethod
    def open(
        cls,
        log: TrialLog,
        protocol: ProtocolSpec,
        stimset: StimulusSet,
        subject: str,
        *,
        seed: int | None = None,
        clock: Clock | None = None,
        responder: str | None = None,
        observer: str | None = None,
        observer_params: dict | None = None,
        participant: dict | None = None,
        monitor: dict | None = None,
        new_session: str | None = None,
        take_over_lock: str | None = None,
    ) -> Session:
        """Create a session, or resume the subject's unfinished one (same saved schedule).

        Plans the start (:func:`~experiment.session.plan.plan_session`: every check once, the
        schedule once), then opens it (:meth:`open_planned`).

        A subject whose session is complete is not run again unless ``new_session`` gives the
        reason for a further session (:meth:`TrialLog.session_to_open`).

        Parameters
        ----------
        log : TrialLog
        protocol : ProtocolSpec
        stimset : StimulusSet
        subject : str
            Subject code (``S01``).
        seed : int, optional
            Root seed of a new session (drawn from the OS if None). On resume it must be None or
            the stored seed.
        clock : Clock, optional
            Session clock for events (``PerfCounterClock`` if omitted).
        responder : str, optional
            Who answers (``"console"``, ``"sim:logistic"``), stored for provenance.
        observer : str, optional
            The simulated observer's name (None for a person): the session is labelled
            simulated in ``tidy_trials`` and every export.
        observer_params : dict, optional
            The simulated observer's parameters (stored as JSON).
        participant : dict, optional
            Participant metadata (age, sex, ...) for ``participants.tsv``; stored as JSON.
        monitor : dict, optional
            The monitor profile whose values replaced the protocol's display (name, sha256,
            fields); stored as JSON.
        new_session : str, optional
            The operator's reason for a further session of a subject who has one (logged as a
            ``new_session`` event). The same reason again resumes or reports that session.
        take_over_lock : str, optional
            The operator's reason to take over the unfinished session's lock held on another
            host (``--take-over-lock REASON``; logged as a ``lock_taken_over`` event).

        Raises
        ------
        SessionComplete
            The subject's session is complete and ``new_session`` is None (or names a
            completed session).
        TrialLogError
            ``new_session`` is given while another unfinished session exists.
        ResumeMismatch
            The unfinished session used another protocol, stimulus set or seed.
        SessionLocked
            Another live process has the session open.
        StimulusSetError
            A stimulus file is missing or its sha256 differs from the manifest.
        ProtocolError
            The protocol asks for objects or levels the stimulus set lacks, or its
            ``display.implant`` grid is finer than a planned stimulus.
        SubjectCodeError, SubjectCollision
            A subject code the subject-code rule refuses, or one an export could not tell from
            a subject already in the log (the checks of ``session run``: :func:`plan_session`).
        """
        plan = plan_session(
            protocol,
            stimset,
            subject,
            log=log,
            seed=seed,
            responder=responder,
            observer=observer,
            observer_params=observer_params,
            participant=participant,
            monitor=monitor,
            new_session=new_session,
            take_over_lock=take_over_lock,
        )
        return cls.open_planned(log, plan, clock=clock)

    @classmethod
    def open_planned(
        cls, log: TrialLog, plan: SessionPlan, *, clock: Clock | None = None
    ) -> Session:
        """Create the planned session, or resume the subject's unfinished one.

        Parameters
        ----------
        log : TrialLog
            The log the plan read (:func:`~experiment.session.plan.plan_session`).
        plan : SessionPlan
            Its schedule is the one written for a new session (rebuilt only if another subject
            joined the log since, moving this one's row of the Latin square), or the saved one
            it read for a resume.
        clock : Clock, optional
            Session clock for events (``PerfCounterClock`` if omitted).

        Raises
        ------
        SessionComplete, TrialLogError, ResumeMismatch, SessionLocked, StimulusSetError
            As :meth:`open`.
        """
        clock = clock if clock is not None else PerfCounterClock()
        protocol, stimset, subject = plan.protocol, plan.stimset, plan.subject

        def resume(row: dict) -> Session:
            return cls._resume(log, plan, row, clock)

        def create() -> Session:
            index, schedule, root_seed = subject_position(log, subject), plan.schedule, plan.seed
            if plan.resumes is not None and not plan.seed_given:  # not the old session's seed
                root_seed = int(np.random.SeedSequence().entropy)
            if plan.resumes is not None or index != plan.subject_index:  # the log moved on
                schedule = build_schedule(
                    protocol, stimset, child_rng(root_seed, 0), subject_index=index
                )
                verify_files(stimset, schedule)
                check_implant_fits(protocol.display, stimset, schedule)
            sid = create_session(
                log,
                protocol,
                subject,
                clock,
                seed=root_seed,
                write_plan=lambda sid: log.write_schedule(sid, schedule),
                open_note=f"new session: {len(schedule)} trials planned",
                new_session=plan.new_session,
                display_json=display_json(protocol.display),
                stimset_path=str(stimset.root),
                stimset_manifest_sha256=stimset.manifest_sha256,
                responder=plan.responder,
                observer=plan.observer,
                observer_params=(
                    None
                    if plan.observer is None
                    else json.dumps(plan.observer_params or {}, default=str)
                ),
                participant_json=(
                    json.dumps(plan.participant, sort_keys=True) if plan.participant else None
                ),
                monitor_json=json.dumps(plan.monitor, sort_keys=True) if plan.monitor else None,
            )
            balance = counterbalance_record(protocol, index)
            if balance is not None:  # the subject's row of the Latin square, with the session
                log.add_event(sid, "counterbalance", json.dumps(balance), clock.now_s())
            return cls(log, protocol, stimset, subject, sid, root_seed, schedule, clock)

        return open_or_create(log, subject, plan.new_session, resume, create)

    @classmethod
    def _resume(cls, log: TrialLog, plan: SessionPlan, row: dict, clock: Clock) -> Session:
        protocol, stimset, subject, observer = (
            plan.protocol,
            plan.stimset,
            plan.subject,
            plan.observer,
        )
        sid = int(row["session_id"])
        if plan.resumes == sid:  # the plan checked the session and read its saved schedule
            stored, schedule = plan.seed, plan.schedule
        else:  # another process started the subject's session after the plan was made
            given = plan.seed if plan.seed_given else None
            stored = check_resumable(log, protocol, stimset, subject, row, given, observer)
            schedule = log.read_schedule(sid)
            verify_files(stimset, schedule)
            check_implant_fits(protocol.display, stimset, schedule)

        def describe() -> tuple[str, str]:
            done = log.answered_count(sid)
            return (
                f"{done} of {len(schedule)} trials were committed",
                f"resuming at trial {done} of {len(schedule)}",
            )

        def note_repeat_viewing() -> None:
            nxt = log.last_committed_trial(sid)
            nxt = 0 if nxt is None else nxt + 1
            seen = log.viewings(sid, nxt) if nxt < len(schedule) else 0
            if seen:
                log.add_event(
                    sid,
                    "note",
                    f"trial {nxt} was shown {seen} time(s) but not answered before the run "
                    "ended; it is shown again and marked as a repeat viewing",
                    clock.now_s(),
                )

        reopen(log, sid, clock, describe, note_repeat_viewing, take_over=plan.take_over_lock)
        return cls(log, protocol, stimset, subject, sid, stored, schedule, clock)

    # -- the position in the schedule ---------------------------------------------------------

    def next_trial(self) -> Trial | None:
        """Return the first unanswered trial of the saved schedule (None when finished)."""
        return self.schedule[self._next] if self._next < len(self.schedule) else None

    def progress(self) -> tuple[int, int]:
        """Return ``(answered, total)`` trials."""
        return self._next, len(self.schedule)

    @property
    def finished(self) -> bool:
        """Whether every planned trial is answered."""
        return self._next >= len(self.schedule)

    def child_rng(self, k: int = 1) -> np.random.Generator:
        """Return the generator of child ``k`` of ``SeedSequence(seed)`` (1: simulated observer)."""
        return child_rng(self.seed, k)

    def image_for(self, trial: Trial) -> np.ndarray:
        """Return the trial's stimulus as the subject is shown it.

        That is the file at native resolution (bool, or float32 [0, 1] for photos), or, when
        the protocol's ``[display] implant`` is set, the stimulus resampled to the implant's
        electrode grid (:func:`stimuli.implants.to_implant_grid`; colour photos stay photos).
        The presenter draws the grid as the implant's phosphenes.

        Raises
        ------
        StimulusSetError
            The file changed since the session started (sha256 differs).
        """
        from experiment.session.stimset import decode_stimulus

        p = self.stimset.root / trial.path
        try:
            data = p.read_bytes()
        except OSError:
            raise StimulusSetError(f"{p}: stimulus file is missing") from None
        if hashlib.sha256(data).hexdigest() != trial.sha256:
            raise StimulusSetError(f"{p}: stimulus file changed during the session (sha256)")
        image = decode_stimulus(p, trial.condition)
        layout = self.protocol.display.implant_layout
        if layout is not None and image.ndim == 2:
            from stimuli.implants import to_implant_grid

            image = to_implant_grid(image, layout)
        return image

    def suggest_score(self, trial: Trial, response: str) -> str:
        """Return a suggested score for ``response`` from ``objects.csv`` names, synonyms, uses."""
        obj = self.stimset.objects[trial.object]
        return suggest_score(response, obj, self.stimset.objects.values())

    # -- writing ------------------------------------------------------------------------------

    def record(self, trial: Trial, answer: Answer, flip: FlipRecord) -> None:
        """Record the answer to the next trial in one durable transaction.

        Raises
        ------
        ValueError
            ``trial`` is not the next unanswered trial, or the score is unknown.
        """
        nxt = self.next_trial()
        if nxt is None:
            raise ValueError(f"session {self.session_id} is finished; no trial to record")
        if trial != nxt:
            raise ValueError(
                f"trial must be the next unanswered trial (index {nxt.index}), got index "
                f"{getattr(trial, 'index', trial)!r}"
            )
        check_score(answer.score, "answer.score")
        recognized = self.protocol.scoring.is_recognized(answer.score)
        if self._next + 1 == len(self.schedule):
            with self.log.atomic():
                self.log.record(self.session_id, trial, flip, answer, recognized)
                self._mark_complete(self.clock.now_s())
        else:
            self.log.record(self.session_id, trial, flip, answer, recognized)
        self._next += 1

    def mark_shown(self, trial: Trial, flip: FlipRecord) -> int:
        """Log the stimulus onset durably, as soon as the frame is on the subject's screen.

        Returns
        -------
        int
            How many times the trial has now been shown; 2 or more (a repeat viewing, e.g. after
            a crash between onset and answer) is also logged as a ``repeat_viewing`` event.
        """
        n = self.log.record_onset(self.session_id, trial.index, flip.onset_s)
        if n > 1:
            self.log_event(
                "repeat_viewing",
                f"trial {trial.index} shown again (viewing {n}); the subject saw it before",
            )
        return n

    def rescore(self, trial_index: int, score: str, rater: str, note: str = "") -> None:
        """Append a new score for an answered trial (the old ones are kept)."""
        check_rater(rater)
        check_score(score)
        self.log.add_score(
            self.session_id,
            trial_index,
            score,
            self.protocol.scoring.is_recognized(score),
            rater,
            note=note,
        )

    # -- the headless loop --------------------------------------------------------------------

    def run(
        self,
        display: Display,
        responder: Responder,
        *,
        progress: Callable[[int, int], None] | None = None,
    ) -> None:
        """Run the remaining trials: show, collect the answer, clear, record; breaks as planned.

        Parameters
        ----------
        display : Display
        responder : Responder
        progress : callable (answered, total) -> None, optional
            Called after each recorded trial.
        """
        part = None
        try:
            for trial in self.schedule.iter_trials(start_after=self._next - 1):
                if trial.part != part:
                    part = trial.part
                    display.show_text(self.protocol.instructions.for_part(part))
                if trial.break_before:
                    self.log_event("break", f"before trial {trial.index}")
                    display.show_text(self.protocol.instructions.rest)
                image = self.image_for(trial)
                flip = display.show_stimulus(image)
                self.mark_shown(trial, flip)
                answer = responder.respond(trial, image)
                off = display.clear()
                self.record(trial, answer, combine_flips(flip, off))
                if progress is not None:
                    progress(*self.progress())
        except (KeyboardInterrupt, Stopped):
            self.log_event("abort", f"interrupted at trial {self._next}")
            raise
        display.show_text(self.protocol.instructions.end)
