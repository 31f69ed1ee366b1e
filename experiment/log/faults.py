"""Fault injection at the trial log's write steps, for the crash-safety tests.

:func:`fault_point` is called by :class:`~experiment.log.triallog.TrialLog` at each write step;
it does nothing unless :data:`FAULT_ENV` is set, so the tests choose kill points at every step
instead of by sleeping.
"""

from __future__ import annotations

import os
import sqlite3

__all__ = ["FAULT_ENV", "FAULT_STEPS", "fault_point", "parse_fault", "reset_faults"]

#: Environment variable that injects a fault at a write step (tests of crash safety):
#: ``STEP@N=ACTION``, where STEP is a step name of :data:`FAULT_STEPS` or ``any``, N counts the
#: hits of that step in this process (1-based), and ACTION is ``exit`` (``os._exit(137)`` at that
#: hit, as a SIGKILL would end the process) or ``enospc`` (SQLite's "database or disk is full" at
#: that hit and every later one).
FAULT_ENV = "CONFOCAL_FAULT"

#: The write steps where a fault can be injected, in the order a trial passes through them.
FAULT_STEPS: tuple[str, ...] = (
    "begin",
    "onset.insert",
    "record.trial",
    "record.score",
    "commit",
    "committed",
)

_fault_spec: tuple[str, int, str] | None | bool = False  # False: not parsed yet
_fault_hits: dict[str, int] = {}


def fault_point(step: str) -> None:
    """Count a write step and inject the fault of :data:`FAULT_ENV` when it is due.

    A no-op when the variable is unset; used by the crash-safety tests to choose kill points
    at every write step instead of by sleeping.
    """
    global _fault_spec
    if _fault_spec is False:
        _fault_spec = parse_fault(os.environ.get(FAULT_ENV, ""))
    if _fault_spec is None:
        return
    want, n, action = _fault_spec
    _fault_hits[step] = _fault_hits.get(step, 0) + 1
    _fault_hits["any"] = _fault_hits.get("any", 0) + 1
    if want not in (step, "any"):
        return
    if action == "exit" and _fault_hits[want] == n:
        os._exit(137)
    if action == "enospc" and _fault_hits[want] >= n:  # a full disk stays full
        raise sqlite3.OperationalError("database or disk is full")


def parse_fault(text: str) -> tuple[str, int, str] | None:
    """Return ``(step, n, action)`` of a :data:`FAULT_ENV` value, or None when it is blank.

    Raises
    ------
    ValueError
        ``text`` is not ``STEP@N=exit|enospc`` with a step of :data:`FAULT_STEPS` (or ``any``)
        and N >= 1.
    """
    if not text.strip():
        return None
    try:
        where, action = text.strip().split("=")
        step, n = where.split("@")
        spec = (step, int(n), action)
    except ValueError:
        raise ValueError(f"{FAULT_ENV} must look like STEP@N=exit|enospc, got {text!r}") from None
    if spec[0] not in (*FAULT_STEPS, "any") or spec[1] < 1 or spec[2] not in ("exit", "enospc"):
        raise ValueError(f"{FAULT_ENV} must look like STEP@N=exit|enospc, got {text!r}")
    return spec


def reset_faults() -> None:
    """Forget the parsed :data:`FAULT_ENV` value and the hit counts (in a forked child).

    The next :func:`fault_point` reads the variable again, so a child process can set or clear
    it after the fork.
    """
    global _fault_spec
    _fault_spec = False
    _fault_hits.clear()
