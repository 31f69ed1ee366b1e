"""Tune the de-cluttering threshold of photo pairs: ``confocal stimuli tune``.

The paper set the Sobel threshold by hand for each confocal (narrow-DOF) photo, "aiming to fully
remove the suppressed background clutter and leave only the OI", and applied it to the paired
wide-DOF photo (Jung et al. 2015, Sec. 3.1). This module proposes that threshold from the pair
itself (the minimum edge retention of :mod:`stimuli.retention`, the method and its numbers are
described there) and shows the candidates on a contact sheet so that a person can check or
overrule it.
"""

from __future__ import annotations

import csv
import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from stimuli import jung2015
from stimuli.errors import InputError
from stimuli.manifest import OBJECTS_COLUMNS, read_objects_csv
from stimuli.retention import RetentionCurve, pair_magnitudes, retention_curve
from stimuli.stimset.pairs import read_pairs
from stimuli.stimset.parallel import ProgressFn, map_objects, thread_count
from stimuli.stimset.params import BuildParams
from stimuli.stimset.prepare import prepare_object
from stimuli.tables import unescape_row, write_table

__all__ = [
    "SHEET_FACTORS",
    "TuneResult",
    "tune_pairs",
    "tuning_sheet",
    "write_thresholds",
]

logger = logging.getLogger(__name__)

#: Factors around the proposed threshold shown on the contact sheet (ours): half an octave
#: apart, so the sheet spans a factor of four.
SHEET_FACTORS: tuple[float, ...] = (0.5, 2**-0.5, 1.0, 2**0.5, 2.0)


@dataclass(frozen=True)
class TuneResult:
    """The proposed threshold of one object and what it does (one row of ``stimuli tune``).

    Parameters
    ----------
    object : str
    role : {'main', 'training'}
    threshold : float
        Proposed Sobel threshold (minimum edge retention).
    previous_threshold : float or None
        The value ``objects.csv`` held before, if any.
    otsu_threshold : float
        Otsu's threshold on the narrow photo, for comparison.
    wide_edge_fraction, narrow_edge_fraction : float in [0, 1]
        Edge-pixel fractions at ``threshold``.
    curve : RetentionCurve
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The photos at the working size (for the contact sheet).
    """

    object: str
    role: str
    threshold: float
    previous_threshold: float | None
    otsu_threshold: float
    wide_edge_fraction: float
    narrow_edge_fraction: float
    curve: RetentionCurve
    wide: np.ndarray
    narrow: np.ndarray

    @property
    def retention(self) -> float:
        """Return ``narrow_edge_fraction / wide_edge_fraction`` (dimensionless)."""
        return (
            self.narrow_edge_fraction / self.wide_edge_fraction if self.wide_edge_fraction else 0.0
        )


def tune_pairs(
    pairs: str | os.PathLike,
    *,
    working_shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX,
    workers: int | None = None,
    progress: ProgressFn | None = None,
) -> list[TuneResult]:
    """Propose a Sobel threshold for every object of a PAIRS input.

    The photos are read, zoom-cropped and resized exactly as ``stimuli build`` does, so the
    proposed values mean the same thing there.

    Parameters
    ----------
    pairs : str or path-like
        PAIRS folder or CSV (:func:`stimuli.stimset.pairs.read_pairs`).
    working_shape_px : (rows, cols)
        Working size (paper: 327x492).
    workers : int, optional
        Threads for reading (default: CPUs, at most 8).
    progress : callable(stage, done, total), optional
        Called as objects are read (stage ``'read'``).

    Returns
    -------
    list of TuneResult
        In PAIRS order.

    Raises
    ------
    InputError
        Bad PAIRS input (see :func:`stimuli.stimset.pairs.read_pairs`), unreadable photos, or photos
        of one pair with different pixel sizes.
    """
    params = BuildParams(working_shape_px=tuple(int(v) for v in working_shape_px))
    inp = read_pairs(pairs)
    workers = thread_count(workers)

    def one(item) -> TuneResult:
        src, info = item
        work = prepare_object(src, info, params, colour=False)
        curve = retention_curve(work.wide, work.narrow)
        t = curve.best_threshold()
        sw, sn = pair_magnitudes(work.wide, work.narrow)
        return TuneResult(
            object=info.object,
            role=info.role,
            threshold=t,
            previous_threshold=info.sobel_threshold,
            otsu_threshold=float(curve.thresholds[0]),
            wide_edge_fraction=float((sw > t).mean()),
            narrow_edge_fraction=float((sn > t).mean()),
            curve=curve,
            wide=work.wide,
            narrow=work.narrow,
        )

    return map_objects(
        one, list(zip(inp.sources, inp.objects, strict=True)), workers, progress, "read"
    )


# --------------------------------------------------------------------------------------------
# contact sheet

#: Cell size on the sheet (rows, cols): half the paper's working size.
_CELL_PX = (164, 246)
_GAP_PX = 6
_LABEL_PX = 14
_BACKGROUND = (48, 48, 48)
_MARK = (230, 40, 40)
_MARK_PX = 4


def _tile(image: np.ndarray, cell_px: tuple[int, int]) -> Image.Image:
    a = np.asarray(image)
    u8 = a.astype(np.uint8) * 255 if a.dtype == bool else np.round(a * 255).astype(np.uint8)
    return (
        Image.fromarray(u8)
        .convert("RGB")
        .resize((cell_px[1], cell_px[0]), Image.Resampling.BILINEAR)
    )


def tuning_sheet(
    results: Sequence[TuneResult], *, factors: Sequence[float] = SHEET_FACTORS
) -> np.ndarray:
    """Draw the candidates of every object: wide and narrow edge images at several thresholds.

    Each object gets two rows: the wide photo and its edge images, then the narrow photo and
    its edge images, at ``factor * threshold`` for each factor; the proposed threshold's column
    is framed in red. Labels give each threshold and the wide photo's edge fraction there.

    Parameters
    ----------
    results : sequence of TuneResult
    factors : sequence of float > 0
        Multiples of the proposed threshold to show (1.0 is the proposed one).

    Returns
    -------
    ndarray of shape (H, W, 3), uint8
        The sheet (RGB).

    Raises
    ------
    InputError
        If ``results`` is empty or a factor is not positive.
    """
    if not results:
        raise InputError("tuning_sheet needs at least one object, got none")
    fs = [float(f) for f in factors]
    if not fs or min(fs) <= 0:
        raise InputError(f"factors must be positive numbers, got {factors!r}")
    ch, cw = _CELL_PX
    font = ImageFont.load_default()
    label_w = 70
    n_cols = 1 + len(fs)
    block_h = _LABEL_PX + 2 * (ch + _GAP_PX)
    width = label_w + n_cols * (cw + _GAP_PX) + _GAP_PX
    height = _LABEL_PX + _GAP_PX + len(results) * (block_h + _GAP_PX)
    sheet = Image.new("RGB", (width, height), _BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    draw.text(
        (_GAP_PX, 2),
        "rows: wide DOF (top), narrow DOF (bottom); columns: photo, edges at multiples of the "
        "proposed threshold (framed in red)",
        fill=(255, 255, 255),
        font=font,
    )
    y0 = _LABEL_PX + _GAP_PX
    for r in results:
        sw, sn = pair_magnitudes(r.wide, r.narrow)
        draw.text(
            (_GAP_PX, y0),
            f"{r.object} ({r.role}): proposed {r.threshold:.4g}, wide edges "
            f"{100 * r.wide_edge_fraction:.1f} %, narrow {100 * r.narrow_edge_fraction:.1f} %"
            f"; Otsu {r.otsu_threshold:.4g}",
            fill=(255, 255, 255),
            font=font,
        )
        top = y0 + _LABEL_PX
        for i, (name, photo, mag) in enumerate((("wide", r.wide, sw), ("narrow", r.narrow, sn))):
            y = top + i * (ch + _GAP_PX)
            draw.text((_GAP_PX, y + ch // 2 - 6), name, fill=(230, 230, 230), font=font)
            x = label_w
            sheet.paste(_tile(photo, _CELL_PX), (x, y))
            for j, f in enumerate(fs):
                t = f * r.threshold
                x = label_w + (j + 1) * (cw + _GAP_PX)
                sheet.paste(_tile(mag > t, _CELL_PX), (x, y))
                if i == 0:
                    draw.text(
                        (x + 3, y + 2),
                        f"t={t:.3f} wide {100 * float((sw > t).mean()):.1f}%",
                        fill=(255, 200, 0),
                        font=font,
                    )
                if f == 1.0:
                    draw.rectangle(
                        (x - _MARK_PX // 2, y - _MARK_PX // 2, x + cw, y + ch),
                        outline=_MARK,
                        width=_MARK_PX,
                    )
        y0 += block_h + _GAP_PX
    return np.asarray(sheet)


# --------------------------------------------------------------------------------------------
# objects.csv


def write_thresholds(
    path: str | os.PathLike, thresholds: Mapping[str, float], *, digits: int = 4
) -> Path:
    """Write per-object Sobel thresholds into ``objects.csv``, keeping every other column.

    An existing file is checked first (:func:`stimuli.manifest.read_objects_csv`), then
    rewritten atomically with the same columns in the same order (``sobel_threshold`` is added
    if missing) and the ``sobel_threshold`` cell of each named object replaced; objects not yet
    in the file are appended. A missing file is created with the standard columns.

    Parameters
    ----------
    path : str or path-like
        The ``objects.csv`` to update.
    thresholds : mapping of object id to float >= 0
    digits : int
        Decimal places written.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        If the existing file is malformed or a threshold is not a finite number >= 0.
    """
    path = Path(path)
    values: dict[str, str] = {}
    for oid, t in thresholds.items():
        v = float(t)
        if not np.isfinite(v) or v < 0:
            raise InputError(
                f"threshold for object {oid!r} must be a finite number >= 0, got {t!r}"
            )
        values[oid] = f"{round(v, digits):.{digits}f}"
    if path.is_file():
        read_objects_csv(path)  # validates before anything is written
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.DictReader(f)
            header = [h.strip() for h in (reader.fieldnames or [])]
            reader.fieldnames = header
            rows = [unescape_row(r) for r in reader]
    else:
        header, rows = list(OBJECTS_COLUMNS), []
    if "sobel_threshold" not in header:
        header.append("sobel_threshold")
    index = {(r.get("object") or "").strip().lower(): r for r in rows}
    for oid, v in values.items():
        row = index.get(oid.lower())
        if row is None:
            row = {h: "" for h in header}
            row["object"] = oid
            rows.append(row)
            index[oid.lower()] = row
        row["sobel_threshold"] = v
    write_table(path, [{h: row.get(h) or "" for h in header} for row in rows], header)
    logger.info("%s: wrote thresholds for %d objects", path, len(values))
    return path
