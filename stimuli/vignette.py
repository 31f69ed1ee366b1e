"""Find the part of a capture that shows the scene: a crop without the vignette rim.

Plenoptic captures (the Lytro Illum's decoded sub-aperture views) have black corners where the
main lens's aperture cuts the micro-images, and often a clipped-white strip (sky). Both
dominate the edges of a confocal image: the rim is the strongest edge in the picture, so the
implant's few electrodes show it instead of the scene. :func:`vignette_crop` finds the largest
box whose border lines are almost free of such pixels, with thresholds taken from the data:

* *dark*: at most :data:`DARK_FRACTION` of the image's median, in any view (the rim moves
  from view to view, and a refocused image averages all of them);
* *clipped*: at least :data:`CLIP_FRACTION` of the image's own maximum in the centre view,
  when that maximum reaches full scale (a dim image that never reaches it has no clipping).

Border lines (top or bottom row, left or right column) are peeled one at a time, always the one
with the largest share of such pixels, until no border line has more than
:data:`BORDER_TOLERANCE` of them.
"""

from __future__ import annotations

import copy

import numpy as np

__all__ = [
    "DARK_FRACTION",
    "CLIP_FRACTION",
    "BORDER_TOLERANCE",
    "MIN_KEEP",
    "apply_view_crop",
    "capture_crop",
    "parse_view_crop",
    "vignette_crop",
]

#: A pixel is vignetted when it is at most this fraction of the image's median (ours: the
#: Lytro rim is exactly 0 and the darkest scene pixels about a third of the median).
DARK_FRACTION: float = 0.1

#: A pixel is clipped when it is at least this fraction of the image's maximum (ours).
CLIP_FRACTION: float = 0.98

#: A border line may keep this fraction of dark or clipped pixels (ours: a few pixels of a
#: shadow or a highlight do not cost a row of scene).
BORDER_TOLERANCE: float = 0.02

#: The crop keeps at least this fraction of each side, or none is made (ours: an image that is
#: mostly dark or clipped is not a vignetted capture).
MIN_KEEP: float = 0.5


def vignette_crop(views: np.ndarray) -> tuple[int, int, int, int] | None:
    """Return the crop ``(x, y, w, h)`` that leaves out a capture's dark rim and clipped strip.

    Parameters
    ----------
    views : ndarray of shape (n_u, n_v, rows, cols) or (rows, cols), float in [0, 1]
        Grey views of a light field (or one image).

    Returns
    -------
    (x, y, w, h) or None
        The box in view pixels (x = column); None when there is nothing to leave out, or when
        the box would keep less than :data:`MIN_KEEP` of a side.

    Raises
    ------
    ValueError
        ``views`` is neither 2-D nor 4-D, or is empty.

    Examples
    --------
    >>> img = np.full((40, 60), 0.5, np.float32)
    >>> img[:5] = 0.0  # a dark strip on top
    >>> vignette_crop(img)
    (0, 5, 60, 35)
    """
    a = np.asarray(views, dtype=np.float32)
    if a.ndim not in (2, 4) or a.size == 0:
        raise ValueError(f"views must be (rows, cols) or (n_u, n_v, rows, cols), got {a.shape}")
    if a.ndim == 4:
        n_u, n_v = a.shape[:2]
        centre = a[n_u // 2, n_v // 2]
        darkest = a.min(axis=(0, 1))
    else:
        centre = darkest = a
    return _crop_from(centre, darkest)


def _median(a: np.ndarray) -> float:
    """``float(np.median(a))`` to the bit for finite values, without importing ``numpy.ma``.

    (``np.median`` imports it for its NaN check: 0.025 s of a scan's start-up.) The middle
    value, or the mean of the two middle values, of a partition, as ``np.median`` takes them.
    """
    flat = np.ravel(a)
    k = flat.size // 2
    if flat.size % 2:
        return float(np.partition(flat, k)[k])
    part = np.partition(flat, [k - 1, k])
    return float(np.mean(part[k - 1 : k + 1]))


def _crop_from(centre: np.ndarray, darkest: np.ndarray) -> tuple[int, int, int, int] | None:
    median = _median(centre)
    top = float(centre.max())
    bad = darkest <= DARK_FRACTION * median
    if top >= CLIP_FRACTION:  # the sensor's white was reached: its pixels carry no scene
        bad |= centre >= CLIP_FRACTION * top
    rows, cols = bad.shape
    r0, r1, c0, c1 = 0, rows, 0, cols
    while r1 - r0 > 0 and c1 - c0 > 0:
        box = bad[r0:r1, c0:c1]
        share = (
            box[0].mean(),
            box[-1].mean(),
            box[:, 0].mean(),
            box[:, -1].mean(),
        )
        k = int(np.argmax(share))
        if share[k] <= BORDER_TOLERANCE:
            break
        if k == 0:
            r0 += 1
        elif k == 1:
            r1 -= 1
        elif k == 2:
            c0 += 1
        else:
            c1 -= 1
    if (r0, r1, c0, c1) == (0, rows, 0, cols):
        return None
    if r1 - r0 < MIN_KEEP * rows or c1 - c0 < MIN_KEEP * cols:
        return None
    return (c0, r0, c1 - c0, r1 - r0)


def capture_crop(lightfield) -> tuple[int, int, int, int] | None:
    """Return a capture's vignette crop, found in the views the plane scan reads.

    The one rule every command uses (``lightfield scan``, ``refocus``, ``stimuli build``, the
    viewer, active search): :func:`vignette_crop` of the centre view and the views on its row
    and column that :func:`stimuli.agreementscan.scan_views` lists, so a command that reads
    only those views finds the same box as one that reads them all.

    Parameters
    ----------
    lightfield : LightField
        A grey light field (only the views of ``scan_views`` are looked at).

    Returns
    -------
    (x, y, w, h) or None
    """
    from stimuli.agreementscan import scan_views

    views = np.asarray(lightfield.views)
    if views.ndim == 5:
        views = views.mean(axis=-1)
    idx = scan_views(views.shape[:2])
    cu, cv = idx[0]
    darkest = np.min(np.stack([views[u, v] for u, v in idx]), axis=0).astype(np.float32)
    return _crop_from(np.asarray(views[cu, cv], np.float32), darkest)


def parse_view_crop(
    text: str | tuple | list | None, option: str = "--view-crop"
) -> str | tuple[int, int, int, int] | None:
    """Check a view-crop setting: ``"auto"``, ``"none"`` / None, or a box ``x,y,w,h``.

    Returns ``"auto"``, ``None`` or the box as a tuple of four ints.

    Raises
    ------
    stimuli.errors.InputError
        Anything else, naming ``option``.
    """
    from stimuli.errors import InputError

    if text is None or (isinstance(text, str) and text.strip().lower() == "none"):
        return None
    if isinstance(text, str) and text.strip().lower() == "auto":
        return "auto"
    try:
        parts = text.split(",") if isinstance(text, str) else list(text)
        x, y, w, h = (int(v) for v in parts)
    except (TypeError, ValueError):
        raise InputError(
            f"{option} must be auto, none or x,y,w,h in pixels, got {text!r}"
        ) from None
    return (x, y, w, h)


def apply_view_crop(lightfield, view_crop="auto", option: str = "--view-crop"):
    """Return the light field cropped as ``view_crop`` says, the box recorded in its meta.

    Parameters
    ----------
    lightfield : LightField
    view_crop : 'auto', 'none', None, (x, y, w, h) or str 'x,y,w,h'
        ``auto``: :func:`capture_crop` (nothing is cut when it finds no rim).
    option : str
        Names the setting in error messages.

    Returns
    -------
    LightField
        ``meta["view_crop"]`` is the box applied (a list) or None, ``meta["view_crop_rule"]``
        is ``'auto'``, ``'given'`` or ``'none'``.

    Raises
    ------
    stimuli.errors.InputError
        A malformed box, or one that does not lie inside the views.
    """
    from stimuli.errors import InputError

    spec = parse_view_crop(view_crop, option)
    if spec is None:
        box, rule = None, "none"
    elif spec == "auto":
        box, rule = capture_crop(lightfield), "auto"
    else:
        box, rule = spec, "given"
    if box is not None:
        x, y, w, h = box
        rows, cols = lightfield.shape_px
        if w < 2 or h < 2 or x < 0 or y < 0 or x + w > cols or y + h > rows:
            raise InputError(
                f"{option} {x},{y},{w},{h} must be a box of at least 2x2 px inside the "
                f"{cols}x{rows} views"
            )
        lightfield = lightfield.cropped(box)
    out = copy.copy(lightfield)  # the caller's light field keeps its meta
    meta = dict(lightfield.meta)
    meta["view_crop"] = None if box is None else [int(v) for v in box]
    meta["view_crop_rule"] = rule
    object.__setattr__(out, "meta", meta)
    return out
