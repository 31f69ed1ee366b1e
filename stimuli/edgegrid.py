"""One confocal image to the prosthesis grid: de-clutter its edges, then compress them.

The step ``lightfield scan``, ``lightfield refocus`` and ``demo --lightfield`` share for each
plane (Jung et al. 2015, Figs. 12-13); the stimulus builder runs the same two steps per level.
"""

from __future__ import annotations

import numpy as np

__all__ = ["declutter_and_compress"]


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
    from stimuli.build.params import parse_threshold
    from stimuli.compress import compress
    from stimuli.declutter import auto_threshold, declutter, declutter_depth

    t = parse_threshold(threshold)
    if t is None and centre_view is not None:
        from stimuli.retention import retention_threshold

        t = retention_threshold(centre_view, image)
    elif t is None:
        t = auto_threshold(image)
    if focus_mask is None:
        edges = declutter(image, threshold=t)
    else:
        edges = declutter_depth(image, focus_mask, threshold=t)
    return edges, compress(edges, grid_px, edge_ratio=edge_ratio), t
