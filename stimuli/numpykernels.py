"""Numpy twins of the compiled loops a small scan runs after its answer, equal to the bit.

``confocal lightfield scan`` prints its planes before it refocuses (the plane sweep's numpy twin,
:mod:`stimuli.planesweep`); what it does next (one refocus per plane, the Sobel filter, the Otsu
histogram, the grid counts) would import numba and load its cache, which costs more CPU time than
the whole rest of the command on a capture of the shared Lytro size (ours: about 0.8-1.5 s of
numba start-up against tens of milliseconds of numpy work). Within :func:`numpy_kernels`, and
only while nothing has imported :mod:`stimuli.kernels`, the Sobel filter runs here instead (the
same float32 / float64 operations in the same order, so the images are the same to the bit,
tested against the compiled loop); the refocus, the Otsu histogram and the grid counts take
their modules' own numpy paths (the refocus's is equal to the bit to its compiled pass,
:mod:`stimuli.shiftadd`).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

import numpy as np

__all__ = ["active", "numpy_kernels", "sobel"]

_ON = [False]


@contextlib.contextmanager
def numpy_kernels() -> Iterator[None]:
    """Within this block, :func:`active` is true while numba's loops are not loaded yet."""
    before = _ON[0]
    _ON[0] = True
    try:
        yield
    finally:
        _ON[0] = before


def active() -> bool:
    """Whether the twins here stand in for the compiled loops (see :func:`numpy_kernels`).

    Returns
    -------
    bool
        True within :func:`numpy_kernels` while :mod:`stimuli.kernels` is not imported.
    """
    return _ON[0] and "stimuli.kernels" not in sys.modules


def _magnitude(gy: np.ndarray, gx: np.ndarray) -> np.ndarray:
    fy, fx = gy.astype(np.float32), gx.astype(np.float32)
    return np.sqrt(fy * fy + fx * fx) / np.float32(np.sqrt(np.float32(2.0)))


def sobel(img: np.ndarray, out: np.ndarray) -> int:
    """Sobel magnitude of a float32 image into ``out``; the number of values outside [0, 1].

    The twin of :func:`stimuli.kernels.sobel_rows` over all rows: the directional sums in
    float64 (exact), rounded to float32, then the float32 magnitude.

    Parameters
    ----------
    img : ndarray, float32, (rows, cols)
    out : ndarray, float32, (rows, cols)
        Written.

    Returns
    -------
    int
        Pixels outside [0, 1] or NaN.
    """
    rows, cols = img.shape
    outside = int(np.count_nonzero(~((img >= 0.0) & (img <= 1.0))))
    f = img.astype(np.float64)
    up = np.concatenate([f[:1], f[:-1]])
    down = np.concatenate([f[1:], f[-1:]])
    smooth = 0.25 * up + 0.5 * f + 0.25 * down
    diff = up - down
    if cols == 1:
        out[:, 0] = _magnitude(diff[:, 0], np.zeros(rows))
        return outside
    out[:, 0] = _magnitude(0.75 * diff[:, 0] + 0.25 * diff[:, 1], smooth[:, 0] - smooth[:, 1])
    out[:, -1] = _magnitude(0.25 * diff[:, -2] + 0.75 * diff[:, -1], smooth[:, -2] - smooth[:, -1])
    if cols > 2:
        gy = 0.25 * diff[:, :-2] + 0.5 * diff[:, 1:-1] + 0.25 * diff[:, 2:]
        out[:, 1:-1] = _magnitude(gy, smooth[:, :-2] - smooth[:, 2:])
    return outside
