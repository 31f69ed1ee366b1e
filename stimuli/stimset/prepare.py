"""Photo preparation of a build: read a pair, zoom, centre-crop to the aspect, resize.

Paper Sec. 3.1 and 4.1, and the module docstring of :mod:`stimuli.stimset` (steps 1-3). The
threshold tuner (``confocal stimuli tune``) prepares its pairs here too, so that the thresholds it
proposes mean the same thing in the build.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from skimage.transform import resize

from stimuli.errors import InputError
from stimuli.flagnames import param
from stimuli.io import check_gray, gray_of, image_shape_px, load_float, rgb_of
from stimuli.manifest import ObjectInfo, format_crop
from stimuli.stimset.lightfield import ConfocalPairImages, field_crop_in_crop, load_confocal_pair
from stimuli.stimset.pairs import PairSource
from stimuli.stimset.params import BuildParams, min_photo_shape_px

if TYPE_CHECKING:
    from stimuli.planechoice import PlaneChoice

__all__ = [
    "ConditionEdges",
    "ObjectImages",
    "zoom_crop",
    "aspect_crop_box",
    "content_crop_box",
    "aspect_pad",
    "to_aspect",
    "scale_crop",
    "MIN_KEPT_SHARE",
    "to_working_size",
    "prepare_object",
    "colour_photos",
]

Box = tuple[int, int, int, int]


@dataclass(frozen=True, eq=False)
class ConditionEdges:
    """One condition's edge image of an object, and what its method measured.

    Parameters
    ----------
    name : str
        The condition (``cluttered``, ``decluttered`` or a method of :mod:`stimuli.methods`).
    edges : ndarray of shape working_shape_px, bool
    measured : dict
        What the method measured (``threshold``, ...), recorded in ``stimulus_set.json``.
    """

    name: str
    edges: np.ndarray
    measured: dict[str, object]


@dataclass(frozen=True, eq=False)
class ObjectImages:
    """One object's images at the working size and what was done to them: a step's result.

    Frozen: each step of the build takes the previous step's result and returns a new one
    (:func:`dataclasses.replace`): the prepare step (:func:`prepare_object`) fills the images
    and their geometry, the de-clutter step (:func:`stimuli.stimset.edges.declutter_object`) the
    threshold and edge images, :func:`stimuli.stimset.conditions.apply_conditions` the
    conditions beyond the paper's pair, and
    :func:`stimuli.stimset.visibility.measure_visibility` the visibility. Every image the later
    steps need travels here; nothing is read from disk again. It pickles (worker processes).

    Parameters
    ----------
    info : ObjectInfo
        The object's ``objects.csv`` row.
    source : PairSource
    wide, narrow : ndarray of shape working_shape_px, float32 in [0, 1]
        Wide-DOF photo (or centre view) and narrow-DOF photo (or confocal image).
    original_shape_px : (rows, cols)
        The wide photo's size on file.
    crop : (x, y, w, h) or None
        Zoom box applied (``objects.csv`` or the PAIRS CSV), on the photo as on file.
    aspect_crop : (x, y, w, h) or None
        Centre crop to the working aspect, on the zoomed wide photo.
    notes : tuple of str
        Things the user should know (a resize of unequal photos, upsampling).
    decoded_shape_px : (rows, cols) or None
        The wide photo's size as decoded (smaller than on file with ``fast_decode``).
    plane : str
        A light-field object's confocal plane (provenance); ``""`` for photos.
    focus : ndarray of uint8 or None
        A light-field object's in-focus evidence at the working size (``declutter='depth'``;
        0 out of focus, 1 in focus, 2 dropped: :func:`stimuli.declutter.in_focus_evidence`).
    plane_choice : PlaneChoice or None
        A light-field object's plane with its evidence and rule
        (:func:`stimuli.planechoice.choose_plane`).
    content_kept : float in [0, 1] or None
        A light-field object's share of the plane's content (or region of interest) that the
        zoom and aspect crops keep.
    declutter : str
        A light-field object's de-cluttering mode (``'sobel'`` or ``'depth'``); ``""`` for
        photos.
    aspect_pad : (top, bottom, left, right) or None
        Padding added instead of the aspect crop when no crop keeps :data:`MIN_KEPT_SHARE` of
        a light-field object's plane content, pixels of the zoomed image.
    valid : ndarray of shape working_shape_px, bool, or None
        With padding: the pixels of the image (not of the padding, nor on its border); edges
        elsewhere are dropped.
    colour : (ndarray, ndarray) of shape (rows, cols, 3), float32 in [0, 1], or None
        A training object's colour photos (wide, narrow) at the working size
        (:func:`colour_photos`), made from the same decode as the grey ones; None otherwise.
    threshold : float or None
        Sobel threshold used (edge mode; de-clutter step).
    threshold_source : str
        Where it came from: ``objects.csv``, ``global`` or ``auto:<method>``.
    wide_edges, narrow_edges : ndarray of bool or None
        Edge images (edge mode; de-clutter step).
    conditions : tuple of ConditionEdges
        A build with conditions beyond the paper's pair: each condition's edge image and what
        its method measured, in the build's order
        (:func:`stimuli.stimset.conditions.apply_conditions`); empty for the paper's pair.
    visibility : dict or None
        A light-field object's on-plane share and object coverage per level
        (:func:`stimuli.stimset.visibility.measure_visibility`), once the set's edge ratio is known.
    """

    info: ObjectInfo
    source: PairSource
    wide: np.ndarray
    narrow: np.ndarray
    original_shape_px: tuple[int, int]
    crop: Box | None
    aspect_crop: Box | None
    notes: tuple[str, ...] = ()
    decoded_shape_px: tuple[int, int] | None = None
    plane: str = ""
    focus: np.ndarray | None = None
    plane_choice: PlaneChoice | None = None
    content_kept: float | None = None
    declutter: str = ""
    aspect_pad: tuple[int, int, int, int] | None = None
    valid: np.ndarray | None = None
    colour: tuple[np.ndarray, np.ndarray] | None = None
    threshold: float | None = None
    threshold_source: str = ""
    wide_edges: np.ndarray | None = None
    narrow_edges: np.ndarray | None = None
    conditions: tuple[ConditionEdges, ...] = ()
    visibility: dict | None = None

    def condition(self, name: str) -> ConditionEdges:
        """Return the condition called ``name`` (:attr:`conditions`).

        Raises
        ------
        KeyError
            No such condition.
        """
        for c in self.conditions:
            if c.name == name:
                return c
        raise KeyError(name)


def _cut(image: np.ndarray, box: Box | None) -> np.ndarray:
    """Return the box ``(x, y, w, h)`` of an image (a view), or the image itself for ``None``."""
    if box is None:
        return image
    x, y, w, h = box
    return image[y : y + h, x : x + w]


def zoom_crop(
    image: np.ndarray, crop: tuple[int, int, int, int] | None, *, where: str = "crop"
) -> np.ndarray:
    """Cut the zoom box ``(x, y, w, h)`` out of a full-resolution image (paper Sec. 4.1).

    Parameters
    ----------
    image : ndarray of shape (rows, cols)
    crop : (x, y, w, h) or None
        Top-left column ``x`` and row ``y``, width and height, pixels; ``None`` = no crop.
    where : str
        Names the field in error messages.

    Returns
    -------
    ndarray
        A copy of the box (the input is not modified).

    Raises
    ------
    InputError
        If the box does not lie inside the image.
    """
    a = np.asarray(image)
    if crop is None:
        return a.copy()
    _check_crop_inside(crop, a.shape[:2], where=where)
    return _cut(a, crop).copy()


def _check_crop_inside(
    crop: tuple[int, int, int, int], shape_px: tuple[int, int], *, where: str
) -> None:
    x, y, w, h = crop
    rows, cols = shape_px
    if x < 0 or y < 0 or w <= 0 or h <= 0 or x + w > cols or y + h > rows:
        raise InputError(
            f"{where}: crop box x,y,w,h = {format_crop(crop)} lies outside the "
            f"{cols}x{rows} image (expected x + w <= {cols} and y + h <= {rows})"
        )


def aspect_crop_box(
    shape_px: tuple[int, int], working_shape_px: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """Return the centred box ``(x, y, w, h)`` with the working aspect, or ``None`` if it fits.

    The box keeps the full width or the full height and trims the other side symmetrically
    (the extra pixel of an odd trim goes to the right or bottom).

    Examples
    --------
    >>> aspect_crop_box((1024, 1536), (327, 492))
    (0, 1, 1536, 1021)
    """
    rows, cols = shape_px
    wr, wc = working_shape_px
    aspect = wc / wr
    new_cols = int(np.floor(rows * aspect + 0.5))
    new_rows = int(np.floor(cols / aspect + 0.5))
    if new_cols < cols:
        return ((cols - new_cols) // 2, 0, new_cols, rows)
    if new_rows < rows:
        return (0, (rows - new_rows) // 2, cols, new_rows)
    return None


def content_crop_box(
    content: np.ndarray, working_shape_px: tuple[int, int]
) -> tuple[tuple[int, int, int, int] | None, float]:
    """Return the working-aspect box that keeps most of ``content``, and the share it keeps.

    The box has the size of :func:`aspect_crop_box` (full width or full height) and slides along
    the trimmed side to the position that keeps the most content pixels; among equally good
    positions, the one nearest the centred box. Without content, the centred box.

    Parameters
    ----------
    content : ndarray of shape (rows, cols), bool
        What the crop should keep (a plane's in-focus pixels, a region of interest).
    working_shape_px : (rows, cols)

    Returns
    -------
    box : (x, y, w, h) or None
        ``None`` when the image already has the working aspect.
    kept : float in [0, 1]
        Share of the content pixels inside the box (1.0 without content).

    Examples
    --------
    >>> m = np.zeros((100, 100), bool); m[80:, 40:60] = True
    >>> content_crop_box(m, (50, 100))
    ((0, 50, 100, 50), 1.0)
    """
    m = np.asarray(content, dtype=bool)
    centred = aspect_crop_box(m.shape, working_shape_px)
    total = int(m.sum())
    if centred is None or total == 0:
        return centred, 1.0
    x, y, w, h = centred
    axis, size, start = (0, h, y) if w == m.shape[1] else (1, w, x)
    profile = m.sum(axis=1 - axis).astype(np.int64)
    cs = np.concatenate([[0], np.cumsum(profile)])
    kept = cs[size:] - cs[:-size]
    best = np.flatnonzero(kept == kept.max())
    pos = int(best[np.argmin(np.abs(best - start))])
    box = (0, pos, w, h) if axis == 0 else (pos, 0, w, h)
    return box, float(kept[pos]) / total


#: A light field's aspect crop must keep at least this share of its plane's content; when no
#: crop does, the image is padded to the working aspect instead (ours: a crop that loses more
#: than a fifth of the object loses the object).
MIN_KEPT_SHARE: float = 0.8


def aspect_pad(
    shape_px: tuple[int, int], working_shape_px: tuple[int, int]
) -> tuple[tuple[int, int], tuple[int, int]]:
    """Return the padding ``((top, bottom), (left, right))`` that brings an image to the aspect.

    The counterpart of :func:`aspect_crop_box`: the short side is extended symmetrically (the
    extra pixel of an odd amount goes to the bottom or right).

    Examples
    --------
    >>> aspect_pad((100, 100), (50, 100))
    ((0, 0), (50, 50))
    """
    rows, cols = shape_px
    wr, wc = working_shape_px
    new_cols = int(np.floor(rows * wc / wr + 0.5))
    new_rows = int(np.floor(cols * wr / wc + 0.5))
    if new_cols > cols:
        d = new_cols - cols
        return ((0, 0), (d // 2, d - d // 2))
    d = max(0, new_rows - rows)
    return ((d // 2, d - d // 2), (0, 0))


def to_aspect(image: np.ndarray, work: ObjectImages) -> np.ndarray:
    """Cut or pad an image in the zoomed photo's frame to the working aspect, as the photos were.

    Parameters
    ----------
    image : ndarray of shape (rows, cols)
        In the frame of the object's photos after the zoom crop (a mask, a plane's support).
    work : ObjectImages
        The object's prepared images (``aspect_crop`` or ``aspect_pad``, if any).

    Returns
    -------
    ndarray
        ``image`` with the object's aspect crop taken, or its aspect padding added (zeros).
    """
    if work.aspect_crop is not None:
        x, y, w, h = work.aspect_crop
        image = image[y : y + h, x : x + w]
    if work.aspect_pad is not None:
        t, b, left, r = work.aspect_pad
        image = np.pad(image, ((t, b), (left, r)))
    return image


def _valid_mask(
    shape_px: tuple[int, int], pad: tuple[tuple[int, int], tuple[int, int]], working: tuple
) -> np.ndarray:
    """Return the working-size pixels wholly inside the image.

    One pixel in from the padding (the Sobel kernel's reach).
    """
    from scipy.ndimage import binary_erosion

    ones = np.pad(np.ones(shape_px, np.float32), pad)
    inside = to_working_size(ones, working) >= 1.0 - 1e-6
    return binary_erosion(inside, iterations=1, border_value=1)


def to_working_size(image: np.ndarray, working_shape_px: tuple[int, int]) -> np.ndarray:
    """Resize a grey image to the working size with scikit-image's anti-aliased resize.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
        Already cropped to the working aspect.
    working_shape_px : (rows, cols)

    Returns
    -------
    ndarray of shape ``working_shape_px``, float32 in [0, 1]
        ``skimage.transform.resize(image, shape, order=1, anti_aliasing=True)`` (a Gaussian
        pre-filter with sigma ``(scale - 1) / 2`` before bilinear sampling).
    """
    img = check_gray(image)
    shape = tuple(int(v) for v in working_shape_px)
    if img.shape == shape:
        return img.copy()
    out = resize(img, shape, order=1, mode="reflect", anti_aliasing=True)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def _draft_shape(
    full_px: tuple[int, int], region_px: tuple[int, int], working_shape_px: tuple[int, int]
) -> tuple[int, int]:
    """Smallest decode size at which the zoom region still covers the working size."""
    s = max(working_shape_px[0] / region_px[0], working_shape_px[1] / region_px[1])
    return (int(np.ceil(full_px[0] * s)), int(np.ceil(full_px[1] * s)))


def scale_crop(
    crop: tuple[int, int, int, int] | None, ref_px: tuple[int, int], shape_px: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """Map a crop box given on an image of size ``ref_px`` to one of size ``shape_px``."""
    if crop is None or tuple(ref_px) == tuple(shape_px):
        return crop
    fy, fx = shape_px[0] / ref_px[0], shape_px[1] / ref_px[1]
    x, y, w, h = crop
    x0, y0 = int(np.floor(x * fx + 0.5)), int(np.floor(y * fy + 0.5))
    x1 = min(shape_px[1], int(np.floor((x + w) * fx + 0.5)))
    y1 = min(shape_px[0], int(np.floor((y + h) * fy + 0.5)))
    return (x0, y0, max(1, x1 - x0), max(1, y1 - y0))


def _load_photos(
    src: PairSource, params: BuildParams, crop: Box | None, colour: bool
) -> tuple[np.ndarray, np.ndarray, tuple[int, int], tuple[int, int], tuple | None]:
    """Decode each photo once; return ``(wide, narrow, wide_full_px, narrow_full_px, rgb)``.

    ``wide`` and ``narrow`` are grey (:func:`stimuli.io.gray_of`); ``rgb`` the two decodes as
    RGB (:func:`stimuli.io.rgb_of`) when ``colour``, else None. Full = the size on file.
    """
    assert src.wide is not None and src.narrow is not None
    if not params.fast_decode:
        decoded = [load_float(src.wide), load_float(src.narrow)]
        full = [d.shape[:2] for d in decoded]
    else:
        full = [image_shape_px(src.wide), image_shape_px(src.narrow)]
        decoded = []
        for path, f in zip((src.wide, src.narrow), full, strict=True):
            region = f if crop is None else (crop[3], crop[2])
            if crop is not None and f != full[0]:
                region = (crop[3] * f[0] / full[0][0], crop[2] * f[1] / full[0][1])
            draft = _draft_shape(f, (max(region[0], 1), max(region[1], 1)), params.working_shape_px)
            decoded.append(load_float(path, draft_shape_px=draft))
    rgb = (rgb_of(decoded[0]), rgb_of(decoded[1])) if colour else None
    return gray_of(decoded[0]), gray_of(decoded[1]), full[0], full[1], rgb


def _load_raw(
    src: PairSource, info: ObjectInfo, params: BuildParams, crop: Box | None, colour: bool
) -> tuple[
    np.ndarray,
    np.ndarray,
    tuple[int, int],
    tuple[int, int],
    ConfocalPairImages | None,
    tuple | None,
]:
    """Return ``(wide, narrow, wide_full_px, narrow_full_px, pair, rgb)`` (full = on file).

    ``pair`` is a light-field object's :class:`ConfocalPairImages` (plane, in-focus mask,
    plane choice), else ``None``; ``rgb`` a photo pair's two photos in colour when ``colour``.
    """
    if src.lightfield is None:
        wide, narrow, wide_full, narrow_full, rgb = _load_photos(src, params, crop, colour)
        return wide, narrow, wide_full, narrow_full, None, rgb
    pair = load_confocal_pair(src, info, params)
    return pair.centre, pair.confocal, pair.centre.shape, pair.confocal.shape, pair, None


def prepare_object(
    src: PairSource, info: ObjectInfo, params: BuildParams, *, colour: bool | None = None
) -> ObjectImages:
    """Read one object's pair and bring both images to the working size.

    Zoom crop (``objects.csv`` wins over the PAIRS CSV), centre crop to the working aspect and
    anti-aliased resize, the same for both images (and a light field's in-focus mask). Each
    photo is decoded once; a training object's colour photos are made from the same decode.

    Parameters
    ----------
    src : PairSource
    info : ObjectInfo
    params : BuildParams
    colour : bool, optional
        Also make the colour photos (:func:`colour_photos`); default: for training objects.

    Returns
    -------
    ObjectImages
        Without edges (see :func:`stimuli.stimset.edges.declutter_object`).

    Raises
    ------
    InputError
        An unreadable photo, photos of one pair with different sizes without
        ``allow_resize``, a photo smaller than :func:`~stimuli.stimset.params.min_photo_shape_px`,
        or a crop box outside the photo.
    """
    crop = info.crop if info.crop is not None else src.crop
    colour = info.role == "training" if colour is None else bool(colour)
    wide_raw, narrow_raw, wide_full, narrow_full, pair, rgb = _load_raw(
        src, info, params, crop, colour
    )
    if pair is not None and pair.choice is not None:  # a field crop in the vignette-cropped views
        crop = field_crop_in_crop(crop, pair.choice.view_crop)
    plane = "" if pair is None else pair.plane
    focus = None if pair is None else pair.focus
    notes: list[str] = []
    name = src.lightfield if src.lightfield is not None else src.wide
    if tuple(wide_full) != tuple(narrow_full):
        msg = (
            f"{src.object}: wide photo {src.wide} is {wide_full[1]}x{wide_full[0]} "
            f"but narrow photo {src.narrow} is {narrow_full[1]}x{narrow_full[0]}"
        )
        if not params.allow_resize:
            raise InputError(
                f"{msg}; the two photos of a pair must have the same pixel size "
                f"(use {param('allow_resize', True)} to resize each on its own)"
            )
        notes.append(msg + "; resized each on its own (--allow-resize)")
    min_px = min_photo_shape_px(params)
    if wide_full[0] < min_px[0] or wide_full[1] < min_px[1]:
        raise InputError(
            f"{name}: photo is {wide_full[1]}x{wide_full[0]} px; expected at least "
            f"{min_px[1]}x{min_px[0]} px (one pixel per cell of the coarsest level at working "
            f"size {params.working_shape_px[1]}x{params.working_shape_px[0]})"
        )
    where = f"object {src.object!r} ({name}): field crop"
    if crop is not None:
        _check_crop_inside(crop, wide_full, where=where)
    wide = zoom_crop(wide_raw, scale_crop(crop, wide_full, wide_raw.shape), where=where)
    narrow = zoom_crop(narrow_raw, scale_crop(crop, wide_full, narrow_raw.shape), where=where)
    box = aspect_crop_box(wide.shape, params.working_shape_px)
    kept = None
    pad = None
    if pair is not None and pair.choice is not None and pair.choice.content is not None:
        # a light field's crop keeps its plane's content (or region of interest), not the centre
        content = zoom_crop(pair.choice.content, scale_crop(crop, wide_full, wide_raw.shape))
        box, kept_in_zoom = content_crop_box(content, params.working_shape_px)
        if kept_in_zoom < MIN_KEPT_SHARE:  # no crop keeps the object: pad to the aspect
            box, pad, kept_in_zoom = None, aspect_pad(wide.shape, params.working_shape_px), 1.0
        total = int(pair.choice.content.sum())
        kept = kept_in_zoom * int(content.sum()) / total if total else 1.0
    out = []
    for img in (wide, narrow):
        img = _cut(img, box)
        if pad is not None:
            img = np.pad(img, pad, mode="constant", constant_values=float(img.mean()))
        if img.shape[0] < params.working_shape_px[0] or img.shape[1] < params.working_shape_px[1]:
            notes.append(
                f"{src.object}: image {img.shape[1]}x{img.shape[0]} is smaller than the working "
                f"size; upsampled"
            )
        out.append(to_working_size(img, params.working_shape_px))
    if focus is not None:  # the in-focus evidence follows the confocal image (zoom, aspect, size)
        layers = []
        for value in (1, 2):  # in focus, dropped (stimuli.declutter.in_focus_evidence)
            f = zoom_crop(
                (focus == value).astype(np.float32),
                scale_crop(crop, wide_full, narrow_raw.shape),
                where=where,
            )
            f = _cut(f, box)
            if pad is not None:
                f = np.pad(f, pad)
            layers.append(to_working_size(f, params.working_shape_px) >= 0.5)
        focus = np.where(layers[1], 2, np.where(layers[0], 1, 0)).astype(np.uint8)
        plane = f"{plane},declutter=depth"
    if not colour:
        colours = None
    elif rgb is None:  # a light field: its grey images on three channels
        colours = (np.repeat(out[0][..., None], 3, axis=2), np.repeat(out[1][..., None], 3, axis=2))
    else:
        colours = colour_photos(rgb, crop, wide_full, params.working_shape_px)
    return ObjectImages(
        info=info,
        source=src,
        wide=out[0],
        narrow=out[1],
        original_shape_px=tuple(int(v) for v in wide_full),
        crop=crop,
        aspect_crop=box,
        notes=tuple(notes),
        decoded_shape_px=tuple(int(v) for v in wide_raw.shape),
        plane=plane,
        focus=focus,
        plane_choice=None if pair is None else pair.choice,
        content_kept=kept,
        declutter="" if pair is None else pair.declutter,
        aspect_pad=None if pad is None else (pad[0][0], pad[0][1], pad[1][0], pad[1][1]),
        valid=None if pad is None else _valid_mask(wide.shape, pad, params.working_shape_px),
        colour=colours,
    )


def colour_photos(
    rgb: tuple[np.ndarray, np.ndarray],
    crop: Box | None,
    original_shape_px: tuple[int, int],
    working_shape_px: tuple[int, int],
) -> tuple[np.ndarray, np.ndarray]:
    """Return a training object's colour photos (wide, narrow) at the working size.

    The same zoom crop, aspect crop and anti-aliased resize as the grey images, per channel
    (Jung et al. 2015, Sec. 3.1: training objects were shown in colour first).

    Parameters
    ----------
    rgb : (ndarray, ndarray) of shape (rows, cols, 3), float32 in [0, 1]
        The two photos as decoded (:func:`stimuli.io.rgb_of`).
    crop : (x, y, w, h) or None
        The zoom box, on the wide photo as on file.
    original_shape_px : (rows, cols)
        The wide photo's size on file.
    working_shape_px : (rows, cols)

    Returns
    -------
    (ndarray, ndarray) of shape (rows, cols, 3), float32 in [0, 1]
    """
    out = []
    for img in rgb:
        img = _cut(img, scale_crop(crop, original_shape_px, img.shape[:2]))
        img = _cut(img, aspect_crop_box(img.shape[:2], working_shape_px))
        img = resize(img, (*working_shape_px, 3), order=1, mode="reflect", anti_aliasing=True)
        out.append(np.clip(img, 0.0, 1.0).astype(np.float32))
    return out[0], out[1]
