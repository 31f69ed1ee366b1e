"""The confocal image of a light field at one plane: the depth given, or the one the builder picks.

:func:`confocal_plane` returns the centre view (the cluttered image) and the shift-and-add refocus
at a plane given by depth or disparity, or, with neither, at the plane
:func:`stimuli.planechoice.choose_plane` picks by default (Jung et al. 2015, Sec. 4).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from stimuli.errors import InputError
from stimuli.lfload import as_lightfield
from stimuli.lfviews import LightField
from stimuli.refocus import refocus

__all__ = ["ConfocalPlane", "confocal_plane", "confocal_pair"]


@dataclass(frozen=True)
class ConfocalPlane:
    """A light field's centre view and its confocal image at one plane, with that plane.

    Parameters
    ----------
    centre_view, confocal_image : ndarray of shape (rows, cols), float32 in [0, 1]
    disparity_px : float
        The plane, pixels per view step.
    depth_m : float or None
        The plane's depth, metres (None without geometry).
    chosen_by : {"depth_m", "disparity_px", "auto"}
        How the plane was chosen (provenance).
    focus_mask : ndarray of shape (rows, cols), bool, or None
        Where the light field is in focus at the plane (:func:`stimuli.declutter.in_focus_mask`),
        when asked for.
    """

    centre_view: np.ndarray
    confocal_image: np.ndarray
    disparity_px: float
    depth_m: float | None
    chosen_by: str
    focus_mask: np.ndarray | None = None

    def describe(self) -> str:
        """One-line provenance: ``disparity=...px,depth=...m,<chosen_by>``."""
        depth = "" if self.depth_m is None else f",depth={self.depth_m:.4g}m"
        return f"disparity={self.disparity_px:.4g}px{depth},{self.chosen_by}"


def confocal_plane(
    path: str | os.PathLike | LightField,
    *,
    depth_m: float | None = None,
    disparity_px: float | None = None,
    focus_mask: bool = False,
) -> ConfocalPlane:
    """Return a light field's centre view and its confocal image at one plane, with the plane.

    The confocal image is the shift-and-add refocus at ``depth_m`` (needs a geometry) or at
    ``disparity_px``; with neither, at the plane the stimulus builder picks by default
    (:func:`stimuli.planechoice.choose_plane`, rule ``'auto'``: the nearest detected plane whose
    support passes a cut relative to the strongest plane's and that is not a border band): the
    object of interest stands in front of the clutter (Jung et al. 2015, Sec. 4), so the nearest
    real plane is the object's, even when a large background wall scores higher.

    Parameters
    ----------
    path : str, path-like or LightField
        Any input :func:`load_lightfield` reads.
    depth_m : float, optional
        Depth of the plane, metres.
    disparity_px : float, optional
        Disparity of the plane, pixels per view step.
    focus_mask : bool
        Also return where the light field is in focus at the plane (depth de-cluttering).

    Returns
    -------
    ConfocalPlane

    Raises
    ------
    InputError
        Both ``depth_m`` and ``disparity_px`` given, a depth without geometry or out of range,
        no object plane found, or any loading error.

    References
    ----------
    Jung et al. (2015), Sec. 4.1-4.2; Ng et al. (2005) for shift-and-add refocusing.
    """
    if depth_m is not None and disparity_px is not None:
        raise InputError("give depth_m or disparity_px, not both")
    lf = as_lightfield(path).gray()
    if depth_m is not None:
        d, how = lf.disparity_px(depth_m), "depth_m"
    elif disparity_px is not None:
        d, how = float(disparity_px), "disparity_px"
        if not math.isfinite(d):
            raise InputError(f"disparity_px must be finite, got {disparity_px!r}")
    else:
        from stimuli.planechoice import choose_plane

        d, how = choose_plane(lf, where=str(lf.source)).disparity_px, "auto"
    confocal = np.clip(refocus(lf, d), 0.0, 1.0).astype(np.float32)
    mask = None
    if focus_mask:
        from stimuli.declutter import in_focus_mask

        mask = in_focus_mask(lf, d)
    return ConfocalPlane(lf.centre_view(), confocal, float(d), lf.depth_m(d), how, mask)


def confocal_pair(
    path: str | os.PathLike | LightField,
    *,
    depth_m: float | None = None,
    disparity_px: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(centre_view, confocal_image)`` of a light field, grey float32 in [0, 1].

    The same as :func:`confocal_plane` without the plane: at ``depth_m``, at ``disparity_px``,
    or at the plane the stimulus builder picks by default.

    Returns
    -------
    centre_view, confocal_image : ndarray of shape (rows, cols), float32 in [0, 1]

    Raises
    ------
    InputError
        As :func:`confocal_plane`.
    """
    c = confocal_plane(path, depth_m=depth_m, disparity_px=disparity_px)
    return c.centre_view, c.confocal_image
