"""Tiny synthetic photo pairs for the builder tests (numpy -> PNG with Pillow, in tmp_path).

Each object is a bright disc-and-bar shape at the bottom centre in front of a striped,
speckled background. The wide-DOF photo has everything sharp; the narrow-DOF photo has the
same object sharp and the background Gaussian-blurred (as a defocused background is).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image
from scipy.ndimage import gaussian_filter

__all__ = ["make_pair", "write_pairs_folder", "write_png"]


def make_pair(
    seed: int, shape_px: tuple[int, int] = (200, 300), blur_px: float = 4.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``(wide, narrow, mask)``: float32 [0, 1] photos and the bool object mask."""
    rng = np.random.default_rng(seed)
    rows, cols = shape_px
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    period = 6 + 3 * (seed % 4)
    background = 0.3 + 0.15 * np.sign(np.sin(2 * np.pi * (xx + 0.6 * yy) / period))
    background = background + 0.1 * (rng.random(shape_px) > 0.8)
    cy, cx, r = 0.72 * rows, 0.5 * cols + 5 * (seed % 3), 0.18 * rows
    mask = (yy - cy) ** 2 + (xx - cx) ** 2 < r**2
    mask |= (np.abs(xx - cx) < 0.04 * cols) & (yy > 0.3 * rows) & (yy < cy)
    obj = np.float32(0.95)
    wide = np.where(mask, obj, background).astype(np.float32)
    narrow = np.where(mask, obj, gaussian_filter(background, blur_px)).astype(np.float32)
    return np.clip(wide, 0, 1), np.clip(narrow, 0, 1), mask


def write_png(image: np.ndarray, path: Path) -> Path:
    """Write a float [0, 1] grey image as an 8-bit PNG."""
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.round(np.asarray(image) * 255).astype(np.uint8)).save(path)
    return path


def write_pairs_folder(
    root: Path, n: int = 3, shape_px: tuple[int, int] = (200, 300), objects_csv: str | None = None
) -> Path:
    """Write ``n`` pairs as ``root/objNN/{wide,narrow}.png`` (+ optional objects.csv text)."""
    for i in range(n):
        wide, narrow, _ = make_pair(i, shape_px)
        write_png(wide, root / f"obj{i:02d}" / "wide.png")
        write_png(narrow, root / f"obj{i:02d}" / "narrow.png")
    if objects_csv is not None:
        (root / "objects.csv").write_text(objects_csv)
    return root
