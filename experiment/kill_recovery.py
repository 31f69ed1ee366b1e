"""Kill test of the trial log: SIGKILL ``session run`` and ``active run``, recover, check the log.

:func:`run_kill_recovery` runs simulated subjects through ``confocal session run --headless
--observer logistic`` and ``confocal active run`` (simulated searcher), kills the command with
SIGKILL after a random delay, and recovers as the README says: the same command again, until
the subject's command ends by itself. The delay is drawn from 0 to 1.25 times a whole run, so the
kills cover the whole run: start-up, the creation of the session, every trial's writes, the
commit that completes the session and the moments after it (then the next run must report the
session complete and write nothing). At the end :func:`check_logs` reads every log and counts
trials lost, trials duplicated, extra sessions, sessions run again after they were complete and
lock rows left on completed sessions.

Python start-up is not paid per kill: the parent imports everything and runs one subject of
each kind first (so every lazy import and cache is warm), then ``os.fork()`` s a child per run,
which calls :func:`experiment.cli.main` with the command's arguments. Each worker has its own
log files (a new one every :data:`SUBJECTS_PER_LOG` subjects), so the workers never wait on
each other's locks. Used by ``benchmarks/bench_kill_recovery.py`` (10,000 kills) and by
``tests/experiment/test_kill_recovery.py`` (a short run in CI).
"""

from __future__ import annotations

import hashlib
import io
import os
import signal
import sqlite3
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "ACTIVE_PROTOCOL",
    "STATIC_PROTOCOL",
    "SUBJECTS_PER_LOG",
    "KillReport",
    "check_logs",
    "run_kill_recovery",
]

#: The recognition protocol of the kill test (ours): 1 training + 3 objects x 2 levels x 2
#: conditions x 2 repetitions = 25 trials, about 50 ms a run on a warm process.
STATIC_PROTOCOL = """
[protocol]
name = "kill_static"

[[blocks]]
part = "training"
objects = "training"
levels = [2]
conditions = ["decluttered"]
trial_order = "listed"

[[blocks]]
part = "main"
objects = "main"
levels = [1, 2]
conditions = ["cluttered", "decluttered"]
repetitions = 2
"""

#: The active-search protocol of the kill test (ours): the three-plane scene, small, 4 trials.
ACTIVE_PROTOCOL = """
[protocol]
name = "kill_active"
pass_allowed_after_s = 0.0
feedback = false

[task]
type = "active_search"
scene = "synthetic:three_plane"
targets = ["pedestrian", "tree"]
conditions = ["decluttered", "cluttered"]
grid_px = [12, 15]
scene_shape_px = [96, 120]
n_planes = 20
time_limit_s = 40.0
scene_grid = [3, 3]
repetitions = 1
trial_order = "random"

[scoring]
primary_rater = "operator"

[scoring.recognized]
named = true
use = true
shape = false
wrong = false
pass = false
"""

#: Subjects per log file before a worker starts a new one (keeps each file small).
SUBJECTS_PER_LOG = 40
#: Kill delays are drawn uniformly from 0 to this many times a whole uninterrupted run.
_DELAY_SPAN = 1.25
#: A subject whose command fails this many times without being killed is given up.
_MAX_FAILURES = 3


@dataclass
class KillReport:
    """What a kill test did and found (all counts; ``failures`` holds one line each)."""

    kills: int = 0
    runs: int = 0
    subjects: int = 0
    static_subjects: int = 0
    active_subjects: int = 0
    trials_checked: int = 0
    lost: int = 0
    duplicated: int = 0
    extra_sessions: int = 0
    rerun_sessions: int = 0
    stale_locks: int = 0
    complete_reports: int = 0
    complete_reports_that_wrote: int = 0
    logs: int = 0
    wall_s: float = 0.0
    full_run_s: dict[str, float] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether nothing was lost, duplicated, added or run again, and nothing else went wrong.

        That is also: no completed session kept a lock, and no command failed.
        """
        return not (
            self.lost
            or self.duplicated
            or self.extra_sessions
            or self.rerun_sessions
            or self.stale_locks
            or self.complete_reports_that_wrote
            or self.failures
        )

    def lines(self) -> list[str]:
        """Return the report as printable lines."""
        per_kill = self.wall_s / self.kills if self.kills else float("nan")
        out = [
            f"kills (SIGKILL): {self.kills} in {self.runs} runs, {per_kill * 1000:.1f} ms of "
            f"wall time per kill",
            f"subjects: {self.subjects} ({self.static_subjects} session run, "
            f"{self.active_subjects} active run) in {self.logs} log files",
            f"trials checked: {self.trials_checked}",
            f"lost: {self.lost}   duplicated: {self.duplicated}   extra sessions: "
            f"{self.extra_sessions}   sessions run again after complete: {self.rerun_sessions}",
            f"stale locks on completed sessions: {self.stale_locks}",
            f"kills after the complete commit (next run reported 'complete'): "
            f"{self.complete_reports}; of those runs, wrote to the log: "
            f"{self.complete_reports_that_wrote}",
            "whole run (warm): "
            + ", ".join(f"{k} {v * 1000:.0f} ms" for k, v in self.full_run_s.items()),
            f"wall time: {self.wall_s:.1f} s",
        ]
        out += [f"FAILURE: {f}" for f in self.failures[:20]]
        if len(self.failures) > 20:
            out.append(f"... and {len(self.failures) - 20} more failures")
        out.append("OK" if self.ok else "FAILED")
        return out


@dataclass
class _Subject:
    code: str
    kind: str  # "static" or "active"
    log: Path
    argv: list[str]
    runs: int = 0
    kills: int = 0
    failures: int = 0
    hashes: tuple[str, str] | None = None


@dataclass
class _Slot:
    index: int
    subject: _Subject | None = None
    pid: int | None = None
    deadline: float | None = None
    started: float = 0.0
    killed: bool = False
    n_subjects: int = 0


def _file_hashes(log: Path) -> tuple[str, str]:
    def one(p: Path) -> str:
        return hashlib.sha256(p.read_bytes()).hexdigest() if p.exists() else "-"

    return one(log), one(Path(f"{log}-wal"))


def _fork_command(argv: list[str], out: Path, release: tuple[int, int] | None = None) -> int:
    """Fork a child that runs ``confocal ARGV`` (output to ``out``); return its pid.

    ``release``: a pipe's ``(read end, write end)``; the child closes the write end and waits
    for the end of the pipe before it runs the command (so that the parent starts several
    children at the same moment by closing its write end).
    """
    from experiment import cli
    from experiment.log import faults

    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid:
        return pid
    code = 99  # pragma: no cover - the child
    try:
        if release is not None:
            os.close(release[1])
            os.read(release[0], 1)  # returns at the end of the pipe
            os.close(release[0])
        fd = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.close(fd)
        sys.stdout = io.TextIOWrapper(open(1, "wb", closefd=False), line_buffering=True)  # noqa: SIM115
        sys.stderr = io.TextIOWrapper(open(2, "wb", closefd=False), line_buffering=True)  # noqa: SIM115
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.environ.pop(faults.FAULT_ENV, None)
        faults.reset_faults()
        try:
            cli.main(argv)
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # noqa: BLE001 - reported through the output file
        traceback.print_exc()
        code = 98
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)


def _setup(workdir: Path) -> tuple[Path, Path, Path]:
    from experiment.testing import make_stimulus_set

    workdir.mkdir(parents=True, exist_ok=True)
    stim = workdir / "stim"
    if not (stim / "manifest.csv").exists():
        make_stimulus_set(stim, n_main=3, n_training=1, levels=(1, 2))
    static = workdir / "kill_static.toml"
    static.write_text(STATIC_PROTOCOL)
    active = workdir / "kill_active.toml"
    active.write_text(ACTIVE_PROTOCOL)
    return stim, static, active


def _argv(kind: str, code: str, log: Path, stim: Path, static: Path, active: Path) -> list[str]:
    seed = str(int(hashlib.sha256(code.encode()).hexdigest()[:8], 16))
    if kind == "static":
        return ["session", "run", "--protocol", str(static), "--stimuli", str(stim),
                "--subject", code, "--data", str(log), "--headless", "--observer", "logistic",
                "--seed", seed]  # fmt: skip
    return ["active", "run", str(active), "--data", str(log), "--subject", code, "--seed", seed]


def run_kill_recovery(
    workdir: str | Path,
    *,
    kills: int,
    workers: int = 2,
    seed: int = 0,
    active_share: float = 0.25,
    progress: Callable[[str], None] | None = None,
) -> KillReport:
    """Kill ``session run`` / ``active run`` at random times until ``kills`` SIGKILLs, recover.

    Parameters
    ----------
    workdir : str or Path
        Folder for the stimulus set, protocols, logs and output files (created).
    kills : int
        SIGKILLs to deliver (at least); then the subjects in progress finish without kills.
    workers : int
        Commands running at once (one per CPU core is right).
    seed : int
        Seed of the kill delays and of which subjects are active-search ones.
    active_share : float
        Fraction of subjects that run ``active run`` (the rest run ``session run``).
    progress : callable (str) -> None, optional
        Called with a line now and then.

    Returns
    -------
    KillReport
    """
    if kills < 0 or workers < 1 or not 0.0 <= active_share <= 1.0:
        raise ValueError("kills must be >= 0, workers >= 1 and active_share in [0, 1]")
    t0 = time.perf_counter()
    workdir = Path(workdir)
    stim, static_proto, active_proto = _setup(workdir)
    rng = np.random.default_rng(seed)
    report = KillReport()
    # warm-up in this process: every lazy import and cache, then a timed whole run of each kind
    warm = workdir / "warmup"
    warm.mkdir(exist_ok=True)
    for kind in ("static", "active"):
        from experiment import cli

        argv = _argv(kind, f"W{kind[0]}", warm / f"{kind}.sqlite", stim, static_proto, active_proto)
        try:
            with open(os.devnull, "w") as null:
                old = sys.stdout
                sys.stdout = null
                try:
                    cli.main(argv)
                finally:
                    sys.stdout = old
        except SystemExit as exc:
            if exc.code:
                raise RuntimeError(f"warm-up {kind} run failed with status {exc.code}") from None
        # timed under the test's own load: `workers` whole runs at once
        start = time.perf_counter()
        pids = [
            _fork_command(
                _argv(kind, f"T{kind[0]}{i}", warm / f"{kind}{i}.sqlite", stim, static_proto,
                      active_proto),
                warm / f"{kind}{i}.out",
            )
            for i in range(workers)
        ]  # fmt: skip
        ends = []
        for i, pid in enumerate(pids):
            status = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
            ends.append(time.perf_counter() - start)
            if status != 0:
                text = (warm / f"{kind}{i}.out").read_text()
                raise RuntimeError(f"timed {kind} run failed ({status}): {text}")
        report.full_run_s[kind] = float(np.median(ends))
    subjects: list[_Subject] = []
    slots = [_Slot(i) for i in range(workers)]
    counter = 0

    def new_subject(slot: _Slot) -> _Subject:
        nonlocal counter
        kind = "active" if rng.random() < active_share else "static"
        code = f"{kind[0].upper()}{counter:06d}"
        counter += 1
        log = workdir / f"w{slot.index}_{kind}_{slot.n_subjects // SUBJECTS_PER_LOG:04d}.sqlite"
        slot.n_subjects += 1
        s = _Subject(code, kind, log, _argv(kind, code, log, stim, static_proto, active_proto))
        subjects.append(s)
        return s

    def start(slot: _Slot) -> None:
        s = slot.subject
        assert s is not None
        s.hashes = _file_hashes(s.log) if s.kills else None
        s.runs += 1
        report.runs += 1
        slot.killed = False
        slot.started = time.perf_counter()
        slot.pid = _fork_command(s.argv, workdir / f"slot{slot.index}.out")
        if report.kills + sum(1 for x in slots if x.deadline is not None) < kills:
            slot.deadline = slot.started + rng.uniform(0.0, _DELAY_SPAN * report.full_run_s[s.kind])
        else:
            slot.deadline = None

    def finished(slot: _Slot, status: int) -> None:
        s = slot.subject
        assert s is not None
        slot.pid, slot.deadline = None, None
        if status == -signal.SIGKILL and slot.killed:
            report.kills += 1
            s.kills += 1
            start(slot)  # the README's recovery: the same command again
            return
        text = (workdir / f"slot{slot.index}.out").read_text(errors="replace")
        if status != 0:
            s.failures += 1
            last = (text.strip().splitlines() or ["(no output)"])[-1]
            if s.failures < _MAX_FAILURES:
                report.failures.append(f"{s.code} ({s.kind}): exit status {status}: {last}")
                start(slot)
                return
            report.failures.append(f"{s.code} ({s.kind}): given up after {s.failures} failures")
        elif "is complete (ended" in text:
            report.complete_reports += 1
            if s.hashes is not None and _file_hashes(s.log) != s.hashes:
                report.complete_reports_that_wrote += 1
                report.failures.append(f"{s.code}: a run that reported 'complete' wrote the log")
        slot.subject = None

    def fill() -> None:
        for slot in slots:
            if slot.subject is None and report.kills + _pending() < kills:
                slot.subject = new_subject(slot)
                start(slot)

    def _pending() -> int:
        return sum(1 for x in slots if x.deadline is not None)

    fill()
    last_note = time.perf_counter()
    while any(slot.pid is not None for slot in slots):
        now = time.perf_counter()
        for slot in slots:
            if slot.pid is not None and slot.deadline is not None and now >= slot.deadline:
                try:
                    os.kill(slot.pid, signal.SIGKILL)
                    slot.killed = True
                except ProcessLookupError:
                    pass
                slot.deadline = None
        while True:
            try:
                pid, wstatus = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                pid = 0
            if pid == 0:
                break
            slot = next(x for x in slots if x.pid == pid)
            finished(slot, os.waitstatus_to_exitcode(wstatus))
        fill()
        deadlines = [x.deadline for x in slots if x.deadline is not None]
        wait = min([0.002, *(d - time.perf_counter() for d in deadlines)])
        if wait > 0:
            time.sleep(wait)
        if progress is not None and time.perf_counter() - last_note > 30:
            last_note = time.perf_counter()
            progress(f"{report.kills} kills, {len(subjects)} subjects, {report.runs} runs")
    checked = check_logs(subjects)
    for k in (
        "trials_checked",
        "lost",
        "duplicated",
        "extra_sessions",
        "rerun_sessions",
        "stale_locks",
    ):
        setattr(report, k, checked[k])
    report.failures += checked["failures"]
    report.subjects = len(subjects)
    report.static_subjects = sum(s.kind == "static" for s in subjects)
    report.active_subjects = report.subjects - report.static_subjects
    report.logs = len({s.log for s in subjects})
    report.wall_s = time.perf_counter() - t0
    return report


def check_logs(subjects: list) -> dict:
    """Read every subject's log and count what a kill may have broken.

    ``subjects`` are objects with ``code``, ``kind`` (``static``/``active``) and ``log``.

    Returns
    -------
    dict
        ``trials_checked`` (planned trials of all subjects), ``lost`` (planned, not answered),
        ``duplicated`` (answered, or scored first, more than once), ``extra_sessions`` (more
        than one session for a subject, or a session of no subject run), ``rerun_sessions``
        (a session opened or resumed after its ``complete`` event), ``stale_locks`` (lock rows
        of completed sessions: ``session status`` would call them open), ``failures`` (lines).
    """
    out = {
        "trials_checked": 0,
        "lost": 0,
        "duplicated": 0,
        "extra_sessions": 0,
        "rerun_sessions": 0,
        "stale_locks": 0,
        "failures": [],
    }
    by_log: dict[Path, list] = {}
    for s in subjects:
        by_log.setdefault(Path(s.log), []).append(s)
    for log, subs in sorted(by_log.items()):
        if not log.exists():
            out["failures"].append(f"{log}: no log file")
            continue
        con = sqlite3.connect(log.resolve().as_uri() + "?mode=ro", uri=True)
        try:
            if not con.execute("SELECT 1 FROM sqlite_master WHERE name = 'sessions'").fetchone():
                out["failures"].append(f"{log.name}: no sessions table")
                continue
            known = {s.code for s in subs}
            for (subject,) in con.execute("SELECT DISTINCT subject FROM sessions"):
                if subject not in known:
                    out["extra_sessions"] += 1
                    out["failures"].append(f"{log.name}: a session of unknown subject {subject}")
            for s in subs:
                _check_subject(con, log, s, out)
            out["stale_locks"] += con.execute(
                "SELECT count(*) FROM locks JOIN sessions USING (session_id) "
                "WHERE sessions.status = 'completed'"
            ).fetchone()[0]
        finally:
            con.close()
    return out


def _check_subject(con: sqlite3.Connection, log: Path, s, out: dict) -> None:
    import json

    rows = con.execute(
        "SELECT session_id, status FROM sessions WHERE subject = ? ORDER BY session_id",
        (s.code,),
    ).fetchall()
    if not rows:
        out["failures"].append(f"{log.name}: {s.code} has no session")
        return
    out["extra_sessions"] += len(rows) - 1
    sid, status = rows[0]
    if status != "completed":
        out["failures"].append(f"{log.name}: {s.code} session {sid} is {status}, not completed")
    kinds = [
        k
        for (k,) in con.execute(
            "SELECT kind FROM events WHERE session_id = ? ORDER BY event_id", (sid,)
        )
    ]
    if kinds.count("open") != 1:
        out["failures"].append(f"{log.name}: {s.code} session {sid} opened {kinds.count('open')}x")
    if "complete" in kinds:
        after = kinds[kinds.index("complete") + 1 :]
        out["rerun_sessions"] += int(any(k in ("open", "resume", "crash") for k in after))
    else:
        out["failures"].append(f"{log.name}: {s.code} session {sid} has no complete event")
    if s.kind == "static":
        planned = con.execute(
            "SELECT trial_index, object, condition, level FROM schedule WHERE session_id = ? "
            "ORDER BY trial_index",
            (sid,),
        ).fetchall()
        answered = con.execute(
            "SELECT trial_index, object, condition, level FROM trials WHERE session_id = ? "
            "ORDER BY trial_index",
            (sid,),
        ).fetchall()
        firsts = con.execute(
            "SELECT count(*) FROM (SELECT trial_index FROM scores WHERE session_id = ? "
            "GROUP BY trial_index HAVING count(*) > 1)",
            (sid,),
        ).fetchone()[0]
        idx = [r[0] for r in answered]
        out["trials_checked"] += len(planned)
        out["lost"] += len({r[0] for r in planned} - set(idx))
        out["duplicated"] += len(idx) - len(set(idx)) + firsts
        if sorted(set(answered)) != sorted(set(planned)) and len(set(idx)) == len(planned):
            out["failures"].append(f"{log.name}: {s.code} answered trials differ from the plan")
        return
    plan = con.execute(
        "SELECT payload FROM active_events WHERE session_id = ? AND kind = 'plan'", (sid,)
    ).fetchall()
    if len(plan) != 1:
        out["failures"].append(f"{log.name}: {s.code} session {sid} has {len(plan)} plans")
        return
    trials = [int(t["index"]) for t in json.loads(plan[0][0])["trials"]]
    counts = dict(
        con.execute(
            "SELECT trial, count(*) FROM active_events WHERE session_id = ? AND kind = 'answer' "
            "GROUP BY trial",
            (sid,),
        ).fetchall()
    )
    out["trials_checked"] += len(trials)
    out["lost"] += sum(1 for t in trials if counts.get(t, 0) == 0)
    out["duplicated"] += sum(max(0, n - 1) for n in counts.values())
