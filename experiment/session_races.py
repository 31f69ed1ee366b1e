"""Race test of the trial log: the same subject started twice at the same moment.

:func:`run_session_races` starts ``confocal session run --headless`` (or ``confocal active run``
with a simulated searcher) twice for the same new subject and the same log, released together
from a barrier, and checks what the README promises: exactly one session per subject, every
planned trial answered once, no lock left on a completed session; the second command either
is refused with one line ("already open") or, when the first finished first, reports the
session complete.

The commands run in children forked from one warm process (as :mod:`experiment.kill_recovery`
does), so the two starts are milliseconds apart, not an interpreter start-up apart: each child
blocks on a pipe until the parent closes it, and both see the end of the pipe at once. Used by
``benchmarks/bench_session_races.py`` (50 races of each command) and by
``tests/experiment/test_session_races.py`` (a few in CI).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from experiment.kill_recovery import _argv, _fork_command, _setup, check_logs

__all__ = ["RaceReport", "run_session_races"]

#: Subjects per log file (each race adds one subject to its command's current log).
SUBJECTS_PER_LOG = 25


@dataclass
class RaceReport:
    """What the races did and found (counts per command; ``failures`` holds one line each)."""

    races: dict[str, int] = field(default_factory=dict)
    ran: dict[str, int] = field(default_factory=dict)
    refused: dict[str, int] = field(default_factory=dict)
    reported_complete: dict[str, int] = field(default_factory=dict)
    trials_checked: int = 0
    lost: int = 0
    duplicated: int = 0
    extra_sessions: int = 0
    stale_locks: int = 0
    wall_s: float = 0.0
    failures: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether every subject has one whole session and nothing else went wrong.

        That is also: nothing is lost or doubled, no lock is left on a completed session and
        every command ended as expected.
        """
        return not (
            self.lost or self.duplicated or self.extra_sessions or self.stale_locks or self.failures
        )

    def lines(self) -> list[str]:
        """Return the report as printable lines."""
        out = []
        for kind, n in self.races.items():
            out.append(
                f"{kind}: {n} races (2 starts each): ran {self.ran.get(kind, 0)}, refused "
                f"'already open' {self.refused.get(kind, 0)}, reported complete "
                f"{self.reported_complete.get(kind, 0)}"
            )
        out += [
            f"trials checked: {self.trials_checked}",
            f"lost: {self.lost}   duplicated: {self.duplicated}   extra sessions: "
            f"{self.extra_sessions}   stale locks on completed sessions: {self.stale_locks}",
            f"wall time: {self.wall_s:.1f} s",
        ]
        out += [f"FAILURE: {f}" for f in self.failures[:20]]
        out.append("OK" if self.ok else "FAILED")
        return out


@dataclass
class _Subject:
    code: str
    kind: str
    log: Path


def _race(argv: list[str], outs: list[Path]) -> list[int]:
    """Fork one child per output file and return their exit statuses.

    Each child runs ``confocal ARGV`` once the parent releases them together.
    """
    r, w = os.pipe()
    try:
        pids = [_fork_command(argv, out, release=(r, w)) for out in outs]
    finally:
        os.close(r)
        time.sleep(0.02)  # let the children reach the pipe
        os.close(w)  # both children see the end of the pipe at once
    return [os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) for pid in pids]


def run_session_races(
    workdir: str | Path,
    *,
    races: int,
    kinds: tuple[str, ...] = ("static", "active"),
    progress: Callable[[str], None] | None = None,
) -> RaceReport:
    """Start the same new subject twice at once, ``races`` times per command, and check the logs.

    Parameters
    ----------
    workdir : str or Path
        Folder for the stimulus set, protocols, logs and output files (created).
    races : int
        Races per command (each a new subject started by two commands at once).
    kinds : tuple of str
        ``static`` (``session run``) and/or ``active`` (``active run``).
    progress : callable (str) -> None, optional
        Called with a line after each command's races.

    Returns
    -------
    RaceReport
    """
    if races < 0 or not set(kinds) <= {"static", "active"}:
        raise ValueError("races must be >= 0 and kinds among 'static', 'active'")
    from experiment import cli

    t0 = time.perf_counter()
    workdir = Path(workdir)
    stim, static_proto, active_proto = _setup(workdir)
    report = RaceReport()
    # warm-up in this process: every lazy import and cache before the first fork
    warm = workdir / "warmup"
    warm.mkdir(exist_ok=True)
    for kind in kinds:
        argv = _argv(kind, f"W{kind[0]}", warm / f"{kind}.sqlite", stim, static_proto, active_proto)
        with open(os.devnull, "w") as null:
            old = sys.stdout
            sys.stdout = null
            try:
                cli.main(argv)
            except SystemExit as exc:
                if exc.code:
                    raise RuntimeError(f"warm-up {kind} run failed ({exc.code})") from None
            finally:
                sys.stdout = old
    subjects: list[_Subject] = []
    for kind in kinds:
        report.races[kind] = races
        for key in ("ran", "refused", "reported_complete"):
            getattr(report, key)[kind] = 0
        for i in range(races):
            code = f"R{kind[0].upper()}{i:05d}"
            log = workdir / f"race_{kind}_{i // SUBJECTS_PER_LOG:04d}.sqlite"
            subjects.append(_Subject(code, kind, log))
            argv = _argv(kind, code, log, stim, static_proto, active_proto)
            outs = [workdir / f"{code}.{j}.out" for j in range(2)]
            statuses = _race(argv, outs)
            for status, out in zip(statuses, outs, strict=True):
                text = out.read_text(errors="replace").strip()
                # the small synthetic scene's depth warning may come first; the refusal is
                # the one other line
                lines = [x for x in text.splitlines() if not x.startswith("warning:")]
                if status == 0 and "trials answered" in text and "is complete" not in text:
                    report.ran[kind] += 1
                elif status == 0 and "is complete (ended" in text:
                    report.reported_complete[kind] += 1
                elif status == 2 and len(lines) == 1 and "already open" in text:
                    report.refused[kind] += 1
                else:
                    last = lines[-1] if lines else "(no output)"
                    report.failures.append(f"{code} ({kind}): exit status {status}: {last}")
        if progress is not None:
            progress(
                f"{kind}: {races} races, ran {report.ran[kind]}, refused {report.refused[kind]}, "
                f"complete {report.reported_complete[kind]}"
            )
    checked = check_logs(subjects)
    for k in ("trials_checked", "lost", "duplicated", "extra_sessions", "stale_locks"):
        setattr(report, k, checked[k])
    report.failures += checked["failures"]
    report.wall_s = time.perf_counter() - t0
    return report
