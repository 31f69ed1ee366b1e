"""``confocal lightfield ...``: scan depth planes, refocus, and write the paper's simulated scene.

Commands
--------
``scan LF --out DIR``
    Sweep confocal planes, detect the planes that hold objects (Jung et al. 2015, Sec. 4.2) and
    write ``planes.csv`` (with each plane's support, prominence and evidence), the
    score-versus-depth plot ``scores.png`` (Fig. 15, Pillow), ``scan.json``, and per
    detected plane the confocal image, its de-cluttered edge image (``--declutter sobel`` or
    ``depth``) and the compressed grid (Figs. 11-13, 16). The range is the one the scene
    occupies unless ``--near/--far`` or ``--disparities`` give it.
``refocus LF (--depth Z | --disparity D) --out IMG``
    One confocal image; ``--grid`` adds its edge and grid images, ``--zoom x,y,w,h`` crops
    first (Fig. 14); ``--stack`` writes a whole focal stack into the folder ``--out``.
``synth --out LF``
    The three-plane scene of Fig. 10 (pedestrian 1 m, tree 4 m, building 9 m; simulated) as a
    lens-array elemental image (``.png`` + ``.toml``), a folder of views, or an ``.npz``, with
    the centre view's ground-truth disparity and depth maps (PFM beside the image or in the
    folder: ``*_disparity.pfm``, ``*_depth.pfm``; arrays ``disparity_px``, ``depth_m`` in the
    ``.npz``).

Grid sizes are written ``COLSxROWS`` as in the paper ("38x25"); the library uses
``shape_px=(rows, cols)``.
"""

from __future__ import annotations

import functools
import inspect
import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from stimuli.cli import seed_option
from stimuli.errors import InputError
from stimuli.lightfield_steps import (
    VIEW_CROP_HELP,
    LoaderOptions,
    check_declutter_mode,
    check_zoom_aspect,
    load_grey,
    parse_disparity_range,
    parse_grid,
    parse_zoom,
    resolve_declutter_mode,
    scan_disparities,
    scan_one,
)
from stimuli.resources import check_memory, finite_option

__all__ = [
    "register",
    "lightfield_app",
    "parse_zoom",
    "parse_grid",
]


def parse_threshold(text: str | float | None) -> float | None:
    """Return the build's Sobel threshold rule (imported when used: ``--help`` stays light)."""
    from stimuli.stimset.params import parse_threshold as parse

    return parse(text)


lightfield_app = typer.Typer(
    name="lightfield",
    help="Light fields (Jung et al. 2015, Sec. 4): scan depth planes, refocus, zoom, synthesise.",
    no_args_is_help=True,
)

_LightFieldPath = Annotated[
    Path, typer.Argument(help="Folder of views, .npy/.npz, or elemental image.")
]
#: The depth range of ``scan`` and of ``refocus --stack``.
_Near = Annotated[
    float | None,
    typer.Option("--near", callback=finite_option(0.0, lo_open=True), help="Nearest depth, m."),
]
_Far = Annotated[
    float | None,
    typer.Option("--far", callback=finite_option(0.0, lo_open=True), help="Farthest depth, m."),
]
_Threshold = Annotated[
    str, typer.Option("--threshold", help="Sobel threshold: 'auto' (Otsu) or a number.")
]
_EdgeRatio = Annotated[
    float,
    typer.Option(
        "--edge-ratio",
        callback=finite_option(0.0, 1.0, hi_open=True),
        help="Compression edge ratio in [0, 1) (paper: 1/13).",
        show_default="1/13 ≈ 0.077",
    ),
]
_LoaderPattern = Annotated[
    str | None,
    typer.Option(
        "--pattern", help="View file-name pattern, e.g. 'img_{row}_{col}' or 'cam{index}'."
    ),
]
_LoaderGridCols = Annotated[
    int | None, typer.Option("--grid-cols", help="Columns of the camera grid for {index} patterns.")
]
_LoaderPitch = Annotated[
    int | None, typer.Option("--pitch", min=1, help="Elemental image: lenslet pitch, pixels.")
]
_LoaderBorder = Annotated[
    int | None,
    typer.Option("--border", min=0, help="Elemental image: invalid border per lenslet, px."),
]
_ViewCrop = Annotated[
    str | None,
    typer.Option(
        "--view-crop",
        help=VIEW_CROP_HELP,
    ),
]
_ViewBin = Annotated[
    int,
    typer.Option(
        "--view-bin",
        help="Average blocks of NxN neighbouring views (wider sub-apertures; lens arrays with "
        "many small views).",
    ),
]
_BitDepth = Annotated[
    int | None,
    typer.Option(
        "--bit-depth",
        help="Bits used in 16-bit images (e.g. 12); default: from the data's maximum.",
    ),
]
_Background = Annotated[
    float,
    typer.Option(
        "--background",
        callback=finite_option(0.0, 1.0),
        help="Grey level (0-1) that views with an alpha channel are composited over; use the "
        "protocol's background (jung2015: 0, black).",
    ),
]
_Axes = Annotated[
    str | None,
    typer.Option("--axes", help=".npy/.npz axis order, e.g. 'uvhw' (default) or 'hwuv'."),
]
_LoaderOffset = Annotated[
    str | None,
    typer.Option("--offset", help="Elemental image: ROW,COL pixels before the first lenslet."),
]


#: Peak memory of ``synth`` per view pixel, bytes (ours: measured about 1,000 B per view pixel
#: for the lens array's 10x10 views at 385x308).
_SYNTH_BYTES_PER_VIEW_PX = 1100
#: Memory per scanned plane, bytes: its disparity, score and a row of ``planes.csv`` (ours).
_BYTES_PER_PLANE = 256


def _check_planes(planes: int) -> None:
    if planes * _BYTES_PER_PLANE > 1 << 20:  # smaller lists need no look at the system
        check_memory(planes * _BYTES_PER_PLANE, f"--planes {planes}")


#: The loader options as command-line parameters, in ``--help`` order: (name, type with its
#: typer option); each default is the field's default in :class:`LoaderOptions`.
_LOADER_OPTIONS: tuple[tuple[str, object], ...] = (
    ("view_crop", _ViewCrop),
    ("pattern", _LoaderPattern),
    ("grid_cols", _LoaderGridCols),
    ("pitch", _LoaderPitch),
    ("border", _LoaderBorder),
    ("offset", _LoaderOffset),
    ("view_bin", _ViewBin),
    ("bit_depth", _BitDepth),
    ("axes", _Axes),
    ("background", _Background),
)


def _takes_loader_options(command: Callable[..., None]) -> Callable[..., None]:
    """Give a command the loader options of :data:`_LOADER_OPTIONS` as its last parameters.

    The command declares one keyword-only ``loader: LoaderOptions`` instead of listing the ten
    options again; typer sees them in the wrapper's signature, and the wrapper gathers them.
    """
    sig = inspect.signature(command, eval_str=True)
    defaults = LoaderOptions()
    extra = [
        inspect.Parameter(
            name, inspect.Parameter.KEYWORD_ONLY, default=getattr(defaults, name), annotation=kind
        )
        for name, kind in _LOADER_OPTIONS
    ]
    own = [p for p in sig.parameters.values() if p.name != "loader"]

    @functools.wraps(command)
    def run(**kwargs) -> None:
        loader = LoaderOptions(**{name: kwargs.pop(name) for name, _ in _LOADER_OPTIONS})
        command(**kwargs, loader=loader)

    run.__signature__ = sig.replace(parameters=own + extra)
    return run


_Declutter = Annotated[
    str,
    typer.Option(
        "--declutter",
        help="De-cluttering: 'sobel' (paper: Sobel + threshold), 'depth' (Sobel edges kept "
        "where the views agree at the plane) or 'auto' (depth on 1-D light fields, else sobel; "
        "as 'stimuli build').",
    ),
]


def _warn_lines(caught) -> None:
    for w in caught:
        typer.echo(f"warning: {w.message}", err=True)


@lightfield_app.command("scan")
@_takes_loader_options
def scan_command(
    lightfield: _LightFieldPath,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write.")],
    planes: Annotated[
        int, typer.Option("--planes", min=3, help="Number of planes (paper: 200).")
    ] = 200,
    near: _Near = None,
    far: _Far = None,
    disparities: Annotated[
        str | None,
        typer.Option(
            "--disparities",
            help="FROM:TO, pixels per view step (default: the range the scene occupies).",
        ),
    ] = None,
    grid: Annotated[str, typer.Option("--grid", help="Prosthesis grid COLSxROWS.")] = "38x25",
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="'agreement' (views agree, with a null; default) or 'haar' (paper's score).",
        ),
    ] = "agreement",
    binning: Annotated[
        int | None,
        typer.Option(
            "--binning", min=1, help="View binning for the scan (default: from the views)."
        ),
    ] = None,
    fast: Annotated[
        bool, typer.Option("--fast", help="Haar scan: whole-pixel shifts (faster).")
    ] = False,
    declutter_mode: _Declutter = "auto",
    threshold: Annotated[
        str,
        typer.Option(
            "--threshold",
            help="Sobel threshold: 'auto' (the stimulus builder's rule: minimum edge retention "
            "of the centre view and the confocal image) or a number.",
        ),
    ] = "auto",
    edge_ratio: _EdgeRatio = 1.0 / 13.0,
    processes: Annotated[
        int | None,
        typer.Option(
            "--processes",
            help="Folder of captures: local worker processes (default: CPUs; 1: run here).",
        ),
    ] = None,
    cluster: Annotated[
        str | None,
        typer.Option(
            "--cluster",
            help="Folder of captures: Dask scheduler address (needs the 'dask' extra).",
        ),
    ] = None,
    plot: Annotated[
        bool,
        typer.Option(
            "--plot/--no-plot",
            help="Draw scores.png (after the answer is printed; --no-plot skips it).",
        ),
    ] = True,
    *,
    loader: LoaderOptions,
) -> None:
    """Scan planes, detect the object planes and write them with their edge and grid images.

    LIGHTFIELD may also be a folder of captures (sub-folders of views or .npz/.npy files):
    each is scanned into its own sub-folder of --out, in worker processes or on a Dask cluster.
    """
    from stimuli.lfbatch import discover_captures, is_capture_folder, run_per_capture
    from stimuli.planes import SCAN_METHODS

    # every option is checked before the light field is read or anything is written
    parse_grid(grid)
    check_declutter_mode(declutter_mode)
    if method not in SCAN_METHODS:
        raise InputError(f"--method must be one of {', '.join(SCAN_METHODS)}, got {method!r}")
    parse_threshold(threshold)
    _check_planes(planes)
    if disparities is not None:
        parse_disparity_range(disparities)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is a file; expected a folder to write")
    opts = {
        "planes": planes,
        "near": near,
        "far": far,
        "disparities": disparities,
        "grid": grid,
        "method": method,
        "binning": binning,
        "fast": fast,
        "declutter_mode": declutter_mode,
        "threshold": threshold,
        "edge_ratio": edge_ratio,
        "plot": plot,
    }
    if processes is not None and processes < 1:
        raise InputError(f"--processes must be >= 1, got {processes}")
    if not is_capture_folder(lightfield):

        def emit(line: str) -> None:
            typer.echo(line, err=line.startswith("warning: "))

        for line in scan_one(lightfield, out, opts, loader, emit):
            emit(line)
        return
    captures = discover_captures(lightfield)
    names = [c.stem if c.is_file() else c.name for c in captures]
    if len(set(names)) != len(names):
        raise InputError(f"{lightfield}: two captures share a name; each needs its own")
    out.mkdir(parents=True, exist_ok=True)
    tasks = [(c, out / n, opts, loader) for c, n in zip(captures, names, strict=True)]
    for i, lines in run_per_capture(scan_one, tasks, processes=processes, cluster=cluster):
        for line in lines:
            typer.echo(f"{names[i]}: {line}", err=line.startswith("warning: "))
    typer.echo(f"scanned {len(captures)} capture(s) of {lightfield} into {out}")


@lightfield_app.command("refocus")
@_takes_loader_options
def refocus_command(
    lightfield: _LightFieldPath,
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG to write (folder with --stack).")],
    depth: Annotated[
        float | None,
        typer.Option("--depth", callback=finite_option(0.0, lo_open=True), help="Plane depth, m."),
    ] = None,
    disparity: Annotated[
        float | None,
        typer.Option(
            "--disparity", callback=finite_option(), help="Plane disparity, px per view step."
        ),
    ] = None,
    stack: Annotated[
        bool,
        typer.Option(
            "--stack",
            help="Write a focal stack into --out: --planes planes from --near to --far, or over "
            "--disparities.",
        ),
    ] = False,
    planes: Annotated[int, typer.Option("--planes", min=3, help="Planes in the stack.")] = 20,
    near: _Near = None,
    far: _Far = None,
    disparities: Annotated[
        str | None, typer.Option("--disparities", help="Stack: FROM:TO, px per view step.")
    ] = None,
    zoom: Annotated[
        str | None,
        typer.Option(
            "--zoom",
            help="Crop x,y,w,h before edges (pixels of the image written: after the view crop).",
        ),
    ] = None,
    grid: Annotated[
        str | None, typer.Option("--grid", help="Also write edges and a COLSxROWS grid.")
    ] = None,
    declutter_mode: _Declutter = "auto",
    threshold: Annotated[
        str,
        typer.Option(
            "--threshold",
            help="Sobel threshold: 'auto' (the stimulus builder's rule, as scan: minimum edge "
            "retention of the centre view and the confocal image) or a number.",
        ),
    ] = "auto",
    edge_ratio: _EdgeRatio = 1.0 / 13.0,
    *,
    loader: LoaderOptions,
) -> None:
    """Write the confocal image at one plane (or a focal stack); optionally zoom and compress.

    The views are read, cropped and de-cluttered as ``scan`` and ``stimuli build`` do (the same
    vignette crop, ``--declutter auto`` rule and threshold rule), so the same plane gives the
    same edge image.
    """
    from stimuli.edgegrid import declutter_and_compress, depth_evidence
    from stimuli.io import save_png, staged_folder
    from stimuli.refocus import iter_focal_stack, refocus

    # every option is checked before the light field is read or anything is written
    check_declutter_mode(declutter_mode)
    grid_px = parse_grid(grid) if grid is not None else None
    parse_threshold(threshold)
    if stack:
        _check_planes(planes)
        if disparities is not None:
            parse_disparity_range(disparities)
    if zoom is not None:
        parse_zoom(zoom, (1 << 30, 1 << 30))
    if out.exists() and out.is_dir() != stack:
        raise InputError(
            f"--out {out} exists and is a {'folder' if out.is_dir() else 'file'}; expected "
            + ("a folder for --stack" if stack else "a PNG file path")
        )
    lf = load_grey(lightfield, loader)
    if stack:
        if depth is not None or disparity is not None:
            raise InputError("--stack scans --near/--far or --disparities, not --depth/--disparity")
        ds = scan_disparities(lf, planes, near, far, disparities)
        with staged_folder(out, what="the focal stack") as folder:  # whole, or nothing
            for k, (d, img) in enumerate(iter_focal_stack(lf, ds)):
                save_png(img, folder / f"plane{k:03d}_{d:+.3f}px.png")
        typer.echo(f"wrote {len(ds)} planes to {out}")
        return
    if (depth is None) == (disparity is None):
        raise InputError("give exactly one of --depth (m) or --disparity (px per view step)")
    d = lf.disparity_px(depth) if depth is not None else float(disparity)
    zoom_box = None
    if zoom is not None:
        zoom_box = parse_zoom(zoom, lf.shape_px)
        if grid_px is not None:
            rs, cs = zoom_box
            check_zoom_aspect((rs.stop - rs.start, cs.stop - cs.start), grid_px)
    import numpy as np

    img = np.clip(refocus(lf, d), 0.0, 1.0).astype(np.float32)
    mode = resolve_declutter_mode(declutter_mode, lf)
    focus, t = None, threshold
    if mode == "depth" and grid_px is not None:  # tested at the edge pixels only
        focus, stats, t = depth_evidence(
            lf, d, img, threshold=threshold, centre_view=lf.centre_view(), box=zoom_box
        )
        if stats.unmeasured:
            typer.echo(
                f"edges the views cannot measure: {stats.unmeasured} px; dropped "
                f"{stats.resolved_off_plane} resolved off the plane "
                f"({100 * stats.to_dict()['dropped_share']:.1f} % of the edges), "
                f"{stats.unresolved} unresolved"
            )
    centre = lf.centre_view()
    if zoom_box is not None:
        rs, cs = zoom_box
        img = np.ascontiguousarray(img[rs, cs])
        centre = np.ascontiguousarray(centre[rs, cs])
        focus = None if focus is None else np.ascontiguousarray(focus[rs, cs])
    if lf.meta.get("view_crop") is not None:
        x, y, w, h = lf.meta["view_crop"]
        typer.echo(f"view crop {x},{y},{w},{h} ({lf.meta.get('view_crop_rule')})")
    save_png(img, out)
    if grid_px is not None:
        edges, cells, t = declutter_and_compress(
            img,
            grid_px,
            threshold=t,
            edge_ratio=edge_ratio,
            focus_mask=focus,
            centre_view=centre,
        )
        save_png(edges, out.with_name(out.stem + "_edges.png"))
        save_png(cells, out.with_name(out.stem + "_grid.png"))
    typer.echo(f"disparity {d:.4g} px/view -> {out}")


@lightfield_app.command("synth")
def synth_command(
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help="NAME.png: the lens array's elemental image (+ NAME.toml); NAME.npz: views; "
            "otherwise a folder of views with lightfield.toml.",
        ),
    ],
    kind: Annotated[
        str | None,
        typer.Option(
            "--kind",
            help="camera (9x9 camera array: pedestrian +12, tree +3, building +1.33 px/view; "
            "the default, as in active search and the viewer) or lens (the paper's lens-array "
            "optics; the default for a .png elemental image).",
        ),
    ] = None,
    size: Annotated[str, typer.Option("--size", help="View size COLSxROWS (paper: 385x308).")] = (
        "385x308"
    ),
    seed: Annotated[int, seed_option("Seed of the textures.")] = 0,
) -> None:
    """Write the paper's simulated three-plane scene (Fig. 10)."""
    from stimuli.io import atomic_path, save_png, staged_folder
    from stimuli.lfsynth import (
        ground_truth_maps,
        render_elemental_image,
        three_plane_lightfield,
        three_plane_scene,
    )
    from stimuli.lightfield import views_from_elemental, write_pfm

    shape = parse_grid(size)
    if kind is None:
        kind = "lens" if out.suffix.lower() == ".png" else "camera"
    if kind not in ("lens", "camera"):
        raise InputError(f"--kind must be 'lens' or 'camera', got {kind!r}")
    suffix = out.suffix.lower()
    if suffix == ".png" and kind != "lens":
        raise InputError("a .png output is an elemental image: use --kind lens")
    if out.exists() and out.is_dir() != (suffix not in (".npz", ".png")):
        raise InputError(
            f"--out {out} exists and is a {'folder' if out.is_dir() else 'file'}; expected "
            + ("a folder of views" if suffix not in (".npz", ".png") else f"a {suffix} file")
        )
    check_memory(shape[0] * shape[1] * _SYNTH_BYTES_PER_VIEW_PX, f"--size {size}")
    if kind == "lens":
        layers = three_plane_scene(shape, rng=seed)
        ei, geometry = render_elemental_image(layers, shape_px=shape)
        views = views_from_elemental(ei, ei.shape[0] // shape[0])
    else:
        lf, layers = three_plane_lightfield(shape, seed=seed)
        views, geometry = lf.views, lf.geometry
    gtoml = "[geometry]\n" + "".join(
        f"{k} = {json.dumps(v)}\n" for k, v in geometry.to_dict().items()
    )
    disp, depth = ground_truth_maps(layers, geometry, shape)

    def write_truth(disp_path: Path, depth_path: Path) -> None:
        for arr, p in ((disp, disp_path), (depth, depth_path)):
            with atomic_path(p) as tmp:
                write_pfm(arr, tmp)

    if suffix == ".npz":
        import numpy as np

        with atomic_path(out) as tmp, open(tmp, "wb") as f:
            np.savez_compressed(
                f,
                views=views,
                geometry=json.dumps(geometry.to_dict()),
                disparity_px=disp,
                depth_m=depth,
            )
    elif suffix == ".png":
        save_png(ei, out)
        write_truth(
            out.with_name(out.stem + "_disparity.pfm"), out.with_name(out.stem + "_depth.pfm")
        )
        p = ei.shape[0] // shape[0]
        with atomic_path(out.with_suffix(".toml")) as tmp:
            tmp.write_text(gtoml + f"\n[elemental]\npitch_px = {p}\nborder_px = 0\n")
    else:
        with staged_folder(out, what="the light field") as folder:  # whole, or nothing
            for u in range(views.shape[0]):
                for v in range(views.shape[1]):
                    save_png(views[u, v], folder / f"view_{u:02d}_{v:02d}.png")
            with atomic_path(folder / "lightfield.toml") as tmp:
                tmp.write_text(gtoml)
            write_truth(folder / "disparity.pfm", folder / "depth.pfm")
    typer.echo(f"wrote {out} ({views.shape[0]}x{views.shape[1]} views of {shape[1]}x{shape[0]})")


def register(app: typer.Typer) -> None:
    """Add the ``lightfield`` group to the root ``confocal`` app."""
    app.add_typer(lightfield_app, name="lightfield")
