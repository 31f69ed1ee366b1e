"""Build a stimulus set: every object through :mod:`stimuli.stimset`'s steps, then the folder."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from stimuli.implants import ImplantLayout
from stimuli.manifest import ObjectInfo
from stimuli.stimset.conditions import apply_conditions
from stimuli.stimset.edges import declutter_object, set_edge_ratio
from stimuli.stimset.implant_views import IMPLANT_PX_PER_ELECTRODE
from stimuli.stimset.pairs import PairSource
from stimuli.stimset.parallel import ProgressFn, map_objects, map_on_pool
from stimuli.stimset.params import (
    BuildParams,
)
from stimuli.stimset.plan import BuildPlan, plan_build
from stimuli.stimset.prepare import (
    ObjectImages,
    prepare_object,
)
from stimuli.stimset.provenance import ObjectSummary
from stimuli.stimset.visibility import measure_visibility
from stimuli.stimset.write import write_stimulus_set

if TYPE_CHECKING:
    from stimuli.lfbatch import CapturePool

__all__ = ["BuildResult", "build_stimulus_set", "run_plan"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class BuildResult:
    """Result of :func:`build_stimulus_set`.

    Parameters
    ----------
    out_dir : Path
        The stimulus-set folder.
    set_id : str
        SHA-256 identifying the set (parameters, object table and input hashes).
    n_stimuli : int
        Rows of ``manifest.csv``.
    edge_ratio : float or None
        Edge ratio used (``None`` in grey mode).
    mean_wide_edge_fraction : float or None
        Mean edge fraction of the main objects' wide-DOF edge images.
    objects : tuple of ObjectSummary
    notes : tuple of str
        Things the user should know (centre crops, upsampling).
    seconds : dict of str to float
        Wall time per stage: ``read``, ``write``, ``total``.
    implants : tuple of str
        Names of the implants whose views were written (``implants/<name>/``).
    n_implant_views : int
        Implant views written: (grid, phosphenes) pairs, one per object, condition and implant.
    """

    out_dir: Path
    set_id: str
    n_stimuli: int
    edge_ratio: float | None
    mean_wide_edge_fraction: float | None
    objects: tuple[ObjectSummary, ...]
    notes: tuple[str, ...] = ()
    seconds: dict[str, float] = field(default_factory=dict)
    implants: tuple[str, ...] = ()
    n_implant_views: int = 0


def build_stimulus_set(
    pairs: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    params: BuildParams | None = None,
    force: bool = False,
    replaces: str | os.PathLike | None = None,
    workers: int | None = None,
    progress: ProgressFn | None = None,
    implants: Sequence[ImplantLayout] = (),
    implant_px_per_electrode: int = IMPLANT_PX_PER_ELECTRODE,
    processes: int | None = 1,
    cluster: str | None = None,
) -> BuildResult:
    """Build a stimulus set from photo pairs (or light fields) into ``out_dir``.

    Parameters
    ----------
    pairs : str or path-like
        PAIRS folder or CSV (see :func:`read_pairs`).
    out_dir : str or path-like
        Stimulus-set folder to write: a new or empty folder (a non-empty one is refused, never
        replaced). Built in a staging folder beside it and renamed at the end; untouched by
        any error.
    params : BuildParams, optional
        Pipeline parameters; defaults are the paper's.
    force : bool
        Build even if ``replaces`` holds a different stimulus set.
    replaces : str or path-like, optional
        A stimulus set the caller moved aside from ``out_dir`` to be replaced by this build
        (``confocal stimuli build`` does so for a set it wrote there before); a different set
        (another ``set_id``) is refused without ``force``.
    workers : int, optional
        Threads for reading and writing (default: the number of CPUs, at most 8).
    progress : callable(stage, done, total), optional
        Called as objects are read (stage ``'read'``) and written (``'write'``), and as their
        implant views are drawn (``'implants'``).
    implants : sequence of ImplantLayout
        Also write each object's two conditions as every one of these implants shows them
        (:func:`stimuli.implants.load_implant`): the image resampled to the electrode grid
        (``implants/<name>/<object>/<condition>_grid.png``) and its phosphenes
        (``<condition>_phosphenes.png``), recorded with sha256 and the full layout under
        ``implants`` in ``stimulus_set.json``.
    implant_px_per_electrode : int in [1, 256]
        Side of each electrode's cell in the phosphene PNGs, px.
    processes : int >= 1 or None
        Worker processes for the per-object work (reading, plane choice, refocus,
        de-cluttering, compression and contact sheets; None: one per CPU). 1 (the default)
        runs it here on ``workers`` threads. The set written is the same, byte for byte,
        apart from its build time; ``manifest.csv`` and ``stimulus_set.json`` are assembled
        here, in object order.
    cluster : str, optional
        Address of a running Dask scheduler that runs the per-object work instead (the
        optional ``dask`` extra; its workers must see the PAIRS input at the same paths).
        Give ``processes=None`` with it.

    Returns
    -------
    BuildResult

    Raises
    ------
    InputError
        Bad input (missing or unreadable photo, empty folder, duplicate ids, crop outside the
        image, photos of different sizes without ``allow_resize``), an ``out_dir`` that is a
        file or a non-empty folder, or ``replaces`` holding a different set without ``force``.
        Also ``processes`` < 1, both ``processes`` and ``cluster``, or ``cluster`` without Dask
        (checked before anything is read).
    ImplantError
        Two implant layouts share a name, or a grid is finer than the working size (checked
        before anything is read or written).

    References
    ----------
    Jung et al. (2015), Sec. 2.2 (de-cluttering, compression) and Sec. 3.1 (stimuli).
    """
    from stimuli.lfbatch import check_pool_options

    t0 = time.perf_counter()
    if cluster is not None and processes == 1:
        processes = None  # the default: the cluster's workers instead of this process
    check_pool_options(processes, cluster)
    plan = plan_build(
        pairs,
        out_dir,
        params=params,
        force=force,
        replaces=replaces,
        workers=workers,
        implants=implants,
        implant_px_per_electrode=implant_px_per_electrode,
    )
    return _run(plan, progress, processes, cluster, t0)


def run_plan(
    plan: BuildPlan,
    *,
    progress: ProgressFn | None = None,
    processes: int | None = 1,
    cluster: str | None = None,
) -> BuildResult:
    """Carry out a checked plan (:func:`stimuli.stimset.plan.plan_build`): read, de-clutter, write.

    The steps take what the plan resolved (parameters, sources, ``plan.ladder``) and pass their
    frozen results forward; each source is read once.

    Parameters
    ----------
    plan : BuildPlan
    progress, processes, cluster
        As :func:`build_stimulus_set`.

    Returns
    -------
    BuildResult

    Raises
    ------
    InputError
        An unreadable photo, and what :func:`build_stimulus_set` raises once reading started.
    """
    from stimuli.lfbatch import check_pool_options

    t0 = time.perf_counter()
    if cluster is not None and processes == 1:
        processes = None  # the default: the cluster's workers instead of this process
    check_pool_options(processes, cluster)
    return _run(plan, progress, processes, cluster, t0)


def _run(
    plan: BuildPlan,
    progress: ProgressFn | None,
    processes: int | None,
    cluster: str | None,
    t0: float,
) -> BuildResult:
    tasks = [
        (s, o, plan.params, plan.inp.root)
        for s, o in zip(plan.inp.sources, plan.inp.objects, strict=True)
    ]
    if processes == 1:
        return _build(plan, tasks, progress, None, t0)
    from stimuli.lfbatch import CapturePool

    with CapturePool(processes, cluster, max_tasks=len(tasks)) as pool:
        return _build(plan, tasks, progress, pool, t0)


def _build(
    plan: BuildPlan,
    tasks: list[tuple[PairSource, ObjectInfo, BuildParams, Path]],
    progress: ProgressFn | None,
    pool: CapturePool | None,
    t0: float,
) -> BuildResult:
    """Read and de-clutter every object, then write the set (on ``pool``, else on threads)."""
    if pool is None or pool.is_local:
        works = map_objects(lambda t: _read_object(*t), tasks, plan.workers, progress, "read")
    else:
        works = map_on_pool(pool, _read_object, tasks, progress, "read")
    t_read = time.perf_counter()
    ratio = set_edge_ratio(works, plan.params)
    # does each light-field stimulus show its object? (from the depth evidence)
    works = [measure_visibility(w, plan.params, ratio.edge_ratio, plan.ladder) for w in works]
    written = write_stimulus_set(plan, works, ratio, progress, pool)
    t_end = time.perf_counter()
    for n in written.notes:
        logger.info("%s", n)
    return BuildResult(
        out_dir=plan.out_dir,
        set_id=plan.set_id,
        n_stimuli=written.n_stimuli,
        edge_ratio=ratio.edge_ratio,
        mean_wide_edge_fraction=ratio.mean_wide_edge_fraction,
        objects=written.objects,
        notes=written.notes,
        seconds={"read": t_read - t0, "write": t_end - t_read, "total": t_end - t0},
        implants=tuple(lay.name for lay in plan.implants),
        n_implant_views=written.n_implant_views,
    )


def _read_object(
    src: PairSource, info: ObjectInfo, params: BuildParams, root: Path
) -> ObjectImages:
    """Prepare one object's pair at the working size and, in edge mode, de-clutter it.

    In edge mode every condition the build names is made. Each step returns a new frozen
    result.
    """
    work = prepare_object(src, info, params)
    if params.mode != "edges":
        return work
    return apply_conditions(declutter_object(work, params), params, root)
