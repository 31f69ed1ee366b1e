"""The checks of the viewer's start options, for Python callers and ``confocal view`` alike.

:meth:`experiment.viewer.app.Viewer.from_options` runs them: :func:`check_options` before the
light field is scanned (what needs no data), :func:`start_state` after (the depth range, the
planes and the view size are known then). A refusal is a :class:`ViewerOptionError` naming the
parameter as Python spells it (``grey_levels must be one of (2, 4, 8), got 3``); the command line
maps the parameter to its flag (:func:`experiment.commands.view.view_command`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from experiment.errors import ConfocalError
from experiment.viewer.state import GREY_LEVELS, ViewerState, check_zoom_box

__all__ = ["COMPUTE_CHOICES", "ViewerOptionError", "check_options", "start_state"]

#: Where the viewer's image pipeline runs (see :class:`experiment.viewer.app.Viewer`).
COMPUTE_CHOICES: tuple[str, ...] = ("auto", "gpu", "cpu")


class ViewerOptionError(ConfocalError):
    """A viewer option that cannot be used.

    Parameters
    ----------
    parameter : str
        The parameter of :meth:`~experiment.viewer.app.Viewer.from_options` at fault.
    message : str
        One line that starts with the parameter's name.
    """

    def __init__(self, parameter: str, message: str) -> None:
        super().__init__(message)
        self.parameter = parameter


def check_options(
    implants: Sequence[str] | None,
    *,
    grey_levels: int,
    threshold: float | None,
    compute: str,
    extension_px: float,
) -> list[str]:
    """Check the options that need no data; return the implant names (default: all, argus2 first).

    Raises
    ------
    ViewerOptionError
        An unknown implant (``implants``), a grey-level count not in :data:`GREY_LEVELS`, a
        negative or non-finite threshold or extension, an unknown ``compute``.
    """
    from stimuli.implants import ImplantError, implant_names, load_implant

    names = list(implants) if implants else sorted(implant_names(), key=lambda n: n != "argus2")
    for n in names:
        try:
            load_implant(n)
        except ImplantError as exc:
            raise ViewerOptionError("implants", str(exc)) from None
    if isinstance(grey_levels, bool) or grey_levels not in GREY_LEVELS:
        raise ViewerOptionError(
            "grey_levels", f"grey_levels must be one of {GREY_LEVELS}, got {grey_levels!r}"
        )
    if threshold is not None and not (math.isfinite(threshold) and threshold >= 0):
        raise ViewerOptionError(
            "threshold", f"threshold must be None (automatic) or >= 0, got {threshold!r}"
        )
    if not math.isfinite(extension_px):
        raise ViewerOptionError("extension_px", f"extension_px must be finite, got {extension_px}")
    if compute not in COMPUTE_CHOICES:
        raise ViewerOptionError(
            "compute", f"compute must be one of {', '.join(COMPUTE_CHOICES)}, got {compute!r}"
        )
    return names


def start_state(
    viewer: Any,
    *,
    disparity_px: float | None = None,
    plane: int | None = None,
    zoom: Sequence[int] | None = None,
    grey_levels: int = 2,
    threshold: float | None = None,
    obstacle_px: tuple[float, float] | None = None,
    marker: Sequence[int] | None = None,
    extension_px: float = 0.0,
    averaging: bool = False,
) -> ViewerState:
    """Return the viewer's first state with the options applied, checked against its data.

    Parameters
    ----------
    viewer : experiment.viewer.app.Viewer
        Its model (depth range, planes, view size) and per-pixel depth (``marker``).
    disparity_px : float, optional
        Start depth, px per view step, inside the scanned range.
    plane : int, optional
        Start at detected plane ``plane`` (1 = nearest).
    zoom : (x, y, w, h), optional
        Zoom box, at least 8x8 view pixels inside the view.
    grey_levels, threshold, extension_px, averaging
        As :class:`~experiment.viewer.state.ViewerState`.
    obstacle_px : (a, b), optional
        Obstacle mode over this disparity range (either order).
    marker : (x, y), optional
        Confocal-extension mode with the marker here (view pixels); the depth follows it.

    Raises
    ------
    ViewerOptionError
        A plane, disparity, zoom box or marker outside what the data offer.
    """
    m, s = viewer.model, viewer.state
    if plane is not None:
        if not 1 <= plane <= len(m.planes_px):
            raise ViewerOptionError(
                "plane", f"plane must be in 1..{len(m.planes_px)} (planes found), got {plane}"
            )
        s = replace(s, disparity_px=m.planes_px[plane - 1], plane=plane - 1)
    if disparity_px is not None:
        lo, hi = m.disparity_range_px
        if not lo <= disparity_px <= hi:
            raise ViewerOptionError(
                "disparity_px", f"disparity_px must be in [{lo:.4g}, {hi:.4g}], got {disparity_px}"
            )
        s = replace(s, disparity_px=float(disparity_px), plane=m.plane_of(disparity_px))
    if zoom is not None:
        try:
            s = replace(s, zoom=check_zoom_box(m, zoom))
        except ValueError:
            rows, cols = m.shape_px
            n = m.min_zoom_px
            raise ViewerOptionError(
                "zoom", f"zoom {tuple(zoom)} must be at least {n}x{n} inside {cols}x{rows}"
            ) from None
    s = replace(
        s,
        grey_levels=int(grey_levels),
        threshold=threshold,
        averaging=bool(averaging),
        extension_px=float(extension_px),
    )
    if obstacle_px is not None:
        a, b = (float(v) for v in obstacle_px)
        s = replace(s, mode="obstacle", obstacle_px=(max(a, b), min(a, b)))
    if marker is not None:
        mx, my = (int(v) for v in marker)
        rows, cols = m.shape_px
        if not (0 <= mx < cols and 0 <= my < rows):
            raise ViewerOptionError(
                "marker", f"marker ({mx}, {my}) must lie inside the {cols}x{rows} view"
            )
        d = m.clamp(viewer.depth().at(mx, my) + s.extension_px)
        s = replace(s, mode="extension", marker=(mx, my), disparity_px=d, plane=m.plane_of(d))
    return s
