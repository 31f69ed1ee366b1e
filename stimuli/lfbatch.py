"""Many light-field captures at once: find them in a folder and run per-capture work in parallel.

A *folder of captures* holds no view images of its own; each sub-folder of views (or with a
``lightfield.toml``) and each ``.npz``/``.npy`` file in it is one capture. The per-capture work
runs here, in local worker processes (``processes``), or on a Dask cluster (``cluster``: the
address of a running scheduler, as ``confocal analyze power --cluster`` uses; Dask is the
optional ``dask`` extra and is imported only then).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from stimuli.errors import InputError
from stimuli.lfload import _IMAGE_SUFFIXES

__all__ = ["is_capture_folder", "discover_captures", "run_per_capture"]

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


def run_per_capture(
    fn: Callable[..., Any],
    tasks: Sequence[tuple],
    *,
    processes: int | None = None,
    cluster: str | None = None,
) -> Iterator[tuple[int, Any]]:
    """Yield ``(index, fn(*tasks[index]))`` as each task finishes (the caller owns the loop).

    Parameters
    ----------
    fn : callable
        A module-level function (it is sent to other processes by name).
    tasks : sequence of tuple
        The arguments of each call.
    processes : int, optional
        Local worker processes (None: one per CPU, at most one per task; 1: run here).
    cluster : str, optional
        Address of a running Dask scheduler; overrides ``processes``.

    Raises
    ------
    InputError
        ``cluster`` given without Dask installed, or ``processes`` < 1.
    """
    if cluster:
        try:
            from dask.distributed import Client, as_completed
        except ImportError:
            raise InputError(
                "--cluster needs Dask: install the 'dask' extra (pip install .[dask])"
            ) from None
        with Client(cluster) as client:
            futs = {client.submit(fn, *args, pure=False): i for i, args in enumerate(tasks)}
            for fut in as_completed(list(futs)):
                yield futs[fut], fut.result()
        return
    if processes is not None and processes < 1:
        raise InputError(f"--processes must be >= 1, got {processes}")
    n = min(processes or len(os.sched_getaffinity(0)), len(tasks))
    if n <= 1:
        for i, args in enumerate(tasks):
            yield i, fn(*args)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=n, mp_context=mp.get_context("spawn")) as ex:
        futs = {ex.submit(fn, *args): i for i, args in enumerate(tasks)}
        for fut in as_completed(futs):
            yield futs[fut], fut.result()
