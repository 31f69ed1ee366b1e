"""The steps behind ``confocal lightfield``.

Its option parsers, the capture read as the loader options say, and the scan of one capture.

:mod:`stimuli.lightfield_cli` declares the commands and their options; the work they share is
here, importable without typer, and :func:`scan_one` is a module-level function so that worker
processes and Dask workers run it by name (``lightfield scan`` over a folder of captures).
numpy and the pipeline are imported inside the functions: ``--help`` stays light.
"""

from __future__ import annotations

import contextlib
import json
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from stimuli.errors import InputError
from stimuli.resources import parse_pair

__all__ = [
    "VIEW_CROP_HELP",
    "LoaderOptions",
    "check_declutter_mode",
    "check_zoom_aspect",
    "load_grey",
    "parse_disparity_range",
    "parse_grid",
    "parse_zoom",
    "resolve_declutter_mode",
    "scan_disparities",
    "scan_one",
]


#: What ``--view-crop`` takes, for the help of every command that reads a capture.
VIEW_CROP_HELP = (
    "Crop every view first: auto (default: leave out the capture's dark vignette rim and "
    "clipped strip, found in the views the plane scan reads; the same box in every command), "
    "none, or x,y,w,h."
)


def parse_grid(text: str) -> tuple[int, int]:
    """Parse ``"38x25"`` (cols x rows, as the paper writes it) into ``shape_px=(rows, cols)``."""
    cols, rows = parse_pair(text, "--grid must be COLSxROWS like 38x25")
    if rows < 1 or cols < 1:
        raise InputError(f"--grid must be positive, got {text!r}")
    return rows, cols


def parse_zoom(text: str, shape_px: tuple[int, int]) -> tuple[slice, slice]:
    """Parse ``"x,y,w,h"`` (pixels, x = column) into slices, checking it lies inside the image."""
    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--zoom must be x,y,w,h in pixels, got {text!r}") from None
    rows, cols = shape_px
    if w < 2 or h < 2 or x < 0 or y < 0 or x + w > cols or y + h > rows:
        raise InputError(
            f"--zoom {text!r} must be a box of at least 2x2 px inside the {cols}x{rows} image"
        )
    return slice(y, y + h), slice(x, x + w)


def _with_the_other_views(some, path: Path, options: LoaderOptions):
    """Return the light field of which ``some`` holds the views ``meta["views_read"]``, whole."""
    from stimuli.lfviews import LightField

    read = {(int(u), int(v)) for u, v in some.meta["views_read"]}

    def others(grid: tuple[int, int]) -> list[tuple[int, int]]:
        return [(u, v) for u in range(grid[0]) for v in range(grid[1]) if (u, v) not in read]

    box = some.meta.get("view_crop")
    crop = "none" if box is None else ",".join(str(int(v)) for v in box)
    rest = load_grey(path, replace(options, view_crop=crop), others, box_inside=True)
    views = rest.views
    for u, v in read:
        views[u, v] = some.views[u, v]
    meta = {k: v for k, v in rest.meta.items() if k != "views_read"}
    meta["view_crop_rule"] = some.meta.get("view_crop_rule")
    return LightField.checked_already(views, rest.geometry, rest.source, meta)


def parse_disparity_range(text: str) -> tuple[float, float]:
    """Parse ``--disparities FROM:TO`` (pixels per view step): two different finite numbers."""
    try:
        a, b = (float(v) for v in text.split(":"))
    except ValueError:
        raise InputError(f"--disparities must be FROM:TO (pixels per view), got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)) or a == b:
        raise InputError(f"--disparities must be two different finite numbers, got {text!r}")
    return a, b


@dataclass(frozen=True)
class LoaderOptions:
    """How ``scan`` and ``refocus`` read their light field (the loader options of both)."""

    view_crop: str | None = "auto"
    pattern: str | None = None
    grid_cols: int | None = None
    pitch: int | None = None
    border: int | None = None
    offset: str | None = None
    view_bin: int = 1
    bit_depth: int | None = None
    axes: str | None = None
    background: float = 0.0


def load_grey(path: Path, options: LoaderOptions, only_views=None, box_inside: bool = False):
    """Return the light field at ``path``, grey; ``only_views`` is ignored when views are binned.

    ``box_inside``: the given ``view_crop`` box is known to lie inside the views (found in an
    earlier read of the same capture), so the views are cropped as they are read.
    """
    from stimuli.lightfield import load_lightfield
    from stimuli.vignette import apply_view_crop, parse_view_crop

    off = None
    if options.offset is not None:
        try:
            off = tuple(int(v) for v in options.offset.split(","))
            if len(off) != 2:
                raise ValueError
        except ValueError:
            raise InputError(f"--offset must be ROW,COL, got {options.offset!r}") from None
    box = None
    if box_inside and options.view_bin == 1:
        spec = parse_view_crop(options.view_crop)
        box = None if spec is None or spec == "auto" else tuple(spec)
    lf = load_lightfield(
        path,
        pattern=options.pattern,
        grid_cols=options.grid_cols,
        pitch_px=options.pitch,
        border_px=options.border,
        offset_px=off,
        bit_depth=options.bit_depth,
        axes=options.axes,
        background=options.background,
        gray=True,
        only_views=only_views if options.view_bin == 1 else None,
        view_box=box,
    ).gray()
    if options.view_bin != 1:
        lf = lf.view_binned(options.view_bin)
    if box is not None:  # cropped as read: recorded as apply_view_crop records a given box
        out = apply_view_crop(lf, "none")
        out.meta.update(view_crop=list(box), view_crop_rule="given")
        return out
    # auto: the vignette crop every command finds in the scan's views (read in every case)
    return apply_view_crop(lf, options.view_crop)


def scan_disparities(
    lf, planes: int, near: float | None, far: float | None, disparities: str | None
):
    """Return the planes to scan: ``--disparities``, ``--near/--far`` (m), or the scene's range."""
    import numpy as np

    from stimuli.planes import default_disparities

    if disparities is not None and (near is not None or far is not None):
        raise InputError("give --near/--far or --disparities, not both")
    if disparities is not None:
        a, b = parse_disparity_range(disparities)
        return np.linspace(a, b, planes)
    if near is not None or far is not None:
        if near is None or far is None:
            raise InputError("--near and --far go together")
        if lf.geometry is None:
            raise InputError(
                f"{lf.source}: no geometry (lightfield.toml), so --near/--far in metres cannot be "
                "used; give --disparities FROM:TO"
            )
        if not near < far:
            raise InputError(f"--near must be < --far, got {near} and {far}")
        depths = np.linspace(near, far, planes)
        return np.array([lf.disparity_px(z) for z in depths])
    return default_disparities(lf, planes)


def check_declutter_mode(declutter_mode: str) -> str:
    """Return ``--declutter`` if it is one of the build's modes; refuse it otherwise."""
    from stimuli.stimset.params import BUILD_DECLUTTER_MODES

    if declutter_mode not in BUILD_DECLUTTER_MODES:
        raise InputError(
            f"--declutter must be one of {', '.join(BUILD_DECLUTTER_MODES)}, got {declutter_mode!r}"
        )
    return declutter_mode


def resolve_declutter_mode(declutter_mode: str, lf) -> str:
    """``'auto'`` as the stimulus builder resolves it: depth on 1-D light fields, else sobel."""
    from stimuli.lfviews import is_one_dimensional

    if declutter_mode != "auto":
        return declutter_mode
    return "depth" if is_one_dimensional(lf.grid) else "sobel"


def check_zoom_aspect(box_hw: tuple[int, int], grid_px: tuple[int, int]) -> None:
    """Refuse a zoom box whose aspect differs from the grid's by more than 10 %.

    Squeezing a portrait box into a landscape grid distorts the object; the message names the
    grid with the box's aspect and the same number of rows.
    """
    h, w = box_hw
    rows, cols = grid_px
    box, grid = w / h, cols / rows
    if abs(math.log(box / grid)) > math.log(1.1):
        fit = max(1, round(rows * box))
        raise InputError(
            f"--zoom box {w}x{h} px (aspect {box:.2f}) does not fit the {cols}x{rows} grid "
            f"(aspect {grid:.2f}): use --grid {fit}x{rows}, or a box of aspect {grid:.2f}"
        )


def scan_one(
    lightfield: Path,
    out: Path,
    opts: dict,
    loader: LoaderOptions,
    emit: Callable[[str], None] | None = None,
) -> list[str]:
    """Scan one capture into ``out`` and return the lines to print (options checked already).

    A module-level function so that worker processes and Dask workers can run it by name. With
    the default range, planes and binning this is the detector ``confocal stimuli build`` and
    ``confocal view`` use (:func:`stimuli.planechoice.detect_planes`), and the plane the builder
    would choose is named. With ``emit``, the answer (warnings, planes, the builder's plane) is
    passed to it line by line as soon as it is known, *before* the folder is written (the score
    plot, refocusing and de-cluttering come after it), and only the closing line is returned.
    """
    import numpy as np

    from stimuli.agreementscan import answer_before_compiled_code, scan_views
    from stimuli.edgegrid import declutter_and_compress, depth_evidence
    from stimuli.io import atomic_path, save_png, staged_folder
    from stimuli.numpykernels import numpy_kernels
    from stimuli.planechoice import choose_plane, detect_planes
    from stimuli.planes import (
        DEFAULT_N_PLANES,
        auto_binning,
        find_object_planes,
        iter_plane_scores,
        scan_result,
    )
    from stimuli.refocus import refocus
    from stimuli.tables import write_table

    planes, near, far, disparities = opts["planes"], opts["near"], opts["far"], opts["disparities"]
    method, binning, fast = opts["method"], opts["binning"], opts["fast"]
    declutter_mode, threshold, edge_ratio = (
        opts["declutter_mode"],
        opts["threshold"],
        opts["edge_ratio"],
    )
    shape = parse_grid(opts["grid"])
    # The agreement scan and the plane choice read a few views (the centre row and column):
    # only those are read before the answer; refocusing reads them all after it.
    lf = load_grey(lightfield, loader, scan_views if method == "agreement" else None)
    mode = resolve_declutter_mode(declutter_mode, lf)
    with warnings.catch_warnings(record=True) as caught, answer_before_compiled_code():
        warnings.simplefilter("always")
        defaults = (near, far, disparities, binning, planes)
        if method == "agreement" and defaults == (None, None, None, None, DEFAULT_N_PLANES):
            scan = detect_planes(lf)  # the build's and the viewer's detector
            ds = scan.disparities_px
        elif method == "agreement":
            ds = scan_disparities(lf, planes, near, far, disparities)
            scan = find_object_planes(lf, ds, binning=binning)
        else:
            from rich.progress import Progress

            ds = scan_disparities(lf, planes, near, far, disparities)
            b = auto_binning(lf) if binning is None else binning
            scores = np.zeros(len(ds))
            with Progress(transient=True) as bar:
                task = bar.add_task("scanning planes", total=len(ds))
                for i, _, sc in iter_plane_scores(lf, ds, binning=b, nearest_shifts=fast):
                    scores[i] = sc
                    bar.advance(task)
            scan = scan_result(lf, ds, scores, binning=b)
    lines: list[str] = []
    say = lines.append if emit is None else emit  # the answer goes out as soon as it is known
    if lf.meta.get("view_crop") is not None:
        x, y, w, h = lf.meta["view_crop"]
        say(f"view crop {x},{y},{w},{h} ({lf.meta.get('view_crop_rule')})")
    for line in [f"warning: {w.message}" for w in caught] + scan.notes():
        say(line)
    for k, p in enumerate(scan.peaks):  # no refocusing needed for the answer
        where = f"{p.depth_m:.3g} m, " if p.depth_m is not None else ""
        evidence = f", support {p.support:.3f}, evidence {p.evidence:.3g}"
        say(
            f"plane{k + 1:02d}: {where}disparity {p.disparity_px:.3f} px/view, "
            f"score {p.score:.3f}{evidence if math.isfinite(p.support) else ''}"
        )
    if scan.peaks and method == "agreement":
        with warnings.catch_warnings(), answer_before_compiled_code():
            warnings.simplefilter("ignore")
            choice = choose_plane(lf, scan=scan)
        k = next(i for i, p in enumerate(scan.peaks) if p.disparity_px == choice.disparity_px)
        use = f"plane{k + 1:02d} ({choice.disparity_px:.3f} px/view)"
        marginal = f"; marginal: {choice.marginal}" if choice.marginal else ""
        say(f"stimuli build --plane auto would use {use}{marginal}")
    if "views_read" in lf.meta:
        lf = _with_the_other_views(lf, lightfield, loader)
    centre = lf.centre_view()
    images = []
    edge_depth: dict = {}  # per plane: the edges the views could not measure (1-D, depth mode)
    # after a numpy sweep (a small capture: the compiled loops are not loaded), refocus and
    # de-clutter in numpy too: the same images to the bit, without numba's start-up (which
    # would cost more than the work); the Haar scan says nothing about the capture's size
    with numpy_kernels() if method == "agreement" else contextlib.nullcontext():
        for k, p in enumerate(scan.peaks):
            img = np.clip(refocus(lf, p.disparity_px), 0.0, 1.0).astype(np.float32)
            focus, t = None, threshold
            if mode == "depth":  # tested at the edge pixels only (the same edges)
                focus, stats, t = depth_evidence(
                    lf, p.disparity_px, img, threshold=threshold, centre_view=centre
                )
                if stats.unmeasured:
                    edge_depth[f"plane{k + 1:02d}"] = stats.to_dict()
            edges, cells, t = declutter_and_compress(
                img,
                shape,
                threshold=t,
                edge_ratio=edge_ratio,
                focus_mask=focus,
                centre_view=centre,
            )
            images.append((f"plane{k + 1:02d}", img, edges, cells))
            say(f"plane{k + 1:02d} edges: threshold {t:.4g} ({mode})")
    # Written whole or not at all: a full disk or a stop leaves --out as it was.
    with staged_folder(out, what="the scan") as tmp:
        rows = scan.rows()
        write_table(tmp / "planes.csv", rows, list(rows[0]))
        with atomic_path(tmp / "scan.json") as part:
            part.write_text(
                json.dumps(
                    # the light field's file name only: no host path in a file that gets shared
                    {
                        "source": Path(lf.source).name,
                        "declutter": mode,
                        "view_crop": lf.meta.get("view_crop"),
                        "view_crop_rule": lf.meta.get("view_crop_rule"),
                    }
                    | ({"edge_depth": edge_depth} if edge_depth else {})
                    | scan.to_dict(),
                    indent=1,
                )
            )
        fast = {"compress_level": 1}  # a scan's pictures: written fast, the same pixels
        save_png(centre, tmp / "centre.png", **fast)
        for stem, img, edges, cells in images:
            save_png(img, tmp / f"{stem}_confocal.png", **fast)
            save_png(edges, tmp / f"{stem}_edges.png", **fast)
            save_png(cells, tmp / f"{stem}_grid.png", **fast)
        if opts.get("plot", True):
            from stimuli.scanplot import plot_scores  # after the answer is out

            plot_scores(scan, tmp / "scores.png")
    span = f"{float(np.min(ds)):.4g}..{float(np.max(ds)):.4g} px/view"
    lines.append(f"{len(scan.peaks)} object plane(s) in {len(ds)} planes ({span}); wrote {out}")
    return lines
