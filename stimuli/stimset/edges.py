"""De-clutter step of a build: each object's threshold and edge images, and the set's edge ratio.

Module docstring of :mod:`stimuli.stimset`, steps 4 and 5 (Jung et al. 2015, Sec. 2.2 and 3.1).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from stimuli.declutter import auto_threshold, bokeh_guard, declutter, declutter_depth
from stimuli.errors import InputError
from stimuli.retention import retention_threshold
from stimuli.stimset.params import BuildParams
from stimuli.stimset.prepare import ObjectImages

__all__ = [
    "SetEdgeRatio",
    "choose_threshold",
    "declutter_object",
    "edge_fraction",
    "set_edge_ratio",
]


def choose_threshold(work: ObjectImages, params: BuildParams) -> tuple[float, str]:
    """Return an object's Sobel threshold and where it came from.

    The object's ``objects.csv`` value, else the global ``params.threshold``, else the automatic
    one at the working size by ``params.threshold_method``: the pair's minimum edge retention
    (:func:`stimuli.retention.retention_threshold`) or Otsu / triangle on the narrow image
    (:func:`stimuli.declutter.auto_threshold`).

    Returns
    -------
    (float >= 0, str)
        The threshold and its source: ``'objects.csv'``, ``'global'`` or ``'auto:<method>'``.
    """
    if work.info.sobel_threshold is not None:
        return float(work.info.sobel_threshold), "objects.csv"
    if params.threshold is not None:
        return float(params.threshold), "global"
    if params.threshold_method == "retention":
        return float(retention_threshold(work.wide, work.narrow)), "auto:retention"
    t = auto_threshold(work.narrow, method=params.threshold_method)
    return float(t), f"auto:{params.threshold_method}"


def declutter_object(work: ObjectImages, params: BuildParams) -> ObjectImages:
    """Return the object with its threshold and edge images (a new result; ``work`` is unchanged).

    The same threshold de-clutters both images, as in the paper. A light field's confocal image
    is de-cluttered by depth when it carries an in-focus mask
    (:func:`stimuli.declutter.declutter_depth`); a photo pair's narrow edges pass the bokeh
    guard when ``params.bokeh_guard`` is set.
    """
    t, source = choose_threshold(work, params)
    wide_edges = declutter(work.wide, threshold=t)
    if work.focus is not None:
        narrow_edges = declutter_depth(work.narrow, work.focus, threshold=t)
    else:
        narrow_edges = declutter(work.narrow, threshold=t)
        if params.bokeh_guard and work.source.lightfield is None:
            narrow_edges = bokeh_guard(narrow_edges, wide_edges)
    if work.valid is not None:  # a padded light field: no edges in the padding
        wide_edges = wide_edges & work.valid
        narrow_edges = narrow_edges & work.valid
    return replace(
        work,
        threshold=t,
        threshold_source=source,
        wide_edges=wide_edges,
        narrow_edges=narrow_edges,
    )


def edge_fraction(edges: np.ndarray) -> float:
    """Return the fraction of edge pixels (True) in a bool edge image, in [0, 1]."""
    e = np.asarray(edges)
    if e.dtype != bool:
        raise InputError(f"edges must be a bool image, got dtype {e.dtype}")
    return float(e.mean()) if e.size else 0.0


@dataclass(frozen=True)
class SetEdgeRatio:
    """The compression edge ratio of a set (both ``None`` in grey mode).

    Parameters
    ----------
    edge_ratio : float in [0, 1) or None
        The given ratio, else the mean wide-DOF edge fraction.
    mean_wide_edge_fraction : float in [0, 1] or None
        Mean edge fraction of the main objects' wide-DOF edge images (all objects' if the set
        has no main object).
    """

    edge_ratio: float | None
    mean_wide_edge_fraction: float | None


def set_edge_ratio(works: Sequence[ObjectImages], params: BuildParams) -> SetEdgeRatio:
    """Return the set's edge ratio: given, or the mean wide-DOF edge fraction (paper: 1/13).

    Raises
    ------
    InputError
        If the mean is 1.0 (every pixel an edge) and no ratio is given.
    """
    if params.mode != "edges":
        return SetEdgeRatio(None, None)
    main = [w for w in works if w.info.role == "main"] or works
    mean_wide = float(np.mean([edge_fraction(w.wide_edges) for w in main]))
    edge_ratio = params.edge_ratio if params.edge_ratio is not None else mean_wide
    if edge_ratio >= 1.0:
        raise InputError("edge ratio from the set is 1.0 (every pixel an edge); give one")
    return SetEdgeRatio(edge_ratio, mean_wide)
