"""``confocal demo --lightfield``: the paper's light-field simulation, Figs. 10-16, computed.

The three-plane scene of Jung et al. (2015) Sec. 4.1 (pedestrian 1 m, tree 4 m, building 9 m) is
rendered through the paper's lens array (1 mm pitch, 3 mm focal length, 40x relay minification,
10x10 pixels per lenslet). From that one capture the demo computes:

* ``fig10_scene.png``: the elemental image (a crop, so lenslets are visible) and the centre view;
* ``fig11_confocal.png``: confocal images at 1, 2.5, 4, 6.5 and 9 m;
* ``fig12_declutter.png``: their de-cluttered (Sobel + threshold) edge images;
* ``fig13_compressed.png``: those compressed to the paper's 28x35 = 980-pixel grid;
* ``fig14_zoom.png``: zoom: the confocal image at the pedestrian's plane cropped around it
  before de-cluttering and compression, against the same grid without zoom;
* ``fig15_scores.png`` and ``planes.csv``: the score over 200 planes and the detected object
  planes (automatic depth-plane detection, Sec. 4.2; the library's default agreement scan with
  a null, :func:`stimuli.planes.find_object_planes`);
* ``fig16_planes.png``: each detected plane's confocal, edge and compressed images.

Every image is computed here; nothing is drawn from stored results.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from experiment.outputs import require_missing_or_empty

__all__ = ["run_lightfield_demo", "FIG11_DEPTHS_M", "FIG13_GRID_PX"]

#: Depths of the confocal images of Fig. 11, metres. Source: Jung et al. 2015, Sec. 4.1.
FIG11_DEPTHS_M: tuple[float, ...] = (1.0, 2.5, 4.0, 6.5, 9.0)
#: Compressed grid of Fig. 13, (rows, cols): 28x35 = 980 pixels. Source: Sec. 4.1.
FIG13_GRID_PX: tuple[int, int] = (28, 35)
#: Planes of the depth scan (Fig. 15 used 200). Source: Sec. 4.2.
SCAN_PLANES: int = 200
#: Depth range of the scan, metres (ours: spans the scene's 1-9 m with room on both sides,
#: inside the simulated lens array's usable range of 0.5-12 m).
SCAN_RANGE_M: tuple[float, float] = (0.6, 12.0)


def _tile(image: np.ndarray, height_px: int) -> Image.Image:
    """Return an image as an 8-bit tile of the given height, magnified by nearest neighbour."""
    a = np.asarray(image)
    u8 = a.astype(np.uint8) * 255 if a.dtype == bool else np.round(a * 255).astype(np.uint8)
    img = Image.fromarray(u8)
    width = max(1, round(img.width * height_px / img.height))
    return img.resize((width, height_px), Image.NEAREST)


def _montage(tiles: list[tuple[str, np.ndarray]], path: Path, *, height_px: int = 200) -> Path:
    """Write labelled tiles side by side (label above each) as one PNG, atomically."""
    from stimuli.io import atomic_path

    ims = [(label, _tile(img, height_px)) for label, img in tiles]
    gap, head = 8, 18
    width = sum(im.width for _, im in ims) + gap * (len(ims) + 1)
    sheet = Image.new("L", (width, height_px + head + gap), 48)
    draw = ImageDraw.Draw(sheet)
    x = gap
    for label, im in ims:
        draw.text((x, 3), label, fill=230)
        sheet.paste(im, (x, head))
        x += im.width + gap
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def run_lightfield_demo(out_dir: str | Path, *, seed: int = 0) -> list[str]:
    """Render the paper's three-plane light field, scan it, and write Figs. 10-16 analogues.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write: a new or empty one (a non-empty folder is refused, never replaced;
        ``confocal demo --force`` replaces a folder an earlier demo wrote).
    seed : int >= 0
        Seed of the scene's textures.

    Returns
    -------
    list of str
        Printable summary lines (detected planes and where the figures are).

    References
    ----------
    Jung et al. (2015), Sec. 4.1 (simulation) and Sec. 4.2 (depth-plane detection).
    """
    from rich.progress import Progress

    from stimuli import jung2015
    from stimuli.edgegrid import declutter_and_compress
    from stimuli.io import atomic_path, save_png
    from stimuli.lfsynth import render_elemental_image, three_plane_scene
    from stimuli.lightfield import LightField, views_from_elemental
    from stimuli.planes import find_object_planes
    from stimuli.refocus import refocus
    from stimuli.scanplot import plot_scores
    from stimuli.tables import write_table

    out = Path(out_dir)
    require_missing_or_empty(out)
    out.mkdir(parents=True, exist_ok=True)

    layers = three_plane_scene(rng=seed)
    elemental, geometry = render_elemental_image(layers)
    p = jung2015.LF_SIM_PIXELS_PER_LENS
    lf = LightField(views_from_elemental(elemental, p), geometry, source="three_plane_scene")
    save_png(elemental, out / "elemental.png")
    centre = lf.centre_view()
    r0, c0 = elemental.shape[0] // 2, elemental.shape[1] // 2
    _montage(
        [
            (f"elemental image ({elemental.shape[1]}x{elemental.shape[0]})", elemental),
            ("elemental image, 12x12 lenslets", elemental[r0 : r0 + 12 * p, c0 : c0 + 12 * p]),
            ("centre view (all in focus)", centre),
        ],
        out / "fig10_scene.png",
        height_px=300,
    )

    ratio = jung2015.EDGE_RATIO
    confocal, edges, grids = [], [], []
    for z in FIG11_DEPTHS_M:
        img = refocus(lf, lf.disparity_px(z))
        e, g, _ = declutter_and_compress(img, FIG13_GRID_PX, edge_ratio=ratio)
        confocal.append((f"{z:g} m", img))
        edges.append((f"{z:g} m", e))
        grids.append((f"{z:g} m ({FIG13_GRID_PX[1]}x{FIG13_GRID_PX[0]})", g))
    _montage(confocal, out / "fig11_confocal.png")
    _montage(edges, out / "fig12_declutter.png")
    _montage(grids, out / "fig13_compressed.png")

    # Fig. 14: zoom = crop the confocal image around the pedestrian before de-cluttering and
    # compressing, so the same 980 cells spend their resolution on the object.
    near = refocus(lf, lf.disparity_px(FIG11_DEPTHS_M[0]))
    nearest = min(layers, key=lambda la: la.depth_m)
    mask = np.asarray(nearest.alpha) > 0.5
    rows, cols = near.shape
    if mask.shape != near.shape:  # textures carry a margin: centre-crop it
        mr, mc = (mask.shape[0] - rows) // 2, (mask.shape[1] - cols) // 2
        mask = mask[mr : mr + rows, mc : mc + cols]
    if mask.any():
        ys, xs = np.nonzero(mask)
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    else:  # fall back to the lower-left third, where the scene puts the pedestrian
        y0, y1, x0, x1 = rows // 3, rows, 0, cols // 2
    # grow the box to the grid's aspect (rows/cols = 28/35) so cells stay square
    h, w = y1 - y0, x1 - x0
    aspect = FIG13_GRID_PX[0] / FIG13_GRID_PX[1]
    if h / w > aspect:
        w = min(cols, int(np.ceil(h / aspect)))
    else:
        h = min(rows, int(np.ceil(w * aspect)))
    cy, cx = (y0 + y1) // 2, (x0 + x1) // 2
    y0 = int(np.clip(cy - h // 2, 0, rows - h))
    x0 = int(np.clip(cx - w // 2, 0, cols - w))
    zoomed = np.ascontiguousarray(near[y0 : y0 + h, x0 : x0 + w])
    _, grid_full, _ = declutter_and_compress(near, FIG13_GRID_PX, edge_ratio=ratio)
    ze, zg, _ = declutter_and_compress(zoomed, FIG13_GRID_PX, edge_ratio=ratio)
    _montage(
        [
            ("1 m, no zoom", grid_full),
            (f"zoom crop x={x0} y={y0} {w}x{h}", zoomed),
            ("zoomed edges", ze),
            ("zoomed, same 980 cells", zg),
        ],
        out / "fig14_zoom.png",
    )

    lo, hi = SCAN_RANGE_M
    ds = np.linspace(lf.disparity_px(lo), lf.disparity_px(hi), SCAN_PLANES)
    with Progress(transient=True) as bar:
        bar.add_task("scanning 200 confocal planes", total=None)
        scan = find_object_planes(lf, ds)  # agreement with a null
    rows_csv = scan.rows()
    write_table(out / "planes.csv", rows_csv, list(rows_csv[0]))
    plot_scores(scan, out / "fig15_scores.png")

    # The scene is synthetic, so each detection can be checked against the true layer depths:
    # a detection within two plane steps (in disparity) of a layer is that layer.
    step_px = float(abs(ds[1] - ds[0]))
    tiles, lines = [], []
    for k, plane in enumerate(scan.peaks):
        img = refocus(lf, plane.disparity_px)
        e, g, _ = declutter_and_compress(img, FIG13_GRID_PX, edge_ratio=ratio)
        label = f"plane {k + 1}: {plane.depth_m:.2f} m"
        tiles += [(label, img), ("edges", e), ("980 cells", g)]
        layer = min(layers, key=lambda la: abs(lf.disparity_px(la.depth_m) - plane.disparity_px))
        off = abs(lf.disparity_px(layer.depth_m) - plane.disparity_px)
        what = (
            f"the {layer.name} ({layer.depth_m:g} m)"
            if off <= 2 * step_px
            else "no layer at this depth: a false detection"
        )
        lines.append(
            f"detected plane {k + 1}: {plane.depth_m:.2f} m = {what} "
            f"(disparity {plane.disparity_px:.3f} px/view, score {plane.score:.3f})"
        )
    if tiles:
        _montage(tiles, out / "fig16_planes.png", height_px=160)
    else:
        lines.append("no object plane was detected (see fig15_scores.png)")
    truth = ", ".join(f"{layer.name} {layer.depth_m:g} m" for layer in layers)
    summary = {
        "seed": seed,
        "layers": [{"name": la.name, "depth_m": la.depth_m} for la in layers],
        "detected_m": [pl.depth_m for pl in scan.peaks],
        "plane_step_m_at": {f"{z:g}": _plane_step_m(lf, ds, z) for z in jung2015.LF_SIM_PLANES_M},
    }
    with atomic_path(out / "lightfield_demo.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
    return [f"scene: {truth}", *lines, f"figures: {out}"]


def _plane_step_m(lf, ds: np.ndarray, depth_m: float) -> float:
    """Depth spacing of the scan's planes around ``depth_m`` (planes are uniform in disparity)."""
    d = lf.disparity_px(depth_m)
    step = float(abs(ds[1] - ds[0]))
    return abs(lf.depth_m(d - step / 2) - lf.depth_m(d + step / 2))
