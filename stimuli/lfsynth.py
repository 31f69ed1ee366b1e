"""Render light fields from a layered scene (:mod:`stimuli.scene`), and the paper's Fig. 10 scene.

Each view is a pinhole (camera array) or orthographic (lens array) image of fronto-parallel
layers: every layer is shifted by its own disparity times the view offset (convention of
:mod:`stimuli.lightfield`: ``I_(du,dv)(y, x) = texture(y + d du, x + d dv)``) and the layers are
composited back to front with their alpha ("over"), so nearer layers occlude farther ones in
every view. Sub-pixel shifts use linear interpolation.

The three-plane scene of Jung et al. (2015), Fig. 10 (pedestrian at 1 m, tree at 4 m, building
at 9 m) is drawn procedurally with Pillow: a person in a striped shirt, a tree with a leafy crown
and a bark-textured trunk, and a brick building with windows and a door under a plain sky.
"""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.lightfield import Geometry, LightField, elemental_from_views
from stimuli.scene import Layer

__all__ = [
    "render_views",
    "render_camera_array",
    "render_elemental_image",
    "lens_array_geometry",
    "three_plane_scene",
    "three_plane_lightfield",
    "random_three_plane_layout",
    "JUNG2015_LAYOUT",
    "RANDOM_LAYOUT_X_FRAC",
    "RANDOM_LAYOUT_FRONT_M",
    "RANDOM_LAYOUT_BACKDROP_M",
    "RANDOM_LAYOUT_MIN_SEPARATION",
    "layer_masks",
    "ground_truth_maps",
    "SIM_SHAPE_PX",
    "SIM_BASELINE_M",
    "SIM_FOCAL_LENGTH_PX",
    "FAR_MARGIN",
]

#: Size (rows, cols) of the simulated confocal images. Source: Jung et al. (2015), Fig. 11
#: ("Confocal images (308x385)").
SIM_SHAPE_PX: tuple[int, int] = (308, 385)

#: The one camera through which every synthetic three-plane light field is seen (ours): a 30 mm
#: baseline and 400 px focal length put the pedestrian (1 m) at +12, the tree (4 m) at +3 and
#: the building (9 m) at +1.33 px per view step (larger = nearer, as in :mod:`stimuli.lightfield`).
#: ``lightfield synth``, active search, the viewer's examples and the benchmarks all use it. The
#: paper's own lens-array optics (``lightfield synth --kind lens`` or a ``.png`` elemental image,
#: and ``demo --lightfield``, which redraws the paper's Figs. 10-16) are the one exception: there
#: the same planes lie at -0.83, -3.33 and -7.5 px per view step (still larger = nearer).
SIM_BASELINE_M = 0.03
SIM_FOCAL_LENGTH_PX = 400.0


def lens_array_geometry(
    *,
    lens_pitch_mm: float = jung2015.LF_SIM_LENS_PITCH_MM,
    lens_focal_mm: float = jung2015.LF_SIM_LENS_FOCAL_MM,
    relay_minification: float = jung2015.LF_SIM_RELAY_MINIFICATION,
    pixels_per_lens: int = jung2015.LF_SIM_PIXELS_PER_LENS,
    near_m: float = 0.5,
    far_m: float = 12.0,
) -> Geometry:
    """Return the lens-array geometry of the paper's simulation (Sec. 4.1).

    ``near_m``/``far_m`` (ours) bracket the scene's 1-9 m with a margin.
    """
    return Geometry(
        kind="lens_array",
        lens_pitch_mm=lens_pitch_mm,
        lens_focal_mm=lens_focal_mm,
        relay_minification=relay_minification,
        pixel_mm=lens_pitch_mm / pixels_per_lens,
        near_m=near_m,
        far_m=far_m,
    )


def _check_layers(layers: list[Layer], shape_px: tuple[int, int]) -> None:
    if not layers:
        raise InputError("layers must not be empty")
    for layer in layers:
        if not isinstance(layer, Layer):
            raise InputError(f"layers must be stimuli.scene.Layer objects, got {type(layer)}")
        t = np.asarray(layer.texture)
        if t.shape[0] < shape_px[0] or t.shape[1] < shape_px[1]:
            raise InputError(
                f"layer {layer.name!r}: texture {t.shape} is smaller than the view {shape_px}"
            )


def _sample(a: np.ndarray, oy: float, ox: float, shape_px: tuple[int, int]) -> np.ndarray:
    """Crop ``shape_px`` from ``a`` at top-left ``(oy, ox)`` (fractional; zero outside)."""
    rows, cols = shape_px
    iy, ix = math.floor(oy), math.floor(ox)
    fy, fx = oy - iy, ox - ix
    pad = 2
    big = np.zeros((rows + pad, cols + pad), dtype=np.float32)
    y0, x0 = iy, ix
    sy0, sx0 = max(0, y0), max(0, x0)
    sy1, sx1 = min(a.shape[0], y0 + rows + pad), min(a.shape[1], x0 + cols + pad)
    if sy1 > sy0 and sx1 > sx0:
        big[sy0 - y0 : sy1 - y0, sx0 - x0 : sx1 - x0] = a[sy0:sy1, sx0:sx1]
    out = (
        (1 - fy) * (1 - fx) * big[:rows, :cols]
        + (1 - fy) * fx * big[:rows, 1 : cols + 1]
        + fy * (1 - fx) * big[1 : rows + 1, :cols]
        + fy * fx * big[1 : rows + 1, 1 : cols + 1]
    )
    return out.astype(np.float32)


def render_views(
    layers: list[Layer],
    disparities_px: list[float],
    grid: tuple[int, int],
    shape_px: tuple[int, int],
) -> np.ndarray:
    """Render a grid of views of layers with given disparities, composited back to front.

    Parameters
    ----------
    layers : list of Layer
        In any order; sorted far to near by ``depth_m`` before compositing.
    disparities_px : list of float
        Disparity of each layer (same order as ``layers``), pixels per view step.
    grid : (n_u, n_v)
    shape_px : (rows, cols)
        View size; each texture is centred on the view (its margin is cropped).

    Returns
    -------
    ndarray of shape (n_u, n_v, rows, cols), float32 in [0, 1]
    """
    _check_layers(layers, shape_px)
    if len(disparities_px) != len(layers):
        raise InputError("disparities_px must give one disparity per layer")
    n_u, n_v = (int(g) for g in grid)
    if n_u < 1 or n_v < 1:
        raise InputError(f"grid must be positive, got {grid!r}")
    rows, cols = shape_px
    order = sorted(range(len(layers)), key=lambda i: -layers[i].depth_m)
    out = np.zeros((n_u, n_v, rows, cols), dtype=np.float32)
    cu, cv = n_u // 2, n_v // 2
    for u in range(n_u):
        for v in range(n_v):
            img = np.zeros((rows, cols), dtype=np.float32)
            for i in order:
                layer, d = layers[i], disparities_px[i]
                t = np.asarray(layer.texture, dtype=np.float32)
                a = np.asarray(layer.alpha, dtype=np.float32)
                oy = (t.shape[0] - rows) / 2 + d * (u - cu)
                ox = (t.shape[1] - cols) / 2 + d * (v - cv)
                ts, al = _sample(t, oy, ox, shape_px), _sample(a, oy, ox, shape_px)
                img = ts * al + img * (1 - al)
            out[u, v] = np.clip(img, 0.0, 1.0)
    return out


#: A rendered camera array's far limit lies at least this factor beyond its deepest layer (ours:
#: the paper's scene, a backdrop at 9 m within 12 m; 1/depth then spans a quarter more).
FAR_MARGIN: float = 4.0 / 3.0


def render_camera_array(
    layers: list[Layer],
    *,
    grid: tuple[int, int] = (9, 9),
    shape_px: tuple[int, int] = SIM_SHAPE_PX,
    focal_length_px: float = 400.0,
    baseline_m: float = 0.01,
    near_m: float = 0.5,
    far_m: float | None = None,
) -> LightField:
    """Render a camera-array light field (parallel pinhole cameras on a square grid).

    A layer at depth ``z`` has disparity ``focal_length_px * baseline_m / z``. Defaults (ours)
    give 4 px per view step at 1 m. ``far_m`` (default: 12 m, or :data:`FAR_MARGIN` times the
    deepest layer's depth where that is farther) is the geometry's far limit, which the plane
    scan's range estimate does not pass: a backdrop close to it had the far side of its
    pixels' spread cut off and piled up at the range's end, and its plane was then missed.

    Returns
    -------
    LightField
        With a camera-array :class:`~stimuli.lightfield.Geometry`.
    """
    if far_m is None:
        far_m = max(12.0, FAR_MARGIN * max((layer.depth_m for layer in layers), default=0.0))
    g = Geometry(
        kind="camera_array",
        focal_length_px=focal_length_px,
        baseline_m=baseline_m,
        near_m=near_m,
        far_m=far_m,
    )
    ds = [g.disparity_px(layer.depth_m) for layer in layers]
    return LightField(render_views(layers, ds, grid, shape_px), g, "synthetic camera array")


def three_plane_lightfield(
    shape_px: tuple[int, int] = SIM_SHAPE_PX,
    *,
    grid: tuple[int, int] = (9, 9),
    seed: int = 0,
) -> tuple[LightField, list[Layer]]:
    """Return the paper's three-plane scene (Fig. 10) as seen by the synthetic camera array.

    The one convention for this scene: :data:`SIM_BASELINE_M` and :data:`SIM_FOCAL_LENGTH_PX`
    put the pedestrian, tree and building at +12, +3 and +1.33 px per view step.

    >>> lf, layers = three_plane_lightfield((64, 80), grid=(3, 3))
    >>> [round(lf.disparity_px(layer.depth_m), 2) for layer in layers]
    [1.33, 3.0, 12.0]
    """
    layers = three_plane_scene(shape_px, rng=seed)
    lf = render_camera_array(
        layers,
        grid=grid,
        shape_px=shape_px,
        focal_length_px=SIM_FOCAL_LENGTH_PX,
        baseline_m=SIM_BASELINE_M,
    )
    return lf, layers


def render_elemental_image(
    layers: list[Layer],
    *,
    shape_px: tuple[int, int] = SIM_SHAPE_PX,
    geometry: Geometry | None = None,
    pixels_per_lens: int = jung2015.LF_SIM_PIXELS_PER_LENS,
) -> tuple[np.ndarray, Geometry]:
    """Render the elemental image a lens array records of the layers (Jung et al. 2015, Fig. 10).

    Parameters
    ----------
    layers : list of Layer
    shape_px : (rows, cols)
        Number of lenslets; the elemental image is ``pixels_per_lens`` times larger.
    geometry : Geometry, optional
        Lens-array geometry (default :func:`lens_array_geometry`).
    pixels_per_lens : int
        Pixels under each lenslet, per axis (paper: 10).

    Returns
    -------
    elemental : ndarray of shape (rows * p, cols * p), float32 in [0, 1]
    geometry : Geometry
    """
    g = geometry or lens_array_geometry(pixels_per_lens=pixels_per_lens)
    if g.kind != "lens_array":
        raise InputError(f"geometry must be a lens array, got kind {g.kind!r}")
    ds = [g.disparity_px(layer.depth_m) for layer in layers]
    p = int(pixels_per_lens)
    views = render_views(layers, ds, (p, p), shape_px)
    return elemental_from_views(views), g


# --------------------------------------------------------------------------------------------
# The paper's three-plane scene
# --------------------------------------------------------------------------------------------


#: Relative amplitude of the fine grain drawn on every object (ours): strong enough that each
#: object's sharpest Haar edges are its own texture, so the depth scan peaks at its plane.
GRAIN: float = 0.35


def _canvas(shape_px: tuple[int, int]) -> tuple[Image.Image, Image.Image]:
    rows, cols = shape_px
    return Image.new("L", (cols, rows), 0), Image.new("L", (cols, rows), 0)


def _to_arrays(
    tex: Image.Image, alpha: Image.Image, rng: np.random.Generator, grain: Image.Image | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Return texture and alpha arrays, with fine random grain where ``grain`` (or alpha) is set.

    The grain (ours: +-GRAIN relative noise, like fabric, bark or brick) gives each object fine,
    aperiodic detail, so that it is sharp at its own plane only and ghost copies of a blurred
    object never line up into a false focus.
    """
    t = np.asarray(tex, dtype=np.float32) / 255.0
    a = np.asarray(alpha, dtype=np.float32) / 255.0
    where = (np.asarray(grain) > 0) if grain is not None else (a > 0)
    noise = rng.uniform(-GRAIN, GRAIN, size=t.shape).astype(np.float32)
    t = np.where(where, np.clip(t * (1.0 + noise) + 0.02 * noise, 0.0, 1.0), t)
    return t.astype(np.float32), a


#: Where the paper's scene puts each object: centre column as a fraction of the view width
#: (ours, read off Fig. 10) and depth, metres (Jung et al. 2015, Sec. 4.1 and Fig. 10).
JUNG2015_LAYOUT: dict[str, dict[str, float]] = {
    "pedestrian": {"x_frac": 0.3, "depth_m": jung2015.LF_SIM_PLANES_M[0]},
    "tree": {"x_frac": 0.62, "depth_m": jung2015.LF_SIM_PLANES_M[1]},
    "building": {"x_frac": 0.56, "depth_m": jung2015.LF_SIM_PLANES_M[2]},
}

#: Range of a randomised pedestrian's or tree's centre column, fraction of the view width
#: (ours: keeps the figure and most of the crown inside the view).
RANDOM_LAYOUT_X_FRAC: tuple[float, float] = (0.2, 0.8)
#: Depth range of the randomised pedestrian and tree, metres (ours: the paper's 1-4 m front
#: objects, widened so that neither depth nor depth order can be learnt).
RANDOM_LAYOUT_FRONT_M: tuple[float, float] = (1.0, 6.0)
#: Depth range of the randomised building, metres (ours: it is the opaque backdrop, so it stays
#: behind both front objects; the paper's 9 m lies inside).
RANDOM_LAYOUT_BACKDROP_M: tuple[float, float] = (7.0, 11.0)
#: Least difference of 1/depth between the two front objects, 1/m (ours: 0.1 /m is 1.2 px per
#: view step with the active task's 400 px x 3 cm camera array, so their planes stay apart).
RANDOM_LAYOUT_MIN_SEPARATION: float = 0.1
#: Least distance between the pedestrian's and the tree's centre columns, fraction of the
#: width (ours: the nearer one never hides the other whole).
_MIN_X_GAP_FRAC = 0.2


def _dx(layout: dict[str, dict[str, float]] | None, name: str, cols: int) -> int:
    """Columns to move an object from where the paper's scene puts it."""
    if layout is None:
        return 0
    return round((layout[name]["x_frac"] - JUNG2015_LAYOUT[name]["x_frac"]) * cols)


def _depth(layout: dict[str, dict[str, float]] | None, name: str) -> float:
    return float((layout or JUNG2015_LAYOUT)[name]["depth_m"])


def _building(shape_px, s, rng, layout=None) -> Layer:
    rows, cols = shape_px
    tex, alpha = _canvas(shape_px)
    dt, da = ImageDraw.Draw(tex), ImageDraw.Draw(alpha)
    da.rectangle([0, 0, cols, rows], fill=255)  # opaque backdrop: sky, building, ground
    dt.rectangle([0, 0, cols, rows], fill=200)  # plain sky
    ground = int(rows * 0.86)
    dt.rectangle([0, ground, cols, rows], fill=110)
    dx = _dx(layout, "building", cols)
    x0, x1 = int(cols * 0.2) + dx, int(cols * 0.92) + dx
    top = int(rows * 0.12)
    dt.rectangle([x0, top, x1, ground], fill=150)
    # Irregular bricks and windows: a periodic facade would make ghost copies of the blurred
    # building line up at wrong planes (aliasing peaks in the depth scan).
    y = top
    while y < ground:
        bh = max(2, int(rng.integers(2, 5) * s))
        dt.line([x0, y, x1, y], fill=int(rng.integers(115, 135)))
        x = x0 + int(rng.integers(0, 8))
        while x < x1:
            dt.line([x, y, x, y + bh], fill=125)
            x += max(3, int(rng.integers(8, 15) * s))
        y += bh
    y = top + int(8 * s)
    while y < ground - int(34 * s):
        win_h = max(4, int(rng.integers(9, 15) * s))
        x = x0 + int(rng.integers(4, 12) * s)
        while x < x1 - int(12 * s):
            win_w = max(3, int(rng.integers(6, 12) * s))
            dt.rectangle([x, y, x + win_w, y + win_h], fill=int(rng.integers(20, 70)))
            dt.line([x + win_w // 2, y, x + win_w // 2, y + win_h], fill=170)
            x += win_w + max(4, int(rng.integers(7, 16) * s))
        y += win_h + max(5, int(rng.integers(8, 16) * s))
    door_x = (x0 + x1) // 2
    dt.rectangle([door_x - int(8 * s), ground - int(26 * s), door_x + int(8 * s), ground], fill=30)
    dt.polygon([(x0 - 6 * s, top), (x1 + 6 * s, top), ((x0 + x1) / 2, top - 18 * s)], fill=90)
    facade = Image.new("L", tex.size, 0)
    ImageDraw.Draw(facade).rectangle([x0, top, x1, ground], fill=255)
    t, a = _to_arrays(tex, alpha, rng, facade)
    return Layer("building", t, a, _depth(layout, "building"))


def _tree(shape_px, s, rng, layout=None) -> Layer:
    rows, cols = shape_px
    tex, alpha = _canvas(shape_px)
    dt, da = ImageDraw.Draw(tex), ImageDraw.Draw(alpha)
    cx, ground = int(cols * 0.62) + _dx(layout, "tree", cols), int(rows * 0.93)
    tw = int(11 * s)
    trunk_top = int(rows * 0.42)
    da.rectangle([cx - tw, trunk_top, cx + tw, ground], fill=255)
    dt.rectangle([cx - tw, trunk_top, cx + tw, ground], fill=70)
    for y in range(trunk_top, ground, max(2, int(4 * s))):
        dx = int(rng.integers(-tw + 1, tw))
        dt.line([cx + dx, y, cx + dx + int(rng.integers(-2, 3)), y + int(3 * s)], fill=30)
    cy, r = int(rows * 0.3), int(min(rows, cols) * 0.2)
    for _ in range(int(160 * s)):
        ang, rad = rng.uniform(0, 2 * math.pi), r * math.sqrt(rng.uniform(0, 1))
        x, y = cx + rad * math.cos(ang) * 1.2, cy + rad * math.sin(ang)
        lr = rng.uniform(4, 10) * s
        box = [x - lr, y - lr, x + lr, y + lr]
        da.ellipse(box, fill=255)
        dt.ellipse(box, fill=int(rng.integers(40, 150)), outline=20)
    t, a = _to_arrays(tex, alpha, rng)
    return Layer("tree", t, a, _depth(layout, "tree"))


def _pedestrian(shape_px, s, rng, layout=None) -> Layer:
    rows, cols = shape_px
    tex, alpha = _canvas(shape_px)
    dt, da = ImageDraw.Draw(tex), ImageDraw.Draw(alpha)
    cx = int(cols * 0.3) + _dx(layout, "pedestrian", cols)
    foot = int(rows * 0.98)
    h = rows * 0.8  # figure height, px
    head_r = h * 0.07
    head_cy = foot - h + head_r
    shoulder = head_cy + head_r * 1.5
    hip = foot - h * 0.47
    body_w = h * 0.13

    def both(shape: str, xy, fill: int, width: int = 0) -> None:
        getattr(da, shape)(xy, fill=255, **({"width": width} if width else {}))
        getattr(dt, shape)(xy, fill=fill, **({"width": width} if width else {}))

    leg_w = int(h * 0.06)
    both("line", [cx - body_w * 0.5, hip, cx - body_w * 0.7, foot], 35, leg_w)
    both("line", [cx + body_w * 0.5, hip, cx + body_w * 0.8, foot], 35, leg_w)
    arm_w = int(h * 0.045)
    both("line", [cx - body_w, shoulder, cx - body_w * 1.6, hip], 210, arm_w)
    both("line", [cx + body_w, shoulder, cx + body_w * 1.7, hip - h * 0.05], 210, arm_w)
    both("rectangle", [cx - body_w, shoulder, cx + body_w, hip], 230)
    y = shoulder
    while y < hip:  # shirt with irregular stripes (no periodic texture: see _building)
        w = max(1, int(rng.integers(1, 4) * s))
        dt.line([cx - body_w, y, cx + body_w, y], fill=int(rng.integers(40, 90)), width=w)
        y += w + max(2, int(rng.integers(3, 9) * s))
    both("ellipse", [cx - head_r, head_cy - head_r, cx + head_r, head_cy + head_r], 180)
    dt.ellipse(
        [cx - head_r, head_cy - head_r, cx + head_r, head_cy - head_r * 0.2], fill=25
    )  # hair
    t, a = _to_arrays(tex, alpha, rng)
    return Layer("pedestrian", t, a, _depth(layout, "pedestrian"))


def _check_layout(layout: dict) -> dict[str, dict[str, float]]:
    """Refuse a layout that does not place exactly the three objects, backdrop farthest."""
    if not isinstance(layout, dict) or set(layout) != set(JUNG2015_LAYOUT):
        got = sorted(layout) if isinstance(layout, dict) else type(layout).__name__
        raise InputError(
            f"layout must place exactly {', '.join(sorted(JUNG2015_LAYOUT))}, got {got}"
        )
    out = {}
    for name, place in layout.items():
        try:
            x, z = float(place["x_frac"]), float(place["depth_m"])
        except (TypeError, KeyError, ValueError):
            raise InputError(
                f"layout[{name!r}] must be {{'x_frac': float, 'depth_m': float}}, got {place!r}"
            ) from None
        if not (0.0 <= x <= 1.0 and math.isfinite(z) and z > 0):
            raise InputError(
                f"layout[{name!r}] needs x_frac in [0, 1] and depth_m > 0, got {place!r}"
            )
        out[name] = {"x_frac": x, "depth_m": z}
    far = max(out["pedestrian"]["depth_m"], out["tree"]["depth_m"])
    if out["building"]["depth_m"] <= far:
        raise InputError(
            f"layout: the building is the opaque backdrop and must be farther than the "
            f"pedestrian and the tree ({far} m), got {out['building']['depth_m']} m"
        )
    return out


def random_three_plane_layout(
    rng: np.random.Generator | int | None = None,
) -> dict[str, dict[str, float]]:
    """Draw where the three-plane scene's objects stand: a new layout for every trial.

    The pedestrian and the tree get a column in :data:`RANDOM_LAYOUT_X_FRAC` (at least a fifth
    of the width apart) and a depth uniform in 1/depth over :data:`RANDOM_LAYOUT_FRONT_M`
    (either may be the nearer, their 1/depth at least :data:`RANDOM_LAYOUT_MIN_SEPARATION`
    apart); the building, the opaque backdrop, a depth in :data:`RANDOM_LAYOUT_BACKDROP_M` and
    a column within 0.1 of the paper's. All ranges are ours, not the paper's.

    Parameters
    ----------
    rng : numpy Generator, int or None

    Returns
    -------
    dict of str -> {'x_frac': float, 'depth_m': float}
        A layout for :func:`three_plane_scene` (plain data: it is logged with the trial).

    Examples
    --------
    >>> a = random_three_plane_layout(3)
    >>> a == random_three_plane_layout(3), sorted(a)
    (True, ['building', 'pedestrian', 'tree'])
    """
    rng = np.random.default_rng(rng)
    lo_x, hi_x = RANDOM_LAYOUT_X_FRAC
    while True:
        xp, xt = rng.uniform(lo_x, hi_x, size=2)
        if abs(xp - xt) >= _MIN_X_GAP_FRAC:
            break
    near_m, far_m = RANDOM_LAYOUT_FRONT_M
    while True:
        inv = rng.uniform(1.0 / far_m, 1.0 / near_m, size=2)
        if abs(inv[0] - inv[1]) >= RANDOM_LAYOUT_MIN_SEPARATION:
            break
    back_m = rng.uniform(1.0 / RANDOM_LAYOUT_BACKDROP_M[1], 1.0 / RANDOM_LAYOUT_BACKDROP_M[0])
    xb = JUNG2015_LAYOUT["building"]["x_frac"] + rng.uniform(-0.1, 0.1)
    return {
        "pedestrian": {"x_frac": round(float(xp), 4), "depth_m": round(float(1 / inv[0]), 4)},
        "tree": {"x_frac": round(float(xt), 4), "depth_m": round(float(1 / inv[1]), 4)},
        "building": {"x_frac": round(float(xb), 4), "depth_m": round(float(1 / back_m), 4)},
    }


def three_plane_scene(
    shape_px: tuple[int, int] = SIM_SHAPE_PX,
    *,
    margin_px: int = 48,
    rng: np.random.Generator | int | None = 0,
    layout: dict[str, dict[str, float]] | None = None,
) -> list[Layer]:
    """Return the paper's simulated scene: pedestrian 1 m, tree 4 m, building 9 m (Fig. 10).

    With a ``layout`` the same three objects stand elsewhere (a trial of a study whose subjects
    must not learn where the objects are; see :func:`random_three_plane_layout`).

    Parameters
    ----------
    shape_px : (rows, cols)
        View size; the textures are ``2 * margin_px`` larger so shifted views stay covered.
    margin_px : int >= 0
        Texture margin on each side, pixels (48 covers the lens-array sim's 5 x 7.5 px shift).
    rng : numpy Generator, int or None
        Seeds the leaf and bark texture.
    layout : dict of str -> {'x_frac': float, 'depth_m': float}, optional
        Each object's centre column (fraction of the view width) and depth, metres. Default:
        :data:`JUNG2015_LAYOUT`.

    Returns
    -------
    list of Layer
        Building, tree, pedestrian, textures float32 in [0, 1].

    Raises
    ------
    stimuli.errors.InputError
        A layout that misses an object, or puts the building (the backdrop) in front.

    References
    ----------
    Jung et al. (2015), Sec. 4.1 and Fig. 10.
    """
    rng = np.random.default_rng(rng)
    rows, cols = (int(v) for v in shape_px)
    if rows < 16 or cols < 16:
        raise InputError(f"shape_px must be at least 16x16, got {shape_px!r}")
    if margin_px < 0:
        raise InputError(f"margin_px must be >= 0, got {margin_px!r}")
    if layout is not None:
        layout = _check_layout(layout)
    big = (rows + 2 * margin_px, cols + 2 * margin_px)
    s = min(rows / SIM_SHAPE_PX[0], cols / SIM_SHAPE_PX[1])

    def centred(layer_fn) -> Layer:
        inner = layer_fn((rows, cols), s, rng, layout)
        t = np.zeros(big, np.float32)
        a = np.zeros(big, np.float32)
        t[margin_px : margin_px + rows, margin_px : margin_px + cols] = inner.texture
        a[margin_px : margin_px + rows, margin_px : margin_px + cols] = inner.alpha
        if inner.name == "building":  # the backdrop extends into the margin
            t = np.pad(inner.texture, margin_px, mode="edge")
            a = np.ones(big, np.float32)
        return Layer(inner.name, t, a, inner.depth_m)

    return [centred(_building), centred(_tree), centred(_pedestrian)]


def layer_masks(layers: list[Layer], shape_px: tuple[int, int]) -> dict[str, np.ndarray]:
    """Return, per layer name, where it is visible in the centre view (after occlusion).

    Returns
    -------
    dict of str -> ndarray of shape ``shape_px``, bool
        A pixel belongs to the nearest layer whose alpha there is > 0.5.
    """
    _check_layers(layers, shape_px)
    rows, cols = shape_px
    covered = np.zeros(shape_px, bool)
    out: dict[str, np.ndarray] = {}
    for layer in sorted(layers, key=lambda lay: lay.depth_m):
        a = np.asarray(layer.alpha)
        oy, ox = (a.shape[0] - rows) // 2, (a.shape[1] - cols) // 2
        m = a[oy : oy + rows, ox : ox + cols] > 0.5
        out[layer.name] = m & ~covered
        covered |= m
    return out


def ground_truth_maps(
    layers: list[Layer], geometry: Geometry, shape_px: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """Return the centre view's ground-truth disparity and depth maps of a layered scene.

    Each pixel takes the nearest layer visible there (:func:`layer_masks`); a pixel no layer
    covers gets disparity NaN and depth ``inf``.

    Returns
    -------
    disparity_px : ndarray of shape ``shape_px``, float32
        Pixels per view step (convention of :mod:`stimuli.lightfield`).
    depth_m : ndarray of shape ``shape_px``, float32
        Metres.
    """
    depth = np.full(shape_px, np.inf, np.float32)
    disp = np.full(shape_px, np.nan, np.float32)
    masks = layer_masks(layers, shape_px)
    for layer in layers:
        m = masks[layer.name]
        depth[m] = layer.depth_m
        disp[m] = geometry.disparity_px(layer.depth_m)
    return disp, depth
