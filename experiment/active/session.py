"""An active-search session: plan, durable event log, resume.

:meth:`ActiveSession.open` creates a session in a trial log (a ``sessions`` row, a ``plan``
event with the trials, the scene's sha256 and its detected planes) or resumes the subject's
unfinished one. The trial is driven by :meth:`start_trial`, :meth:`press` and :meth:`answer`,
which a live viewer calls for each key and which :meth:`iter_run` calls for a (simulated)
searcher. Every input and every displayed state is an ``active_events`` row committed before
the next one is produced; the answer and its score are one transaction. Opening, resuming,
locking, completing and closing the session in the log is the recognition session's
(:mod:`experiment.session.lifecycle`).

Scenes: a task may list several scenes. The fixed ones (the paper's scene, recorded light
fields) are loaded and scanned for planes when the session opens (the plan keeps their sha256
and planes under ``scenes``); a randomised scene is rebuilt for each trial from the layout and
texture seed the plan saved, and scanned then. Each ``trial_start`` logs the trial's ``scene``,
its ``scene_sha256``, ``planes_px``, ``objects_px`` and (randomised scenes) ``layout`` and
``scene_seed``; a resumed trial must rebuild to the same sha256.

Resume: the trials with an ``answer`` row are done; a trial whose attempt was cut by a crash is
marked ``attempt_abandoned`` and restarted as attempt + 1 (its old rows stay: the log is
append-only; analysis uses the answered attempt).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from experiment.active import adapter
from experiment.active.eventlog import ActiveEventLog
from experiment.active.searcher import Action, Observation, Searcher
from experiment.active.task import ActiveSearchSpec, ActiveTrial, condition_order, plan_trials
from experiment.clock import Clock, PerfCounterClock
from experiment.log import ResumeMismatch, TrialLog
from experiment.protocol import ProtocolError, ProtocolSpec
from experiment.session import lifecycle
from experiment.session.scoring import check_rater, check_score, suggest_score
from experiment.viewer.reference import CpuRenderer, Panes
from experiment.viewer.state import ViewerModel, ViewerState, apply_action
from stimuli.errors import InputError
from stimuli.manifest import ObjectInfo, check_object_id

__all__ = ["ActiveSession", "SCENE_OBJECTS", "Scorer", "auto_scorer"]

#: Names, synonyms and uses of the synthetic three-plane scene's objects (for scoring answers).
SCENE_OBJECTS: dict[str, ObjectInfo] = {
    "pedestrian": ObjectInfo(
        "pedestrian",
        "pedestrian",
        ("person", "man", "woman", "human", "walker", "people"),
        ("walking",),
        "main",
    ),
    "tree": ObjectInfo("tree", "tree", ("bush", "plant", "oak"), ("shade",), "main"),
    "building": ObjectInfo(
        "building",
        "building",
        ("house", "wall", "block", "brick building", "home"),
        ("living in", "shelter"),
        "main",
    ),
}

#: A scorer: ``(trial, response) -> (score, rater)``; the operator console is one, and
#: :func:`auto_scorer` (the static study's suggested score) is the headless one.
Scorer = Callable[[ActiveTrial, str], tuple[str, str]]


def _scene_object(
    name: str, synonyms: tuple[str, ...] = (), uses: tuple[str, ...] = ()
) -> ObjectInfo:
    """Return the record of a scene's object.

    Its id is its name when that is a safe id, else one derived from it (a scene may name an
    object ``red car``; records' ids are folder-safe).
    """
    try:
        check_object_id(name, where="scene object")
        object_id = name
    except InputError:
        object_id = "scene-" + hashlib.sha256(name.encode()).hexdigest()[:16]
    return ObjectInfo(object_id, name, synonyms, uses, "main")


def _object_info(name: str, objects: dict[str, ObjectInfo] | None = None) -> ObjectInfo:
    if objects and name in objects:
        return objects[name]
    return SCENE_OBJECTS.get(name) or _scene_object(name)


def auto_scorer(
    trial: ActiveTrial,
    response: str,
    targets: tuple[str, ...] = (),
    objects: dict[str, ObjectInfo] | None = None,
) -> tuple[str, str]:
    """Score an answer as the console suggests it.

    See :func:`~experiment.session.scoring.suggest_score`.

    ``objects`` adds the names, synonyms and uses of a recorded scene's targets (from its
    description) to :data:`SCENE_OBJECTS`.
    """
    others = [_object_info(t, objects) for t in targets if t != trial.target]
    return suggest_score(response, _object_info(trial.target, objects), others), "auto"


class _SceneState:
    """A loaded scene with what the keys and the renderers of its trials need."""

    def __init__(self, scene: adapter.Scene, info: dict[str, Any], task: ActiveSearchSpec):
        self.scene = scene
        self.planes_px = tuple(float(p) for p in info["planes_px"])
        near, far = info["scan_px"]
        self.depth_step_px = float(info["depth_step_px"])
        self.model = adapter.search_model(
            self.planes_px,
            float(near),
            float(far),
            self.depth_step_px,
            scene.shape_px,
            zoom_allowed=task.zoom_allowed,
        )
        self.renderers: dict[str, CpuRenderer] = {}

    def renderer(self, condition: str, grid_px) -> CpuRenderer:
        if condition not in self.renderers:
            self.renderers[condition] = adapter.search_renderer(self.scene, grid_px, condition)
        return self.renderers[condition]


def _scan_info(scene: adapter.Scene, task: ActiveSearchSpec) -> dict[str, Any]:
    """Scan a scene for its planes: what the plan (or a trial_start) records about it."""
    ds, planes = adapter.detect_planes(scene, n_planes=task.n_planes)
    return {
        "sha256": scene.sha256,
        "planes_px": list(planes),
        "depth_step_px": float(task.depth_step_px or scene.depth_step_px()),
        "scan_px": [float(ds.max()), float(ds.min())],
        "objects_px": dict(scene.objects),
    }


def _scenes_sha256(shas: dict[str, str]) -> str:
    """Return the session's scene hash: the scene's own for one scene, else a hash of them all."""
    if len(shas) == 1:
        return next(iter(shas.values()))
    text = json.dumps(shas, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _check_targets(task: ActiveSearchSpec, objects: dict[str, tuple[str, ...] | None]) -> None:
    """Every target is in some scene, every scene holds some target (one line if not)."""
    for t in task.targets:
        if not any(o is None or t in o for o in objects.values()):
            where = ", ".join(f"{k} ({', '.join(o or ())})" for k, o in objects.items())
            raise ProtocolError(f"task.targets: {t!r} is not an object of {where}")
    for k, o in objects.items():
        if o is not None and not set(o) & set(task.targets):
            raise ProtocolError(
                f"task.scene: {k!r} holds none of task.targets (its objects: {', '.join(o)})"
            )


def _subject_index(log: TrialLog, subject: str) -> int:
    """Return the subject's 0-based position among this log's subjects (first session first)."""
    order: list[str] = []
    for row in log.sessions():
        if row["subject"] not in order:
            order.append(row["subject"])
    return order.index(subject) if subject in order else len(order)


def _grid_hex(grid: np.ndarray) -> str:
    return np.packbits(np.asarray(grid, dtype=bool).ravel()).tobytes().hex()


class ActiveSession(lifecycle.LoggedSession):
    """One subject's active-search session in a trial log. Create with :meth:`open`.

    Attributes
    ----------
    session_id : int
    subject : str
    protocol : ProtocolSpec
    task : ActiveSearchSpec
    scene : adapter.Scene
        The running (or next) trial's scene.
    trials : list of ActiveTrial
        The saved plan.
    plan : dict
        The ``plan`` event's payload.
    planes_px : tuple of float
        Detected object planes (nearest first) of that scene.
    events : ActiveEventLog
    clock : Clock
    """

    def __init__(self, log, protocol, subject, session_id, seed, scenes, plan, clock) -> None:
        self.log = log
        self.protocol = protocol
        self.task: ActiveSearchSpec = protocol.task
        self.subject = subject
        self.session_id = session_id
        self.seed = seed
        first = self.task.scenes[0]
        self.trials = [
            t if t.scene else ActiveTrial(t.index, t.target, t.condition, t.repetition, first)
            for t in (ActiveTrial.from_dict(d) for d in plan["trials"])
        ]
        self.plan = plan
        self.events = ActiveEventLog(log, session_id)
        self.clock = clock
        self._states: dict[tuple, _SceneState] = {}
        for name, scene in scenes.items():
            self._states[(name, None)] = _SceneState(scene, self._fixed_info(name), self.task)
        self._objects: dict[str, ObjectInfo] = {}
        for scene in scenes.values():
            self._learn_words(scene)
        self._shown: _SceneState | None = None
        self._current: tuple[ActiveTrial, int, float] | None = None
        self.state: ViewerState | None = None
        self.view: Panes | None = None

    def _fixed_info(self, name: str) -> dict[str, Any]:
        info = self.plan.get("scenes", {}).get(name)
        if info is None:  # a plan written before several scenes: its one scene at top level
            info = {k: self.plan[k] for k in ("planes_px", "depth_step_px", "scan_px")}
        return info

    def _learn_words(self, scene: adapter.Scene) -> None:
        for name, (syn, uses) in scene.synonyms.items():
            self._objects[name] = _scene_object(name, tuple(syn), tuple(uses))

    @property
    def object_infos(self) -> dict[str, ObjectInfo]:
        """Names, synonyms and uses of the recorded scenes' targets (for scoring)."""
        return dict(self._objects)

    def _scene_state(self, trial: ActiveTrial) -> _SceneState:
        """Return the trial's scene, loaded (fixed scenes at open; a randomised one rebuilt now)."""
        if trial.layout is None:
            return self._states[(trial.scene, None)]
        key = (trial.scene, trial.scene_seed, json.dumps(trial.layout, sort_keys=True))
        if key not in self._states:
            for k in [k for k in self._states if k[1] is not None]:
                del self._states[k]  # keep one randomised scene in memory
            scene = adapter.load_scene(
                trial.scene,
                shape_px=self.task.scene_shape_px,
                grid=self.task.scene_grid,
                seed=int(trial.scene_seed or 0),
                layout=trial.layout,
            )
            self._check_rebuilt(trial, scene)
            self._states[key] = _SceneState(scene, _scan_info(scene, self.task), self.task)
        return self._states[key]

    def _check_rebuilt(self, trial: ActiveTrial, scene: adapter.Scene) -> None:
        """Refuse a resumed trial whose scene is not the one its first attempt showed."""
        for r in self.events.rows():
            if r["trial"] == trial.index and r["kind"] == "trial_start":
                logged = r["payload"].get("scene_sha256")
                if logged is not None and logged != scene.sha256:
                    raise ResumeMismatch(
                        f"{self.log.path}: session {self.session_id} trial {trial.index}: the "
                        f"rebuilt scene {trial.scene} (layout {trial.layout}) has sha256 "
                        f"{scene.sha256[:12]}..., the logged one {logged[:12]}...; the scene "
                        "generator changed since the session began"
                    )
                return

    def _shown_state(self) -> _SceneState:
        if self._shown is None:
            nxt = self.next_trial() or self.trials[-1]
            self._shown = self._scene_state(nxt)
        return self._shown

    @property
    def scene(self) -> adapter.Scene:
        """The scene of the running (or next) trial."""
        return self._shown_state().scene

    @property
    def planes_px(self) -> tuple[float, ...]:
        """Detected object planes (nearest first) of the running (or next) trial's scene."""
        return self._shown_state().planes_px

    # -- creation and resume ------------------------------------------------------------------

    @classmethod
    def open(
        cls,
        log: TrialLog,
        protocol: ProtocolSpec,
        subject: str,
        *,
        seed: int | None = None,
        clock: Clock | None = None,
        responder: str | None = None,
        new_session: str | None = None,
        subject_index: int | None = None,
        take_over_lock: str | None = None,
    ) -> ActiveSession:
        """Create an active-search session, or resume the subject's unfinished one.

        ``subject_index`` picks the row of the condition-order Latin square
        (``counterbalance = "latin_square"``); default: the subject's position among the
        subjects of this log. It is saved in the plan (``counterbalance``).

        A subject whose session is complete is not run again unless ``new_session`` gives the
        reason for a further session (logged as a ``new_session`` event; the same reason again
        resumes or reports that session). ``take_over_lock`` (the operator's reason,
        ``--take-over-lock REASON``) takes over the unfinished session's lock held on another
        host, logged as a ``lock_taken_over`` event.

        Raises
        ------
        SessionComplete
            The subject's session is complete and ``new_session`` is None (or names a
            completed session).
        TrialLogError
            ``new_session`` is given while another unfinished session exists.
        ProtocolError
            The protocol has no active-search ``[task]``, a target no scene holds, a scene
            with none of the targets, or a scene description with a bad field.
        ResumeMismatch
            The unfinished session used another protocol, scene or seed.
        SessionLocked
            Another live process has the session open.
        """
        task = protocol.task
        if not isinstance(task, ActiveSearchSpec):
            raise ProtocolError(
                f"{protocol.source_path or protocol.name}: not an active-search protocol "
                '(needs [task] type = "active_search")'
            )
        lifecycle.check_subject_and_seed(subject, seed)
        if subject_index is not None and (
            isinstance(subject_index, bool)
            or not isinstance(subject_index, int)
            or subject_index < 0
        ):
            raise ValueError(f"subject_index must be an integer >= 0, got {subject_index!r}")
        clock = clock if clock is not None else PerfCounterClock()
        base_dir = None if protocol.source_path is None else Path(protocol.source_path).parent
        objects = {k: adapter.scene_objects(k, base_dir=base_dir) for k in task.scenes}
        _check_targets(task, objects)
        scenes = {
            k: adapter.load_scene(
                k, shape_px=task.scene_shape_px, grid=task.scene_grid, base_dir=base_dir
            )
            for k in task.scenes
            if k != adapter.RANDOM_SCENE
        }
        shas = {k: v.sha256 for k, v in scenes.items()}
        if adapter.RANDOM_SCENE in task.scenes:
            shas[adapter.RANDOM_SCENE] = "layout and textures drawn per trial (see the plan)"
        scenes_sha = _scenes_sha256(shas)

        def resume(row: dict) -> ActiveSession:
            return cls._resume(
                log, protocol, subject, row, seed, scenes, scenes_sha, clock, take_over_lock
            )

        def create() -> ActiveSession:
            root = int(seed) if seed is not None else int(np.random.SeedSequence().entropy % 2**63)
            index = _subject_index(log, subject) if subject_index is None else int(subject_index)
            infos = {k: _scan_info(v, task) for k, v in scenes.items()}
            trials = plan_trials(
                task,
                np.random.default_rng(np.random.SeedSequence(root).spawn(1)[0]),
                scene_objects=objects,
                subject_index=index,
            )
            plan: dict[str, Any] = {
                "trials": [t.to_dict() for t in trials],
                "task": task.to_dict(),
                "scenes": infos,
                "counterbalance": {
                    "scheme": task.counterbalance,
                    "subject_index": index,
                    "condition_order": list(
                        condition_order(task, index)
                        if task.counterbalance == "latin_square"
                        else task.conditions
                    ),
                },
            }
            if len(infos) == 1 and len(task.scenes) == 1:
                # one fixed scene: its facts at top level too, as plans have always had them
                (info,) = infos.values()
                plan.update(
                    scene_sha256=info["sha256"],
                    planes_px=info["planes_px"],
                    depth_step_px=info["depth_step_px"],
                    scan_px=info["scan_px"],
                    objects_px=info["objects_px"],
                )
            sid = lifecycle.create_session(
                log,
                protocol,
                subject,
                clock,
                seed=root,
                write_plan=lambda sid: ActiveEventLog(log, sid).append("plan", plan, clock.now_s()),
                open_note=f"active search: {len(trials)} trials in {len(task.scenes)} scene(s)",
                new_session=new_session,
                display_json=json.dumps(protocol.display.to_dict(), sort_keys=True),
                stimset_path=", ".join(task.scenes),
                stimset_manifest_sha256=scenes_sha,
                responder=responder,
            )
            return cls(log, protocol, subject, sid, root, scenes, plan, clock)

        return lifecycle.open_or_create(log, subject, new_session, resume, create)

    @classmethod
    def _resume(
        cls, log, protocol, subject, row, seed, scenes, scenes_sha, clock, take_over_lock=None
    ) -> ActiveSession:
        sid = int(row["session_id"])
        if row["protocol_sha256"] != protocol.content_sha256():
            raise ResumeMismatch(
                f"{log.path}: subject {subject} has unfinished session {sid} with protocol "
                f"{row['protocol_name']!r}; resume it with that protocol, unchanged"
            )
        if row["stimset_manifest_sha256"] != scenes_sha:
            raise ResumeMismatch(
                f"{log.path}: session {sid} searched scene {row['stimset_path']} with sha256 "
                f"{row['stimset_manifest_sha256'][:12]}...; {', '.join(protocol.task.scenes)} "
                "now differs"
            )
        stored = lifecycle.stored_seed(log, subject, row, seed)
        events = ActiveEventLog(log, sid)
        plan = events.plan()
        if plan is None:
            raise ResumeMismatch(f"{log.path}: session {sid} is not an active-search session")
        last = events.last_t_s()
        if last is not None and hasattr(clock, "advance") and clock.now_s() < last:
            clock.advance(last - clock.now_s())  # a simulated clock continues where it stopped

        def describe() -> tuple[str, str]:
            n = len(events.committed_trials())
            return f"{n} active-search trials were committed", f"resuming after {n} trials"

        def abandon_cut_attempts() -> None:
            done = events.committed_trials()
            for t in plan["trials"]:
                k = int(t["index"])
                n = events.attempts(k)
                if k not in done and n > 0:
                    events.append(
                        "attempt_abandoned",
                        {"reason": "session resumed"},
                        clock.now_s(),
                        trial=k,
                        attempt=n - 1,
                    )

        lifecycle.reopen(log, sid, clock, describe, abandon_cut_attempts, take_over=take_over_lock)
        return cls(log, protocol, subject, sid, stored, scenes, plan, clock)

    # -- position -----------------------------------------------------------------------------

    def next_trial(self) -> ActiveTrial | None:
        """Return the first trial without an answer (None when finished)."""
        done = self.events.committed_trials()
        for t in self.trials:
            if t.index not in done:
                return t
        return None

    def progress(self) -> tuple[int, int]:
        """Return ``(answered, total)`` trials."""
        return len(self.events.committed_trials()), len(self.trials)

    @property
    def model(self) -> ViewerModel:
        """The depth range, planes and step the keys work on (the running trial's scene)."""
        return self._shown_state().model

    def _renderer(self, condition: str) -> CpuRenderer:
        return self._shown_state().renderer(condition, self.task.grid_px)

    def _state_payload(self) -> dict[str, Any]:
        s, v = self.state, self.view
        assert s is not None and v is not None
        return {
            "depth_px": s.disparity_px,
            "depth_m": self.scene.depth_m(s.disparity_px),
            "plane": s.plane,
            "zoom": None if s.zoom is None else list(s.zoom),
            "grid_px": list(self.task.grid_px),
            "on_cells": int(np.count_nonzero(v.grid)),
            "implant": _grid_hex(v.grid),
        }

    # -- driving a trial ----------------------------------------------------------------------

    def start_trial(self, searcher_name: str = "live") -> tuple[ActiveTrial, list[dict]]:
        """Show the next trial's cue and first view; return it and the events written."""
        trial = self.next_trial()
        if trial is None:
            raise ValueError(f"session {self.session_id} is finished; no trial to start")
        attempt = self.events.attempts(trial.index)
        shown = self._scene_state(trial)
        self._shown = shown
        m = shown.model
        onset = self.clock.now_s()
        self._current = (trial, attempt, onset)
        self.state = ViewerState(m.near_px, plane=m.plane_of(m.near_px))
        self.view = self._renderer(trial.condition).render(self.state)
        start: dict[str, Any] = {
            "target": trial.target,
            "condition": trial.condition,
            "cue": f"find the {trial.target}",
            "searcher": searcher_name,
            "scene": trial.scene,
            "scene_sha256": shown.scene.sha256,
            "planes_px": list(shown.planes_px),
            "depth_step_px": shown.depth_step_px,
            "objects_px": dict(shown.scene.objects),
        }
        if trial.layout is not None:
            start["layout"] = trial.layout
            start["scene_seed"] = trial.scene_seed
        out = [
            self._append("trial_start", start, onset),
            self._append("state", self._state_payload(), onset),
        ]
        return trial, out

    def _append(self, kind: str, payload: dict, t_s: float) -> dict:
        trial, attempt, _ = self._current  # type: ignore[misc]
        seq = self.events.append(kind, payload, t_s, trial=trial.index, attempt=attempt)
        return {
            "trial": trial.index,
            "attempt": attempt,
            "seq": seq,
            "t_s": t_s,
            "kind": kind,
            "payload": json.loads(json.dumps(payload, sort_keys=True)),
        }

    @property
    def onset_s(self) -> float:
        """Clock time of the current trial's onset, seconds."""
        if self._current is None:
            raise ValueError("no trial is running")
        return self._current[2]

    def elapsed_s(self) -> float:
        """Seconds since the current trial's onset."""
        return self.clock.now_s() - self.onset_s

    def press(self, key: str, action: str, *, box=None, t_s: float | None = None) -> list[dict]:
        """Apply one input (not answer/pass): log the key, then the state it shows.

        ``t_s`` is when the input happened on the session clock (a presenter process stamps
        the subject's keys itself); default now.
        """
        if self._current is None or self.state is None:
            raise ValueError("no trial is running; call start_trial() first")
        if action in ("answer", "pass"):
            raise ValueError("use answer() for answer and pass")
        new = apply_action(self.model, self.state, action, box=box)
        t = self.clock.now_s() if t_s is None else float(t_s)
        payload: dict[str, Any] = {"key": key, "action": action}
        if box is not None:
            payload["box"] = [int(v) for v in box]
        out = [self._append("key", payload, t)]
        if new != self.state:
            self.state = new
            self.view = self._renderer(self._current[0].condition).render(new)
            out.append(self._append("state", self._state_payload(), t))
        return out

    def answer(
        self,
        response: str,
        *,
        key: str = "Enter",
        score: str | None = None,
        rater: str | None = None,
        scorer: Scorer | None = None,
        t_s: float | None = None,
    ) -> list[dict]:
        """Record the answer and its score in one transaction; the trial is then committed.

        ``t_s`` is when the subject answered (their answer key, stamped by the presenter
        process; the operator scores later): the ``key`` and ``answer`` rows and ``rt_s`` use
        it, the ``score`` row is stamped when it is given. Default now.
        """
        if self._current is None or self.state is None:
            raise ValueError("no trial is running; call start_trial() first")
        trial, attempt, onset = self._current
        if score is None:
            if scorer is not None:
                score, rater = scorer(trial, response)
            else:
                score, rater = auto_scorer(trial, response, self.task.targets, self._objects)
        check_score(score)
        rater = rater or self.protocol.scoring.primary_rater
        now = self.clock.now_s()
        t = now if t_s is None else min(float(t_s), now)
        action = "pass" if not response.strip() else "answer"
        rows = [
            ("key", {"key": key, "action": action}, t),
            (
                "answer",
                {"response": response, "rt_s": t - onset, "state": self._state_payload()},
                t,
            ),
            (
                "score",
                {
                    "score": score,
                    "recognized": self.protocol.scoring.is_recognized(score),
                    "rater": rater,
                    "primary": True,
                },
                now,
            ),
        ]
        finished = self.progress()[0] + 1 == len(self.trials)
        with self.log.atomic():
            seqs = self.events.append_many(rows, trial=trial.index, attempt=attempt)
            if finished:
                self._mark_complete(now)
        self._current = None
        return [
            {
                "trial": trial.index,
                "attempt": attempt,
                "seq": s,
                "t_s": tt,
                "kind": k,
                "payload": json.loads(json.dumps(p, sort_keys=True)),
            }
            for s, (k, p, tt) in zip(seqs, rows, strict=True)
        ]

    def rescore(self, trial_index: int, score: str, rater: str) -> dict:
        """Append a new score for an answered trial (old scores are kept; H16).

        The new score is primary when ``rater`` is the trial's first rater or the protocol's
        primary rater.
        """
        check_score(score)
        check_rater(rater)
        rows = [r for r in self.events.rows() if r["trial"] == trial_index and r["kind"] == "score"]
        if not rows:
            raise ValueError(f"trial {trial_index} has no answer to re-score")
        first = rows[0]["payload"]["rater"]
        primary = rater in (first, self.protocol.scoring.primary_rater)
        payload = {
            "score": score,
            "recognized": self.protocol.scoring.is_recognized(score),
            "rater": rater,
            "primary": primary,
        }
        t = self.clock.now_s()
        seq = self.events.append(
            "score", payload, t, trial=trial_index, attempt=rows[-1]["attempt"]
        )
        return {
            "trial": trial_index,
            "attempt": rows[-1]["attempt"],
            "seq": seq,
            "t_s": t,
            "kind": "score",
            "payload": payload,
        }

    # -- the headless loop --------------------------------------------------------------------

    def _wait(self, dt_s: float) -> None:
        if dt_s > 0 and hasattr(self.clock, "advance"):
            self.clock.advance(dt_s)

    def iter_run(
        self, searcher: Searcher, *, scorer: Scorer | None = None, max_actions: int = 10_000
    ) -> Iterator[dict]:
        """Run the remaining trials with ``searcher``; yield every event as it is committed.

        A trial ends with the searcher's answer or pass, or with a pass at the task's time
        limit.
        """
        while (trial := self.next_trial()) is not None:
            searcher.start(trial.target, trial.index)
            _, rows = self.start_trial(searcher.name)
            yield from rows
            for _ in range(max_actions):
                obs = Observation(
                    trial.target,
                    trial.condition,
                    self.state,
                    self.view,
                    self.model,
                    self.elapsed_s(),
                    self.task.zoom_allowed,
                    self.scene,
                )
                act: Action = searcher.next_action(obs)
                if self.elapsed_s() + act.delay_s >= self.task.time_limit_s:
                    self._wait(self.task.time_limit_s - self.elapsed_s())
                    yield from self.answer("", key="timeout", scorer=scorer)
                    break
                self._wait(act.delay_s)
                if act.action in ("answer", "pass"):
                    resp = act.response if act.action == "answer" else ""
                    yield from self.answer(resp, key=act.key, scorer=scorer)
                    break
                yield from self.press(act.key, act.action, box=act.box)
            else:
                raise RuntimeError(f"searcher {searcher.name} did not finish trial {trial.index}")

    def run(self, searcher: Searcher, *, scorer: Scorer | None = None) -> list[dict]:
        """Run the remaining trials; return the events written (a thin loop over iter_run)."""
        return list(self.iter_run(searcher, scorer=scorer))
