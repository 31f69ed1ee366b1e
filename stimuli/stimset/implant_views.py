"""Implant views of a build: each object's stimuli as an implant shows them.

Module docstring of :mod:`stimuli.stimset`, step 7: grid and phosphene PNGs under
``implants/<name>/<object>/``, recorded with the implant's whole layout in ``stimulus_set.json``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.implants import ImplantError, ImplantLayout, render_phosphenes, to_implant_grid
from stimuli.io import save_png, sha256_file
from stimuli.stimset.params import BuildParams
from stimuli.stimset.prepare import ObjectImages

__all__ = [
    "IMPLANT_PX_PER_ELECTRODE",
    "check_implants",
    "write_implant_views",
    "implants_record",
]

#: Side of each electrode's square cell in the implant views' phosphene PNGs, px (ours, not the
#: paper's: large enough to show a Gaussian's shape, small enough that Alpha IMS's 39x39 grid
#: stays a 624x624 px image).
IMPLANT_PX_PER_ELECTRODE: int = 16


def check_implants(
    implants: Sequence[ImplantLayout], px_per_electrode: int, params: BuildParams
) -> tuple[ImplantLayout, ...]:
    """Check the implant layouts against each other and the working size; return them as a tuple.

    Raises
    ------
    InputError
        If an item is not an ``ImplantLayout`` or ``px_per_electrode`` is not in [1, 256].
    ImplantError
        If a name cannot name a folder, two layouts share a name, or a grid is finer than the
        working size.
    """
    out = tuple(implants)
    for lay in out:
        if not isinstance(lay, ImplantLayout):
            raise InputError(f"implants must hold ImplantLayout objects, got {type(lay).__name__}")
    for lay in out:
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", lay.name):
            raise ImplantError(
                f"{param('implants')}: layout name {lay.name!r} cannot name a folder in the set; "
                "use "
                "letters, digits, '.', '_' or '-' (starting with a letter or digit)"
            )
    names = [lay.name for lay in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ImplantError(
            f"{param('implants')}: two layouts are named {twice[0]!r} (a layout's name is its "
            "file stem, which names its folder in the set); rename one file"
        )
    p = px_per_electrode
    if isinstance(p, bool) or not isinstance(p, int) or not 1 <= p <= 256:
        raise InputError(f"implant_px_per_electrode must be an integer in [1, 256], got {p!r}")
    rows, cols = params.working_shape_px
    for lay in out:
        if lay.rows > rows or lay.cols > cols:
            raise ImplantError(
                f"{param('implants')} {lay.name}: its {lay.cols}x{lay.rows} grid is finer than "
                f"the {cols}x{rows} working size; use a larger {param('working_shape_px')}"
            )
    return out


def write_implant_views(
    work: ObjectImages,
    tmp: Path,
    implants: Sequence[ImplantLayout],
    edge_ratio: float | None,
    px_per_electrode: int,
) -> list[dict]:
    """Write one object's implant views (grid and phosphene PNGs); return their JSON entries.

    Each condition's image at the working size (the edge image, i.e. the window-1 stimulus; in
    grey mode the grey photo) resampled to every implant's electrode grid
    (:func:`stimuli.implants.to_implant_grid`, with the set's edge ratio) and drawn as its
    phosphenes (:func:`stimuli.implants.render_phosphenes`), under
    ``tmp/implants/<name>/<object>/``.
    """
    oid = work.info.object
    from stimuli.stimset.conditions import object_conditions

    images = {c: grey if edges is None else edges for c, grey, edges in object_conditions(work)}
    kw = {} if edge_ratio is None else {"edge_ratio": edge_ratio}
    entries = []
    for lay in implants:
        folder = tmp / "implants" / lay.name / oid
        folder.mkdir(parents=True)
        alive = lay.alive_mask()
        shape_px = (lay.rows * px_per_electrode, lay.cols * px_per_electrode)
        for condition in images:
            grid = to_implant_grid(images[condition], lay, **kw)
            drawn = render_phosphenes(
                grid, shape_px, shape=lay.phosphene_shape, size=lay.phosphene_size, alive=alive
            )
            entry: dict = {"implant": lay.name, "object": oid, "condition": condition}
            for kind, img in (("grid", grid), ("phosphenes", drawn)):
                name = f"{condition}_{kind}.png"
                path = save_png(img, folder / name)
                entry[kind] = {
                    "path": f"implants/{lay.name}/{oid}/{name}",
                    "sha256": sha256_file(path),
                    "width": int(img.shape[1]),
                    "height": int(img.shape[0]),
                }
            entries.append(entry)
    return entries


def implants_record(
    implants: Sequence[ImplantLayout],
    views: list[dict],
    params: BuildParams,
    edge_ratio: float | None,
    px_per_electrode: int,
) -> list[dict]:
    """Return the ``implants`` entry of ``stimulus_set.json``: each layout in full, its files."""
    if params.mode == "edges":
        method = (
            f"each condition's edge image at the working size (the window-1 stimulus), "
            f"compressed to the grid: an electrode is on where its window's edge fraction exceeds "
            f"the set's edge ratio {edge_ratio:.6g} (Jung et al. 2015, Sec. 2.2)"
        )
    else:
        method = (
            "each condition's grey photo at the working size, compressed to the grid: window "
            "means quantised to the implant's levels (Jung et al. 2015, Fig. 2)"
        )
    return [
        {
            "name": lay.name,
            "layout": lay.to_dict(),
            "grid_shape_px": [lay.rows, lay.cols],
            "px_per_electrode": px_per_electrode,
            "phosphenes_shape_px": [lay.rows * px_per_electrode, lay.cols * px_per_electrode],
            "resampling": method,
            "edge_ratio": edge_ratio,
            "drawing": "stimuli.implants.render_phosphenes with the layout's phosphene_shape, "
            "phosphene_size and dropout (alive_mask from its seed); square cells",
            "files": [v for v in views if v["implant"] == lay.name],
        }
        for lay in implants
    ]
