"""The one place where the active-search task calls the light-field pipeline of :mod:`stimuli`.

Every call into ``stimuli`` (scene synthesis, loading, refocus, de-clutter, compress, plane
detection) goes through a function here, so a rename in ``stimuli`` is a one-line fix. Only
public ``stimuli`` functions are used. Nothing here needs OpenGL: this is the CPU reference
pipeline the GL viewer is compared against.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "SYNTHETIC_PREFIX",
    "Scene",
    "load_scene",
    "refocus_image",
    "implant_view",
    "edge_image",
    "detect_planes",
    "object_edge_template",
]

#: Scene names that start with this are rendered, not loaded (``synthetic:three_plane``).
SYNTHETIC_PREFIX = "synthetic:"


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
    """

    name: str
    lightfield: object
    objects: dict[str, float] = field(default_factory=dict)
    masks: dict[str, np.ndarray] = field(default_factory=dict)
    appearances: dict[str, np.ndarray] = field(default_factory=dict)
    sha256: str = ""

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


def load_scene(
    name: str,
    *,
    shape_px: tuple[int, int] | None = None,
    grid: tuple[int, int] = (7, 7),
    baseline_m: float = 0.03,
    seed: int = 0,
) -> Scene:
    """Render the synthetic three-plane scene, or load a light field from a path.

    Parameters
    ----------
    name : str
        ``"synthetic:three_plane"`` (Jung et al. 2015, Fig. 10: pedestrian 1 m, tree 4 m,
        building 9 m), or a light-field file or folder that ``confocal lightfield`` reads.
    shape_px : (rows, cols), optional
        View size of the synthetic scene (default: the paper's 308x385).
    grid : (n_u, n_v)
        Views of the synthetic scene's camera array.
    baseline_m : float > 0
        Spacing of its cameras, metres (ours: 3 cm with 400 px focal length puts the pedestrian
        at 12, the tree at 3 and the building at 1.33 px per view step, so a 7x7 array blurs
        each plane's neighbours by several pixels, as the paper's 10x10 lens array does).
    seed : int
        Seed of the synthetic scene's textures.

    Returns
    -------
    Scene

    Raises
    ------
    stimuli.errors.InputError
        An unknown synthetic scene or an unreadable light field.
    """
    import hashlib

    from stimuli.errors import InputError

    if name.startswith(SYNTHETIC_PREFIX):
        from stimuli.lfsynth import SIM_SHAPE_PX, layer_masks, render_camera_array
        from stimuli.lfsynth import three_plane_scene as _three_plane

        kind = name[len(SYNTHETIC_PREFIX) :]
        if kind != "three_plane":
            raise InputError(f"scene must be 'synthetic:three_plane' or a path, got {name!r}")
        shape = tuple(int(v) for v in (shape_px or SIM_SHAPE_PX))
        layers = _three_plane(shape, rng=seed)
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
    else:
        from stimuli.lightfield import load_lightfield

        path = Path(name)
        if not path.exists():
            raise InputError(f"{path}: light field not found")
        lf = load_lightfield(path).gray()
        objects, masks, looks = {}, {}, {}
    sha = hashlib.sha256(np.ascontiguousarray(lf.views).tobytes()).hexdigest()
    return Scene(name, lf, objects, masks, looks, sha)


def refocus_image(scene: Scene, disparity_px: float) -> np.ndarray:
    """Return the confocal image at a disparity (float32 (rows, cols) in [0, 1]); Ng 2005."""
    from stimuli.refocus import refocus

    return refocus(scene.lightfield, float(disparity_px), workers=1)


def _crop(image: np.ndarray, box_xywh: tuple[int, int, int, int] | None) -> np.ndarray:
    if box_xywh is None:
        return image
    x, y, w, h = box_xywh
    return np.ascontiguousarray(image[y : y + h, x : x + w])


def edge_image(image: np.ndarray, *, threshold: float | None = None) -> tuple[np.ndarray, float]:
    """De-clutter: Sobel edges above a threshold (Otsu when None). Returns (edges, threshold)."""
    from stimuli.declutter import auto_threshold, declutter

    t = auto_threshold(image) if threshold is None else float(threshold)
    return declutter(image, threshold=t), t


def implant_view(
    image: np.ndarray,
    grid_px: tuple[int, int],
    *,
    zoom_box_xywh: tuple[int, int, int, int] | None = None,
    edge_ratio: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Crop (zoom), de-clutter and compress an image to the implant grid (Figs. 12-14).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
        The confocal image (de-cluttered condition) or the centre view (cluttered).
    grid_px : (rows, cols)
        The implant's electrode grid.
    zoom_box_xywh : (x, y, w, h), optional
        Crop applied before de-clutter and compression (zoom, Fig. 14).
    edge_ratio : float in [0, 1), optional
        Compression edge ratio (default: the paper's 1/13).

    Returns
    -------
    edges : ndarray of shape (h, w), bool
    grid : ndarray of shape ``grid_px``, bool
    """
    from stimuli import jung2015
    from stimuli.compress import compress

    ratio = jung2015.EDGE_RATIO if edge_ratio is None else edge_ratio
    edges, _ = edge_image(_crop(image, zoom_box_xywh))
    return edges, compress(edges, tuple(grid_px), edge_ratio=ratio)


def object_edge_template(
    appearance: np.ndarray,
    grid_px: tuple[int, int],
    *,
    zoom_box_xywh: tuple[int, int, int, int] | None = None,
) -> np.ndarray:
    """Return an object's implant view when it is alone and in focus (a recogniser template)."""
    return implant_view(appearance, grid_px, zoom_box_xywh=zoom_box_xywh)[1]


def detect_planes(scene: Scene, *, n_planes: int) -> tuple[np.ndarray, tuple[float, ...]]:
    """Scan the scene for object planes (Jung et al. 2015, Sec. 4.2).

    Returns
    -------
    disparities_px : ndarray of shape (n_planes,)
        The scanned disparities (near to far).
    planes_px : tuple of float
        Detected object planes, nearest first.
    """
    from stimuli.planes import auto_binning, default_disparities, find_object_planes

    lf = scene.lightfield
    if getattr(lf, "geometry", None) is not None:
        ds = default_disparities(lf, n_planes)
    else:
        m = 0.9 * scene.max_disparity_px()
        ds = np.linspace(m, -m, n_planes)
    scan = find_object_planes(lf, ds, binning=auto_binning(lf), workers=1)
    ds = np.sort(np.asarray(scan.disparities_px, dtype=np.float64))[::-1]
    return ds, tuple(float(p.disparity_px) for p in scan.peaks)
