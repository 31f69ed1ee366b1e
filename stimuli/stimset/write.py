"""Writing a stimulus set: stimulus PNGs, contact sheets, implant views, manifest, set record.

The set is written into a staging folder beside the output folder and renamed onto it at the
end (:func:`stimuli.io.staged_folder`: only onto a missing or empty folder, never deleting
anything), so the output folder is untouched by any error; a full disk ends with a one-line
message. With worker processes or a Dask cluster, each object is compressed and drawn there
(:func:`render_object`, in memory) and its PNGs are written here as it comes back.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from stimuli.contact import contact_sheet, save_contact_sheet
from stimuli.io import save_png, sha256_file, staged_folder, to_uint8
from stimuli.manifest import StimulusRecord, format_crop, write_manifest, write_objects_csv
from stimuli.stimset.conditions import conditions_record, object_conditions
from stimuli.stimset.edges import SetEdgeRatio
from stimuli.stimset.implant_views import write_implant_views
from stimuli.stimset.levels import Ladder, edges_on_ladder, grey_on_ladder, level_labels
from stimuli.stimset.pairs import path_in_pairs
from stimuli.stimset.parallel import ProgressFn, map_objects, map_on_pool
from stimuli.stimset.params import BuildParams
from stimuli.stimset.plan import BuildPlan
from stimuli.stimset.prepare import ObjectImages
from stimuli.stimset.provenance import (
    ObjectSummary,
    build_notes,
    object_summary,
    object_warnings,
    set_record,
)
from stimuli.stimset.visibility import visibility_line

if TYPE_CHECKING:
    from stimuli.lfbatch import CapturePool

__all__ = ["WrittenSet", "RenderedObject", "write_stimulus_set", "render_object"]


@dataclass(frozen=True)
class WrittenSet:
    """What :func:`write_stimulus_set` wrote.

    Parameters
    ----------
    n_stimuli : int
        Rows of ``manifest.csv``.
    objects : tuple of ObjectSummary
    notes : tuple of str
        Things the user should know (centre crops, upsampling).
    n_implant_views : int
        (grid, phosphenes) pairs written, one per object, condition and implant.
    """

    n_stimuli: int
    objects: tuple[ObjectSummary, ...]
    notes: tuple[str, ...]
    n_implant_views: int


def write_stimulus_set(
    plan: BuildPlan,
    works: list[ObjectImages],
    ratio: SetEdgeRatio,
    progress: ProgressFn | None = None,
    pool: CapturePool | None = None,
) -> WrittenSet:
    """Write the whole set into ``plan.out_dir``, through a staging folder renamed at the end.

    Parameters
    ----------
    plan : BuildPlan
    works : list of ObjectImages
        Every object, prepared (and de-cluttered in edge mode), in object order.
    ratio : SetEdgeRatio
    progress : callable(stage, done, total), optional
        Called as objects are written (``'write'``) and their implant views drawn
        (``'implants'``).
    pool : CapturePool, optional
        Worker processes or a Dask cluster that compress each object and draw its contact
        sheet (:func:`render_object`, in memory); this process writes the PNGs as each object
        comes back. Without one, ``plan.workers`` threads do both.

    Returns
    -------
    WrittenSet

    Raises
    ------
    InputError
        If the disk fills up (the partial set is removed, ``out_dir`` left as it was).
    """
    out_dir, edge_ratio = plan.out_dir, ratio.edge_ratio
    labels = level_labels(plan.ladder)
    with staged_folder(out_dir, what="the stimulus set") as tmp:
        (tmp / "contact").mkdir()
        tasks = [(w, plan.params, edge_ratio, plan.ladder) for w in works]

        def save(i: int, rendered: RenderedObject) -> tuple[list[StimulusRecord], list]:
            records = _save_rendered(
                rendered, works[i], tmp, plan.params, edge_ratio, plan.inp.root, plan.hashes[i]
            )
            return records, _overview_rows(rendered, works[i])

        if pool is None or pool.is_local:
            saved = map_objects(
                lambda i: save(i, render_object(*tasks[i])),
                range(len(works)),
                plan.workers,
                progress,
                "write",
            )
        else:
            saved = map_on_pool(pool, render_object, tasks, progress, "write", then=save)
        records = [r for recs, _ in saved for r in recs]
        views: list[dict] = []
        if plan.implants:
            per_object_views = map_objects(
                lambda w: write_implant_views(
                    w, tmp, plan.implants, edge_ratio, plan.implant_px_per_electrode
                ),
                works,
                plan.workers,
                progress,
                "implants",
            )
            views = [v for vs in per_object_views for v in vs]
        write_manifest(records, tmp / "manifest.csv")
        write_objects_csv(plan.inp.objects, tmp / "objects.csv")
        _write_overview(works, [rows for _, rows in saved], tmp, labels)
        summaries = tuple(object_summary(w) for w in works)
        notes = build_notes(works, plan.params)
        meta = set_record(plan, ratio, summaries, notes, len(records), tmp / "manifest.csv", views)
        record = conditions_record(plan.params, works)
        if record is not None:
            meta["conditions"] = record
        (tmp / "stimulus_set.json").write_text(json.dumps(meta, indent=2) + "\n", "utf-8")
    return WrittenSet(
        n_stimuli=len(records), objects=summaries, notes=notes, n_implant_views=len(views)
    )


@dataclass(frozen=True)
class RenderedObject:
    """One object's stimuli and contact sheet, in memory (:func:`render_object`).

    Parameters
    ----------
    stimuli : tuple of (condition, level, window_px, file name, image)
        In the order they are listed in ``manifest.csv``; images bool (edges) or float32 in
        [0, 1] (photos, grey mode; colour photos ``(rows, cols, 3)``).
    sheet : ndarray of uint8
        The object's contact sheet (``contact/<object>.png``).
    """

    stimuli: tuple[tuple[str, int, int, str, np.ndarray], ...]
    sheet: np.ndarray


def render_object(
    work: ObjectImages,
    params: BuildParams,
    edge_ratio: float | None,
    ladder: Ladder,
) -> RenderedObject:
    """Compress one object at every level of the plan's ladder and draw its contact sheet.

    In memory: writes nothing and reads nothing (it may run in a worker process or on a Dask
    cluster). The photo of the object, and a training object's colour photos (made by the
    prepare step), come first, then each condition at every level of ``ladder``
    (``plan.ladder``), ``<condition>_L<level>_w<window>.png``.
    """
    oid = work.info.object
    grey = params.mode == "grey"
    top = len(ladder)
    out: list[tuple[str, int, int, str, np.ndarray]] = [("photo", top, 1, "photo.png", work.wide)]
    if work.info.role == "training":
        if work.colour is None:
            raise ValueError(f"{oid}: a training object's colour photos were not prepared")
        colour_wide, colour_confocal = work.colour
        out.append(("colour_wide", top, 1, "colour_wide.png", colour_wide))
        out.append(("colour_confocal", top, 1, "colour_confocal.png", colour_confocal))
    rows = []
    for condition, img, edges in object_conditions(work):
        if grey:
            stims = grey_on_ladder(img, ladder, grey_levels=params.grey_levels)
        else:
            stims = edges_on_ladder(edges, ladder, edge_ratio=edge_ratio)
        for level, window, stim in stims:
            name = f"{condition}_L{level}_w{window:02d}.png"
            out.append((condition, level, window, name, stim))
        rows.append((condition, [s for _, _, s in stims]))
    warnings = object_warnings(work)
    sheet = contact_sheet(
        rows,
        column_labels=level_labels(ladder),
        title=("WARNING " if warnings else "")
        + f"{oid}: {work.info.display_name} ({work.info.role}; "
        + ("grey" if grey else f"threshold {work.threshold:.4g}, edge ratio {edge_ratio:.4g}")
        + ")"
        + (f"; {visibility_line(work.visibility)}" if work.visibility else ""),
        subtitle="; ".join(w.split(": ", 1)[1] for w in warnings),
    )
    return RenderedObject(tuple(out), sheet)


def _save_rendered(
    rendered: RenderedObject,
    work: ObjectImages,
    tmp: Path,
    params: BuildParams,
    edge_ratio: float | None,
    root: Path,
    hashes: dict[str, str],
) -> list[StimulusRecord]:
    """Write a rendered object into the staging folder; return its ``manifest.csv`` rows.

    Its stimuli go to ``tmp/<object>/`` and its contact sheet to ``tmp/contact/<object>.png``.
    """
    oid = work.info.object
    folder = tmp / oid
    folder.mkdir()
    src = work.source
    if src.lightfield is not None:
        sources = {
            "cluttered": (path_in_pairs(src.lightfield, root) + "#centre", hashes["lightfield"]),
            "decluttered": (
                path_in_pairs(src.lightfield, root) + "#confocal@" + work.plane,
                hashes["lightfield"],
            ),
        }
    else:
        sources = {
            "cluttered": (path_in_pairs(src.wide, root), hashes["wide"]),
            "decluttered": (path_in_pairs(src.narrow, root), hashes["narrow"]),
        }
    for c in work.conditions:  # every method works on the narrow photo
        sources.setdefault(c.name, sources["decluttered"])
    sources["photo"] = sources["cluttered"]
    sources["colour_wide"] = sources["cluttered"]
    sources["colour_confocal"] = sources["decluttered"]
    grey = params.mode == "grey"
    common = dict(
        object=oid,
        role=work.info.role,
        sobel_threshold=None if grey else work.threshold,
        edge_ratio=None if grey else edge_ratio,
        mode=params.mode,
        crop=format_crop(work.crop),
        grey_levels=params.grey_levels if grey else None,
        threshold_source="" if grey else work.threshold_source,
    )
    records = []
    for condition, level, window, name, img in rendered.stimuli:
        path = save_png(img, folder / name)
        h, w = img.shape[:2]
        records.append(
            StimulusRecord(
                condition=condition,
                level=level,
                window=window,
                width=w,
                height=h,
                pixels=w * h,
                path=f"{oid}/{name}",
                sha256=sha256_file(path),
                source=sources[condition][0],
                source_sha256=sources[condition][1],
                **common,
            )
        )
    save_contact_sheet(rendered.sheet, tmp / "contact" / f"{oid}.png")
    return records


def _overview_rows(rendered: RenderedObject, work: ObjectImages) -> list:
    """Return one object's rows of the overview sheet: each condition's stimuli by level.

    As the PNGs hold them (:func:`stimuli.io.to_uint8`), from memory: nothing is read back.
    """
    rows = []
    for condition, _, _ in object_conditions(work):
        stims = sorted((s for s in rendered.stimuli if s[0] == condition), key=lambda s: s[1])
        rows.append((f"{work.info.object} {condition[:5]}", [to_uint8(s[4]) for s in stims]))
    return rows


def _write_overview(
    works: list[ObjectImages], per_object: list[list], tmp: Path, labels: list[str]
) -> None:
    rows = [row for object_rows in per_object for row in object_rows]
    sheet = contact_sheet(
        rows,
        cell_shape_px=(65, 98),
        column_labels=labels,
        title="all objects, every level ("
        + " / ".join(c for c, _, _ in object_conditions(works[0]))
        + ")",
    )
    save_contact_sheet(sheet, tmp / "contact" / "all.png")
