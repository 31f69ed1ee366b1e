"""Conditions of a build beyond the paper's pair: each named condition's edges by its method.

The paper's set holds two conditions (``cluttered``, ``decluttered``). ``--conditions`` names
any list: ``cluttered`` (the wide-DOF photo's edges) and de-clutter methods of
:mod:`stimuli.methods` (``decluttered`` and ``sobel`` are the build's de-clutter step, the
paper's; the others run their method on the object's images at the working size, with the
object's own threshold). Every condition then goes through the same compression ladder
(:mod:`stimuli.stimset.levels`). A method that needs the object's mask reads ``OBJECT/mask.png``
in the PAIRS folder (non-zero = object, the photos' pixel size), cut, cropped and resized as
the photos were.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.methods.base import MethodInput
from stimuli.methods.registry import ALIASES, BASELINE_CONDITION, PAPER_CONDITIONS, get_method
from stimuli.stimset.pairs import PairsInput, PairSource
from stimuli.stimset.params import BuildParams
from stimuli.stimset.prepare import (
    ConditionEdges,
    ObjectImages,
    scale_crop,
    to_aspect,
    to_working_size,
    zoom_crop,
)

__all__ = [
    "MASK_NAME",
    "mask_path",
    "check_conditions",
    "apply_conditions",
    "conditions_record",
    "object_conditions",
]

#: File name of an object's own mask, in its PAIRS folder.
MASK_NAME: str = "mask.png"

#: Condition names whose edges are the build's own de-clutter step (the paper's Sobel).
_OWN_STEP = ("decluttered", "sobel")


def mask_path(root: Path, src: PairSource) -> Path:
    """Return where an object's mask is read: ``PAIRS/OBJECT/mask.png``.

    Parameters
    ----------
    root : Path
        The PAIRS folder (the CSV's folder for a CSV input).
    src : PairSource
    """
    return Path(root) / src.object / MASK_NAME


def check_conditions(params: BuildParams, inp: PairsInput) -> None:
    """Refuse, before anything is read, conditions this input cannot give.

    Raises
    ------
    InputError
        Conditions beyond the paper's pair in grey mode; ``depth`` with a photo pair (one line
        naming the object); a method that needs a mask with an object that has none (one line
        naming the object and the file expected).
    """
    conds = params.conditions
    if conds == PAPER_CONDITIONS:
        return
    if params.mode != "edges":
        raise InputError(
            f"{param('conditions', ','.join(conds))}: conditions beyond cluttered,decluttered "
            f"need {param('mode', 'edges')}"
        )
    for name in conds:
        if name == BASELINE_CONDITION or name in _OWN_STEP:
            continue
        method = get_method(name)
        for src in inp.sources:
            if "focus" in method.needs and src.kind == "photos":
                raise InputError(
                    f"condition {name}: object {src.object!r} is a photo pair; {name} needs "
                    "light fields (views to compare)"
                )
            if "mask" in method.needs and not mask_path(inp.root, src).is_file():
                raise InputError(
                    f"condition {name}: object {src.object!r} has no mask "
                    f"{mask_path(inp.root, src)} (expected an image, non-zero = object)"
                )


def _load_mask(work: ObjectImages, root: Path, params: BuildParams) -> np.ndarray:
    """Load the object's mask through the photos' zoom crop, aspect crop and resize, at 0.5."""
    from stimuli.io import load_gray

    path = mask_path(root, work.source)
    try:
        m = load_gray(path)
    except InputError as exc:
        raise InputError(f"condition mask: object {work.info.object!r}: {exc}") from None
    if m.shape != tuple(work.original_shape_px):
        raise InputError(
            f"{path}: mask is {m.shape[1]}x{m.shape[0]} px, expected the photo's "
            f"{work.original_shape_px[1]}x{work.original_shape_px[0]}"
        )
    m = (m > 0).astype(np.float32)
    if work.decoded_shape_px is not None and tuple(work.decoded_shape_px) != m.shape:
        m = to_working_size(m, work.decoded_shape_px)  # --fast-decode read the photos smaller
    m = zoom_crop(m, scale_crop(work.crop, work.original_shape_px, m.shape), where=f"{path}")
    m = to_aspect(m, work)
    return to_working_size(m, params.working_shape_px) >= 0.5


def apply_conditions(work: ObjectImages, params: BuildParams, root: Path) -> ObjectImages:
    """Return the object with its conditions: each one's edge image and what its method measured.

    Run after :func:`stimuli.stimset.edges.declutter_object` (the object's threshold and the two
    paper images); does nothing for the paper's pair.

    Parameters
    ----------
    work : ObjectImages
    params : BuildParams
    root : Path
        The PAIRS folder (for ``OBJECT/mask.png``).

    Returns
    -------
    ObjectImages
        A new result with :attr:`~ObjectImages.conditions` set (``work`` itself for the paper's
        pair; ``work`` is unchanged).
    """
    if params.conditions == PAPER_CONDITIONS:
        return work
    mask = None
    out: dict[str, ConditionEdges] = {}
    for name in params.conditions:
        if name == BASELINE_CONDITION:
            out[name] = ConditionEdges(name, work.wide_edges, {"threshold": work.threshold})
            continue
        if name in _OWN_STEP:
            out[name] = ConditionEdges(name, work.narrow_edges, {"threshold": work.threshold})
            continue
        method = get_method(name)
        if "mask" in method.needs and mask is None:
            mask = _load_mask(work, root, params)
        images = MethodInput(
            object=work.info.object,
            wide=work.wide,
            narrow=work.narrow,
            threshold=float(work.threshold),
            kind=work.source.kind,
            focus=work.focus,
            mask=mask if "mask" in method.needs else None,
        )
        res = method.run(images)
        edges = res.edges if work.valid is None else res.edges & work.valid
        out[name] = ConditionEdges(name, edges, dict(res.measured))
    return replace(work, conditions=tuple(out.values()))


def object_conditions(work: ObjectImages) -> list[tuple[str, np.ndarray, np.ndarray | None]]:
    """Return an object's conditions in order: ``(name, grey image, edge image or None)``.

    The paper's pair (cluttered: the wide photo; decluttered: the narrow one) unless the build
    named other conditions; a method's grey image is the narrow photo it worked on.
    """
    if not work.conditions:
        return [
            ("cluttered", work.wide, work.wide_edges),
            ("decluttered", work.narrow, work.narrow_edges),
        ]
    return [
        (c.name, work.wide if c.name == BASELINE_CONDITION else work.narrow, c.edges)
        for c in work.conditions
    ]


def conditions_record(params: BuildParams, works) -> dict | None:
    """Return ``stimulus_set.json``'s ``conditions`` entry (``None`` for the paper's pair).

    Each condition's method (``cluttered``: none), description, reference, version, source,
    fixed parameters, and per object what the method measured.
    """
    if params.conditions == PAPER_CONDITIONS:
        return None
    rec: dict = {}
    for name in params.conditions:
        if name == BASELINE_CONDITION:
            entry: dict = {
                "method": None,
                "description": "Sobel edges of the wide-DOF photo at the object's threshold "
                "(the paper's cluttered images)",
            }
        else:
            m = get_method(name)
            entry = {
                "method": m.name,
                "alias_of": m.name if name in ALIASES else None,
                "description": m.description,
                "reference": m.reference,
                "version": m.version,
                "source": m.source,
                "parameters": {
                    "threshold_rule": params.threshold_method
                    if params.threshold is None
                    else "global",
                    **dict(m.parameters),
                },
            }
        entry["measured"] = {
            w.info.object: {k: _jsonable(v) for k, v in w.condition(name).measured.items()}
            for w in works
        }
        rec[name] = entry
    return rec


def _jsonable(v):
    if isinstance(v, np.generic):
        return v.item()
    return v
