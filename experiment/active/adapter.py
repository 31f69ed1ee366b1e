"""The one place where the active-search task calls the light-field pipeline of :mod:`stimuli`.

Every call into ``stimuli`` (scene synthesis, loading, refocus, de-clutter, compress, plane
detection) goes through a function here, so a rename in ``stimuli`` is a one-line fix. Only
public ``stimuli`` functions are used. Nothing here needs OpenGL. What the subject sees is drawn
by the viewer's one CPU renderer (:class:`experiment.viewer.reference.CpuRenderer`, built by
:func:`search_renderer`), and the keys move the viewer's state machine
(:mod:`experiment.viewer.state`, with the model :func:`search_model` builds).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "CONDITIONS",
    "search_model",
    "search_renderer",
    "SYNTHETIC_PREFIX",
    "FIXED_SCENE",
    "RANDOM_SCENE",
    "SYNTHETIC_SCENES",
    "SYNTHETIC_OBJECTS",
    "scene_objects",
    "draw_layout",
    "Scene",
    "load_scene",
    "detect_planes",
    "object_edge_template",
]

#: Scene names that start with this are rendered, not loaded (``synthetic:three_plane``).
SYNTHETIC_PREFIX = "synthetic:"
#: The paper's Fig. 10 scene, the same in every trial.
FIXED_SCENE = "synthetic:three_plane"
#: The same three objects at new columns and depths in every trial (drawn from the session's
#: seed and logged with the trial; :func:`stimuli.lfsynth.random_three_plane_layout`).
RANDOM_SCENE = "synthetic:random_three_plane"
#: The synthetic scenes a protocol may name.
SYNTHETIC_SCENES: tuple[str, ...] = (FIXED_SCENE, RANDOM_SCENE)
#: The objects of both synthetic scenes.
SYNTHETIC_OBJECTS: tuple[str, ...] = ("pedestrian", "tree", "building")

#: Conditions of a search: the implant path starts from the confocal image (de-cluttered) or
#: from the all-in-focus centre view (cluttered).
CONDITIONS: tuple[str, ...] = ("decluttered", "cluttered")

#: A search's depth is on a detected plane only when it is that plane (float noise aside).
PLANE_TOLERANCE_PX: float = 1e-6

#: A search's smallest zoom box either way, view pixels (ours).
MIN_ZOOM_PX: int = 2


@dataclass(frozen=True, eq=False)
class Scene:
    """A light field to search, with what is known about its objects.

    Attributes
    ----------
    name : str
        ``synthetic:three_plane`` or the light field's path.
    lightfield : stimuli.lightfield.LightField
        Grey views ``(n_u, n_v, rows, cols)``, float32 in [0, 1].
    objects : dict of str to float
        Object name -> disparity of its plane, px per view step (synthetic scenes only).
    masks : dict of str to ndarray of shape (rows, cols), bool
        Where each object is visible in the centre view (synthetic scenes only).
    appearances : dict of str to ndarray of shape (rows, cols), float32 in [0, 1]
        Each object in focus where it is visible in the centre view, mid grey elsewhere
        (synthetic scenes only; the simulated recogniser's memory of the object).
    sha256 : str
        SHA-256 of the views' bytes (provenance, H15).
    synonyms : dict of str to (synonyms, uses)
        Words the scorer accepts for a recorded scene's targets (from its description).
    layout : dict or None
        Where a randomised synthetic scene's objects stand (logged with the trial).
    edge_masks : dict of str to ndarray of shape (rows, cols), bool
        A recorded scene's targets: their appearance is the whole view refocused at their
        plane, and only its edges inside this box make the recogniser's template.
    scan_px : (nearest, farthest) or None
        Disparity range of the depth scan (a recorded scene's description), else the default.
    """

    name: str
    lightfield: object
    objects: dict[str, float] = field(default_factory=dict)
    masks: dict[str, np.ndarray] = field(default_factory=dict)
    appearances: dict[str, np.ndarray] = field(default_factory=dict)
    sha256: str = ""
    synonyms: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = field(default_factory=dict)
    layout: dict | None = None
    scan_px: tuple[float, float] | None = None
    edge_masks: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def shape_px(self) -> tuple[int, int]:
        """Size ``(rows, cols)`` of one view."""
        return tuple(self.lightfield.shape_px)  # type: ignore[attr-defined,return-value]

    def depth_m(self, disparity_px: float) -> float | None:
        """Return the depth in metres of a disparity (None without a geometry)."""
        return self.lightfield.depth_m(disparity_px)  # type: ignore[attr-defined]

    def centre_view(self) -> np.ndarray:
        """Return the all-in-focus centre view, float32 (rows, cols)."""
        return self.lightfield.centre_view()  # type: ignore[attr-defined]

    def depth_step_px(self) -> float:
        """Disparity step that moves the outermost view by one pixel (the depth resolution)."""
        n_u, n_v = self.lightfield.grid  # type: ignore[attr-defined]
        cu, cv = n_u // 2, n_v // 2
        return 1.0 / max(cu, n_u - 1 - cu, cv, n_v - 1 - cv, 1)

    def max_disparity_px(self) -> float:
        """Largest usable |disparity| (outer views still overlap the centre view)."""
        return float(self.lightfield.max_disparity_px())  # type: ignore[attr-defined]


def scene_objects(name: str, *, base_dir: str | Path | None = None) -> tuple[str, ...] | None:
    """Return the objects a scene entry holds without rendering or loading it.

    Synthetic scenes: :data:`SYNTHETIC_OBJECTS`; a scene description: its targets; a plain
    light field: None (its objects are unknown; any target may be cued).

    Raises
    ------
    stimuli.errors.InputError
        An unknown synthetic scene.
    experiment.protocol.ProtocolError
        A scene description with a bad field (one line naming the file and field).
    """
    from experiment.active.scenefile import read_scene_file, scene_file_for
    from stimuli.errors import InputError

    if name.startswith(SYNTHETIC_PREFIX):
        if name not in SYNTHETIC_SCENES:
            raise InputError(
                f"scene must be one of {', '.join(SYNTHETIC_SCENES)} or a path, got {name!r}"
            )
        return SYNTHETIC_OBJECTS
    desc = scene_file_for(name, base_dir)
    return None if desc is None else read_scene_file(desc).names


def draw_layout(name: str, rng: np.random.Generator | int | None) -> dict | None:
    """Return a new object layout for a trial of a randomised scene (None for other scenes)."""
    if name != RANDOM_SCENE:
        return None
    from stimuli.lfsynth import random_three_plane_layout

    return random_three_plane_layout(rng)


def _synthetic(name, shape_px, grid, baseline_m, seed, layout):
    from stimuli.lfsynth import SIM_SHAPE_PX, layer_masks, render_camera_array
    from stimuli.lfsynth import three_plane_scene as _three_plane

    shape = tuple(int(v) for v in (shape_px or SIM_SHAPE_PX))
    layers = _three_plane(shape, rng=seed, layout=layout)
    lf = render_camera_array(layers, grid=grid, shape_px=shape, baseline_m=baseline_m)
    masks = layer_masks(layers, shape)
    objects, looks = {}, {}
    for layer in layers:
        objects[layer.name] = float(lf.disparity_px(layer.depth_m))
        t, a = np.asarray(layer.texture), np.asarray(layer.alpha)
        oy, ox = (t.shape[0] - shape[0]) // 2, (t.shape[1] - shape[1]) // 2
        t = t[oy : oy + shape[0], ox : ox + shape[1]]
        a = a[oy : oy + shape[0], ox : ox + shape[1]]
        # the object as seen in the scene: only where it is visible (occlusion included)
        a = a * masks[layer.name]
        looks[layer.name] = np.clip(a * t + (1 - a) * 0.5, 0, 1).astype(np.float32)
    return lf, objects, masks, looks


def _recorded(desc):
    """Load a described light field.

    Each target's look is the view refocused at its plane (its template keeps that view's edges
    inside its box: :func:`object_edge_template`).
    """
    from stimuli.errors import InputError
    from stimuli.lightfield import load_lightfield
    from stimuli.refocus import refocus
    from stimuli.vignette import apply_view_crop

    lf = load_lightfield(desc.lightfield).gray()
    rows, cols = load_rows_cols = lf.shape_px
    ox = oy = 0
    auto = desc.crop_xywh is None
    if auto:  # the vignette crop every command finds (scan, build, the viewer)
        lf = apply_view_crop(lf, "auto")
        if lf.meta.get("view_crop") is not None:
            ox, oy = lf.meta["view_crop"][:2]
            rows, cols = lf.shape_px
    else:
        x, y, w, h = desc.crop_xywh
        if x + w > cols or y + h > rows:
            raise InputError(
                f"{desc.path}: scene.crop_xywh {list(desc.crop_xywh)} must lie inside the "
                f"{cols}x{rows} views of {desc.lightfield}"
            )
        lf, ox, oy = lf.cropped(desc.crop_xywh), x, y
        rows, cols = lf.shape_px
    objects, masks, looks, words = {}, {}, {}, {}
    full_rows, full_cols = load_rows_cols
    for i, t in enumerate(desc.targets):
        x, y, w, h = t.box_xywh
        if x + w > full_cols or y + h > full_rows:  # outside the capture itself, crop or not
            raise InputError(
                f"{desc.path}: targets[{i}].box_xywh {list(t.box_xywh)} must lie inside the "
                f"{full_cols}x{full_rows} views of {desc.lightfield}"
            )
        x, y = x - ox, y - oy
        if auto:  # a box reaching into the rim the crop left out keeps its part inside
            x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, cols), min(y + h, rows)
            x, y, w, h = x0, y0, max(x1 - x0, 0), max(y1 - y0, 0)
        if x + w > cols or y + h > rows or w < 1 or h < 1:
            raise InputError(
                f"{desc.path}: targets[{i}].box_xywh {list(t.box_xywh)} must lie inside the "
                f"searched {cols}x{rows} view"
            )
        m = np.zeros((rows, cols), bool)
        m[y : y + h, x : x + w] = True
        img = refocus(lf, t.disparity_px, workers=1)
        objects[t.name] = t.disparity_px
        masks[t.name] = m
        looks[t.name] = np.asarray(img, dtype=np.float32)
        words[t.name] = (t.synonyms, t.uses)
    return lf, objects, masks, looks, words


def load_scene(
    name: str,
    *,
    shape_px: tuple[int, int] | None = None,
    grid: tuple[int, int] = (7, 7),
    baseline_m: float = 0.03,
    seed: int = 0,
    layout: dict | None = None,
    base_dir: str | Path | None = None,
) -> Scene:
    """Render a synthetic scene, or load a recorded light field (with its targets, if described).

    Parameters
    ----------
    name : str
        ``"synthetic:three_plane"`` (Jung et al. 2015, Fig. 10: pedestrian 1 m, tree 4 m,
        building 9 m), ``"synthetic:random_three_plane"`` (the same objects where ``layout``
        puts them), a scene description (``.toml``, or a light-field folder holding
        ``scene.toml``: :mod:`experiment.active.scenefile`), or a light-field file or folder
        that ``confocal lightfield`` reads.
    shape_px : (rows, cols), optional
        View size of a synthetic scene (default: the paper's 308x385).
    grid : (n_u, n_v)
        Views of the synthetic scene's camera array.
    baseline_m : float > 0
        Spacing of its cameras, metres (ours: 3 cm with 400 px focal length puts the pedestrian
        at 12, the tree at 3 and the building at 1.33 px per view step, so a 7x7 array blurs
        each plane's neighbours by several pixels, as the paper's 10x10 lens array does).
    seed : int
        Seed of the synthetic scene's textures.
    layout : dict, optional
        Object layout of ``synthetic:random_three_plane`` (required there; see
        :func:`draw_layout`).
    base_dir : str or Path, optional
        Folder relative scene paths are read from (the protocol's).

    Returns
    -------
    Scene

    Raises
    ------
    stimuli.errors.InputError
        An unknown synthetic scene, a missing layout, an unreadable light field, a box or crop
        outside the views.
    experiment.protocol.ProtocolError
        A scene description with a bad field.
    """
    import hashlib

    from experiment.active.scenefile import read_scene_file, scene_file_for
    from stimuli.errors import InputError

    words: dict = {}
    scan = None
    edge_masks: dict = {}
    if name.startswith(SYNTHETIC_PREFIX):
        if name not in SYNTHETIC_SCENES:
            raise InputError(
                f"scene must be one of {', '.join(SYNTHETIC_SCENES)} or a path, got {name!r}"
            )
        if name == RANDOM_SCENE and layout is None:
            raise InputError(f"scene {name!r} needs the trial's layout (draw_layout)")
        if name == FIXED_SCENE:
            layout = None
        lf, objects, masks, looks = _synthetic(name, shape_px, grid, baseline_m, seed, layout)
    elif (desc_path := scene_file_for(name, base_dir)) is not None:
        desc = read_scene_file(desc_path)
        lf, objects, masks, looks, words = _recorded(desc)
        scan, edge_masks = desc.scan_px, masks
    else:
        from stimuli.lightfield import load_lightfield

        path = Path(name)
        if not path.is_absolute() and base_dir is not None and not path.exists():
            path = Path(base_dir) / path
        if not path.exists():
            raise InputError(f"{path}: light field not found")
        from stimuli.vignette import apply_view_crop

        # the vignette crop every command finds (scan, build, the viewer)
        lf = apply_view_crop(load_lightfield(path).gray(), "auto")
        objects, masks, looks = {}, {}, {}
    sha = hashlib.sha256(np.ascontiguousarray(lf.views).tobytes()).hexdigest()
    return Scene(name, lf, objects, masks, looks, sha, words, layout, scan, edge_masks)


def _crop(image: np.ndarray, box_xywh: tuple[int, int, int, int] | None) -> np.ndarray:
    if box_xywh is None:
        return image
    x, y, w, h = box_xywh
    return np.ascontiguousarray(image[y : y + h, x : x + w])


def object_edge_template(
    appearance: np.ndarray,
    grid_px: tuple[int, int],
    *,
    zoom_box_xywh: tuple[int, int, int, int] | None = None,
    mask: np.ndarray | None = None,
) -> np.ndarray:
    """Return an object's implant view when it is alone and in focus (a recogniser template).

    The viewer's pipeline (:func:`experiment.viewer.reference.implant_cells`) on the object's
    appearance cropped to the zoom box; the lit electrodes, bool ``grid_px``. ``mask``
    (rows, cols) bool keeps only the de-cluttered edges inside it before compression: a
    recorded target is its whole view refocused at its plane, cut to its box after edge
    detection so that the box's border makes no edges of its own.
    """
    from experiment.viewer.reference import implant_cells

    img = _crop(np.asarray(appearance, dtype=np.float32), zoom_box_xywh)
    keep = None if mask is None else _crop(np.asarray(mask, dtype=bool), zoom_box_xywh)
    cells = implant_cells(img, tuple(grid_px), edge_mask=keep)[3]  # type: ignore[arg-type]
    return cells >= 0.5


def detect_planes(scene: Scene, *, n_planes: int) -> tuple[np.ndarray, tuple[float, ...]]:
    """Scan the scene for object planes (Jung et al. 2015, Sec. 4.2).

    Returns
    -------
    disparities_px : ndarray of shape (n_planes,)
        The scanned disparities (near to far).
    planes_px : tuple of float
        Detected object planes, nearest first.
    """
    from stimuli.planes import (
        DEFAULT_N_PLANES,
        auto_binning,
        default_disparities,
        find_object_planes,
    )

    lf = scene.lightfield
    if scene.scan_px is not None:
        ds = np.linspace(scene.scan_px[0], scene.scan_px[1], n_planes)
    elif getattr(lf, "geometry", None) is not None:
        ds = default_disparities(lf, n_planes)
    elif n_planes == DEFAULT_N_PLANES:  # a recorded capture: the detector every command uses
        from stimuli.planechoice import detect_planes as detect

        scan = detect(lf, workers=1)
        ds = np.sort(np.asarray(scan.disparities_px, dtype=np.float64))[::-1]
        return ds, tuple(float(p.disparity_px) for p in scan.peaks)
    else:
        ds = None
    if ds is None:
        scan = find_object_planes(lf, n_planes=n_planes, workers=1)
    else:
        scan = find_object_planes(lf, ds, binning=auto_binning(lf), workers=1)
    ds = np.sort(np.asarray(scan.disparities_px, dtype=np.float64))[::-1]
    return ds, tuple(float(p.disparity_px) for p in scan.peaks)


def search_model(
    planes_px: tuple[float, ...],
    near_px: float,
    far_px: float,
    depth_step_px: float,
    shape_px: tuple[int, int],
    *,
    zoom_allowed: bool = True,
):
    """Return the viewer model of a search: what its keys (actions) work on.

    Parameters
    ----------
    planes_px : tuple of float
        Detected object planes, nearest first (decreasing disparity).
    near_px, far_px : float
        Ends of the depth range the keys can reach (``near_px > far_px``).
    depth_step_px : float > 0
        Disparity change per depth key.
    shape_px : (rows, cols)
        View size (zoom boxes must lie inside it).
    zoom_allowed : bool

    Returns
    -------
    experiment.viewer.state.ViewerModel
    """
    from experiment.viewer.state import ViewerModel

    return ViewerModel(
        shape_px=tuple(int(v) for v in shape_px),  # type: ignore[arg-type]
        disparity_range_px=(float(far_px), float(near_px)),
        step_px=float(depth_step_px),
        planes_px=tuple(float(p) for p in planes_px),
        implants=("",),
        plane_tolerance_px=PLANE_TOLERANCE_PX,
        min_zoom_px=MIN_ZOOM_PX,
        zoom_allowed=bool(zoom_allowed),
    )


def search_renderer(scene: Scene, grid_px: tuple[int, int], condition: str):
    """Return the viewer's CPU renderer for a search's scene, implant grid and condition.

    Raises
    ------
    ValueError
        A condition not in :data:`CONDITIONS`.
    """
    from experiment.viewer.reference import CpuRenderer

    if condition not in CONDITIONS:
        raise ValueError(f"condition must be decluttered or cluttered, got {condition!r}")
    lf = scene.lightfield
    return CpuRenderer(lf, tuple(grid_px), cluttered=condition == "cluttered", workers=1)  # type: ignore[arg-type]
