"""Where log lines go while a console owns the terminal: the session log beside the trial log."""

from __future__ import annotations

import contextlib
import logging
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["session_log_path", "logs_to_file"]


def session_log_path(session: Any) -> Path | None:
    """Return the session log file beside the trial log (``study.sqlite`` -> ``study.log``).

    ``None`` for an in-memory trial log.
    """
    db = str(getattr(getattr(session, "log", None), "path", ":memory:"))
    return None if db == ":memory:" else Path(db).with_suffix(".log")


@contextlib.contextmanager
def logs_to_file(path: str | Path | None, *, prefix: str = "") -> Iterator[None]:
    """Send every log record (moderngl-window's included) to ``path`` instead of the terminal.

    While the console owns the terminal, a log line written there would tear its screen. Handlers
    that write to stdout or stderr are detached from every logger, a file handler (append, level
    INFO) is put on the root logger, and everything is put back on exit. ``path=None`` only
    silences the terminal.

    Parameters
    ----------
    path : str or Path or None
        The session log file.
    prefix : str
        Written after the time stamp on every line (e.g. ``"session 3"``).
    """
    root = logging.getLogger()
    terminal = (sys.stderr, sys.stdout, sys.__stderr__, sys.__stdout__)
    moved: list[tuple[logging.Logger, logging.Handler]] = []
    loggers = [root, *(logging.getLogger(n) for n in list(logging.root.manager.loggerDict))]
    for lg in loggers:
        for h in list(lg.handlers):
            if (
                isinstance(h, logging.StreamHandler)
                and not isinstance(h, logging.FileHandler)
                and getattr(h, "stream", None) in terminal
            ):
                lg.removeHandler(h)
                moved.append((lg, h))
    handler: logging.Handler = (
        logging.NullHandler() if path is None else logging.FileHandler(path, encoding="utf-8")
    )
    tag = f" {prefix}" if prefix else ""
    handler.setFormatter(logging.Formatter(f"%(asctime)s{tag} %(name)s %(levelname)s: %(message)s"))
    old_level = root.level
    root.setLevel(min(old_level, logging.INFO) if old_level else logging.INFO)
    root.addHandler(handler)
    try:
        yield
    finally:
        root.removeHandler(handler)
        handler.close()
        root.setLevel(old_level)
        for lg, h in moved:
            lg.addHandler(h)
