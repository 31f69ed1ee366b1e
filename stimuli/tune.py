"""Tune the de-cluttering threshold of photo pairs (issue 15, point 7).

The paper set the Sobel threshold by hand for each confocal (narrow-DOF) photo, "aiming to fully
remove the suppressed background clutter and leave only the OI", and applied it to the paired
wide-DOF photo (Jung et al. 2015, Sec. 3.1). This module proposes that threshold from the pair
itself and shows the candidates on a contact sheet so that a person can check or overrule it.

Method: minimum edge retention (ours, not the paper's)
------------------------------------------------------
Both photos show the same scene. The in-focus object has sharp edges in both; the background
has sharp edges in the wide photo only, because the narrow aperture blurs it. For a threshold
``t`` let ``f_wide(t)`` and ``f_narrow(t)`` be the fractions of pixels whose Sobel magnitude
exceeds ``t``. Their ratio, the *edge retention* ``f_narrow(t) / f_wide(t)``, falls as ``t``
rises past the weak gradients of the blurred background (they vanish from the narrow edge image
but their sharp twins stay in the wide one), and stops falling, or rises again, once only the
object's edges, present in both photos, are left to remove. The proposed threshold is the one
with the lowest retention: the point where the narrow photo has shed the largest share of the
wide photo's edges, i.e. where the blurred background is gone and nothing is gained by cutting
further into the in-focus edges.

Candidates run from Otsu's threshold on the narrow photo's Sobel magnitude
(:func:`stimuli.declutter.auto_threshold`: the split between its weak gradients, flat regions
and blur, and its strong ones) up to the magnitude's 0.99 quantile (:data:`UPPER_QUANTILE`), in
steps of equal pixel counts, so the search range comes from the photo in front of it, not from
constants on the Sobel scale. Ties go to the lowest threshold, which keeps the most edges. When
the narrow photo's blurred background is already below Otsu's threshold (strong blur, as in the
synthetic pairs of ``stimuli synth``) the retention rises from there on and the proposal is
Otsu's threshold itself; when the blur leaves gradients above it (real photos at 492x327) the
proposal moves up until they are gone.

On the six real pairs in ``dof_pairs/`` (VABD and EBB!, 492x327) this gives a mean wide-DOF
edge fraction of 0.068 (paper: 1/13 = 0.077), against 0.28 with Otsu's threshold alone, and the
share of edge pixels inside the in-focus mask rises from 1-30 % (wide) to 5-90 % (narrow) for
every pair; see ``tests/stimuli/test_tune.py``. The upper quantile matters for three of the six
pairs, whose retention still falls there: with 0.97, 0.98 or 0.995 instead of 0.99 the mean is
0.098, 0.085 or 0.060, still in the paper's range. Where the retention curve is flat (EBB! 2979,
whose background is hardly blurred) the proposal can move by 20 % with the candidate grid; the
contact sheet shows the neighbours for such cases.

References
----------
Jung, J.-H., Aloni, D., Yitzhaky, Y., & Peli, E. (2015). Active confocal imaging for visual
prostheses. Vision Research 111, 182-196, Sec. 2.2 and 3.1.
"""

from __future__ import annotations

import csv
import logging
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from stimuli import jung2015
from stimuli.declutter import auto_threshold, sobel_magnitude
from stimuli.errors import InputError
from stimuli.io import atomic_path, check_gray
from stimuli.manifest import OBJECTS_COLUMNS, read_objects_csv
from stimuli.tables import unescape_row, write_table

__all__ = [
    "UPPER_QUANTILE",
    "N_CANDIDATES",
    "RetentionCurve",
    "TuneResult",
    "retention_curve",
    "retention_threshold",
    "tune_pairs",
    "tuning_sheet",
    "save_tuning_sheet",
    "write_thresholds",
]

logger = logging.getLogger(__name__)

#: Quantile of the narrow photo's Sobel magnitude that bounds the threshold search from above
#: (ours, not the paper's). Above it fewer than 1 % of the pixels stay edges, about the outline
#: of an object a third of the frame wide (at 492x327 a 160x160 px outline is ~0.4 % of the
#: pixels), so a higher threshold would start to erase the object itself.
UPPER_QUANTILE: float = 0.99

#: Number of candidate thresholds between Otsu's threshold and the upper quantile (ours): at
#: most 0.5 % of the pixels apart, finer than a viewer can tell apart on the contact sheet.
N_CANDIDATES: int = 100

#: Factors around the proposed threshold shown on the contact sheet (ours): half an octave
#: apart, so the sheet spans a factor of four.
SHEET_FACTORS: tuple[float, ...] = (0.5, 2**-0.5, 1.0, 2**0.5, 2.0)

ProgressFn = Callable[[str, int, int], None]


@dataclass(frozen=True)
class RetentionCurve:
    """Edge fractions of a photo pair over candidate thresholds.

    Parameters
    ----------
    thresholds : ndarray of shape (n,), float
        Candidate Sobel thresholds, ascending (scale of :func:`stimuli.declutter.sobel_magnitude`).
    wide_fraction, narrow_fraction : ndarray of shape (n,), float in [0, 1]
        Fraction of pixels above each threshold in the wide and narrow photo.
    """

    thresholds: np.ndarray
    wide_fraction: np.ndarray
    narrow_fraction: np.ndarray

    @property
    def retention(self) -> np.ndarray:
        """Return ``narrow_fraction / wide_fraction`` (dimensionless; ``inf`` where wide is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            r = self.narrow_fraction / self.wide_fraction
        return np.where(self.wide_fraction > 0, r, np.inf)

    def best_index(self) -> int:
        """Return the index of the lowest retention (the lowest threshold among ties)."""
        return int(np.argmin(self.retention))


def _pair_magnitudes(wide: np.ndarray, narrow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w, n = check_gray(wide), check_gray(narrow)
    if w.shape != n.shape:
        raise InputError(
            f"wide and narrow images must have the same shape, got {w.shape} and {n.shape}"
        )
    return sobel_magnitude(w), sobel_magnitude(n)


def _fraction_above(sorted_values: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    n = sorted_values.size
    return 1.0 - np.searchsorted(sorted_values, thresholds, side="right") / n


def retention_curve(
    wide: np.ndarray, narrow: np.ndarray, *, n_candidates: int = N_CANDIDATES
) -> RetentionCurve:
    """Return the edge fractions of a pair at thresholds spread over the narrow photo's range.

    Parameters
    ----------
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The wide-DOF and narrow-DOF (confocal) photos of one object, at the working size.
    n_candidates : int >= 2
        Number of candidate thresholds: quantiles of the narrow photo's Sobel magnitude evenly
        spaced in probability from Otsu's threshold to :data:`UPPER_QUANTILE` (repeated
        values dropped; only Otsu's threshold when it is above that quantile).

    Returns
    -------
    RetentionCurve

    Raises
    ------
    InputError
        If an image is not a grey image in [0, 1], the shapes differ or ``n_candidates < 2``.
    """
    if int(n_candidates) < 2:
        raise InputError(f"n_candidates must be >= 2, got {n_candidates!r}")
    sw, sn = _pair_magnitudes(wide, narrow)
    sorted_n = np.sort(sn.ravel())
    t_otsu = auto_threshold(narrow)
    q_otsu = 1.0 - float(_fraction_above(sorted_n, np.array([t_otsu]))[0])
    if q_otsu < UPPER_QUANTILE:
        q = np.linspace(q_otsu, UPPER_QUANTILE, int(n_candidates))[1:]
        # quantiles of the sorted values by index (nearest rank): np.quantile would sort again
        idx = np.clip(np.round(q * (sorted_n.size - 1)).astype(np.int64), 0, sorted_n.size - 1)
        ts = np.unique(np.concatenate([[t_otsu], sorted_n[idx]]).astype(np.float64))
        ts = ts[ts >= t_otsu]
    else:
        ts = np.array([t_otsu], np.float64)
    return RetentionCurve(
        thresholds=ts,
        wide_fraction=_fraction_above(np.sort(sw.ravel()), ts),
        narrow_fraction=_fraction_above(sorted_n, ts),
    )


def retention_threshold(wide: np.ndarray, narrow: np.ndarray) -> float:
    """Propose the Sobel threshold that removes the blurred background of a photo pair.

    The threshold with the lowest edge retention ``f_narrow(t) / f_wide(t)`` (module docstring).

    Parameters
    ----------
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The wide-DOF and narrow-DOF photos of one object, at the working size.

    Returns
    -------
    float >= 0
        On the scale of :func:`stimuli.declutter.sobel_magnitude`; never below Otsu's threshold
        on the narrow photo (:func:`stimuli.declutter.auto_threshold`), which is also the
        answer for a photo without gradients or a wide photo without edges above any candidate.

    References
    ----------
    Jung et al. (2015), Sec. 3.1 (the threshold the paper set by hand).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> from scipy.ndimage import gaussian_filter
    >>> bg = rng.random((64, 96)).astype(np.float32)
    >>> wide = 0.5 * bg; wide[16:48, 32:64] = 1.0
    >>> narrow = 0.5 * gaussian_filter(bg, 3); narrow[16:48, 32:64] = 1.0
    >>> t = retention_threshold(wide, narrow)
    >>> edges = sobel_magnitude(narrow) > t
    >>> bool(edges[16, 40:56].all()), bool(edges[:10].any())
    (True, False)
    """
    return _best_threshold(retention_curve(wide, narrow))


def _best_threshold(curve: RetentionCurve) -> float:
    # thresholds[0] is Otsu's threshold (retention_curve), the fallback when no wide edges
    if not np.isfinite(curve.retention).any():
        return float(curve.thresholds[0])
    return float(curve.thresholds[curve.best_index()])


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
        PAIRS folder or CSV (:func:`stimuli.build.read_pairs`).
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
        Bad PAIRS input (see :func:`stimuli.build.read_pairs`), unreadable photos, or photos
        of one pair with different pixel sizes.
    """
    from stimuli.build import BuildParams, _map, _prepare, read_pairs

    params = BuildParams(working_shape_px=tuple(int(v) for v in working_shape_px))
    inp = read_pairs(pairs)
    workers = min(8, os.cpu_count() or 1) if workers is None else max(1, int(workers))

    def one(item) -> TuneResult:
        src, info = item
        work = _prepare(src, info, params)
        curve = retention_curve(work.wide, work.narrow)
        t = _best_threshold(curve)
        sw, sn = _pair_magnitudes(work.wide, work.narrow)
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

    return list(
        _map(one, list(zip(inp.sources, inp.objects, strict=True)), workers, progress, "read")
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
        sw, sn = _pair_magnitudes(r.wide, r.narrow)
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


def save_tuning_sheet(sheet: np.ndarray, path: str | os.PathLike) -> Path:
    """Write a sheet from :func:`tuning_sheet` as PNG, atomically; return the path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        Image.fromarray(np.asarray(sheet, dtype=np.uint8)).save(tmp, format="PNG")
    return path


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
