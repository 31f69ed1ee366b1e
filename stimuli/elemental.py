"""Lens-array elemental images: regrid one picture into sub-aperture views, and back.

Under a lens array each lenslet images the scene from all view directions at once; pixel
``(i, j)`` under lenslet ``(k, l)`` is pixel ``(k, l)`` of view ``(i, j)``.
"""

from __future__ import annotations

import numpy as np

from stimuli.errors import InputError

__all__ = ["views_from_elemental", "elemental_from_views"]


def views_from_elemental(
    image: np.ndarray, pitch_px: int, *, border_px: int = 0, offset_px: tuple[int, int] = (0, 0)
) -> np.ndarray:
    """Regrid a lens-array elemental image into sub-aperture views.

    Pixel ``(i, j)`` under lenslet ``(k, l)`` becomes pixel ``(k, l)`` of view ``(i, j)``.

    Parameters
    ----------
    image : ndarray of shape (rows, cols) or (rows, cols, C), float32 in [0, 1]
    pitch_px : int >= 1
        Lenslet pitch in pixels; partial lenslets after the last whole one are dropped.
    border_px : int >= 0
        Invalid pixels along each side of every lenslet, dropped (``2 * border_px < pitch_px``).
    offset_px : (rows, cols)
        Pixels skipped at the top and left before the first whole lenslet.

    Returns
    -------
    ndarray of shape (pitch - 2 b, pitch - 2 b, rows / pitch, cols / pitch[, C]), float32

    References
    ----------
    Jung et al. (2015), Sec. 4.1 (elemental images, computational integral imaging).
    """
    a = np.asarray(image)
    if a.ndim not in (2, 3):
        raise InputError(f"elemental image must be 2-D or (rows, cols, C), got shape {a.shape}")
    if isinstance(pitch_px, bool) or not isinstance(pitch_px, (int, np.integer)) or pitch_px < 1:
        raise InputError(f"pitch_px must be a positive integer, got {pitch_px!r}")
    if not isinstance(border_px, (int, np.integer)) or border_px < 0 or 2 * border_px >= pitch_px:
        raise InputError(
            f"border_px must be an integer in [0, pitch_px / 2), got {border_px!r} "
            f"for pitch_px {pitch_px}"
        )
    oy, ox = (int(o) for o in offset_px)
    if oy < 0 or ox < 0:
        raise InputError(f"offset_px must be >= 0, got {offset_px!r}")
    a = a[oy:, ox:]
    nk, nl = a.shape[0] // pitch_px, a.shape[1] // pitch_px
    if nk < 2 or nl < 2:
        raise InputError(
            f"lenslet pitch {pitch_px} px leaves fewer than 2x2 whole lenslets in the "
            f"{a.shape[0]}x{a.shape[1]} px elemental image (after offset {offset_px})"
        )
    # A partial lenslet at the right or bottom edge (a sensor is rarely a whole number of
    # lenslets) is dropped.
    a = a[: nk * pitch_px, : nl * pitch_px]
    v = a.reshape(nk, pitch_px, nl, pitch_px, *a.shape[2:])
    v = np.moveaxis(v, (1, 3), (0, 1))  # (p, p, nk, nl[, C])
    b = int(border_px)
    v = v[b : pitch_px - b, b : pitch_px - b]
    return np.ascontiguousarray(v, dtype=np.float32)


def elemental_from_views(views: np.ndarray) -> np.ndarray:
    """Interleave views ``(p, p, nk, nl[, C])`` into an elemental image ``(nk p, nl p[, C])``.

    The inverse of :func:`views_from_elemental` with no border.
    """
    v = np.asarray(views)
    if v.ndim not in (4, 5) or v.shape[0] != v.shape[1]:
        raise InputError(f"views must be (p, p, rows, cols[, C]), got shape {v.shape}")
    p, _, nk, nl = v.shape[:4]
    e = np.moveaxis(v, (0, 1), (1, 3))  # (nk, p, nl, p[, C])
    return np.ascontiguousarray(e.reshape(nk * p, nl * p, *v.shape[4:]))
