"""Experiment engine: protocols, schedules, sessions, the SQLite trial log, presenter and console.

The ``confocal`` command's root lives in :mod:`experiment.cli`.

When this package is imported as the ``confocal`` command (its console script, or
``python -m experiment.cli``), the first lines below make SIGINT and SIGTERM end the start-up
with one line and status 130 or 143, before anything heavy is imported and before anything is
written; :func:`experiment.signals.stop_on_signals` takes over once the command runs.
"""

from __future__ import annotations

# Only modules loaded before any Python code runs, and ``_signal``, the C half of ``signal``:
# built in and loaded at once, where ``signal`` itself imports enum first (tens of
# milliseconds on a busy machine, in which a Ctrl-C gave a traceback).
import _signal
import os as _os
import sys as _sys


def _is_the_command() -> bool:
    """Whether this process is the ``confocal`` command (not a library user, test or worker)."""
    argv0 = _sys.argv[0] if _sys.argv else ""
    if _os.path.basename(argv0) == "confocal":
        return True
    if argv0 != "-m":  # ``python -m PKG.MOD`` shows "-m" while the module is being found
        return False
    orig = list(getattr(_sys, "orig_argv", ()))
    return any(
        a == "-m" and b == "experiment.cli" for a, b in zip(orig, orig[1:], strict=False)
    ) or ("-mexperiment.cli" in orig)


def _stop_at_start(signum: int, frame: object) -> None:
    """Handle a stop signal before the command runs.

    Nothing is open or written yet: print one line and exit now.
    """
    name = {_signal.SIGINT: "SIGINT", _signal.SIGTERM: "SIGTERM"}.get(signum, f"signal {signum}")
    line = f"confocal: stopped by {name}; the log is closed, nothing half-written\n"
    _os.write(2, line.encode())
    _os._exit(128 + signum)


def _last_exit_function() -> None:
    """Run last of the exit functions, being registered first (see :mod:`experiment.signals`)."""
    signals = _sys.modules.get("experiment.signals")
    if signals is not None:
        signals._at_exit()


#: Whether this process is the ``confocal`` command, with the start-up guard installed.
_COMMAND = _is_the_command()
if _COMMAND:
    for _sig in (_signal.SIGTERM, _signal.SIGINT):
        # ``cmd &`` in sh starts with SIGINT ignored: keep it ignored
        if not (_sig == _signal.SIGINT and _signal.getsignal(_sig) == _signal.SIG_IGN):
            _signal.signal(_sig, _stop_at_start)
    import atexit as _atexit

    _atexit.register(_last_exit_function)

from experiment.errors import ConfocalError  # noqa: E402 - after the start-up guard

__all__ = ["ConfocalError"]
