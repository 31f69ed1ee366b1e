"""Compression levels of a build: each stimulus at every window (Jung et al. 2015, Sec. 2.2, 3.1).

Module docstring of :mod:`stimuli.stimset`, step 6.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from stimuli import jung2015
from stimuli.compress import compress, compress_grey, resolution_ladder
from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = [
    "Ladder",
    "level_ladder",
    "level_labels",
    "edge_ladder",
    "grey_ladder",
    "edges_on_ladder",
    "grey_on_ladder",
]

#: A set's levels, as :func:`level_ladder` gives them: ``((level, window_px, (rows, cols)), ...)``.
Ladder = Sequence[tuple[int, int, tuple[int, int]]]


def level_ladder(
    shape_px: tuple[int, int], windows_px: Sequence[int]
) -> list[tuple[int, int, tuple[int, int]]]:
    """Return a set's levels: ``[(level, window_px, (rows, cols)), ...]``, 1 = fewest pixels.

    Examples
    --------
    >>> level_ladder((327, 492), (1, 40))
    [(1, 40, (8, 12)), (2, 1, (327, 492))]
    """
    return [
        (i + 1, w, s) for i, (w, s) in enumerate(resolution_ladder(shape_px, tuple(windows_px)))
    ]


def edge_ladder(
    edges: np.ndarray, *, edge_ratio: float, windows_px: Sequence[int] = jung2015.WINDOWS_PX
) -> list[tuple[int, int, np.ndarray]]:
    """Compress an edge image at every window: ``[(level, window, stimulus), ...]``.

    Parameters
    ----------
    edges : ndarray of shape (rows, cols), bool
    edge_ratio : float in [0, 1)
        A cell is on when its window's edge fraction exceeds this.
    windows_px : sequence of int

    Returns
    -------
    list of (level, window_px, ndarray of bool)
        Level 1 is the fewest pixels (window 40 for the paper's windows); window 1 is the edge
        image itself (a copy).

    References
    ----------
    Jung et al. (2015), Sec. 2.2 and 3.1.
    """
    e = np.asarray(edges)
    return edges_on_ladder(e, level_ladder(e.shape, windows_px), edge_ratio=edge_ratio)


def grey_ladder(
    image: np.ndarray, *, grey_levels: int, windows_px: Sequence[int] = jung2015.WINDOWS_PX
) -> list[tuple[int, int, np.ndarray]]:
    """Grey-level compression of a photo at every window (Fig. 2): ``[(level, window, img)]``.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    grey_levels : int >= 2
        Number of grey levels.
    windows_px : sequence of int

    Returns
    -------
    list of (level, window_px, ndarray of float32 in [0, 1])
    """
    img = check_gray(image)
    return grey_on_ladder(img, level_ladder(img.shape, windows_px), grey_levels=grey_levels)


def _check_ladder(shape_px: tuple[int, int], ladder: Ladder) -> None:
    for level, w, shape in ladder:
        if w == 1 and tuple(shape) != tuple(shape_px):
            raise InputError(
                f"ladder: level {level} (window 1) is {shape[1]}x{shape[0]} px but the image is "
                f"{shape_px[1]}x{shape_px[0]}; expected a ladder made for the image's size"
            )


def edges_on_ladder(
    edges: np.ndarray, ladder: Ladder, *, edge_ratio: float
) -> list[tuple[int, int, np.ndarray]]:
    """Compress an edge image at every level of a given ladder (a build's ``plan.ladder``).

    Parameters
    ----------
    edges : ndarray of shape (rows, cols), bool
    ladder : sequence of (level, window_px, (rows, cols))
        The levels (:func:`level_ladder`); each stimulus has its level's shape, and window 1
        is the edge image itself (a copy).
    edge_ratio : float in [0, 1)
        A cell is on when its window's edge fraction exceeds this.

    Returns
    -------
    list of (level, window_px, ndarray of bool)
        In the ladder's order.

    Raises
    ------
    InputError
        A window-1 level whose shape is not the image's.
    """
    e = np.asarray(edges)
    _check_ladder(e.shape, ladder)
    return [
        (level, w, e.copy() if w == 1 else compress(e, shape, edge_ratio=edge_ratio))
        for level, w, shape in ladder
    ]


def grey_on_ladder(
    image: np.ndarray, ladder: Ladder, *, grey_levels: int
) -> list[tuple[int, int, np.ndarray]]:
    """Grey-level compression of a photo at every level of a given ladder (Fig. 2).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    ladder : sequence of (level, window_px, (rows, cols))
        The levels (:func:`level_ladder`).
    grey_levels : int >= 2
        Number of grey levels.

    Returns
    -------
    list of (level, window_px, ndarray of float32 in [0, 1])
        In the ladder's order.

    Raises
    ------
    InputError
        A window-1 level whose shape is not the image's.
    """
    img = check_gray(image)
    _check_ladder(img.shape, ladder)
    return [
        (level, w, compress_grey(img, shape, grey_levels=grey_levels)) for level, w, shape in ladder
    ]


def level_labels(ladder: Sequence[tuple[int, int, tuple[int, int]]]) -> list[str]:
    """Return the contact sheets' column labels of a :func:`level_ladder`: ``'L1 12x8 (w40)'``."""
    return [f"L{lv} {s[1]}x{s[0]} (w{w})" for lv, w, s in ladder]
