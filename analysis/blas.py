"""BLAS on one thread while the analysis runs.

The analysis multiplies small matrices (a few hundred binomial rows by a few dozen columns in
the Firth fits and their profiles, a few hundred walkers in the Weibull batch). OpenBLAS splits
each such call over its threads by default, whose start-up and spinning after every call cost
more CPU than the arithmetic: on the 1,920-trial study the fits took about twice the CPU
time with two BLAS threads as with one (``benchmarks/bench_analysis.py``), and no less wall
time. The same limit as ``stimuli.rowthreads.one_blas_thread`` (the packages do not import each
other).
"""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["one_blas_thread", "on_one_blas_thread"]

_CONTROLLER: dict[str, Any] = {}


def one_blas_thread() -> contextlib.AbstractContextManager:
    """Return a context in which BLAS runs on one thread (the previous limits restored after).

    The limit is process-wide, so it is set only from the main thread, where no other thread
    can be inside a fit to have it undone under it; elsewhere the context changes nothing.

    Returns
    -------
    context manager
        A no-op off the main thread or where ``threadpoolctl`` cannot be loaded.
    """
    if threading.current_thread() is not threading.main_thread():
        return contextlib.nullcontext()
    if "ctl" not in _CONTROLLER:
        try:
            from threadpoolctl import ThreadpoolController

            _CONTROLLER["ctl"] = ThreadpoolController()
        except ImportError:  # pragma: no cover - a declared dependency
            _CONTROLLER["ctl"] = None
    ctl = _CONTROLLER["ctl"]
    return contextlib.nullcontext() if ctl is None else ctl.limit(limits=1, user_api="blas")


def on_one_blas_thread(gen: Callable[..., Iterator[Any]]) -> Callable[..., Iterator[Any]]:
    """Decorate a generator function so that its body runs with BLAS on one thread.

    The limit holds from the first ``next`` until the generator finishes or is closed (also
    while it is suspended at a ``yield``, so for its caller too).

    Parameters
    ----------
    gen : callable
        A generator function.

    Returns
    -------
    callable
        The same generator function, limited.
    """

    @functools.wraps(gen)
    def limited(*args: Any, **kwargs: Any) -> Iterator[Any]:
        with one_blas_thread():
            return (yield from gen(*args, **kwargs))

    return limited
