"""Reading what a program run in a pseudo-terminal (``pty.fork``) writes to its screen."""

from __future__ import annotations

import os
import select
import time


def read_pty(fd: int, out: bytearray, until: float, *, poll_s: float = 0.05) -> bool:
    """Append what the program on pseudo-terminal ``fd`` writes to ``out`` until ``until``.

    Reads for a fixed time rather than until the screen is quiet: a blinking cursor redraws it
    continuously, so "wait until quiet" would never return.

    Parameters
    ----------
    fd : int
        The parent's side of the pseudo-terminal.
    out : bytearray
        The output so far; extended in place.
    until : float
        When to stop, in :func:`time.monotonic` seconds.
    poll_s : float
        The longest wait for output between two checks of the time, seconds.

    Returns
    -------
    bool
        False as soon as the program's side has closed (nothing more will come), else True.
    """
    while time.monotonic() < until:
        ready, _, _ = select.select([fd], [], [], poll_s)
        if ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # Linux: EIO once the program's side has closed
                return False
            if not chunk:
                return False
            out.extend(chunk)
    return True
