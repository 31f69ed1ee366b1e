"""Synthetic photo pairs: nameable objects in front of cluttered backgrounds.

Each scene imitates one photo of the paper's study (Jung et al. 2015, Sec. 3.1): a household
or office object, about 10 deg wide, bottom centre, 0.8 m from the camera, in front of its own
cluttered background at 1.5-3 m (a patterned wall, a shelf of books or binders, clothes on a
rail or a pin board, hanging cables). Every part is a drawn shape with shading or texture
(filled outlines, gradients, highlights), evaluated as anti-aliased signed-distance fields on
whole-array numpy grids. The drawings live in :mod:`stimuli.objects` (one module per family of
objects, the backgrounds, and the drawing kit); this module lays out, renders and writes scenes.

Scenes are :class:`stimuli.scene.Layer` stacks in the reference pinhole camera's image
coordinates, with a margin around the camera image (``margin_px``) so that off-centre views of
a light field still see texture at their borders. :func:`write_pairs` renders each scene with
:func:`stimuli.scene.render_pair` (f/22 and f/1.7) and writes a PAIRS folder for
``confocal stimuli build``.

Units: object drawings use *object units* (1 unit = the object's nominal width, 10 deg at
0.8 m, about 194 px at 492x327), with y up and the object's base at y = 0. Backgrounds are drawn
in metres on their own plane, y up, origin on the optical axis.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.io import check_missing_or_empty, save_png, staged_folder
from stimuli.manifest import OBJECTS_COLUMNS
from stimuli.objects.backgrounds import BACKGROUNDS
from stimuli.objects.drawing import Canvas
from stimuli.objects.registry import DRAWERS, ObjectKind, find_kind, object_kinds
from stimuli.objects.registry import KINDS as _KINDS  # the name write_pairs uses
from stimuli.scene import Layer, ThinLensCamera, centre_crop_offset, render_pair
from stimuli.tables import table_text

__all__ = [
    "ObjectKind",
    "object_kinds",
    "make_scene",
    "object_mask",
    "object_width_px",
    "write_pairs",
    "OBJECT_WIDTH_DEG",
    "BACKGROUND_DEPTHS_M",
    "OBJECTS_CSV_COLUMNS",
]


#: Angular width of each object, degrees. Source: Jung et al. 2015, Sec. 3.1 ("about 10 deg").
OBJECT_WIDTH_DEG: float = 10.0

#: Depth range of the cluttered background, metres (nearest, farthest). Ours, not the paper's:
#: the paper's backgrounds (shelves, clothes, wires, files) were "behind" the object at 80 cm;
#: 1.5-3 m gives circles of confusion of about 20-32 px at f/1.7 and 1.6-2.5 px at f/22.
BACKGROUND_DEPTHS_M: tuple[float, float] = (1.5, 3.0)

#: Columns of ``objects.csv``: the builder's per-object table, defined in :mod:`stimuli.manifest`.
OBJECTS_CSV_COLUMNS: tuple[str, ...] = tuple(c for c in OBJECTS_COLUMNS if c != "roi")

#: Texture margin around the camera image on each side, as a fraction of the image width.
#: Ours: enough for the parallax of the outermost views of a small-baseline light field.
_MARGIN_FRACTION = 0.1

#: Gap between the object's base and the bottom of the image, fraction of the image height (ours).
_BASE_GAP_FRACTION = 0.03

#: Range of the contrast factor applied to each background layer around mid-grey. Ours, not the
#: paper's: with full-contrast drawings the set's mean wide-DOF edge fraction was about 14 %,
#: twice the paper's 7.7 % (Sec. 2.2); lowering background contrast brings it nearer.
_BACKGROUND_CONTRAST: tuple[float, float] = (0.55, 0.8)


# --------------------------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------------------------


def _texture_shape(camera: ThinLensCamera, margin_px: int) -> tuple[int, int]:
    return (camera.shape_px[0] + 2 * margin_px, camera.shape_px[1] + 2 * margin_px)


def object_width_px(camera: ThinLensCamera) -> float:
    """Return the image width of a 10 deg wide object seen by ``camera``, pixels.

    Parameters
    ----------
    camera : ThinLensCamera

    Returns
    -------
    float
        ``2 * focal_length_px * tan(5 deg)`` (pinhole projection of an object centred on the
        axis); about 194 px for the paper's 492 px wide, 25 deg field.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (objects about 10 deg wide).

    Examples
    --------
    >>> round(object_width_px(ThinLensCamera()), 1)
    194.2
    """
    return 2.0 * camera.focal_length_px * math.tan(math.radians(OBJECT_WIDTH_DEG) / 2.0)


def make_scene(
    kind: str | ObjectKind,
    *,
    rng: np.random.Generator | int | None = None,
    camera: ThinLensCamera | None = None,
    margin_px: int | None = None,
) -> list[Layer]:
    """Build the layered scene of one object in front of its own cluttered background.

    Parameters
    ----------
    kind : str or ObjectKind
        One of :func:`object_kinds` (by ``name``).
    rng : numpy.random.Generator, int or None
        Source of all random choices (object variant and background).
    camera : ThinLensCamera, optional
        Sets the image size and projection. Default: ``ThinLensCamera()``.
    margin_px : int >= 0, optional
        Texture margin around the camera image on each side, pixels. Default: 10 % of the
        image width.

    Returns
    -------
    list of Layer
        Farthest first: a wall (2.7-3.0 m), a shelf (2.0-2.6 m), clothes or a pin board
        (1.6-2.0 m), cables (1.5-1.7 m), and the object (``"object:<name>"``) at the camera's
        focus distance, 10 deg wide, bottom centre. Textures have shape
        ``(rows + 2 * margin_px, cols + 2 * margin_px)``.

    Raises
    ------
    InputError
        If ``kind`` is unknown or ``margin_px`` is negative.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (objects about 10 deg wide at ~80 cm in front of shelves,
    clothes, wires and files).
    """
    k = find_kind(kind)
    rng = np.random.default_rng(rng)
    # The object gets its own stream, drawn first: how many numbers the background uses
    # (which varies with the image size) then never changes the object.
    obj_rng = np.random.default_rng(rng.integers(0, 2**63))
    cam = ThinLensCamera() if camera is None else camera
    if not isinstance(cam, ThinLensCamera):
        raise InputError(f"camera must be a ThinLensCamera, got {type(cam).__name__}")
    if margin_px is None:
        margin_px = int(round(_MARGIN_FRACTION * cam.shape_px[1]))
    if isinstance(margin_px, bool) or not isinstance(margin_px, (int, np.integer)) or margin_px < 0:
        raise InputError(f"margin_px must be an integer >= 0, got {margin_px!r}")
    shape = _texture_shape(cam, int(margin_px))
    centre = ((shape[0] - 1) / 2.0, (shape[1] - 1) / 2.0)
    f_px = cam.focal_length_px

    layers = []
    near, far = BACKGROUND_DEPTHS_M
    depths = {
        "wall": rng.uniform(2.7, far),
        "shelf": rng.uniform(2.0, 2.6),
        "middle": rng.uniform(1.6, 2.0),
        "cables": rng.uniform(near, 1.7),
    }
    middle = "clothes" if rng.random() < 0.5 else "pinboard"
    for name, label in (
        ("wall", "wall"),
        ("shelf", "shelf"),
        ("middle", middle),
        ("cables", "cables"),
    ):
        cv = Canvas(shape, f_px / depths[name], centre)
        BACKGROUNDS[label](cv, rng)
        layer = cv.layer(label, depths[name])
        # The background is lit less evenly than the object on the table: its contrast is
        # lowered around mid-grey by a random factor (ours; it brings the wide-DOF edge
        # fraction of the set near the paper's, see _BACKGROUND_CONTRAST).
        contrast = rng.uniform(*_BACKGROUND_CONTRAST)
        tex = (0.5 + contrast * (layer.texture - 0.5)).astype(np.float32)
        layers.append(Layer(layer.name, tex, layer.alpha, layer.depth_m))

    r0, _ = centre_crop_offset(shape, cam.shape_px)
    bottom_row = r0 + cam.shape_px[0] - 1 - _BASE_GAP_FRACTION * cam.shape_px[0]
    scale = obj_rng.uniform(0.94, 1.06)
    centre_col = centre[1] + obj_rng.uniform(-0.03, 0.03) * object_width_px(cam)
    obj = Canvas(shape, object_width_px(cam) * scale, (bottom_row, centre_col))
    DRAWERS[k.name](obj, obj_rng)
    obj.place(bottom_row, centre_col)
    layers.append(obj.layer(f"object:{k.name}", cam.focus_m))
    return layers


def object_mask(layers: Sequence[Layer], camera: ThinLensCamera) -> np.ndarray:
    """Return the object layer's alpha cropped to the camera image, float32 in [0, 1].

    Parameters
    ----------
    layers : sequence of Layer
        A scene from :func:`make_scene` (its one layer named ``"object:..."``).
    camera : ThinLensCamera
        The camera the scene is seen through; the mask is cropped to its image.

    Returns
    -------
    ndarray of shape ``camera.shape_px``, float32 in [0, 1]
        How much of each pixel the object covers (1 inside, fractional at its edge).

    Raises
    ------
    InputError
        If no layer's name starts with ``"object:"``.
    """
    for layer in layers:
        if layer.name.startswith("object:"):
            r0, c0 = centre_crop_offset(layer.alpha.shape, camera.shape_px)
            rows, cols = camera.shape_px
            return np.ascontiguousarray(
                layer.alpha[r0 : r0 + rows, c0 : c0 + cols], dtype=np.float32
            )
    raise InputError("layers must hold one layer named 'object:<kind>', found none")


# --------------------------------------------------------------------------------------------
# PAIRS folder
# --------------------------------------------------------------------------------------------


#: Kinds used for main objects, in order: the 20 main kinds, then the spares (ours).
_MAIN_ORDER: tuple[int, ...] = (*range(20), *range(23, len(_KINDS)))
#: Kinds used for training objects, in order (ours).
_TRAINING_ORDER: tuple[int, ...] = (20, 21, 22)


def _assign_kinds(n_main: int, n_training: int) -> tuple[list[ObjectKind], list[ObjectKind]]:
    """Assign main kinds first from the main order; training kinds from what is left."""
    order = list(_MAIN_ORDER) + list(_TRAINING_ORDER)
    main = order[:n_main]
    left = [i for i in list(_TRAINING_ORDER) + list(_MAIN_ORDER)[::-1] if i not in main]
    return [_KINDS[i] for i in main], [_KINDS[i] for i in left[:n_training]]


def _check_count(name: str, value: object, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def write_pairs(
    out_dir: str | os.PathLike,
    *,
    n_objects: int = 20,
    n_training: int = 3,
    seed: int = 0,
    shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX,
    compress_level: int = 6,
) -> Path:
    """Render synthetic photo pairs and write a PAIRS folder for the stimulus builder.

    Main objects are drawn from the 20 main kinds of :func:`object_kinds` (then the spare
    kinds), training objects from the 3 training kinds (then unused main kinds, last first).
    Main object ``i`` (0-based) is drawn from ``SeedSequence(seed, spawn_key=(0, i))`` and
    training object ``j`` from ``spawn_key=(1, j)``, so a scene does not depend on how many
    objects are written.

    Layout of ``out_dir``:

    =============================  =============================================================
    ``objNN_<kind>/wide.png``      f/22 photo, 8-bit grey, ``shape_px``
    ``objNN_<kind>/narrow.png``    f/1.7 photo, 8-bit grey, ``shape_px``
    ``objNN_<kind>/mask.png``      the object's alpha (coverage, 255 = object), for tests
    ``trainNN_<kind>/...``         the same for training objects
    ``objects.csv``                one row per object, columns :data:`OBJECTS_CSV_COLUMNS`
    ``synth.json``                 seed, camera, depths and package version (provenance)
    =============================  =============================================================

    ``objects.csv`` columns: ``object`` (folder name), ``name`` (display name), ``synonyms``
    and ``uses`` (``;``-separated), ``role`` (``main`` or ``training``); ``sobel_threshold``,
    ``crop``, ``plane_depth_m`` and ``plane_disparity_px`` are left empty for the builder.

    Parameters
    ----------
    out_dir : str or path-like
        Folder to create: a new or empty folder (a non-empty one is refused, never replaced).
        Written to a staging folder beside it and renamed at the end.
    n_objects : int >= 1
        Main objects.
    n_training : int >= 0
        Training objects (after the main ones); ``n_objects + n_training`` at most the number
        of :func:`object_kinds` (26).
    seed : int >= 0
        Seed of every random choice.
    shape_px : (rows, cols)
        Photo size, pixels (the paper's working size by default; e.g. ``(1024, 1536)`` for the
        benchmark). Each at least 32.
    compress_level : int in 0..9
        zlib's effort for the PNG files (:func:`stimuli.io.save_png`). The pixels are the same
        at any level; 1 writes them faster and larger, for pairs that are read once (the
        demo's knowledge renderings).

    Returns
    -------
    Path
        ``out_dir``.

    Raises
    ------
    InputError
        If ``out_dir`` exists and is not empty or is a file, or a count,
        ``seed``, ``shape_px`` or ``compress_level`` is invalid.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (20 objects, f/1.7 and f/22 photos).
    """
    n_obj = _check_count("n_objects", n_objects, 1)
    n_tr = _check_count("n_training", n_training, 0)
    if n_obj + n_tr > len(_KINDS):
        raise InputError(
            f"n_objects + n_training must be <= {len(_KINDS)} (the kinds available), "
            f"got {n_obj} + {n_tr}"
        )
    seed_i = _check_count("seed", seed, 0)
    if isinstance(compress_level, bool) or compress_level not in range(10):
        raise InputError(f"compress_level must be an integer 0..9, got {compress_level!r}")
    try:
        rows, cols = (int(v) for v in shape_px)
    except (TypeError, ValueError):
        raise InputError(f"shape_px must be (rows, cols), got {shape_px!r}") from None
    if rows < 32 or cols < 32:
        raise InputError(f"shape_px must be at least (32, 32), got {shape_px!r}")
    out = Path(out_dir)
    check_missing_or_empty(out)

    camera = ThinLensCamera(shape_px=(rows, cols))
    main_kinds, training_kinds = _assign_kinds(n_obj, n_tr)
    jobs = [("main", i, k) for i, k in enumerate(main_kinds)]
    jobs += [("training", i, k) for i, k in enumerate(training_kinds)]
    with staged_folder(out) as tmp:
        records = []
        scenes = []
        for role, i, kind in jobs:
            prefix = "obj" if role == "main" else "train"
            folder = f"{prefix}{i + 1:02d}_{kind.name}"
            # One independent stream per (role, index): an object's scene does not depend on
            # how many objects of either role are written.
            child = np.random.SeedSequence(seed_i, spawn_key=(int(role == "training"), i))
            layers = make_scene(kind, rng=np.random.default_rng(child), camera=camera)
            wide, narrow = render_pair(layers, camera=camera)
            d = tmp / folder
            d.mkdir()
            save_png(wide, d / "wide.png", compress_level=compress_level)
            save_png(narrow, d / "narrow.png", compress_level=compress_level)
            save_png(object_mask(layers, camera), d / "mask.png", compress_level=compress_level)
            records.append(
                {
                    "object": folder,
                    "name": kind.display_name,
                    "synonyms": ";".join(kind.synonyms),
                    "uses": ";".join(kind.uses),
                    "role": role,
                    "sobel_threshold": "",
                    "crop": "",
                    "plane_depth_m": "",
                    "plane_disparity_px": "",
                }
            )
            scenes.append(
                {
                    "object": folder,
                    "layers": [{"name": la.name, "depth_m": round(la.depth_m, 4)} for la in layers],
                }
            )
        (tmp / "objects.csv").write_text(
            table_text(records, OBJECTS_CSV_COLUMNS), encoding="utf-8"
        )  # formula-safe cells
        from stimuli import __version__

        meta = {
            "generator": "stimuli.synth.write_pairs",
            "version": __version__,
            "seed": seed_i,
            "n_objects": n_obj,
            "n_training": n_tr,
            "camera": {
                "shape_px": [rows, cols],
                "focal_length_mm": camera.focal_length_mm,
                "hfov_deg": camera.hfov_deg,
                "focus_m": camera.focus_m,
                "wide_f_number": jung2015.WIDE_F_NUMBER,
                "narrow_f_number": jung2015.NARROW_F_NUMBER,
            },
            "object_width_deg": OBJECT_WIDTH_DEG,
            "scenes": scenes,
        }
        (tmp / "synth.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
    return out
