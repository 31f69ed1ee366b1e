"""What a build records about itself: object summaries, notes and ``stimulus_set.json``.

``stimulus_set.json`` (house style H15) holds the set id, the software version and git commit,
the time of the build, every parameter, the edge ratio, the levels, the PAIRS input and each
object's sources with their sha256, and the implant layouts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path

from stimuli.io import sha256_file
from stimuli.software import git_commit
from stimuli.stimset.edges import SetEdgeRatio, edge_fraction
from stimuli.stimset.implant_views import implants_record
from stimuli.stimset.pairs import pairs_record, path_in_pairs
from stimuli.stimset.params import BuildParams
from stimuli.stimset.plan import BuildPlan
from stimuli.stimset.prepare import MIN_KEPT_SHARE, ObjectImages
from stimuli.stimset.visibility import visibility_warnings

__all__ = [
    "NEARLY_EMPTY_SHARE",
    "object_warnings",
    "SET_FORMAT",
    "SET_FORMAT_VERSION",
    "ObjectSummary",
    "object_summary",
    "build_notes",
    "set_record",
]

#: Name and version of the ``stimulus_set.json`` format written here.
SET_FORMAT = "confocal-stimulus-set"
SET_FORMAT_VERSION = 1


#: A de-cluttered image is *nearly empty* when it holds fewer than this fraction of the edge
#: pixels of the same object's cluttered image at the same threshold (ours: a tenth; the
#: reference is the object's own cluttered image, not an absolute count).
NEARLY_EMPTY_SHARE: float = 0.1


def object_warnings(work: ObjectImages) -> list[str]:
    """Return the warnings about a light-field object's stimulus: marginal plane, nearly empty.

    Empty for photo pairs. Shown as ``note:`` lines, recorded in ``stimulus_set.json`` and
    marked on the object's contact sheet.
    """
    out: list[str] = []
    choice = work.plane_choice
    if choice is not None and getattr(choice, "marginal", ""):
        out.append(f"{work.info.object}: marginal plane ({choice.describe()}): {choice.marginal}")
    if work.source.lightfield is not None and work.narrow_edges is not None:
        wide = edge_fraction(work.wide_edges)
        narrow = edge_fraction(work.narrow_edges)
        if narrow < NEARLY_EMPTY_SHARE * wide or narrow == 0.0:
            out.append(
                f"{work.info.object}: the de-cluttered image is nearly empty ({100 * narrow:.2f} "
                f"% edge pixels, cluttered {100 * wide:.2f} %); check the plane"
            )
    out.extend(visibility_warnings(work.info.object, work.visibility))
    return out


@dataclass(frozen=True)
class ObjectSummary:
    """What the build did to one object (also recorded in ``stimulus_set.json``).

    A light-field object also records ``plane`` (:meth:`stimuli.planechoice.PlaneChoice.to_dict`:
    disparity, depth, support, evidence, rule, alternatives), ``content_kept`` (share of the
    plane's content the crops keep), ``declutter`` (the mode applied), ``warnings`` and, when
    no aspect crop keeps the plane, ``aspect_pad`` (top, bottom, left, right padding, px); these
    are ``None`` (and absent from the record) for photo pairs. ``visibility``: the share of
    the de-cluttered stimulus's white pixels on the plane's support and the object's coverage,
    per level (:mod:`stimuli.stimset.visibility`).
    """

    object: str
    role: str
    sobel_threshold: float | None
    threshold_source: str
    wide_edge_fraction: float | None
    narrow_edge_fraction: float | None
    original_shape_px: tuple[int, int]
    crop: tuple[int, int, int, int] | None
    aspect_crop: tuple[int, int, int, int] | None
    decoded_shape_px: tuple[int, int] | None = None
    plane: dict | None = None
    content_kept: float | None = None
    declutter: str | None = None
    warnings: tuple[str, ...] | None = None
    aspect_pad: tuple[int, int, int, int] | None = None
    visibility: dict | None = None


def object_summary(work: ObjectImages) -> ObjectSummary:
    """Return the summary of one built object."""
    lf = work.source.lightfield is not None
    choice = work.plane_choice
    return ObjectSummary(
        object=work.info.object,
        role=work.info.role,
        sobel_threshold=work.threshold,
        threshold_source=work.threshold_source,
        wide_edge_fraction=None if work.wide_edges is None else edge_fraction(work.wide_edges),
        narrow_edge_fraction=None
        if work.narrow_edges is None
        else edge_fraction(work.narrow_edges),
        original_shape_px=work.original_shape_px,
        crop=work.crop,
        aspect_crop=work.aspect_crop,
        decoded_shape_px=work.decoded_shape_px,
        plane=None if choice is None else choice.to_dict(),
        content_kept=work.content_kept,
        declutter=(work.declutter or None) if lf else None,
        warnings=tuple(object_warnings(work)) if lf else None,
        aspect_pad=work.aspect_pad,
        visibility=work.visibility if lf else None,
    )


def build_notes(works: Sequence[ObjectImages], params: BuildParams) -> tuple[str, ...]:
    """Return what the user should know about a build: centre crops, then each object's notes."""
    notes: list[str] = []
    cropped = [w for w in works if w.aspect_crop is not None and w.content_kept is None]
    if cropped:
        rows, cols = params.working_shape_px
        shapes = sorted({(w.aspect_crop[2], w.aspect_crop[3]) for w in cropped})
        notes.append(
            f"centre-cropped {len(cropped)} of {len(works)} objects to the working aspect "
            f"{cols}:{rows} (kept " + ", ".join(f"{a}x{b}" for a, b in shapes) + " px)"
        )
    for w in works:
        notes.extend(w.notes)
    for w in works:
        if w.aspect_pad is not None:
            notes.append(
                f"{w.info.object}: no crop to the working aspect keeps {100 * MIN_KEPT_SHARE:.0f} "
                "% of its plane's content; padded to the aspect instead (no edges in the padding)"
            )
        if w.content_kept is not None and w.aspect_crop is not None:
            notes.append(
                f"{w.info.object}: cropped to the working aspect around its plane's content "
                f"(kept {100 * w.content_kept:.0f} % of it)"
            )
        notes.extend(object_warnings(w))
    return tuple(notes)


def set_record(
    plan: BuildPlan,
    ratio: SetEdgeRatio,
    summaries: Sequence[ObjectSummary],
    notes: Sequence[str],
    n_stimuli: int,
    manifest: Path,
    implant_views: list[dict],
) -> dict:
    """Return the content of ``stimulus_set.json``.

    Parameters
    ----------
    plan : BuildPlan
    ratio : SetEdgeRatio
    summaries : sequence of ObjectSummary
        In object order.
    notes : sequence of str
    n_stimuli : int
        Rows of ``manifest.csv``.
    manifest : Path
        The ``manifest.csv`` written (its sha256 is recorded).
    implant_views : list of dict
        Entries from :func:`stimuli.stimset.implant_views.write_implant_views`.
    """
    params, inp = plan.params, plan.inp
    meta = {
        "format": SET_FORMAT,
        "format_version": SET_FORMAT_VERSION,
        "set_id": plan.set_id,
        "software": {
            "package": "active-confocal",
            "version": _version(),
            "git_commit": git_commit(),
        },
        "built_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "reference": "Jung, Aloni, Yitzhaky & Peli (2015), Vision Research 111, 182-196",
        "parameters": params.to_dict(),
        "edge_ratio": ratio.edge_ratio,
        "edge_ratio_source": None
        if ratio.edge_ratio is None
        else (
            "given"
            if params.edge_ratio is not None
            else "auto: mean wide-DOF edge fraction of the main objects"
        ),
        "mean_wide_edge_fraction": ratio.mean_wide_edge_fraction,
        "levels": [
            {"level": lv, "window": w, "width": s[1], "height": s[0], "pixels": s[0] * s[1]}
            for lv, w, s in plan.ladder
        ],
        "pairs": pairs_record(plan.pairs),
        "objects_csv": None
        if inp.objects_csv is None
        else {"file": inp.objects_csv.name, "sha256": sha256_file(inp.objects_csv)},
        "objects": [
            {
                **_summary_dict(s),
                "kind": src.kind,
                "sources": {
                    k: {"path": path_in_pairs(getattr(src, k), inp.root), "sha256": h[k]} for k in h
                },
            }
            for s, src, h in zip(summaries, inp.sources, plan.hashes, strict=True)
        ],
        "notes": list(notes),
        "n_stimuli": n_stimuli,
        "manifest_sha256": sha256_file(manifest),
    }
    if plan.implants:
        meta["implants"] = implants_record(
            plan.implants, implant_views, params, ratio.edge_ratio, plan.implant_px_per_electrode
        )
    return meta


def _version() -> str:
    from stimuli import __version__

    return __version__


def _summary_dict(s: ObjectSummary) -> dict:
    d = asdict(s)
    for k in ("original_shape_px", "crop", "aspect_crop", "decoded_shape_px"):
        d[k] = None if d[k] is None else list(d[k])
    for k in ("plane", "content_kept", "declutter", "warnings", "aspect_pad", "visibility"):
        if d[k] is None:
            del d[k]
    if "aspect_pad" in d:
        d["aspect_pad"] = list(d["aspect_pad"])
    if "warnings" in d:
        d["warnings"] = list(d["warnings"])
    return d
