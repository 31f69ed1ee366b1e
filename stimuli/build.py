"""Build a stimulus set from photo pairs (or light fields): Jung et al. 2015, Sec. 3.1.

The pipeline, per object
------------------------
1. Read the wide-DOF ("conventional") and narrow-DOF ("confocal") photos with
   :func:`stimuli.io.load_gray` (luminance, float32 in [0, 1], EXIF orientation applied). A
   light-field object gives the pair through ``stimuli.planes.confocal_pair`` instead: its
   centre view is the cluttered image and the confocal image the de-cluttered one.
2. Zoom (optional, paper Sec. 4.1, Fig. 14): the ``crop`` box ``x,y,w,h`` of ``objects.csv`` is
   cut out at full resolution before anything else.
3. Centre-crop to the working aspect (492:327 by default) if needed, then an anti-aliased resize
   to the working size with ``skimage.transform.resize(..., anti_aliasing=True)``.
4. Sobel magnitude and threshold (:mod:`stimuli.declutter`): the per-object value of
   ``objects.csv``, else the global ``threshold``, else an automatic one at the working size:
   by default the pair's minimum edge retention (:func:`stimuli.tune.retention_threshold`,
   the method of ``confocal stimuli tune``), or Otsu / triangle on the narrow-DOF image
   (:func:`stimuli.declutter.auto_threshold`); the same value is applied to the wide-DOF
   image, as in the paper.
5. Edge ratio ``r``: given, or the mean edge-pixel fraction over the wide-DOF edge images of the
   set's main objects (the paper found 1/13 = 7.7 %).
6. Compression by non-overlapping windows 1, 2, 3, 5, 7, 13, 18, 40 (:mod:`stimuli.compress`);
   in grey mode the photos themselves are compressed to ``grey_levels`` levels (Fig. 2).
7. Implant views (optional, issue 14): for each implant layout given, each condition's image at
   the working size (the edge image, i.e. the window-1 stimulus; in grey mode the grey photo)
   is resampled to the implant's electrode grid (:func:`stimuli.implants.to_implant_grid`, with
   the set's edge ratio) and drawn as its phosphenes (:func:`stimuli.implants.render_phosphenes`,
   :data:`IMPLANT_PX_PER_ELECTRODE` px per electrode), under ``implants/<name>/<object>/``.
   ``stimulus_set.json`` lists every file with its sha256 and the implant's whole layout.

The set is written into a temporary folder beside the output folder and renamed onto it at
the end, so the output folder is untouched by any error.
"""

from __future__ import annotations

import errno
import hashlib
import json
import logging
import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from skimage.transform import resize

from stimuli import jung2015
from stimuli.compress import compress, compress_grey, resolution_ladder
from stimuli.contact import contact_sheet, save_contact_sheet
from stimuli.declutter import (
    AUTO_THRESHOLD_METHODS,
    DECLUTTER_MODES,
    auto_threshold,
    bokeh_guard,
    declutter,
    declutter_depth,
)
from stimuli.errors import InputError
from stimuli.implants import ImplantError, ImplantLayout, render_phosphenes, to_implant_grid
from stimuli.io import (
    check_gray,
    check_missing_or_empty,
    image_shape_px,
    load_gray,
    load_rgb,
    new_staging_folder,
    save_png,
    sha256_file,
    swap_in,
)
from stimuli.manifest import (
    ObjectInfo,
    StimulusRecord,
    check_object_id,
    format_crop,
    parse_crop,
    read_objects_csv,
    write_manifest,
    write_objects_csv,
)
from stimuli.tune import retention_threshold

__all__ = [
    "BuildParams",
    "PairSource",
    "PairsInput",
    "ObjectSummary",
    "BuildResult",
    "parse_working_size",
    "parse_threshold",
    "parse_edge_ratio",
    "read_pairs",
    "zoom_crop",
    "aspect_crop_box",
    "to_working_size",
    "edge_fraction",
    "edge_ladder",
    "grey_ladder",
    "build_stimulus_set",
    "THRESHOLD_METHODS",
    "IMPLANT_PX_PER_ELECTRODE",
    "min_photo_shape_px",
]

logger = logging.getLogger(__name__)

#: Name and version of the ``stimulus_set.json`` format written here.
SET_FORMAT = "confocal-stimulus-set"
SET_FORMAT_VERSION = 1

#: Automatic threshold methods of the build (ours, not the paper's: the paper set the threshold
#: by hand). ``'retention'`` (the default) uses both photos of a pair; the others only the narrow
#: photo. On the six real photo pairs in ``dof_pairs/`` Otsu leaves a mean wide-DOF edge fraction
#: of 0.28, retention 0.068 (paper 0.077); see ``stimuli/tune.py``.
THRESHOLD_METHODS: tuple[str, ...] = ("retention", *AUTO_THRESHOLD_METHODS)

#: Side of each electrode's square cell in the implant views' phosphene PNGs, px (ours, not the
#: paper's: large enough to show a Gaussian's shape, small enough that Alpha IMS's 39x39 grid
#: stays a 624x624 px image).
IMPLANT_PX_PER_ELECTRODE: int = 16

#: Conditions drawn as implant views: the two edge (or grey) stimuli of every object.
_IMPLANT_CONDITIONS: tuple[str, ...] = ("cluttered", "decluttered")

_MODES = ("edges", "grey")
_SIZE_RE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")
_LIGHTFIELD_NAMES = ("lightfield", "lightfield.npz")

ProgressFn = Callable[[str, int, int], None]


# --------------------------------------------------------------------------------------------
# parameters


def parse_working_size(text: str) -> tuple[int, int]:
    """Parse ``"WIDTHxHEIGHT"`` (the paper's order, e.g. ``"492x327"``) into ``(rows, cols)``.

    Raises
    ------
    InputError
        If the text is not two positive integers separated by ``x``.

    Examples
    --------
    >>> parse_working_size("492x327")
    (327, 492)
    """
    m = _SIZE_RE.match(str(text))
    if not m or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise InputError(
            f"--working-size must be WIDTHxHEIGHT in pixels (e.g. 492x327), got {text!r}"
        )
    return (int(m.group(2)), int(m.group(1)))


#: Largest Sobel magnitude of an image in [0, 1]: scikit-image's kernels have weights summing
#: to 1 per side, so |Gx|, |Gy| <= 1 and sqrt((Gx**2 + Gy**2) / 2) <= 1.
_MAX_SOBEL = 1.0


def parse_threshold(text: str | float | None) -> float | None:
    """Parse a Sobel threshold: ``"auto"`` (or ``None``) gives ``None``, else a number >= 0.

    Raises
    ------
    InputError
        If the text is neither ``auto`` nor a number in [0, 1] (no Sobel magnitude exceeds 1).
    """
    if text is None or (isinstance(text, str) and text.strip().lower() == "auto"):
        return None
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise InputError(f"--threshold must be 'auto' or a number >= 0, got {text!r}") from None
    if not np.isfinite(v) or v < 0:
        raise InputError(f"--threshold must be 'auto' or a number >= 0, got {text!r}")
    if v > _MAX_SOBEL:
        raise InputError(
            f"--threshold must be 'auto' or a number in [0, {_MAX_SOBEL:g}] (the Sobel magnitude "
            f"of an image in [0, 1] is at most {_MAX_SOBEL:g}, so no pixel would be an edge), "
            f"got {text!r}"
        )
    return v


def parse_edge_ratio(text: str | float | None) -> float | None:
    """Parse an edge ratio: ``"auto"`` (or ``None``) gives ``None``, else a number in [0, 1).

    Raises
    ------
    InputError
        If the text is neither ``auto`` nor a number in [0, 1).
    """
    if text is None or (isinstance(text, str) and text.strip().lower() == "auto"):
        return None
    try:
        v = float(text)
    except (TypeError, ValueError):
        msg = f"--edge-ratio must be 'auto' or a number in [0, 1), got {text!r}"
        raise InputError(msg) from None
    if not (0.0 <= v < 1.0):
        raise InputError(f"--edge-ratio must be 'auto' or a number in [0, 1), got {text!r}")
    return v


@dataclass(frozen=True)
class BuildParams:
    """Parameters of a stimulus-set build (every field is recorded in ``stimulus_set.json``).

    Parameters
    ----------
    working_shape_px : (rows, cols)
        Working size of the edge images (paper: 327 x 492).
    threshold : float >= 0 or None
        Global Sobel threshold; ``None`` = automatic per object (objects.csv values win).
    threshold_method : {'retention', 'otsu', 'triangle'}
        Automatic threshold method: ``'retention'`` uses both photos of the pair
        (:func:`stimuli.tune.retention_threshold`); the others the narrow photo alone
        (:func:`stimuli.declutter.auto_threshold`).
    edge_ratio : float in [0, 1) or None
        Compression edge ratio; ``None`` = mean wide-DOF edge fraction of the set.
    mode : {'edges', 'grey'}
        Binary edge stimuli, or grey-level compression of the photos (Fig. 2).
    grey_levels : int >= 2
        Grey levels in grey mode (the paper shows 8, 4 and 2).
    allow_resize : bool
        Accept pairs whose two photos differ in pixel size (each is resized on its own).
    windows_px : tuple of int
        Compression windows (paper: 1, 2, 3, 5, 7, 13, 18, 40).
    declutter : {'sobel', 'depth'}
        De-cluttering of light-field objects: the paper's Sobel + threshold, or Sobel edges kept
        where the light field's views agree at the plane (:func:`stimuli.declutter.in_focus_mask`;
        ours, beyond the paper). Photo pairs always use Sobel.
    bokeh_guard : bool
        Photo pairs: drop narrow-DOF edges with no wide-DOF edge nearby
        (:func:`stimuli.declutter.bokeh_guard`; ours, beyond the paper).
    fast_decode : bool
        Decode JPEG photos at reduced size (1/2, 1/4 or 1/8 in the DCT domain, Pillow's
        ``draft``), just large enough for the working size, before the anti-aliased resize.
        About 3-5x faster per photo; the images differ slightly from a full decode (on the real
        VABD/EBB! pairs 96-99 % of edge pixels agree). Off by default; recorded in the set.
    """

    working_shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX
    threshold: float | None = None
    threshold_method: str = "retention"
    edge_ratio: float | None = None
    mode: str = "edges"
    grey_levels: int = 8
    allow_resize: bool = False
    windows_px: tuple[int, ...] = jung2015.WINDOWS_PX
    fast_decode: bool = False
    declutter: str = "sobel"
    bokeh_guard: bool = False

    def __post_init__(self) -> None:
        for name in (
            "working_shape_px",
            "threshold",
            "threshold_method",
            "edge_ratio",
            "mode",
            "grey_levels",
            "windows_px",
            "declutter",
        ):
            getattr(self, f"_check_{name}")()

    def _check_working_shape_px(self) -> None:
        s = self.working_shape_px
        if len(s) != 2 or any(int(v) < 1 for v in s):
            raise InputError(f"working_shape_px must be (rows, cols) > 0, got {s!r}")

    def _check_threshold(self) -> None:
        if self.threshold is not None and not (np.isfinite(self.threshold) and self.threshold >= 0):
            raise InputError(f"threshold must be None or a number >= 0, got {self.threshold!r}")

    def _check_threshold_method(self) -> None:
        if self.threshold_method not in THRESHOLD_METHODS:
            raise InputError(
                f"threshold_method must be one of {THRESHOLD_METHODS}, "
                f"got {self.threshold_method!r}"
            )

    def _check_edge_ratio(self) -> None:
        if self.edge_ratio is not None and not (0.0 <= self.edge_ratio < 1.0):
            raise InputError(f"edge_ratio must be None or in [0, 1), got {self.edge_ratio!r}")

    def _check_declutter(self) -> None:
        if self.declutter not in DECLUTTER_MODES:
            raise InputError(f"declutter must be one of {DECLUTTER_MODES}, got {self.declutter!r}")

    def _check_mode(self) -> None:
        if self.mode not in _MODES:
            raise InputError(f"mode must be one of {_MODES}, got {self.mode!r}")

    def _check_grey_levels(self) -> None:
        g = self.grey_levels
        if isinstance(g, bool) or not isinstance(g, int) or not 2 <= g <= 256:
            raise InputError(f"grey_levels must be an integer in [2, 256], got {g!r}")

    def _check_windows_px(self) -> None:
        w = self.windows_px
        if not w or any(isinstance(v, bool) or int(v) != v or v < 1 for v in w):
            raise InputError(f"windows_px must be positive integers, got {w!r}")
        if len(set(w)) != len(w):
            raise InputError(f"windows_px must not repeat a window, got {w!r}")

    def to_dict(self) -> dict:
        """Return the parameters as JSON-ready values."""
        d = asdict(self)
        d["working_shape_px"] = list(self.working_shape_px)
        d["windows_px"] = list(self.windows_px)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> BuildParams:
        """Inverse of :meth:`to_dict`."""
        d = dict(d)
        d["working_shape_px"] = tuple(d["working_shape_px"])
        d["windows_px"] = tuple(d["windows_px"])
        return cls(**d)


# --------------------------------------------------------------------------------------------
# input discovery


@dataclass(frozen=True)
class PairSource:
    """Where one object's images come from.

    Parameters
    ----------
    object : str
        Object id.
    wide, narrow : Path or None
        Wide-DOF and narrow-DOF photos (both set, or both ``None`` for a light field).
    lightfield : Path or None
        Light-field folder or ``.npz`` file, read by ``stimuli.planes.confocal_pair``.
    crop : (x, y, w, h) or None
        Crop box from the PAIRS CSV (``objects.csv`` wins when both give one).
    """

    object: str
    wide: Path | None = None
    narrow: Path | None = None
    lightfield: Path | None = None
    crop: tuple[int, int, int, int] | None = None

    @property
    def kind(self) -> str:
        """``'photos'`` or ``'lightfield'``."""
        return "lightfield" if self.lightfield is not None else "photos"


@dataclass(frozen=True)
class PairsInput:
    """A parsed PAIRS input: the sources, the object table, and where they came from."""

    root: Path
    sources: tuple[PairSource, ...]
    objects: tuple[ObjectInfo, ...]
    objects_csv: Path | None = None


def _find_named(folder: Path, stem: str) -> Path | None:
    hits = sorted(
        p for p in folder.iterdir() if p.is_file() and p.stem.lower() == stem and p.suffix
    )
    if len(hits) > 1:
        raise InputError(
            f"{folder}: more than one {stem}.* file ({', '.join(p.name for p in hits)}); "
            "expected exactly one"
        )
    return hits[0] if hits else None


def _find_lightfield(folder: Path) -> Path | None:
    for name in _LIGHTFIELD_NAMES:
        p = folder / name
        if p.exists():
            return p
    return None


def _pairs_from_folder(root: Path) -> list[PairSource]:
    subs = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith((".", "_")))
    if not subs:
        raise InputError(
            f"{root}: no object sub-folders; expected one folder per object holding wide.* and "
            "narrow.* (or a CSV object,wide,narrow)"
        )
    out = []
    for sub in subs:
        check_object_id(sub.name, where=f"{sub}: folder name")
        wide, narrow = _find_named(sub, "wide"), _find_named(sub, "narrow")
        if wide is not None and narrow is not None:
            out.append(PairSource(sub.name, wide=wide, narrow=narrow))
            continue
        lf = _find_lightfield(sub)
        if lf is not None and wide is None and narrow is None:
            out.append(PairSource(sub.name, lightfield=lf))
            continue
        missing = (
            "wide.* (wide depth-of-field photo)"
            if wide is None
            else ("narrow.* (narrow depth-of-field photo)")
        )
        raise InputError(f"{sub}: missing {missing}; each object folder needs wide.* and narrow.*")
    return out


def _pairs_from_csv(path: Path) -> list[PairSource]:
    import csv

    from stimuli.tables import unescape_cell

    base = path.parent
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.DictReader(f)
            header = [h.strip() for h in (reader.fieldnames or [])]
            reader.fieldnames = header
            if "object" not in header or not (
                {"wide", "narrow"} <= set(header) or "lightfield" in header
            ):
                raise InputError(
                    f"{path}: expected columns object,wide,narrow[,crop] (or object,lightfield), "
                    f"got {header!r}"
                )
            rows = [(reader.line_num, r) for r in reader]
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text CSV file") from None
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file ({exc})") from None
    out = []
    for line, r in rows:
        r = {k: unescape_cell((v or "").strip()) for k, v in r.items() if k is not None}
        if not any(r.values()):
            continue
        where = f"{path}, line {line}"
        oid = check_object_id(r.get("object", ""), where=f"{where}: field object")
        crop = parse_crop(r.get("crop"), where=f"{where}: field crop")
        wide, narrow, lf = r.get("wide", ""), r.get("narrow", ""), r.get("lightfield", "")
        if wide and narrow:
            out.append(PairSource(oid, wide=base / wide, narrow=base / narrow, crop=crop))
        elif lf and not (wide or narrow):
            out.append(PairSource(oid, lightfield=base / lf, crop=crop))
        else:
            field_name = "narrow" if wide else "wide"
            raise InputError(
                f"{where}: field {field_name} is empty; each row needs both wide and narrow "
                "photos (or a lightfield)"
            )
    if not out:
        raise InputError(f"{path}: no object rows; expected object,wide,narrow lines")
    return out


def read_pairs(pairs: str | os.PathLike) -> PairsInput:
    """Read a PAIRS input: a folder of object sub-folders, or a CSV ``object,wide,narrow[,crop]``.

    Parameters
    ----------
    pairs : str or path-like
        Folder: one sub-folder per object holding ``wide.*`` and ``narrow.*`` (or a
        ``lightfield/`` folder or ``lightfield.npz``), and optionally ``objects.csv``. CSV:
        columns ``object,wide,narrow[,crop]`` or ``object,lightfield``, paths relative to the
        CSV; an ``objects.csv`` beside it is read too.

    Returns
    -------
    PairsInput
        Objects in folder-name order (folder) or file order (CSV); objects missing from
        ``objects.csv`` get default rows.

    Raises
    ------
    InputError
        If the input is missing or empty, a pair lacks a photo, an object id repeats
        (case-insensitively) or ``objects.csv`` is malformed.
    """
    p = Path(pairs)
    if p.is_dir():
        root = p
        sources = _pairs_from_folder(p)
        objects_csv = p / "objects.csv"
    elif p.is_file():
        root = p.parent
        sources = _pairs_from_csv(p)
        objects_csv = p.parent / "objects.csv"
        if objects_csv.resolve() == p.resolve():
            objects_csv = None
    else:
        raise InputError(f"{p}: PAIRS not found; expected a folder of object folders or a CSV")
    seen: dict[str, str] = {}
    for s in sources:
        key = s.object.lower()
        if key in seen:
            raise InputError(
                f"{pairs}: duplicate object id {s.object!r} (also {seen[key]!r}); ids must be "
                "unique"
            )
        seen[key] = s.object
    infos: dict[str, ObjectInfo] = {}
    if objects_csv is not None and objects_csv.is_file():
        for o in read_objects_csv(objects_csv):
            infos[o.object.lower()] = o
        unknown = sorted(set(infos) - set(seen))
        if unknown:
            logger.warning("%s: objects not in PAIRS are ignored: %s", objects_csv, unknown)
    else:
        objects_csv = None
    objects = tuple(infos.get(s.object.lower(), ObjectInfo(s.object)) for s in sources)
    objects = tuple(replace(o, object=s.object) for o, s in zip(objects, sources, strict=True))
    return PairsInput(root=root, sources=tuple(sources), objects=objects, objects_csv=objects_csv)


# --------------------------------------------------------------------------------------------
# pure image steps


def zoom_crop(
    image: np.ndarray, crop: tuple[int, int, int, int] | None, *, where: str = "crop"
) -> np.ndarray:
    """Cut the zoom box ``(x, y, w, h)`` out of a full-resolution image (paper Sec. 4.1).

    Parameters
    ----------
    image : ndarray of shape (rows, cols)
    crop : (x, y, w, h) or None
        Top-left column ``x`` and row ``y``, width and height, pixels; ``None`` = no crop.
    where : str
        Names the field in error messages.

    Returns
    -------
    ndarray
        A copy of the box (the input is not modified).

    Raises
    ------
    InputError
        If the box does not lie inside the image.
    """
    a = np.asarray(image)
    if crop is None:
        return a.copy()
    _check_crop_inside(crop, a.shape[:2], where=where)
    x, y, w, h = crop
    return a[y : y + h, x : x + w].copy()


def _check_crop_inside(
    crop: tuple[int, int, int, int], shape_px: tuple[int, int], *, where: str
) -> None:
    x, y, w, h = crop
    rows, cols = shape_px
    if x < 0 or y < 0 or w <= 0 or h <= 0 or x + w > cols or y + h > rows:
        raise InputError(
            f"{where}: crop box x,y,w,h = {format_crop(crop)} lies outside the "
            f"{cols}x{rows} image (expected x + w <= {cols} and y + h <= {rows})"
        )


def aspect_crop_box(
    shape_px: tuple[int, int], working_shape_px: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """Return the centred box ``(x, y, w, h)`` with the working aspect, or ``None`` if it fits.

    The box keeps the full width or the full height and trims the other side symmetrically
    (the extra pixel of an odd trim goes to the right or bottom).

    Examples
    --------
    >>> aspect_crop_box((1024, 1536), (327, 492))
    (0, 1, 1536, 1021)
    """
    rows, cols = shape_px
    wr, wc = working_shape_px
    aspect = wc / wr
    new_cols = int(np.floor(rows * aspect + 0.5))
    new_rows = int(np.floor(cols / aspect + 0.5))
    if new_cols < cols:
        return ((cols - new_cols) // 2, 0, new_cols, rows)
    if new_rows < rows:
        return (0, (rows - new_rows) // 2, cols, new_rows)
    return None


def to_working_size(image: np.ndarray, working_shape_px: tuple[int, int]) -> np.ndarray:
    """Resize a grey image to the working size with scikit-image's anti-aliased resize.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
        Already cropped to the working aspect.
    working_shape_px : (rows, cols)

    Returns
    -------
    ndarray of shape ``working_shape_px``, float32 in [0, 1]
        ``skimage.transform.resize(image, shape, order=1, anti_aliasing=True)`` (a Gaussian
        pre-filter with sigma ``(scale - 1) / 2`` before bilinear sampling).
    """
    img = check_gray(image)
    shape = tuple(int(v) for v in working_shape_px)
    if img.shape == shape:
        return img.copy()
    out = resize(img, shape, order=1, mode="reflect", anti_aliasing=True)
    return np.clip(out, 0.0, 1.0).astype(np.float32)


def edge_fraction(edges: np.ndarray) -> float:
    """Return the fraction of edge pixels (True) in a bool edge image, in [0, 1]."""
    e = np.asarray(edges)
    if e.dtype != bool:
        raise InputError(f"edges must be a bool image, got dtype {e.dtype}")
    return float(e.mean()) if e.size else 0.0


def _ladder(shape_px: tuple[int, int], windows_px: Sequence[int]) -> list[tuple[int, int, tuple]]:
    """``[(level, window, (rows, cols)), ...]``, level 1 = fewest pixels."""
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
    out = []
    for level, w, shape in _ladder(e.shape, windows_px):
        stim = e.copy() if w == 1 else compress(e, shape, edge_ratio=edge_ratio)
        out.append((level, w, stim))
    return out


def grey_ladder(
    image: np.ndarray, *, levels: int, windows_px: Sequence[int] = jung2015.WINDOWS_PX
) -> list[tuple[int, int, np.ndarray]]:
    """Grey-level compression of a photo at every window (Fig. 2): ``[(level, window, img)]``.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    levels : int >= 2
        Number of grey levels.
    windows_px : sequence of int

    Returns
    -------
    list of (level, window_px, ndarray of float32 in [0, 1])
    """
    img = check_gray(image)
    return [
        (level, w, compress_grey(img, shape, levels=levels))
        for level, w, shape in _ladder(img.shape, windows_px)
    ]


# --------------------------------------------------------------------------------------------
# the build


@dataclass(frozen=True)
class ObjectSummary:
    """What the build did to one object (also recorded in ``stimulus_set.json``)."""

    object: str
    role: str
    sobel_threshold: float | None
    threshold_source: str
    wide_edge_fraction: float | None
    narrow_edge_fraction: float | None
    original_shape_px: tuple[int, int]
    crop: tuple[int, int, int, int] | None
    aspect_crop: tuple[int, int, int, int] | None
    decoded_shape_px: tuple[int, int] | None = None


@dataclass(frozen=True)
class BuildResult:
    """Result of :func:`build_stimulus_set`.

    Parameters
    ----------
    out_dir : Path
        The stimulus-set folder.
    set_id : str
        SHA-256 identifying the set (parameters, object table and input hashes).
    n_stimuli : int
        Rows of ``manifest.csv``.
    edge_ratio : float or None
        Edge ratio used (``None`` in grey mode).
    mean_wide_edge_fraction : float or None
        Mean edge fraction of the main objects' wide-DOF edge images.
    objects : tuple of ObjectSummary
    notes : tuple of str
        Things the user should know (centre crops, upsampling).
    seconds : dict of str to float
        Wall time per stage: ``read``, ``write``, ``total``.
    implants : tuple of str
        Names of the implants whose views were written (``implants/<name>/``).
    n_implant_views : int
        Implant views written: (grid, phosphenes) pairs, one per object, condition and implant.
    """

    out_dir: Path
    set_id: str
    n_stimuli: int
    edge_ratio: float | None
    mean_wide_edge_fraction: float | None
    objects: tuple[ObjectSummary, ...]
    notes: tuple[str, ...] = ()
    seconds: dict[str, float] = field(default_factory=dict)
    implants: tuple[str, ...] = ()
    n_implant_views: int = 0


@dataclass
class _Work:
    """One object's working images (internal, mutable while building)."""

    info: ObjectInfo
    source: PairSource
    wide: np.ndarray
    narrow: np.ndarray
    original_shape_px: tuple[int, int]
    crop: tuple[int, int, int, int] | None
    aspect_crop: tuple[int, int, int, int] | None
    notes: list[str]
    threshold: float | None = None
    threshold_source: str = ""
    wide_edges: np.ndarray | None = None
    narrow_edges: np.ndarray | None = None
    decoded_shape_px: tuple[int, int] | None = None
    plane: str = ""
    focus: np.ndarray | None = None


def _sha256_source(path: Path) -> str:
    if path.is_dir():
        h = hashlib.sha256()
        files = sorted(p for p in path.rglob("*") if p.is_file())
        if not files:
            raise InputError(f"{path}: light-field folder is empty")
        for p in files:
            h.update(f"{p.relative_to(path).as_posix()}:{sha256_file(p)}\n".encode())
        return h.hexdigest()
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    return sha256_file(path)


def _source_hashes(src: PairSource) -> dict[str, str]:
    if src.lightfield is not None:
        if not src.lightfield.exists():
            raise InputError(f"{src.lightfield}: light field of object {src.object!r} not found")
        return {"lightfield": _sha256_source(src.lightfield)}
    out = {}
    for role, p in (("wide", src.wide), ("narrow", src.narrow)):
        assert p is not None
        if not p.is_file():
            raise InputError(
                f"{p}: {role} photo of object {src.object!r} not found (expected a "
                f"{'wide' if role == 'wide' else 'narrow'} depth-of-field image file)"
            )
        out[role] = sha256_file(p)
    return out


def _rel(path: Path, root: Path) -> str:
    """``path`` relative to the PAIRS root; outside it, the file name (with its sha256 beside it,
    that identifies it; an absolute path would name the builder's machine in a shared set)."""
    try:
        return Path(os.path.abspath(path)).relative_to(os.path.abspath(root)).as_posix()
    except ValueError:
        return Path(path).name


def _pairs_record(pairs: Path) -> dict:
    """``stimulus_set.json``'s ``pairs``: the input's name, kind, sha256 (a CSV) and, for
    ``stimuli synth`` output, its generator, seed and version; never a host path."""
    rec: dict = {"name": pairs.name, "kind": "folder" if pairs.is_dir() else "csv"}
    if pairs.is_file():
        rec["sha256"] = sha256_file(pairs)
    synth = pairs / "synth.json"
    if synth.is_file():
        try:
            d = json.loads(synth.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            d = None
        if isinstance(d, dict):
            rec["synth"] = {k: d.get(k) for k in ("generator", "seed", "version")}
    return rec


def _draft_shape(
    full_px: tuple[int, int], region_px: tuple[int, int], working_shape_px: tuple[int, int]
) -> tuple[int, int]:
    """Smallest decode size at which the zoom region still covers the working size."""
    s = max(working_shape_px[0] / region_px[0], working_shape_px[1] / region_px[1])
    return (int(np.ceil(full_px[0] * s)), int(np.ceil(full_px[1] * s)))


def _load_raw(
    src: PairSource, info: ObjectInfo, params: BuildParams, crop: tuple | None
) -> tuple[np.ndarray, np.ndarray, tuple[int, int], tuple[int, int], str]:
    """Return ``(wide, narrow, wide_full_px, narrow_full_px, plane, focus)`` (full = on file).

    ``plane`` describes the confocal plane of a light-field object (provenance), else ``""``;
    ``focus`` is its in-focus mask in the depth de-cluttering mode, else ``None``.
    """
    if src.lightfield is None:
        assert src.wide is not None and src.narrow is not None
        if not params.fast_decode:
            wide, narrow = load_gray(src.wide), load_gray(src.narrow)
            return wide, narrow, wide.shape, narrow.shape, "", None
        full = [image_shape_px(src.wide), image_shape_px(src.narrow)]
        out = []
        for path, f in zip((src.wide, src.narrow), full, strict=True):
            region = f if crop is None else (crop[3], crop[2])
            if crop is not None and f != full[0]:
                region = (crop[3] * f[0] / full[0][0], crop[2] * f[1] / full[0][1])
            draft = _draft_shape(f, (max(region[0], 1), max(region[1], 1)), params.working_shape_px)
            out.append(load_gray(path, draft_shape_px=draft))
        return out[0], out[1], full[0], full[1], "", None
    from stimuli.planes import confocal_plane

    if info.plane_depth_m is None and info.plane_disparity_px is None:
        logger.info("%s: no plane in objects.csv; light-field module picks it", src.object)
    extra = {"focus_mask": True} if params.declutter == "depth" else {}
    plane = confocal_plane(
        src.lightfield,
        depth_m=info.plane_depth_m,
        disparity_px=info.plane_disparity_px,
        **extra,
    )
    where = f"{src.lightfield}: confocal_plane"
    centre = check_gray(plane.centre_view, f"{where} centre view")
    confocal = check_gray(plane.confocal_image, f"{where} image")
    logger.info("%s: confocal image at %s", src.object, plane.describe())
    focus = getattr(plane, "focus_mask", None)
    return centre, confocal, centre.shape, confocal.shape, plane.describe(), focus


def _scale_crop(
    crop: tuple[int, int, int, int] | None, ref_px: tuple[int, int], shape_px: tuple[int, int]
) -> tuple[int, int, int, int] | None:
    """Map a crop box given on an image of size ``ref_px`` to one of size ``shape_px``."""
    if crop is None or tuple(ref_px) == tuple(shape_px):
        return crop
    fy, fx = shape_px[0] / ref_px[0], shape_px[1] / ref_px[1]
    x, y, w, h = crop
    x0, y0 = int(np.floor(x * fx + 0.5)), int(np.floor(y * fy + 0.5))
    x1 = min(shape_px[1], int(np.floor((x + w) * fx + 0.5)))
    y1 = min(shape_px[0], int(np.floor((y + h) * fy + 0.5)))
    return (x0, y0, max(1, x1 - x0), max(1, y1 - y0))


def min_photo_shape_px(params: BuildParams) -> tuple[int, int]:
    """Return the smallest photo ``(rows, cols)`` the builder accepts for ``params``.

    A photo must give at least one pixel per cell of the coarsest level (working size divided
    by the largest window, rounded up) and at least 3x3 for the Sobel filter; anything smaller
    would be upsampled into a stimulus set with no information in it (issue 10: a 1x1 photo).
    """
    w = max(params.windows_px)
    rows, cols = params.working_shape_px
    return max(3, -(-rows // w)), max(3, -(-cols // w))


def _prepare(src: PairSource, info: ObjectInfo, params: BuildParams) -> _Work:
    crop = info.crop if info.crop is not None else src.crop
    wide_raw, narrow_raw, wide_full, narrow_full, plane, focus = _load_raw(src, info, params, crop)
    notes: list[str] = []
    name = src.lightfield if src.lightfield is not None else src.wide
    if tuple(wide_full) != tuple(narrow_full):
        msg = (
            f"{src.object}: wide photo {src.wide} is {wide_full[1]}x{wide_full[0]} "
            f"but narrow photo {src.narrow} is {narrow_full[1]}x{narrow_full[0]}"
        )
        if not params.allow_resize:
            raise InputError(
                f"{msg}; the two photos of a pair must have the same pixel size "
                "(use --allow-resize to resize each on its own)"
            )
        notes.append(msg + "; resized each on its own (--allow-resize)")
    min_px = min_photo_shape_px(params)
    if wide_full[0] < min_px[0] or wide_full[1] < min_px[1]:
        raise InputError(
            f"{name}: photo is {wide_full[1]}x{wide_full[0]} px; expected at least "
            f"{min_px[1]}x{min_px[0]} px (one pixel per cell of the coarsest level at working "
            f"size {params.working_shape_px[1]}x{params.working_shape_px[0]})"
        )
    where = f"object {src.object!r} ({name}): field crop"
    if crop is not None:
        _check_crop_inside(crop, wide_full, where=where)
    wide = zoom_crop(wide_raw, _scale_crop(crop, wide_full, wide_raw.shape), where=where)
    narrow = zoom_crop(narrow_raw, _scale_crop(crop, wide_full, narrow_raw.shape), where=where)
    box = aspect_crop_box(wide.shape, params.working_shape_px)
    out = []
    for img in (wide, narrow):
        b = aspect_crop_box(img.shape, params.working_shape_px)
        if b is not None:
            x, y, w, h = b
            img = img[y : y + h, x : x + w]
        if img.shape[0] < params.working_shape_px[0] or img.shape[1] < params.working_shape_px[1]:
            notes.append(
                f"{src.object}: image {img.shape[1]}x{img.shape[0]} is smaller than the working "
                f"size; upsampled"
            )
        out.append(to_working_size(img, params.working_shape_px))
    if focus is not None:  # the in-focus mask follows the confocal image (zoom, aspect, resize)
        f = zoom_crop(
            focus.astype(np.float32),
            _scale_crop(crop, wide_full, narrow_raw.shape),
            where=where,
        )
        b = aspect_crop_box(f.shape, params.working_shape_px)
        if b is not None:
            x, y, w, h = b
            f = f[y : y + h, x : x + w]
        focus = to_working_size(f, params.working_shape_px) >= 0.5
        plane = f"{plane},declutter=depth"
    return _Work(
        info=info,
        source=src,
        wide=out[0],
        narrow=out[1],
        original_shape_px=tuple(int(v) for v in wide_full),
        crop=crop,
        aspect_crop=box,
        notes=notes,
        decoded_shape_px=tuple(int(v) for v in wide_raw.shape),
        plane=plane,
        focus=focus,
    )


def _edges(work: _Work, params: BuildParams) -> _Work:
    if work.info.sobel_threshold is not None:
        t, t_src = work.info.sobel_threshold, "objects.csv"
    elif params.threshold is not None:
        t, t_src = params.threshold, "global"
    elif params.threshold_method == "retention":
        t = retention_threshold(work.wide, work.narrow)
        t_src = "auto:retention"
    else:
        t = auto_threshold(work.narrow, method=params.threshold_method)
        t_src = f"auto:{params.threshold_method}"
    work.threshold, work.threshold_source = float(t), t_src
    work.wide_edges = declutter(work.wide, threshold=t)
    if work.focus is not None:
        work.narrow_edges = declutter_depth(work.narrow, work.focus, threshold=t)
    else:
        work.narrow_edges = declutter(work.narrow, threshold=t)
        if params.bokeh_guard and work.source.lightfield is None:
            work.narrow_edges = bokeh_guard(work.narrow_edges, work.wide_edges)
    return work


def _git_commit() -> str | None:
    try:
        r = subprocess.run(
            ["git", "-C", str(Path(__file__).resolve().parent), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() or None if r.returncode == 0 else None


def _set_id(
    params: BuildParams,
    inp: PairsInput,
    hashes: list[dict[str, str]],
    implants: Sequence[ImplantLayout] = (),
    px_per_electrode: int = IMPLANT_PX_PER_ELECTRODE,
) -> str:
    blob: dict = {
        "params": params.to_dict(),
        "objects": [o.to_row() for o in inp.objects],
        "sources": [
            {"object": s.object, "kind": s.kind, "crop": format_crop(s.crop), "sha256": h}
            for s, h in zip(inp.sources, hashes, strict=True)
        ],
    }
    if implants:  # a set without implant views keeps the id it had before they existed
        blob["implants"] = {
            "layouts": [lay.to_dict() for lay in implants],
            "px_per_electrode": px_per_electrode,
        }
    return hashlib.sha256(json.dumps(blob, sort_keys=True).encode()).hexdigest()


def _check_out_dir(out_dir: Path, set_id: str, force: bool, replaces: Path | None) -> None:
    check_missing_or_empty(out_dir)
    if replaces is None or force:
        return
    try:
        meta = json.loads((replaces / "stimulus_set.json").read_text(encoding="utf-8"))
        old_id = meta.get("set_id")
    except (OSError, ValueError, AttributeError):
        old_id = None
    if old_id is not None and old_id != set_id:
        raise InputError(
            f"{out_dir}: --out folder already holds a different stimulus set (set_id "
            f"{str(old_id)[:12]}, this build {set_id[:12]}); use --force to replace it"
        )


def _map(fn: Callable, items: Sequence, workers: int, progress: ProgressFn | None, stage: str):
    total = len(items)
    if progress:
        progress(stage, 0, total)
    results = []
    if workers <= 1:
        for i, it in enumerate(items):
            results.append(fn(it))
            if progress:
                progress(stage, i + 1, total)
        return results
    with ThreadPoolExecutor(max_workers=workers) as ex:
        futures = [ex.submit(fn, it) for it in items]
        try:
            for i, fut in enumerate(futures):
                results.append(fut.result())
                if progress:
                    progress(stage, i + 1, total)
        except BaseException:
            # Stopped (a signal) or failed: drop the objects not started, so the caller's
            # cleanup of the temporary folder waits only for the ones being written.
            ex.shutdown(wait=True, cancel_futures=True)
            raise
    return results


def _colour_photos(work: _Work, params: BuildParams) -> tuple[np.ndarray, np.ndarray]:
    """Full-resolution colour photos (wide, narrow) for training (Jung et al. 2015, Sec. 3.1).

    The same zoom crop, aspect crop and anti-aliased resize as the grey images, per channel; a
    light-field object's grey centre view and confocal image on three channels.
    """
    src = work.source
    if src.lightfield is not None:
        return tuple(np.repeat(g[..., None], 3, axis=2) for g in (work.wide, work.narrow))
    out = []
    for path in (src.wide, src.narrow):
        rgb = load_rgb(path)
        crop = _scale_crop(work.crop, work.original_shape_px, rgb.shape[:2])
        if crop is not None:
            x, y, w, h = crop
            rgb = rgb[y : y + h, x : x + w]
        box = aspect_crop_box(rgb.shape[:2], params.working_shape_px)
        if box is not None:
            x, y, w, h = box
            rgb = rgb[y : y + h, x : x + w]
        shape = (*params.working_shape_px, 3)
        rgb = resize(rgb, shape, order=1, mode="reflect", anti_aliasing=True)
        out.append(np.clip(rgb, 0.0, 1.0).astype(np.float32))
    return out[0], out[1]


def _write_object(
    work: _Work,
    tmp: Path,
    params: BuildParams,
    edge_ratio: float | None,
    root: Path,
    hashes: dict[str, str],
    ladder_labels: list[str],
) -> list[StimulusRecord]:
    oid = work.info.object
    folder = tmp / oid
    folder.mkdir()
    src = work.source
    if src.lightfield is not None:
        sources = {
            "cluttered": (_rel(src.lightfield, root) + "#centre", hashes["lightfield"]),
            "decluttered": (
                _rel(src.lightfield, root) + "#confocal@" + work.plane,
                hashes["lightfield"],
            ),
        }
    else:
        sources = {
            "cluttered": (_rel(src.wide, root), hashes["wide"]),
            "decluttered": (_rel(src.narrow, root), hashes["narrow"]),
        }
    sources["photo"] = sources["cluttered"]
    sources["colour_wide"] = sources["cluttered"]
    sources["colour_confocal"] = sources["decluttered"]
    grey = params.mode == "grey"
    common = dict(
        object=oid,
        role=work.info.role,
        sobel_threshold=None if grey else work.threshold,
        edge_ratio=None if grey else edge_ratio,
        mode=params.mode,
        crop=format_crop(work.crop),
        grey_levels=params.grey_levels if grey else None,
        threshold_source="" if grey else work.threshold_source,
    )
    records = []

    def emit(img: np.ndarray, condition: str, level: int, window: int, name: str) -> None:
        path = save_png(img, folder / name)
        h, w = img.shape[:2]
        records.append(
            StimulusRecord(
                condition=condition,
                level=level,
                window=window,
                width=w,
                height=h,
                pixels=w * h,
                path=f"{oid}/{name}",
                sha256=sha256_file(path),
                source=sources[condition][0],
                source_sha256=sources[condition][1],
                **common,
            )
        )

    n_levels = len(params.windows_px)
    emit(work.wide, "photo", n_levels, 1, "photo.png")
    if work.info.role == "training":
        colour_wide, colour_confocal = _colour_photos(work, params)
        emit(colour_wide, "colour_wide", n_levels, 1, "colour_wide.png")
        emit(colour_confocal, "colour_confocal", n_levels, 1, "colour_confocal.png")
    rows = []
    for condition, img, edges in (
        ("cluttered", work.wide, work.wide_edges),
        ("decluttered", work.narrow, work.narrow_edges),
    ):
        if grey:
            ladder = grey_ladder(img, levels=params.grey_levels, windows_px=params.windows_px)
        else:
            ladder = edge_ladder(edges, edge_ratio=edge_ratio, windows_px=params.windows_px)
        for level, window, stim in ladder:
            emit(stim, condition, level, window, f"{condition}_L{level}_w{window:02d}.png")
        rows.append((condition, [s for _, _, s in ladder]))
    sheet = contact_sheet(
        rows,
        column_labels=ladder_labels,
        title=f"{oid}: {work.info.display_name} ({work.info.role}; "
        + ("grey" if grey else f"threshold {work.threshold:.4g}, edge ratio {edge_ratio:.4g}")
        + ")",
    )
    save_contact_sheet(sheet, tmp / "contact" / f"{oid}.png")
    return records


def _check_implants(
    implants: Sequence[ImplantLayout], px_per_electrode: int, params: BuildParams
) -> tuple[ImplantLayout, ...]:
    """Check the implant layouts against each other and the working size, before any writing."""
    out = tuple(implants)
    for lay in out:
        if not isinstance(lay, ImplantLayout):
            raise InputError(f"implants must hold ImplantLayout objects, got {type(lay).__name__}")
    for lay in out:
        if not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", lay.name):
            raise ImplantError(
                f"--implant: layout name {lay.name!r} cannot name a folder in the set; use "
                "letters, digits, '.', '_' or '-' (starting with a letter or digit)"
            )
    names = [lay.name for lay in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ImplantError(
            f"--implant: two layouts are named {twice[0]!r} (a layout's name is its file stem, "
            "which names its folder in the set); rename one file"
        )
    p = px_per_electrode
    if isinstance(p, bool) or not isinstance(p, int) or not 1 <= p <= 256:
        raise InputError(f"implant_px_per_electrode must be an integer in [1, 256], got {p!r}")
    rows, cols = params.working_shape_px
    for lay in out:
        if lay.rows > rows or lay.cols > cols:
            raise ImplantError(
                f"--implant {lay.name}: its {lay.cols}x{lay.rows} grid is finer than the "
                f"{cols}x{rows} working size; use a larger --working-size"
            )
    return out


def _write_implant_views(
    work: _Work,
    tmp: Path,
    implants: Sequence[ImplantLayout],
    edge_ratio: float | None,
    px_per_electrode: int,
) -> list[dict]:
    """Write one object's implant views (grid and phosphene PNGs); return their JSON entries."""
    oid = work.info.object
    images = (
        {"cluttered": work.wide, "decluttered": work.narrow}
        if work.wide_edges is None
        else {"cluttered": work.wide_edges, "decluttered": work.narrow_edges}
    )
    kw = {} if edge_ratio is None else {"edge_ratio": edge_ratio}
    entries = []
    for lay in implants:
        folder = tmp / "implants" / lay.name / oid
        folder.mkdir(parents=True)
        alive = lay.alive_mask()
        shape_px = (lay.rows * px_per_electrode, lay.cols * px_per_electrode)
        for condition in _IMPLANT_CONDITIONS:
            grid = to_implant_grid(images[condition], lay, **kw)
            drawn = render_phosphenes(
                grid, shape_px, shape=lay.phosphene_shape, size=lay.phosphene_size, alive=alive
            )
            entry: dict = {"implant": lay.name, "object": oid, "condition": condition}
            for kind, img in (("grid", grid), ("phosphenes", drawn)):
                name = f"{condition}_{kind}.png"
                path = save_png(img, folder / name)
                entry[kind] = {
                    "path": f"implants/{lay.name}/{oid}/{name}",
                    "sha256": sha256_file(path),
                    "width": int(img.shape[1]),
                    "height": int(img.shape[0]),
                }
            entries.append(entry)
    return entries


def _implants_meta(
    implants: Sequence[ImplantLayout],
    views: list[dict],
    params: BuildParams,
    edge_ratio: float | None,
    px_per_electrode: int,
) -> list[dict]:
    """The ``implants`` entry of ``stimulus_set.json``: each layout in full, with its files."""
    if params.mode == "edges":
        method = (
            f"each condition's edge image at the working size (the window-1 stimulus), "
            f"compressed to the grid: an electrode is on where its window's edge fraction exceeds "
            f"the set's edge ratio {edge_ratio:.6g} (Jung et al. 2015, Sec. 2.2)"
        )
    else:
        method = (
            "each condition's grey photo at the working size, compressed to the grid: window "
            "means quantised to the implant's levels (Jung et al. 2015, Fig. 2)"
        )
    return [
        {
            "name": lay.name,
            "layout": lay.to_dict(),
            "grid_shape_px": [lay.rows, lay.cols],
            "px_per_electrode": px_per_electrode,
            "phosphenes_shape_px": [lay.rows * px_per_electrode, lay.cols * px_per_electrode],
            "resampling": method,
            "edge_ratio": edge_ratio,
            "drawing": "stimuli.implants.render_phosphenes with the layout's phosphene_shape, "
            "phosphene_size and dropout (alive_mask from its seed); square cells",
            "files": [v for v in views if v["implant"] == lay.name],
        }
        for lay in implants
    ]


def build_stimulus_set(
    pairs: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    params: BuildParams | None = None,
    force: bool = False,
    replaces: str | os.PathLike | None = None,
    workers: int | None = None,
    progress: ProgressFn | None = None,
    implants: Sequence[ImplantLayout] = (),
    implant_px_per_electrode: int = IMPLANT_PX_PER_ELECTRODE,
) -> BuildResult:
    """Build a stimulus set from photo pairs (or light fields) into ``out_dir``.

    Parameters
    ----------
    pairs : str or path-like
        PAIRS folder or CSV (see :func:`read_pairs`).
    out_dir : str or path-like
        Stimulus-set folder to write: a new or empty folder (a non-empty one is refused, never
        replaced). Built in a staging folder beside it and renamed at the end; untouched by
        any error.
    params : BuildParams, optional
        Pipeline parameters; defaults are the paper's.
    force : bool
        Build even if ``replaces`` holds a different stimulus set.
    replaces : str or path-like, optional
        A stimulus set the caller moved aside from ``out_dir`` to be replaced by this build
        (``confocal stimuli build`` does so for a set it wrote there before); a different set
        (another ``set_id``) is refused without ``force``.
    workers : int, optional
        Threads for reading and writing (default: the number of CPUs, at most 8).
    progress : callable(stage, done, total), optional
        Called as objects are read (stage ``'read'``) and written (``'write'``), and as their
        implant views are drawn (``'implants'``).
    implants : sequence of ImplantLayout
        Also write each object's two conditions as every one of these implants shows them
        (:func:`stimuli.implants.load_implant`): the image resampled to the electrode grid
        (``implants/<name>/<object>/<condition>_grid.png``) and its phosphenes
        (``<condition>_phosphenes.png``), recorded with sha256 and the full layout under
        ``implants`` in ``stimulus_set.json``.
    implant_px_per_electrode : int in [1, 256]
        Side of each electrode's cell in the phosphene PNGs, px.

    Returns
    -------
    BuildResult

    Raises
    ------
    InputError
        Bad input (missing or unreadable photo, empty folder, duplicate ids, crop outside the
        image, photos of different sizes without ``allow_resize``), an ``out_dir`` that is a
        file or a non-empty folder, or ``replaces`` holding a different set without ``force``.
    ImplantError
        Two implant layouts share a name, or a grid is finer than the working size (checked
        before anything is read or written).

    References
    ----------
    Jung et al. (2015), Sec. 2.2 (de-cluttering, compression) and Sec. 3.1 (stimuli).
    """
    t0 = time.perf_counter()
    params = BuildParams() if params is None else params
    if not isinstance(params, BuildParams):
        raise InputError(f"params must be a BuildParams, got {type(params).__name__}")
    implants = _check_implants(implants, implant_px_per_electrode, params)
    workers = min(8, os.cpu_count() or 1) if workers is None else max(1, int(workers))
    out_dir = Path(out_dir)
    inp = read_pairs(pairs)
    if implants and any(o.object == "implants" for o in inp.objects):
        raise InputError(
            f"{inp.root}: an object is named 'implants', the folder of the implant views; "
            "rename it or build without --implant"
        )
    hashes = [_source_hashes(s) for s in inp.sources]
    set_id = _set_id(params, inp, hashes, implants, implant_px_per_electrode)
    _check_out_dir(out_dir, set_id, force, None if replaces is None else Path(replaces))

    works = _map(
        lambda pair: (
            _edges(_prepare(pair[0], pair[1], params), params)
            if params.mode == "edges"
            else _prepare(pair[0], pair[1], params)
        ),
        list(zip(inp.sources, inp.objects, strict=True)),
        workers,
        progress,
        "read",
    )
    t_read = time.perf_counter()

    mean_wide = None
    edge_ratio = None
    if params.mode == "edges":
        main = [w for w in works if w.info.role == "main"] or works
        mean_wide = float(np.mean([edge_fraction(w.wide_edges) for w in main]))
        edge_ratio = params.edge_ratio if params.edge_ratio is not None else mean_wide
        if edge_ratio >= 1.0:
            raise InputError("edge ratio from the set is 1.0 (every pixel an edge); give one")

    ladder = _ladder(params.working_shape_px, params.windows_px)
    labels = [f"L{lv} {s[1]}x{s[0]} (w{w})" for lv, w, s in ladder]
    tmp = None
    try:
        tmp = new_staging_folder(out_dir)  # its marker is the set's first write
        (tmp / "contact").mkdir()
        per_object = _map(
            lambda wh: _write_object(wh[0], tmp, params, edge_ratio, inp.root, wh[1], labels),
            list(zip(works, hashes, strict=True)),
            workers,
            progress,
            "write",
        )
        records = [r for recs in per_object for r in recs]
        views: list[dict] = []
        if implants:
            per_object_views = _map(
                lambda w: _write_implant_views(
                    w, tmp, implants, edge_ratio, implant_px_per_electrode
                ),
                works,
                workers,
                progress,
                "implants",
            )
            views = [v for vs in per_object_views for v in vs]
        write_manifest(records, tmp / "manifest.csv")
        write_objects_csv(inp.objects, tmp / "objects.csv")
        _write_overview(works, per_object, tmp, labels)
        summaries = tuple(
            ObjectSummary(
                object=w.info.object,
                role=w.info.role,
                sobel_threshold=w.threshold,
                threshold_source=w.threshold_source,
                wide_edge_fraction=None if w.wide_edges is None else edge_fraction(w.wide_edges),
                narrow_edge_fraction=None
                if w.narrow_edges is None
                else edge_fraction(w.narrow_edges),
                original_shape_px=w.original_shape_px,
                crop=w.crop,
                aspect_crop=w.aspect_crop,
                decoded_shape_px=w.decoded_shape_px,
            )
            for w in works
        )
        notes = _notes(works, params)
        meta = {
            "format": SET_FORMAT,
            "format_version": SET_FORMAT_VERSION,
            "set_id": set_id,
            "software": {
                "package": "active-confocal",
                "version": _version(),
                "git_commit": _git_commit(),
            },
            "built_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            "reference": "Jung, Aloni, Yitzhaky & Peli (2015), Vision Research 111, 182-196",
            "parameters": params.to_dict(),
            "edge_ratio": edge_ratio,
            "edge_ratio_source": None
            if edge_ratio is None
            else (
                "given"
                if params.edge_ratio is not None
                else "auto: mean wide-DOF edge fraction of the main objects"
            ),
            "mean_wide_edge_fraction": mean_wide,
            "levels": [
                {"level": lv, "window": w, "width": s[1], "height": s[0], "pixels": s[0] * s[1]}
                for lv, w, s in ladder
            ],
            "pairs": _pairs_record(Path(pairs)),
            "objects_csv": None
            if inp.objects_csv is None
            else {"file": inp.objects_csv.name, "sha256": sha256_file(inp.objects_csv)},
            "objects": [
                {
                    **_summary_dict(s),
                    "kind": src.kind,
                    "sources": {
                        k: {
                            "path": _rel(getattr(src, k), inp.root),
                            "sha256": h[k],
                        }
                        for k in h
                    },
                }
                for s, src, h in zip(summaries, inp.sources, hashes, strict=True)
            ],
            "notes": list(notes),
            "n_stimuli": len(records),
            "manifest_sha256": sha256_file(tmp / "manifest.csv"),
        }
        if implants:
            meta["implants"] = _implants_meta(
                implants, views, params, edge_ratio, implant_px_per_electrode
            )
        (tmp / "stimulus_set.json").write_text(json.dumps(meta, indent=2) + "\n", "utf-8")
        swap_in(tmp, out_dir)
    except BaseException as exc:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise InputError(
                f"{out_dir}: the disk is full ({exc.strerror or exc}) while writing the stimulus "
                f"set; the partial set was removed and {out_dir} was left as it was"
            ) from None
        raise
    t_end = time.perf_counter()
    for n in notes:
        logger.info("%s", n)
    return BuildResult(
        out_dir=out_dir,
        set_id=set_id,
        n_stimuli=len(records),
        edge_ratio=edge_ratio,
        mean_wide_edge_fraction=mean_wide,
        objects=summaries,
        notes=notes,
        seconds={"read": t_read - t0, "write": t_end - t_read, "total": t_end - t0},
        implants=tuple(lay.name for lay in implants),
        n_implant_views=len(views),
    )


def _version() -> str:
    from stimuli import __version__

    return __version__


def _summary_dict(s: ObjectSummary) -> dict:
    d = asdict(s)
    for k in ("original_shape_px", "crop", "aspect_crop", "decoded_shape_px"):
        d[k] = None if d[k] is None else list(d[k])
    return d


def _notes(works: list[_Work], params: BuildParams) -> tuple[str, ...]:
    notes: list[str] = []
    cropped = [w for w in works if w.aspect_crop is not None]
    if cropped:
        rows, cols = params.working_shape_px
        shapes = sorted({(w.aspect_crop[2], w.aspect_crop[3]) for w in cropped})
        notes.append(
            f"centre-cropped {len(cropped)} of {len(works)} objects to the working aspect "
            f"{cols}:{rows} (kept " + ", ".join(f"{a}x{b}" for a, b in shapes) + " px)"
        )
    for w in works:
        notes.extend(w.notes)
    return tuple(notes)


def _write_overview(
    works: list[_Work], per_object: list[list[StimulusRecord]], tmp: Path, labels: list[str]
) -> None:
    from PIL import Image

    rows = []
    for w, recs in zip(works, per_object, strict=True):
        for condition in ("cluttered", "decluttered"):
            imgs = [
                np.asarray(Image.open(tmp / r.path))
                for r in sorted(recs, key=lambda r: r.level)
                if r.condition == condition
            ]
            rows.append((f"{w.info.object} {condition[:5]}", imgs))
    sheet = contact_sheet(
        rows,
        cell_shape_px=(65, 98),
        column_labels=labels,
        title="all objects, every level (cluttered / decluttered)",
    )
    save_contact_sheet(sheet, tmp / "contact" / "all.png")
