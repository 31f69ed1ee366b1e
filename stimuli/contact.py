"""Contact sheets: each object at every level in both conditions, like Jung et al. 2015 Figs. 4-7.

Sheets are drawn with Pillow (no matplotlib in ``stimuli``; house style H13). Every stimulus is
magnified with nearest-neighbour sampling to one cell size, so all levels show at the same
on-screen size, as the subjects saw them, and every prosthesis pixel stays a sharp square.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from stimuli.errors import InputError
from stimuli.io import atomic_path

__all__ = ["contact_sheet", "save_contact_sheet"]

#: Grey of the background between cells (8-bit). Mid-dark so white and black cells both show.
_BACKGROUND = 64
#: Gap between cells and around the sheet, pixels.
_GAP_PX = 6
#: Height of a label line, pixels (Pillow's default bitmap font is 11 px high).
_LABEL_PX = 14


def _to_u8(image: np.ndarray) -> np.ndarray:
    a = np.asarray(image)
    if a.ndim != 2:
        raise InputError(f"contact-sheet image must be 2-D (rows, cols), got shape {a.shape}")
    if a.dtype == bool:
        return a.astype(np.uint8) * 255
    if a.dtype == np.uint8:
        return a
    if np.issubdtype(a.dtype, np.floating):
        if a.size and (not np.all(np.isfinite(a)) or a.min() < 0 or a.max() > 1):
            raise InputError("contact-sheet float image must be finite and in [0, 1]")
        return np.round(a * 255.0).astype(np.uint8)
    raise InputError(f"contact-sheet image must be bool, uint8 or float, got dtype {a.dtype}")


def contact_sheet(
    rows: Sequence[tuple[str, Sequence[np.ndarray]]],
    *,
    cell_shape_px: tuple[int, int] = (109, 164),
    column_labels: Sequence[str] | None = None,
    title: str = "",
    subtitle: str = "",
) -> np.ndarray:
    """Lay out images in a labelled grid, each magnified (nearest neighbour) to one cell size.

    Parameters
    ----------
    rows : sequence of (label, images)
        One row per label; images are 2-D bool, uint8 or float in [0, 1], any size. Rows may
        have different lengths.
    cell_shape_px : (rows, cols)
        Size every image is magnified to, pixels (keeps the images' common aspect).
    column_labels : sequence of str, optional
        Printed above the columns.
    title : str
        Printed at the top.
    subtitle : str
        A warning printed under the title, white on black (empty: no line).

    Returns
    -------
    ndarray of shape (H, W), uint8
        The sheet.

    Raises
    ------
    InputError
        If ``rows`` is empty or an image is not 2-D.
    """
    if not rows:
        raise InputError("contact_sheet needs at least one row, got none")
    ch, cw = (int(v) for v in cell_shape_px)
    if ch < 1 or cw < 1:
        raise InputError(f"cell_shape_px must be positive, got {cell_shape_px!r}")
    font = ImageFont.load_default()
    label_w = 8 + max(
        int(ImageDraw.Draw(Image.new("L", (1, 1))).textlength(lbl, font=font)) for lbl, _ in rows
    )
    n_cols = max(len(imgs) for _, imgs in rows)
    top = (
        _GAP_PX
        + (_LABEL_PX if title else 0)
        + (_LABEL_PX if subtitle else 0)
        + (_LABEL_PX if column_labels else 0)
    )
    width = label_w + _GAP_PX + n_cols * (cw + _GAP_PX)
    height = top + len(rows) * (ch + _GAP_PX) + _GAP_PX
    sheet = Image.new("L", (width, height), _BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    y_text = _GAP_PX // 2
    if title:
        draw.text((_GAP_PX, y_text), title, fill=255, font=font)
        y_text += _LABEL_PX
    if subtitle:
        draw.rectangle((0, y_text - 1, width, y_text + _LABEL_PX - 2), fill=0)
        draw.text((_GAP_PX, y_text), subtitle, fill=255, font=font)
        y_text += _LABEL_PX
    if column_labels:
        for j, lbl in enumerate(column_labels[:n_cols]):
            draw.text((label_w + _GAP_PX + j * (cw + _GAP_PX), y_text), lbl, fill=230, font=font)
    for i, (lbl, imgs) in enumerate(rows):
        y = top + i * (ch + _GAP_PX)
        draw.text((_GAP_PX, y + ch // 2 - 6), lbl, fill=255, font=font)
        for j, img in enumerate(imgs):
            tile = Image.fromarray(_to_u8(img)).resize((cw, ch), Image.Resampling.NEAREST)
            sheet.paste(tile, (label_w + _GAP_PX + j * (cw + _GAP_PX), y))
    return np.asarray(sheet)


def save_contact_sheet(sheet: np.ndarray, path: str | os.PathLike) -> Path:
    """Write a sheet as PNG, atomically; return the path.

    The sheet is a uint8 image, grey ``(H, W)`` or RGB ``(H, W, 3)``: one from
    :func:`contact_sheet` or :func:`stimuli.tune.tuning_sheet`.
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        Image.fromarray(np.asarray(sheet, dtype=np.uint8)).save(tmp, format="PNG")
    return path
