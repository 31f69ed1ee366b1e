"""Many light-field captures at once: find them in a folder and run per-capture work in parallel.

A *folder of captures* holds no view images of its own; each sub-folder of views (or with a
``lightfield.toml``) and each ``.npz``/``.npy`` file in it is one capture. The per-capture work
runs here, in local worker processes (``processes``), or on a Dask cluster (``cluster``: the
address of a running scheduler, as ``confocal analyze power --cluster`` uses; Dask is the
optional ``dask`` extra and is imported only then).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.lfload import _IMAGE_SUFFIXES

__all__ = [
    "is_capture_folder",
    "discover_captures",
    "check_pool_options",
    "CapturePool",
    "run_per_capture",
]

_ARRAY_SUFFIXES = {".npz", ".npy"}


def _visible(p: Path) -> bool:
    return not p.name.startswith((".", "_"))


def is_capture_folder(path: str | os.PathLike) -> bool:
    """Return True when ``path`` is a folder of captures rather than one light field.

    One light field: a folder holding view images (or a ``lightfield.toml``), or a file. A folder
    of captures holds neither, but sub-folders or ``.npz``/``.npy`` files.
    """
    p = Path(path)
    if not p.is_dir():
        return False
    entries = [e for e in p.iterdir() if _visible(e)]
    if (p / "lightfield.toml").exists() or any(
        e.is_file() and e.suffix.lower() in _IMAGE_SUFFIXES for e in entries
    ):
        return False
    return any(e.is_dir() or e.suffix.lower() in _ARRAY_SUFFIXES for e in entries)


def discover_captures(folder: str | os.PathLike) -> list[Path]:
    """Return the captures in a folder of captures, sorted by name.

    Each visible sub-folder holding view images or a ``lightfield.toml``, and each ``.npz`` or
    ``.npy`` file, is one capture; other entries are ignored.

    Raises
    ------
    InputError
        The folder holds no capture.
    """
    root = Path(folder)
    out = []
    for e in sorted(root.iterdir()):
        if not _visible(e):
            continue
        if e.is_file() and e.suffix.lower() in _ARRAY_SUFFIXES:
            out.append(e)
        elif e.is_dir() and (
            (e / "lightfield.toml").exists()
            or any(f.is_file() and f.suffix.lower() in _IMAGE_SUFFIXES for f in e.iterdir())
        ):
            out.append(e)
    if not out:
        raise InputError(
            f"{root}: no light-field capture found; expected sub-folders of views or .npz/.npy "
            "files, one per capture"
        )
    return out


def check_pool_options(processes: int | None, cluster: str | None) -> None:
    """Refuse bad ``processes`` / ``cluster`` values before any work is done.

    Raises
    ------
    InputError
        ``processes`` < 1, both given, or ``cluster`` given without Dask installed (the
        optional ``dask`` extra).
    """
    if processes is not None and (isinstance(processes, bool) or processes < 1):
        raise InputError(f"{param('processes')} must be >= 1, got {processes}")
    if cluster is not None and processes is not None:
        raise InputError(
            f"{param('processes', processes)} and {param('cluster', cluster)} exclude each other: "
            "give one "
            "(local worker processes, or the workers of a Dask scheduler)"
        )
    if cluster is not None:
        if not str(cluster).strip():
            raise InputError(f"{param('cluster')} must be a Dask scheduler address, got ''")
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise InputError(
                f"{param('cluster')} needs Dask: install the 'dask' extra (pip install .[dask])"
            ) from None


def _call_keeping_warnings(fn: Callable[..., Any], *args: Any) -> tuple[Any, list[tuple]]:
    """Run ``fn(*args)`` in a worker; return its result and the warnings it raised."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # the caller's filters decide when they are re-raised
        result = fn(*args)
    return result, [(str(w.message), w.category, w.filename, w.lineno) for w in caught]


def _reraise_warnings(caught: list[tuple]) -> None:
    for message, category, filename, lineno in caught:
        warnings.warn_explicit(message, category, filename, lineno)


class CapturePool:
    """Where per-capture work runs: here, in local worker processes, or on a Dask cluster.

    A context manager: the workers (or the scheduler connection) live from ``__enter__`` to
    ``__exit__``, so several rounds of work (:meth:`imap`) share them.

    Parameters
    ----------
    processes : int, optional
        Local worker processes (None: one per CPU; 1: run here), at most ``max_tasks``.
    cluster : str, optional
        Address of a running Dask scheduler (then ``processes`` must be None).
    max_tasks : int, optional
        The most tasks one round will have (no more processes are started).

    Raises
    ------
    InputError
        As :func:`check_pool_options`.
    """

    def __init__(
        self,
        processes: int | None = None,
        cluster: str | None = None,
        *,
        max_tasks: int | None = None,
    ) -> None:
        check_pool_options(processes, cluster)
        self.cluster = cluster
        n = processes or len(os.sched_getaffinity(0))
        #: Worker processes (1: the calling process runs every task); 0 with a cluster.
        self.processes = 0 if cluster else max(1, min(n, max_tasks or n))
        self._client: Any = None
        self._executor: Any = None

    def __enter__(self) -> CapturePool:
        if self.cluster:
            from dask.distributed import Client

            self._client = Client(self.cluster)
        elif self.processes > 1:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self._executor = ProcessPoolExecutor(
                max_workers=self.processes, mp_context=mp.get_context("spawn")
            )
        return self

    def __exit__(self, *exc: object) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    @property
    def is_local(self) -> bool:
        """Whether tasks run in this process (one process, no cluster)."""
        return self._client is None and self._executor is None

    def imap(self, fn: Callable[..., Any], tasks: Sequence[tuple]) -> Iterator[tuple[int, Any]]:
        """Yield ``(index, fn(*tasks[index]))`` as each task finishes (the caller owns the loop).

        ``fn`` must be a module-level function (it is sent to the workers by name). Warnings a
        task raises in a worker are raised again here as its result arrives (so the command
        line shows them as it does for work done here). The first exception raised by a task
        propagates; the tasks not yet started are cancelled and
        those running are waited for first, so that nothing the caller cleans up is written
        to afterwards (local processes; a Dask task already running cannot be stopped).
        """
        if self.is_local:
            for i, args in enumerate(tasks):
                yield i, fn(*args)
            return
        if self._client is not None:
            from dask.distributed import as_completed, wait

            futs = {
                self._client.submit(_call_keeping_warnings, fn, *args, pure=False): i
                for i, args in enumerate(tasks)
            }
            try:
                for fut in as_completed(list(futs)):
                    result, caught = fut.result()
                    _reraise_warnings(caught)
                    yield futs[fut], result
            except BaseException:
                self._client.cancel(list(futs))
                wait(list(futs))
                raise
            return
        from concurrent.futures import as_completed as done_first
        from concurrent.futures import wait as wait_all

        pending = {
            self._executor.submit(_call_keeping_warnings, fn, *args): i
            for i, args in enumerate(tasks)
        }
        try:
            for fut in done_first(pending):
                result, caught = fut.result()
                _reraise_warnings(caught)
                yield pending[fut], result
        except BaseException:
            for fut in pending:
                fut.cancel()
            wait_all(list(pending))
            raise


def run_per_capture(
    fn: Callable[..., Any],
    tasks: Sequence[tuple],
    *,
    processes: int | None = None,
    cluster: str | None = None,
) -> Iterator[tuple[int, Any]]:
    """Yield ``(index, fn(*tasks[index]))`` as each task finishes (the caller owns the loop).

    One round of work on a :class:`CapturePool` of its own.

    Parameters
    ----------
    fn : callable
        A module-level function (it is sent to other processes by name).
    tasks : sequence of tuple
        The arguments of each call.
    processes : int, optional
        Local worker processes (None: one per CPU, at most one per task; 1: run here).
    cluster : str, optional
        Address of a running Dask scheduler (then ``processes`` must be None).

    Raises
    ------
    InputError
        ``cluster`` given without Dask installed or with ``processes``, or ``processes`` < 1.
    """
    with CapturePool(processes, cluster, max_tasks=len(tasks)) as pool:
        yield from pool.imap(fn, tasks)
