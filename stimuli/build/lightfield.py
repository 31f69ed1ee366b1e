"""Light-field objects of a build: the pair of images at the confocal plane.

A light-field object gives its pair through :func:`stimuli.planes.confocal_plane`: the centre
view is the cluttered image and the confocal image (the refocus at the object's plane) the
de-cluttered one. The plane comes from ``objects.csv`` (``plane_depth_m`` or
``plane_disparity_px``); without one, the light-field module picks the nearest object plane.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from stimuli.build.pairs import PairSource
from stimuli.build.params import BuildParams
from stimuli.io import check_gray
from stimuli.manifest import ObjectInfo

__all__ = ["ConfocalPairImages", "load_confocal_pair"]

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
        The plane, as :meth:`stimuli.planes.ConfocalPlane.describe` gives it (provenance).
    focus : ndarray of shape (rows, cols), bool, or None
        Where the views agree at the plane, in the ``depth`` de-cluttering mode; else ``None``.
    """

    centre: np.ndarray
    confocal: np.ndarray
    plane: str
    focus: np.ndarray | None


def load_confocal_pair(
    src: PairSource, info: ObjectInfo, params: BuildParams
) -> ConfocalPairImages:
    """Return a light-field object's centre view and confocal image at its plane.

    Parameters
    ----------
    src : PairSource
        A light-field source (``src.lightfield`` set).
    info : ObjectInfo
        Its ``objects.csv`` row (the plane, if given).
    params : BuildParams
        ``params.declutter == 'depth'`` also asks for the in-focus mask.

    Returns
    -------
    ConfocalPairImages

    Raises
    ------
    InputError
        If the light field cannot be read or its images are not grey images in [0, 1].
    """
    from stimuli.planes import confocal_plane

    if info.plane_depth_m is None and info.plane_disparity_px is None:
        logger.info("%s: no plane in objects.csv; light-field module picks it", src.object)
    extra = {"focus_mask": True} if params.declutter == "depth" else {}
    plane = confocal_plane(
        src.lightfield,
        depth_m=info.plane_depth_m,
        disparity_px=info.plane_disparity_px,
        **extra,
    )
    where = f"{src.lightfield}: confocal_plane"
    centre = check_gray(plane.centre_view, f"{where} centre view")
    confocal = check_gray(plane.confocal_image, f"{where} image")
    logger.info("%s: confocal image at %s", src.object, plane.describe())
    focus = getattr(plane, "focus_mask", None)
    return ConfocalPairImages(centre, confocal, plane.describe(), focus)
