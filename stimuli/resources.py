"""Check that a job fits in memory before allocating it, and option values before any work.

A size typed on the command line (a 24,000 px photo, a 10^9-plane scan) is estimated first and
refused with the memory it would need, instead of dying with a ``MemoryError`` traceback or being
killed by the kernel with no message.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from stimuli.errors import InputError

#: Largest seed a command accepts (ours): SQLite's INTEGER and NumPy's int64 hold it, so every
#: seed can be logged and typed again; a larger one is no more random.
MAX_SEED: int = 2**63 - 1

#: Most depth planes of the viewer's startup scan (ours): the paper scans 200; at 10^5 the steps
#: are far below what a refocus can resolve, and the count only sets the time of the scan.
MAX_PLANES: int = 100_000

#: Longest subject, rater or object id (ours): ids become file and folder names and table
#: cells; 64 characters is far more than any study's naming scheme needs.
MAX_ID_CHARS: int = 64

__all__ = [
    "MAX_ID_CHARS",
    "MAX_PLANES",
    "MAX_SEED",
    "available_memory_bytes",
    "check_memory",
    "format_bytes",
    "finite_number",
    "finite_option",
    "parse_pair",
]


def available_memory_bytes() -> int:
    """Return the memory the system can give a new allocation now, bytes (``MemAvailable``).

    Read by ``psutil`` (imported here, not with the module, to keep ``--help`` fast).
    """
    import psutil

    return int(psutil.virtual_memory().available)


def format_bytes(n: float) -> str:
    """Return ``n`` bytes in a short human unit (``'3.2 GiB'``)."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PiB"  # pragma: no cover


def check_memory(needed_bytes: float, what: str) -> None:
    """Refuse a job whose estimated working memory exceeds the memory available now.

    Parameters
    ----------
    needed_bytes : float
        Estimated peak memory of the job, bytes (an estimate from array sizes; it only has to
        be right to within a small factor to turn a crash into a message).
    what : str
        What asked for it, with the option that set the size (``"--size 24000x24000"``).

    Raises
    ------
    InputError
        Naming ``what``, the memory needed and the memory available.
    """
    avail = available_memory_bytes()
    try:  # an int from a typed count (--planes 10**308) can be too large for a float
        needed_bytes = float(needed_bytes)
    except OverflowError:
        needed_bytes = math.inf
    if not math.isfinite(needed_bytes) or needed_bytes > avail:
        raise InputError(
            f"{what} needs about {format_bytes(needed_bytes)} of memory but only "
            f"{format_bytes(avail)} is available; choose a smaller value"
        )


def finite_option(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
):
    """Return a typer callback that refuses NaN, infinities and values outside a range.

    The message names the option and the range (typer prints it in its usage box), e.g.
    ``Invalid value for '--hold-s': must be a finite number >= 0, got inf``.
    """
    import typer

    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"{'<' if hi_open else '<='} {hi:g}")
    want = "a finite number" + (" " + " and ".join(parts) if parts else "")

    def callback(value):
        if value is None:
            return value
        v = float(value)
        bad = not math.isfinite(v)
        if lo is not None:
            bad = bad or (v <= lo if lo_open else v < lo)
        if hi is not None:
            bad = bad or (v >= hi if hi_open else v > hi)
        if bad:
            raise typer.BadParameter(f"must be {want}, got {value!r}")
        return value

    return callback


def finite_number(
    value: Any,
    name: str,
    *,
    expected: str = "a number",
    error: type[Exception] = InputError,
) -> float:
    """Return ``value`` as a float; refuse one that is no number, NaN or infinite.

    Parameters
    ----------
    value : object
        What the caller was given (a float, an int, a numpy scalar, a numeric string).
    name : str
        The argument's name, as the message gives it (``'slope_px_per_view'``).
    expected : str, optional
        What ``name`` must be, as the message gives it (``'a number of seconds'``).
    error : type of Exception, optional
        The caller's one-line error (:class:`~stimuli.errors.InputError` by default).

    Returns
    -------
    float
        The finite value.

    Raises
    ------
    InputError
        Or ``error``: ``<name> must be <expected>, got <value>`` when ``float(value)`` fails,
        ``<name> must be finite, got <value>`` for NaN or an infinity.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise error(f"{name} must be {expected}, got {value!r}") from None
    if not math.isfinite(v):
        raise error(f"{name} must be finite, got {value!r}")
    return v


def parse_pair(
    text: str,
    refusal: str,
    *,
    cast: Callable[[str], Any] = int,
    error: type[Exception] = InputError,
) -> tuple[Any, Any]:
    """Parse an option's ``"AxB"`` (two values joined by ``x`` or ``X``) in the order typed.

    Parameters
    ----------
    text : str
        The option's value, e.g. ``"38x25"``.
    refusal : str
        The message's start for a value that is not two values joined by ``x``: the option and
        the form it takes (``'--grid must be COLSxROWS like 38x25'``); ``, got <text>`` follows.
    cast : callable, optional
        Converts each side (``int``; ``float`` for sizes in cm).
    error : type of Exception, optional
        The caller's one-line error (:class:`~stimuli.errors.InputError` by default).

    Returns
    -------
    tuple
        ``(cast(A), cast(B))``.

    Raises
    ------
    InputError
        Or ``error``, when ``text`` is not two values joined by ``x`` or ``cast`` refuses one.

    Examples
    --------
    >>> parse_pair("38x25", "--grid must be COLSxROWS like 38x25")
    (38, 25)
    """
    try:
        a, b = text.lower().split("x")
        return cast(a), cast(b)
    except ValueError:
        raise error(f"{refusal}, got {text!r}") from None
