"""Does a light-field stimulus show its object? Measured per object and level.

The measure is taken from the depth evidence.

The plane a light-field object is built at comes with its *support*: the pixels whose views
agree best on that plane or within the band of disparities its object spans
(:attr:`stimuli.planechoice.PlaneChoice.on_plane`, :func:`stimuli.planechoice.plane_extent`:
from the depth scan, never from the edges judged). The support follows the stimulus through
the build's crops and resize; then, at every level of the de-cluttered condition:

* ``on_plane``: the share of the white pixels (cells) that lie on the plane. A white pixel is
  on the plane when it lies on the plane's region (the support with its gaps closed and its
  holes filled: a 1-D light field's views cannot place an edge parallel to their baseline, so
  the support has gaps along such edges), widened by :data:`ON_PLANE_MARGIN_PX` (an outline
  lies where the views stop agreeing, at the object's rim), or within the scan's own reach of
  the support (:attr:`~stimuli.planechoice.PlaneChoice.reach_px`: the scan gives a pixel the
  best plane of a box around it, so near an occluding outline, where the box straddles object
  and background, the support stops short of the outline). And a white stroke (8-connected)
  that lies mostly on the plane is the plane's whole: its other pixels are edges whose depth
  the views could not measure (an outline along the baseline, an untextured face with no
  support) that connect to the plane's structure. On a 1-D light field, so are the white
  pixels lying between two on-plane white pixels of their row along the baseline (give or
  take a pixel across): the pieces of an edge along the baseline that the views cannot place.
  A stimulus whose white lies mostly off the plane shows clutter, not the object.
* ``object_coverage``: the share of the object's cells that are white, the object's cells being
  those at least half covered by its region. At the low levels (few cells) an object of
  which few cells light up is not seen.

Both are written to ``stimulus_set.json`` (``visibility``), shown on the contact sheet, and a
warning is given when the full-resolution ``on_plane`` share is below :data:`MIN_ON_PLANE` or
the coverage at any of the :data:`LOW_LEVELS` lowest levels is below :data:`MIN_COVERAGE`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy import ndimage

from stimuli.stimset.params import BuildParams
from stimuli.stimset.prepare import ObjectImages, to_aspect, to_working_size, zoom_crop

__all__ = [
    "LOW_LEVELS",
    "MIN_COVERAGE",
    "MIN_ON_PLANE",
    "ON_PLANE_MARGIN_PX",
    "measure_visibility",
    "object_visibility",
    "plane_support",
    "visibility_line",
    "visibility_warnings",
]

#: Margin around the plane's support within which a white pixel counts as on the plane,
#: working-size pixels (ours: the outline lies at the rim of the support, where the scan's 5 px
#: agreement window straddles object and background; 3 px is under 1 % of the working width).
ON_PLANE_MARGIN_PX: int = 3

#: A stimulus is flagged when fewer than this share of its full-resolution white pixels lie on
#: the plane (ours: then most of what the subject sees is clutter).
MIN_ON_PLANE: float = 0.5

#: A stimulus is flagged when, at a low level, fewer than this share of the object's cells are
#: white (ours: at L1-L3 an object has 20-100 cells; under a tenth of them lit it has no shape).
MIN_COVERAGE: float = 0.1

#: The low levels checked for coverage: the coarsest this many (ours: L1-L3, the paper's
#: 12x8, 27x18 and 38x25 grids, where recognition is decided).
LOW_LEVELS: int = 3

#: Closing radius that joins the support's pieces into the object's region, working-size px.
_REGION_CLOSE_PX = 6


def plane_support(
    work: ObjectImages, params: BuildParams, *, reach: bool = False
) -> np.ndarray | None:
    """Return a light-field object's plane support at the working size (bool), else None.

    The plane choice's support (full resolution of the cropped views) taken through the
    object's field crop, aspect crop or padding and resize, as its images were. With
    ``reach``, the support widened by the scan's reach
    (:attr:`~stimuli.planechoice.PlaneChoice.reach_px`) at full resolution first.
    """
    choice = work.plane_choice
    if choice is None or getattr(choice, "on_plane", None) is None:
        return None
    m = np.asarray(choice.on_plane, dtype=bool)
    r = int(getattr(choice, "reach_px", 0) or 0) if reach else 0
    if r > 0 and m.any():
        m = ndimage.distance_transform_edt(~m) <= r
    m = m.astype(np.float32)
    m = zoom_crop(m, work.crop) if work.crop is not None else m
    m = to_aspect(m, work)
    if m.size == 0:
        return np.zeros(params.working_shape_px, bool)
    return to_working_size(m, params.working_shape_px) > 0.25


def _cell_bounds(n: int, k: int) -> np.ndarray:
    return np.linspace(0, n, k + 1).round().astype(int)


def _cell_mean(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Mean of ``mask`` over each cell of a ``shape`` grid laid over it."""
    rows, cols = mask.shape
    rb, cb = _cell_bounds(rows, shape[0]), _cell_bounds(cols, shape[1])
    s = np.add.reduceat(np.add.reduceat(mask.astype(np.float64), rb[:-1], 0), cb[:-1], 1)
    area = np.outer(np.diff(rb), np.diff(cb))
    return s / np.maximum(area, 1)


def _disk(r: int) -> np.ndarray:
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    return yy * yy + xx * xx <= r * r


def _strokes_on(white: np.ndarray, near: np.ndarray, along: tuple[int, ...] = ()) -> np.ndarray:
    """White pixels on the plane: those ``near`` it, and every pixel of a stroke mostly near.

    A stroke is an 8-connected set of white pixels; "mostly" is more than half of its pixels.
    With ``along`` (the baseline's axis of a 1-D light field), also the white pixels that lie
    between two on-plane white pixels of their row (or column) along it, give or take a
    pixel across: pieces of one edge along the baseline, whose depth the views cannot measure.
    """
    on = white & near
    lab, n = ndimage.label(white, np.ones((3, 3), bool))
    if n == 0:
        return on
    share = np.bincount(lab.ravel(), weights=on.ravel(), minlength=n + 1) / np.maximum(
        np.bincount(lab.ravel(), minlength=n + 1), 1
    )
    mostly = share > 0.5
    mostly[0] = False
    on = on | mostly[lab]
    if len(along) == 1:
        a = along[0]
        band = ndimage.maximum_filter1d(on.view(np.uint8), 3, axis=1 - a) > 0
        b = np.moveaxis(band, a, 1)
        k = b.shape[1]
        idx = np.arange(k)
        left = np.maximum.accumulate(np.where(b, idx, -1), axis=1) >= 0
        right = np.minimum.accumulate(np.where(b, idx, k)[:, ::-1], axis=1)[:, ::-1] < k
        on = on | (white & np.moveaxis(left & right, 1, a))
    return on


def object_visibility(
    work: ObjectImages, params: BuildParams, ladder: list[tuple[int, int, np.ndarray]]
) -> dict | None:
    """Measure how well a light-field object's de-cluttered stimuli show it (module notes).

    Parameters
    ----------
    work : ObjectImages
        A de-cluttered light-field object.
    params : BuildParams
    ladder : list of (level, window_px, ndarray of bool)
        Its de-cluttered stimuli (:func:`stimuli.stimset.levels.edge_ladder`).

    Returns
    -------
    dict or None
        ``{"levels": [{"level", "on_plane", "object_coverage"}, ...], "support_share",
        "other_planes_px"}`` (shares in [0, 1], ``None`` where undefined: no white pixel, no
        object cell; the other detected planes, px per view step, which the warning names);
        None for photo pairs and grey mode.
    """
    support = plane_support(work, params)
    if support is None or params.mode != "edges":
        return None
    region = ndimage.binary_fill_holes(
        ndimage.binary_closing(support, _disk(_REGION_CLOSE_PX), border_value=0)
    )
    near = ndimage.binary_dilation(region | support, _disk(ON_PLANE_MARGIN_PX))
    near |= plane_support(work, params, reach=True)
    if work.valid is not None:
        region &= work.valid
    along = tuple(getattr(work.plane_choice, "baseline_axes", ()) or ())
    levels = []
    for level, _, stim in ladder:
        s = np.asarray(stim, dtype=bool)
        on = _strokes_on(s, _cell_mean(near, s.shape) > 0, along)
        obj = _cell_mean(region, s.shape) >= 0.5
        lit = int(s.sum())
        levels.append(
            {
                "level": int(level),
                "on_plane": None if lit == 0 else float(on.sum() / lit),
                "object_coverage": None if not obj.any() else float(s[obj].mean()),
            }
        )
    choice = work.plane_choice
    others = [
        float(c.disparity_px)
        for c in getattr(choice, "candidates", ())
        if abs(float(c.disparity_px) - float(choice.disparity_px)) > 1e-9
    ]
    return {"levels": levels, "support_share": float(support.mean()), "other_planes_px": others}


def visibility_warnings(name: str, vis: dict | None) -> list[str]:
    """Return the warnings a visibility record raises (module notes), ``name: ...`` each."""
    if not vis:
        return []
    out = []
    levels = sorted(vis["levels"], key=lambda r: r["level"])
    top = levels[-1]
    share = top["on_plane"]
    if share is None or share < MIN_ON_PLANE:
        said = "no white pixel" if share is None else f"{100 * share:.0f} % of its white pixels"
        others = vis.get("other_planes_px") or []
        hint = (
            "; other detected planes: "
            + ", ".join(f"{d:.4g}" for d in others)
            + " px per view step: choose one with --plane or objects.csv plane_disparity_px"
            if others
            else "; choose another plane with --plane or objects.csv plane_disparity_px"
        )
        out.append(
            f"{name}: the de-cluttered stimulus may not show its object: {said} at "
            f"L{top['level']} on the plane's support (visibility on_plane, from the depth scan; "
            f"under {100 * MIN_ON_PLANE:.0f} %){hint}"
        )
    low = [
        r
        for r in levels[:LOW_LEVELS]
        if r["object_coverage"] is not None and r["object_coverage"] < MIN_COVERAGE
    ]
    if low:
        cov = ", ".join(f"L{r['level']} {100 * r['object_coverage']:.0f} %" for r in low)
        out.append(
            f"{name}: the object covers few of its cells at the low levels (visibility "
            f"object_coverage {cov}; under "
            f"{100 * MIN_COVERAGE:.0f} %)"
        )
    if vis.get("support_share", 1.0) == 0.0:
        out.append(f"{name}: the plane has no support in the stimulus (no pixel agrees on it)")
    return out


def visibility_line(vis: dict | None) -> str:
    """One line for the contact sheet: the L8 on-plane share and the low levels' coverage."""
    if not vis:
        return ""
    levels = sorted(vis["levels"], key=lambda r: r["level"])

    def pct(v):
        return "-" if v is None else f"{100 * v:.0f}%"

    top = levels[-1]
    cov = " ".join(f"L{r['level']} {pct(r['object_coverage'])}" for r in levels[:LOW_LEVELS])
    return f"on plane L{top['level']} {pct(top['on_plane'])}; object coverage {cov}"


def measure_visibility(
    work: ObjectImages,
    params: BuildParams,
    edge_ratio: float | None,
    ladder: Sequence[tuple[int, int, tuple[int, int]]],
) -> ObjectImages:
    """Return the object with its :func:`object_visibility` at ``edge_ratio`` (a new result).

    Its de-cluttered stimuli are compressed at every level of ``ladder`` (``plan.ladder``).
    The visibility is None for photo pairs, grey mode and objects without edges (then ``work``
    itself is returned).
    """
    from stimuli.stimset.levels import edges_on_ladder

    if work.plane_choice is None or work.narrow_edges is None or edge_ratio is None:
        return work
    stims = edges_on_ladder(work.narrow_edges, ladder, edge_ratio=edge_ratio)
    return replace(work, visibility=object_visibility(work, params, stims))
