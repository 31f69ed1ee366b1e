"""Light-field objects of a build: the pair of images at the chosen plane, and how it was chosen.

A light-field object's centre view is the cluttered image and the confocal image (the refocus
at the object's plane) the de-cluttered one. The plane (:func:`stimuli.planechoice.choose_plane`):
``objects.csv``'s ``plane_depth_m`` or ``plane_disparity_px``, else the detected plane holding
most of its ``roi``, else the build's ``--plane`` rule (default ``auto``: the nearest detected
plane that passes the evidence cuts of :mod:`stimuli.planechoice`). The plane's in-focus
content travels with the images, so that the aspect crop keeps it.

De-cluttering that knows the geometry
-------------------------------------
Refocusing blurs what lies off the plane only along the directions in which the views are
spread. With a single row (or column) of views an edge parallel to the baseline is as sharp off
the plane as on it, and Sobel keeps such background edges at every depth. So with
``declutter='auto'`` (the default) a light field whose views lie along one axis, or mostly
along one (:func:`is_one_dimensional`), is de-cluttered by view agreement
(:func:`stimuli.declutter.in_focus_mask`, which compares the centre view with its neighbours
along the baseline only, and :func:`stimuli.declutter.declutter_depth`): an edge is kept only
where the views agree at the plane. Other light fields use the paper's Sobel mode.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stimuli.io import check_gray
from stimuli.lfviews import ANISOTROPY_RATIO, is_one_dimensional
from stimuli.manifest import ObjectInfo
from stimuli.stimset.pairs import PairSource
from stimuli.stimset.params import BuildParams

__all__ = [
    "ANISOTROPY_RATIO",
    "ConfocalPairImages",
    "field_crop_in_crop",
    "roi_in_crop",
    "is_one_dimensional",
    "load_confocal_pair",
]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ConfocalPairImages:
    """A light-field object's two images and its plane.

    Parameters
    ----------
    centre : ndarray of shape (rows, cols), float32 in [0, 1]
        The centre view (the cluttered image).
    confocal : ndarray of shape (rows, cols), float32 in [0, 1]
        The confocal image at the plane (the de-cluttered image).
    plane : str
        The plane, as :meth:`stimuli.planechoice.PlaneChoice.describe` gives it (provenance).
    focus : ndarray of shape (rows, cols), uint8, or None
        Where the views agree at the plane, in the ``depth`` de-cluttering mode
        (:func:`stimuli.declutter.in_focus_evidence`: 0 out, 1 in focus, 2 dropped); else
        ``None``.
    choice : PlaneChoice or None
        The plane with its evidence, the rule and the alternatives, and its content mask.
    declutter : {'sobel', 'depth'}
        The de-cluttering mode applied.
    """

    centre: np.ndarray
    confocal: np.ndarray
    plane: str
    focus: np.ndarray | None
    choice: object = None
    declutter: str = "sobel"


def roi_in_crop(roi, box, where: str):
    """Return a region of interest (box ``x,y,w,h`` or mask, capture pixels) in the cropped views.

    Parameters
    ----------
    roi : (x, y, w, h), ndarray of shape (rows, cols) or None
        In the capture's centre-view pixels, as ``objects.csv`` gives it.
    box : (x, y, w, h) or None
        The view crop applied (:func:`stimuli.vignette.apply_view_crop`).
    where : str
        Names the object in error messages.

    Returns
    -------
    (x, y, w, h), ndarray or None
        The part of the region inside the crop, in the cropped views' pixels.

    Raises
    ------
    InputError
        The region lies wholly in the cropped-away rim.
    """
    from stimuli.errors import InputError

    if roi is None or box is None:
        return roi
    cx, cy, cw, ch = (int(v) for v in box)
    if isinstance(roi, np.ndarray):
        return roi[cy : cy + ch, cx : cx + cw] if roi.shape[0] >= cy + ch else roi
    x, y, w, h = (int(v) for v in roi)
    x0, y0 = max(x, cx), max(y, cy)
    x1, y1 = min(x + w, cx + cw), min(y + h, cy + ch)
    if x1 <= x0 or y1 <= y0:
        raise InputError(
            f"{where}: roi box x,y,w,h = {x},{y},{w},{h} lies in the vignette rim left out by the "
            f"view crop {cx},{cy},{cw},{ch}"
        )
    return (x0 - cx, y0 - cy, x1 - x0, y1 - y0)


def field_crop_in_crop(crop, box):
    """Return a field crop ``(x, y, w, h)`` (capture pixels) in the pixels of the cropped views.

    The part inside the view crop ``box``; None stays None, and so does any crop when no view
    crop was made. A field crop wholly outside the view crop is returned unchanged (the
    build's own check then names it).
    """
    if crop is None or box is None:
        return crop
    cx, cy, cw, ch = (int(v) for v in box)
    x, y, w, h = (int(v) for v in crop)
    x0, y0 = max(x, cx), max(y, cy)
    x1, y1 = min(x + w, cx + cw), min(y + h, cy + ch)
    if x1 <= x0 or y1 <= y0:
        return crop
    return (x0 - cx, y0 - cy, x1 - x0, y1 - y0)


def load_confocal_pair(
    src: PairSource, info: ObjectInfo, params: BuildParams
) -> ConfocalPairImages:
    """Return a light-field object's centre view and confocal image at its plane.

    Parameters
    ----------
    src : PairSource
        A light-field source (``src.lightfield`` set).
    info : ObjectInfo
        Its ``objects.csv`` row (the plane or the region of interest, if given).
    params : BuildParams
        ``params.plane`` is the rule without either; ``params.declutter`` (module notes)
        decides whether the in-focus mask is computed.

    Returns
    -------
    ConfocalPairImages

    Raises
    ------
    InputError
        If the light field or the roi mask cannot be read, the roi lies outside the view, no
        plane is found, or its images are not grey images in [0, 1].
    """
    from stimuli.io import load_gray
    from stimuli.lfload import as_lightfield
    from stimuli.planechoice import choose_plane
    from stimuli.refocus import refocus
    from stimuli.vignette import apply_view_crop

    where = f"object {src.object!r} ({src.lightfield})"
    # the vignette crop every command finds (lightfield scan, refocus, the viewer, active search)
    lf = apply_view_crop(as_lightfield(src.lightfield).gray(), "auto")
    box = lf.meta.get("view_crop")
    roi = info.roi
    if src.roi_mask is not None:
        roi = load_gray(src.roi_mask) > 0
    roi = roi_in_crop(roi, box, where)
    choice = choose_plane(
        lf,
        rule=params.plane,
        disparity_px=info.plane_disparity_px,
        depth_m=info.plane_depth_m,
        roi=roi,
        where=where,
    )
    d = choice.disparity_px
    mode = params.declutter
    if mode == "auto":
        mode = "depth" if is_one_dimensional(lf.grid) else "sobel"
    confocal = np.clip(refocus(lf, d), 0.0, 1.0).astype(np.float32)
    focus = None
    if mode == "depth":
        from dataclasses import replace

        from stimuli.declutter import in_focus_evidence
        from stimuli.edgedepth import baseline_axes

        focus, stats = in_focus_evidence(lf, d, confocal=confocal)
        if len(baseline_axes(lf.grid)) == 1:
            choice = replace(choice, edge_depth=stats.to_dict())
    centre = check_gray(lf.centre_view(), f"{src.lightfield}: centre view")
    confocal = check_gray(confocal, f"{src.lightfield}: confocal image")
    logger.info("%s: confocal image at %s (%s)", src.object, choice.describe(), mode)
    return ConfocalPairImages(centre, confocal, choice.describe(), focus, choice, mode)
