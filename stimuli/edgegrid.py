"""One confocal image to the prosthesis grid: de-clutter its edges, then compress them.

The step ``lightfield scan``, ``lightfield refocus`` and ``demo --lightfield`` share for each
plane (Jung et al. 2015, Figs. 12-13); the stimulus builder runs the same two steps per level.
"""

from __future__ import annotations

import numpy as np

__all__ = ["declutter_and_compress", "edge_threshold", "depth_evidence"]


def edge_threshold(
    image: np.ndarray, threshold: str | float = "auto", centre_view: np.ndarray | None = None
) -> float:
    """Get the Sobel threshold :func:`declutter_and_compress` uses (its parameters, same names)."""
    from stimuli.declutter import auto_threshold
    from stimuli.stimset.params import parse_threshold

    t = parse_threshold(threshold)
    if t is None and centre_view is not None:
        from stimuli.retention import retention_threshold

        t = retention_threshold(centre_view, image)
    elif t is None:
        t = auto_threshold(image)
    return t


def depth_evidence(
    lightfield,
    slope_px_per_view: float,
    image: np.ndarray,
    *,
    threshold: str | float = "auto",
    centre_view: np.ndarray | None = None,
    box: tuple[slice, slice] | None = None,
):
    """Return the in-focus evidence :func:`declutter_and_compress` reads, tested only there.

    :func:`stimuli.declutter.in_focus_evidence` with ``where`` = the Sobel edges of ``image``
    (cut to ``box``, rows and columns, if given) at :func:`edge_threshold`: the depth edges
    are those of the evidence tested everywhere, to the bit, at a cost that grows with the
    edges, not the image.

    Returns
    -------
    evidence : ndarray of shape (rows, cols), uint8
        Of the whole image (right at the edge pixels inside ``box``; cut it to ``box``).
    stats : stimuli.edgedepth.EdgeDepthStats
    threshold : float
        The threshold: pass it on to :func:`declutter_and_compress`.
    """
    from stimuli.declutter import declutter, in_focus_evidence

    rs, cs = box if box is not None else (slice(None), slice(None))
    img = np.ascontiguousarray(image[rs, cs])
    centre = None if centre_view is None else np.ascontiguousarray(centre_view[rs, cs])
    t = edge_threshold(img, threshold, centre)
    at = np.zeros(np.shape(image), bool)
    at[rs, cs] = declutter(img, threshold=t)
    evidence, stats = in_focus_evidence(lightfield, slope_px_per_view, confocal=image, where=at)
    return evidence, stats, t


def declutter_and_compress(
    image: np.ndarray,
    grid_px: tuple[int, int],
    *,
    threshold: str | float = "auto",
    edge_ratio: float,
    focus_mask: np.ndarray | None = None,
    centre_view: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, float]:
    """De-clutter a confocal image and compress it to the prosthesis grid.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    grid_px : (rows, cols)
        Prosthesis grid.
    threshold : 'auto' or float >= 0
        Sobel threshold; ``'auto'`` is :func:`stimuli.declutter.auto_threshold` (Otsu).
    edge_ratio : float in [0, 1)
        Compression edge ratio (paper: 1/13).
    focus_mask : ndarray of shape (rows, cols), bool or uint8, optional
        Depth mode: keep only the edges the light field says are in focus
        (:func:`stimuli.declutter.in_focus_mask`, :func:`stimuli.declutter.declutter_depth`);
        without it, the paper's Sobel mode.
    centre_view : ndarray of shape (rows, cols), float32 in [0, 1], optional
        The light field's centre view: ``'auto'`` is then the stimulus builder's rule, the
        pair's minimum edge retention (:func:`stimuli.retention.retention_threshold`, centre
        view as the wide photo), instead of Otsu.

    Returns
    -------
    edges : ndarray of shape (rows, cols), bool
    grid : ndarray of shape ``grid_px``, bool
    threshold : float
        The threshold used.
    """
    from stimuli.compress import compress
    from stimuli.declutter import declutter, declutter_depth

    t = edge_threshold(image, threshold, centre_view)
    if focus_mask is None:
        edges = declutter(image, threshold=t)
    else:
        edges = declutter_depth(image, focus_mask, threshold=t)
    return edges, compress(edges, grid_px, edge_ratio=edge_ratio), t
