"""Plan of a build: every argument checked and resolved once, before any image is read.

:func:`plan_build` turns the arguments of :func:`stimuli.stimset.build_stimulus_set` into a frozen
:class:`BuildPlan`: the parameters, the implant layouts, the thread count, the PAIRS input with
its source hashes, the set id and the levels. The output folder is checked here too, so that a
refused build has read no photo and written nothing.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.implants import ImplantLayout
from stimuli.io import check_missing_or_empty
from stimuli.manifest import format_crop
from stimuli.stimset.conditions import check_conditions
from stimuli.stimset.implant_views import IMPLANT_PX_PER_ELECTRODE, check_implants
from stimuli.stimset.levels import level_ladder
from stimuli.stimset.pairs import PairsInput, read_pairs, source_hashes
from stimuli.stimset.parallel import thread_count
from stimuli.stimset.params import BuildParams

__all__ = ["BuildPlan", "plan_build", "set_id"]


@dataclass(frozen=True)
class BuildPlan:
    """What a build will do, resolved from its arguments (see :func:`plan_build`).

    Parameters
    ----------
    pairs : Path
        The PAIRS argument as given (folder or CSV).
    out_dir : Path
        The stimulus-set folder to write (missing or empty).
    params : BuildParams
    inp : PairsInput
        The objects and their sources.
    hashes : tuple of dict
        Each source's sha256 (:func:`stimuli.stimset.pairs.source_hashes`), in object order.
    set_id : str
        SHA-256 of the parameters, object table, source hashes and implant layouts.
    workers : int >= 1
        Threads for reading and writing.
    implants : tuple of ImplantLayout
    implant_px_per_electrode : int in [1, 256]
    ladder : tuple of (level, window_px, (rows, cols))
        The set's levels (:func:`stimuli.stimset.levels.level_ladder`).
    """

    pairs: Path
    out_dir: Path
    params: BuildParams
    inp: PairsInput
    hashes: tuple[dict[str, str], ...]
    set_id: str
    workers: int
    implants: tuple[ImplantLayout, ...]
    implant_px_per_electrode: int
    ladder: tuple[tuple[int, int, tuple[int, int]], ...]


def plan_build(
    pairs: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    params: BuildParams | None,
    force: bool,
    replaces: str | os.PathLike | None,
    workers: int | None,
    implants: Sequence[ImplantLayout],
    implant_px_per_electrode: int,
) -> BuildPlan:
    """Check the arguments of a build and resolve them into a :class:`BuildPlan`.

    Parameters are those of :func:`stimuli.stimset.build_stimulus_set`, all given.

    Returns
    -------
    BuildPlan

    Raises
    ------
    InputError
        ``params`` not a BuildParams, bad PAIRS input or a missing source, an object named
        ``implants`` with implant views asked for, an ``out_dir`` that is a file or a non-empty
        folder, or ``replaces`` holding a different set without ``force``.
    ImplantError
        Two implant layouts share a name, or a grid is finer than the working size.
    """
    params = BuildParams() if params is None else params
    if not isinstance(params, BuildParams):
        raise InputError(f"params must be a BuildParams, got {type(params).__name__}")
    implants = check_implants(implants, implant_px_per_electrode, params)
    n_threads = thread_count(workers)
    out_dir = Path(out_dir)
    inp = read_pairs(pairs)
    if implants and any(o.object == "implants" for o in inp.objects):
        raise InputError(
            f"{inp.root}: an object is named 'implants', the folder of the implant views; "
            f"rename it or build without {param('implants')}"
        )
    params = _check_light_field_options(params, inp)
    check_conditions(params, inp)
    hashes = tuple(source_hashes(s) for s in inp.sources)
    sid = set_id(params, inp, hashes, implants, implant_px_per_electrode)
    _check_out_dir(out_dir, sid, force, None if replaces is None else Path(replaces))
    return BuildPlan(
        pairs=Path(pairs),
        out_dir=out_dir,
        params=params,
        inp=inp,
        hashes=hashes,
        set_id=sid,
        workers=n_threads,
        implants=implants,
        implant_px_per_electrode=implant_px_per_electrode,
        ladder=tuple(level_ladder(params.working_shape_px, params.windows_px)),
    )


def _check_light_field_options(params: BuildParams, inp: PairsInput) -> BuildParams:
    """Refuse light-field options on photo pairs; resolve ``declutter='auto'``.

    ``declutter='auto'`` for a set without light fields resolves to the Sobel mode it applies (so
    its id and record are unchanged).
    """
    photos = [s for s in inp.sources if s.lightfield is None]
    if params.declutter == "depth" and photos:
        raise InputError(
            f"{param('declutter', 'depth')} needs light fields, but object {photos[0].object!r} "
            f"is a photo pair (its views cannot be compared); use {param('declutter', 'auto')} "
            f"or {param('declutter', 'sobel')}"
        )
    for s, o in zip(inp.sources, inp.objects, strict=True):
        if s.lightfield is None and o.roi is not None:
            raise InputError(
                f"objects.csv: object {s.object!r}: field roi chooses a light field's plane, "
                "but the object is a photo pair; leave roi empty"
            )
        if s.roi_mask is not None and not s.roi_mask.is_file():
            raise InputError(
                f"objects.csv: object {s.object!r}: field roi: mask image {s.roi_mask} not found"
            )
    if params.declutter == "auto" and len(photos) == len(inp.sources):
        params = replace(params, declutter="sobel")
    return params


def set_id(
    params: BuildParams,
    inp: PairsInput,
    hashes: Sequence[dict[str, str]],
    implants: Sequence[ImplantLayout] = (),
    px_per_electrode: int = IMPLANT_PX_PER_ELECTRODE,
) -> str:
    """Return the SHA-256 that identifies a stimulus set: parameters, objects, sources, implants.

    A set built without implant views keeps the id it had before implant views existed.
    """
    blob: dict = {
        "params": params.to_dict(),
        "objects": [o.to_row() for o in inp.objects],
        "sources": [
            {"object": s.object, "kind": s.kind, "crop": format_crop(s.crop), "sha256": h}
            for s, h in zip(inp.sources, hashes, strict=True)
        ],
    }
    if implants:
        blob["implants"] = {
            "layouts": [lay.to_dict() for lay in implants],
            "px_per_electrode": px_per_electrode,
        }
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()


def _check_out_dir(out_dir: Path, set_id: str, force: bool, replaces: Path | None) -> None:
    check_missing_or_empty(out_dir)
    if replaces is None or force:
        return
    try:
        meta = json.loads((replaces / "stimulus_set.json").read_text(encoding="utf-8"))
        old_id = meta.get("set_id")
    except (OSError, ValueError, AttributeError):
        old_id = None
    if old_id is not None and old_id != set_id:
        raise InputError(
            f"{out_dir}: {param('out_dir')} folder already holds a different stimulus set "
            f"(set_id {str(old_id)[:12]}, this build {set_id[:12]}); use {param('force', True)} "
            "to replace it"
        )
