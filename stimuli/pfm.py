"""PFM files (portable float maps): the ground-truth disparity and depth maps of light fields."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from stimuli.errors import InputError

__all__ = ["read_pfm", "write_pfm"]


def read_pfm(path: str | os.PathLike) -> np.ndarray:
    """Read a PFM file (grey ``Pf`` or colour ``PF``) as float32, top row first.

    PFM stores rows bottom to top; the result is flipped so that row 0 is the top of the image.
    A negative scale means little-endian.

    Returns
    -------
    ndarray of shape (rows, cols) or (rows, cols, 3), float32
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: PFM file not found")
    with open(path, "rb") as f:
        header = f.readline().strip()
        if header not in (b"Pf", b"PF"):
            raise InputError(f"{path}: not a PFM file (header {header[:8]!r})")
        dims = f.readline().split()
        while not dims:
            dims = f.readline().split()
        try:
            width, height = int(dims[0]), int(dims[1])
            scale = float(f.readline().strip())
        except (ValueError, IndexError):
            raise InputError(f"{path}: bad PFM header") from None
        channels = 3 if header == b"PF" else 1
        dtype = "<f4" if scale < 0 else ">f4"
        data = np.frombuffer(f.read(), dtype=dtype)
    n = width * height * channels
    if data.size < n:
        raise InputError(f"{path}: PFM data truncated ({data.size} of {n} values)")
    a = (
        data[:n].reshape(height, width, channels)
        if channels == 3
        else data[:n].reshape(height, width)
    )
    return np.ascontiguousarray(a[::-1]).astype(np.float32)


def write_pfm(array: np.ndarray, path: str | os.PathLike) -> Path:
    """Write a 2-D float array as a little-endian grey PFM (rows stored bottom to top)."""
    a = np.asarray(array, dtype="<f4")
    if a.ndim != 2:
        raise InputError(f"array must be 2-D (rows, cols), got shape {a.shape}")
    path = Path(path)
    with open(path, "wb") as f:
        f.write(b"Pf\n%d %d\n-1.0\n" % (a.shape[1], a.shape[0]))
        f.write(np.ascontiguousarray(a[::-1]).tobytes())
    return path
