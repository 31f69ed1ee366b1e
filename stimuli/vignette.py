"""Find the part of a capture that shows the scene: a crop without the vignette rim.

Plenoptic captures (the Lytro Illum's decoded sub-aperture views) have black corners where the
main lens's aperture cuts the micro-images, and often a clipped-white strip (sky). Both
dominate the edges of a confocal image: the rim is the strongest edge in the picture, so the
implant's few electrodes show it instead of the scene. :func:`vignette_crop` finds the largest
box whose border lines are almost free of such pixels, with thresholds taken from the data:

* *dark*: at most :data:`DARK_FRACTION` of the image's median, in any view (the rim moves
  from view to view, and a refocused image averages all of them);
* *clipped*: at least :data:`CLIP_FRACTION` of the image's own maximum in the centre view,
  when that maximum reaches full scale (a dim image that never reaches it has no clipping).

Border lines (top or bottom row, left or right column) are peeled one at a time, always the one
with the largest share of such pixels, until no border line has more than
:data:`BORDER_TOLERANCE` of them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DARK_FRACTION", "CLIP_FRACTION", "BORDER_TOLERANCE", "MIN_KEEP", "vignette_crop"]

#: A pixel is vignetted when it is at most this fraction of the image's median (ours: the
#: Lytro rim is exactly 0 and the darkest scene pixels about a third of the median).
DARK_FRACTION: float = 0.1

#: A pixel is clipped when it is at least this fraction of the image's maximum (ours).
CLIP_FRACTION: float = 0.98

#: A border line may keep this fraction of dark or clipped pixels (ours: a few pixels of a
#: shadow or a highlight do not cost a row of scene).
BORDER_TOLERANCE: float = 0.02

#: The crop keeps at least this fraction of each side, or none is made (ours: an image that is
#: mostly dark or clipped is not a vignetted capture).
MIN_KEEP: float = 0.5


def vignette_crop(views: np.ndarray) -> tuple[int, int, int, int] | None:
    """Return the crop ``(x, y, w, h)`` that leaves out a capture's dark rim and clipped strip.

    Parameters
    ----------
    views : ndarray of shape (n_u, n_v, rows, cols) or (rows, cols), float in [0, 1]
        Grey views of a light field (or one image).

    Returns
    -------
    (x, y, w, h) or None
        The box in view pixels (x = column); None when there is nothing to leave out, or when
        the box would keep less than :data:`MIN_KEEP` of a side.

    Raises
    ------
    ValueError
        ``views`` is neither 2-D nor 4-D, or is empty.

    Examples
    --------
    >>> img = np.full((40, 60), 0.5, np.float32)
    >>> img[:5] = 0.0  # a dark strip on top
    >>> vignette_crop(img)
    (0, 5, 60, 35)
    """
    a = np.asarray(views, dtype=np.float32)
    if a.ndim not in (2, 4) or a.size == 0:
        raise ValueError(f"views must be (rows, cols) or (n_u, n_v, rows, cols), got {a.shape}")
    if a.ndim == 4:
        n_u, n_v = a.shape[:2]
        centre = a[n_u // 2, n_v // 2]
        darkest = a.min(axis=(0, 1))
    else:
        centre = darkest = a
    median = float(np.median(centre))
    top = float(centre.max())
    bad = darkest <= DARK_FRACTION * median
    if top >= CLIP_FRACTION:  # the sensor's white was reached: its pixels carry no scene
        bad |= centre >= CLIP_FRACTION * top
    rows, cols = bad.shape
    r0, r1, c0, c1 = 0, rows, 0, cols
    while r1 - r0 > 0 and c1 - c0 > 0:
        box = bad[r0:r1, c0:c1]
        share = (
            box[0].mean(),
            box[-1].mean(),
            box[:, 0].mean(),
            box[:, -1].mean(),
        )
        k = int(np.argmax(share))
        if share[k] <= BORDER_TOLERANCE:
            break
        if k == 0:
            r0 += 1
        elif k == 1:
            r1 -= 1
        elif k == 2:
            c0 += 1
        else:
            c1 -= 1
    if (r0, r1, c0, c1) == (0, rows, 0, cols):
        return None
    if r1 - r0 < MIN_KEEP * rows or c1 - c0 < MIN_KEEP * cols:
        return None
    return (c0, r0, c1 - c0, r1 - r0)
