"""Stimulus-set tables: ``objects.csv`` and ``manifest.csv`` read and write (house style H15).

``objects.csv`` (optional in a PAIRS input; always written into a stimulus set)
-------------------------------------------------------------------------------

==================  ==========================================================================
column              meaning
==================  ==========================================================================
object              object id; also the name of its folder in PAIRS and in the stimulus set
name                display name (default: the object id)
synonyms            accepted names, ``;``-separated (scoring uses them)
uses                accepted uses, ``;``-separated (describing the use counted, Sec. 3.1)
role                ``main`` (default) or ``training`` (the 3 training objects, Sec. 3.1)
sobel_threshold     Sobel threshold for this object (scale of ``sobel_magnitude``); empty = auto
crop                zoom box ``x,y,w,h`` in full-resolution pixels of the photo; empty = none
plane_depth_m       light-field objects: depth of the confocal plane, metres; empty = none
plane_disparity_px  light-field objects: disparity of the plane, pixels per view step
roi                 light-field objects: region of interest the plane is taken from, a box
                    ``x,y,w,h`` in full-resolution pixels of the centre view (before
                    ``crop``), or a mask image (non-zero = region, centre-view size) relative
                    to the ``objects.csv`` folder; empty = none. Written only when used.
==================  ==========================================================================

``manifest.csv`` (one row per stimulus)
---------------------------------------

==============  ==============================================================================
column          meaning
==============  ==============================================================================
object          object id
role            ``main`` or ``training``
condition       ``cluttered`` (wide DOF), ``decluttered`` (narrow DOF), ``photo``, or a
                de-clutter method's name (``--conditions``, :mod:`stimuli.methods`)
level           1 (fewest pixels, window 40) ... 8 (full, window 1); ``photo`` rows are 8
window          compression window, pixels of the working image (1 = none)
width, height   stimulus size, pixels
pixels          ``width * height``
path            PNG file, relative to the stimulus-set folder
sha256          SHA-256 of the PNG file
sobel_threshold threshold used for this object (empty in grey mode)
edge_ratio      edge ratio of the set (empty in grey mode)
source          input photo (or light field) the stimulus was made from
source_sha256   SHA-256 of that input (of the sorted file hashes for a folder)
mode            ``edges`` (binary) or ``grey``
crop            zoom box ``x,y,w,h`` applied at full resolution; empty = none
grey_levels     number of grey levels in grey mode; empty in edges mode
threshold_source where the threshold came from: ``objects.csv``, ``global`` or ``auto:<method>``
==============  ==============================================================================
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

from stimuli.errors import InputError
from stimuli.tables import unescape_cell, write_table

__all__ = [
    "OBJECTS_COLUMNS",
    "MANIFEST_COLUMNS",
    "CONDITIONS",
    "ROLES",
    "ObjectInfo",
    "ManifestEntry",
    "StimulusRecord",
    "parse_crop",
    "format_crop",
    "check_object_id",
    "read_objects_csv",
    "write_objects_csv",
    "read_manifest",
    "write_manifest",
]

#: Columns of ``objects.csv``, in order.
OBJECTS_COLUMNS: tuple[str, ...] = (
    "object",
    "name",
    "synonyms",
    "uses",
    "role",
    "sobel_threshold",
    "crop",
    "plane_depth_m",
    "plane_disparity_px",
    "roi",
)

#: Columns of ``manifest.csv``, in order.
MANIFEST_COLUMNS: tuple[str, ...] = (
    "object",
    "role",
    "condition",
    "level",
    "window",
    "width",
    "height",
    "pixels",
    "path",
    "sha256",
    "sobel_threshold",
    "edge_ratio",
    "source",
    "source_sha256",
    "mode",
    "crop",
    "grey_levels",
    "threshold_source",
)

#: Stimulus conditions: wide-DOF edges, narrow-DOF edges, the grey wide-DOF photo, and the
#: full-resolution colour photos of training objects, wide-DOF and confocal (Sec. 3.1).
CONDITIONS: tuple[str, ...] = (
    "cluttered",
    "decluttered",
    "photo",
    "colour_wide",
    "colour_confocal",
)
#: Object roles: the 20 test objects and the 3 training objects (Sec. 3.1).
ROLES: tuple[str, ...] = ("main", "training")

#: A condition named after a de-clutter method (:mod:`stimuli.methods`): lower-case letters,
#: digits and ``_``, starting with a letter.
_METHOD_RE = re.compile(r"^[a-z][a-z0-9_]{0,31}$")

_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


def check_object_id(object_id: str, *, where: str) -> str:
    """Return ``object_id`` if it is a safe folder name, else raise naming ``where``.

    Ids are used as folder and file names, so they may hold letters, digits, ``.``, ``_`` and
    ``-``, must start with a letter or digit, and have at most
    :data:`stimuli.resources.MAX_ID_CHARS` characters.
    """
    from stimuli.resources import MAX_ID_CHARS

    if isinstance(object_id, str) and len(object_id) > MAX_ID_CHARS:
        raise InputError(
            f"{where}: object id must be at most {MAX_ID_CHARS} characters, got "
            f"{len(object_id)} ({object_id[:20]!r}...)"
        )
    if not isinstance(object_id, str) or not _ID_RE.match(object_id):
        raise InputError(
            f"{where}: object id must be letters, digits, '.', '_' or '-' (starting with a letter "
            f"or digit), got {object_id!r}"
        )
    return object_id


def parse_crop(text: str | None, *, where: str) -> tuple[int, int, int, int] | None:
    """Parse a crop box ``"x,y,w,h"`` (full-resolution pixels); empty text gives ``None``.

    Parameters
    ----------
    text : str or None
        ``x,y`` is the top-left corner (column, row), ``w,h`` the width and height, pixels.
    where : str
        Names the file and field in error messages.

    Returns
    -------
    (x, y, w, h) or None

    Raises
    ------
    InputError
        If the text is not four integers with ``x, y >= 0`` and ``w, h > 0``.

    Examples
    --------
    >>> parse_crop("10, 20, 300, 200", where="crop")
    (10, 20, 300, 200)
    """
    if text is None or str(text).strip() == "":
        return None
    parts = [p.strip() for p in str(text).split(",")]
    try:
        if len(parts) != 4:
            raise ValueError
        x, y, w, h = (int(p) for p in parts)
    except ValueError:
        raise InputError(
            f"{where}: crop must be 'x,y,w,h' (four integers, full-resolution pixels), got {text!r}"
        ) from None
    if x < 0 or y < 0 or w <= 0 or h <= 0:
        raise InputError(f"{where}: crop must have x, y >= 0 and w, h > 0, got {text!r}")
    return (x, y, w, h)


def format_crop(crop: tuple[int, int, int, int] | None) -> str:
    """Format a crop box as ``"x,y,w,h"`` (empty string for ``None``)."""
    return "" if crop is None else ",".join(str(int(v)) for v in crop)


def _parse_float(text: str | None, *, where: str, minimum: float | None = None) -> float | None:
    if text is None or str(text).strip() == "":
        return None
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{where}: expected a number, got {text!r}") from None
    if not math.isfinite(v) or (minimum is not None and v < minimum):
        bound = "" if minimum is None else f" >= {minimum:g}"
        raise InputError(f"{where}: expected a finite number{bound}, got {text!r}")
    return v


def _split_list(text: str | None) -> tuple[str, ...]:
    if not text:
        return ()
    return tuple(p.strip() for p in str(text).split(";") if p.strip())


def _fmt(v: object) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, tuple):
        return ";".join(str(x) for x in v)
    return str(v)


@dataclass(frozen=True)
class ObjectInfo:
    """One row of ``objects.csv``, parsed and checked.

    Each field is the column of the same name in the module docstring's table; an empty cell
    takes the field's default. ``synonyms`` and ``uses`` are tuples, ``crop`` and a box ``roi``
    are ``(x, y, w, h)`` tuples, and a mask ``roi`` is its path as written.
    """

    object: str
    name: str = ""
    synonyms: tuple[str, ...] = ()
    uses: tuple[str, ...] = ()
    role: str = "main"
    sobel_threshold: float | None = None
    crop: tuple[int, int, int, int] | None = None
    plane_depth_m: float | None = None
    plane_disparity_px: float | None = None
    roi: tuple[int, int, int, int] | str | None = None

    def __post_init__(self) -> None:
        check_object_id(self.object, where="objects.csv: object")
        if self.role not in ROLES:
            raise InputError(
                f"objects.csv: object {self.object!r}: role must be one of {ROLES}, "
                f"got {self.role!r}"
            )
        if self.sobel_threshold is not None and not (
            math.isfinite(self.sobel_threshold) and self.sobel_threshold >= 0
        ):
            raise InputError(
                f"objects.csv: object {self.object!r}: sobel_threshold must be a number >= 0, "
                f"got {self.sobel_threshold!r}"
            )
        if self.plane_depth_m is not None and not self.plane_depth_m > 0:
            raise InputError(
                f"objects.csv: object {self.object!r}: plane_depth_m must be > 0, "
                f"got {self.plane_depth_m!r}"
            )

    @property
    def display_name(self) -> str:
        """The display name, or the object id when no name is given."""
        return self.name or self.object

    def to_row(self) -> dict[str, str]:
        """Return the ``objects.csv`` row as strings."""
        return {
            "object": self.object,
            "name": self.display_name,
            "synonyms": _fmt(self.synonyms),
            "uses": _fmt(self.uses),
            "role": self.role,
            "sobel_threshold": _fmt(self.sobel_threshold),
            "crop": format_crop(self.crop),
            "plane_depth_m": _fmt(self.plane_depth_m),
            "plane_disparity_px": _fmt(self.plane_disparity_px),
        } | ({} if self.roi is None else {"roi": _format_roi(self.roi)})

    @classmethod
    def from_row(cls, row: dict[str, str | None], *, where: str) -> ObjectInfo:
        """Build from an ``objects.csv`` row; ``where`` names the file and line in errors."""
        oid = (row.get("object") or "").strip()
        check_object_id(oid, where=f"{where}: field object")
        role = (row.get("role") or "").strip() or "main"
        if role not in ROLES:
            raise InputError(f"{where}: field role must be one of {ROLES}, got {role!r}")
        return cls(
            object=oid,
            name=(row.get("name") or "").strip(),
            synonyms=_split_list(row.get("synonyms")),
            uses=_split_list(row.get("uses")),
            role=role,
            sobel_threshold=_parse_float(
                row.get("sobel_threshold"), where=f"{where}: field sobel_threshold", minimum=0.0
            ),
            crop=parse_crop(row.get("crop"), where=f"{where}: field crop"),
            plane_depth_m=_parse_float(
                row.get("plane_depth_m"), where=f"{where}: field plane_depth_m", minimum=0.0
            ),
            plane_disparity_px=_parse_float(
                row.get("plane_disparity_px"), where=f"{where}: field plane_disparity_px"
            ),
            roi=_parse_roi(row.get("roi"), where=f"{where}: field roi"),
        )


def _parse_roi(text: str | None, *, where: str) -> tuple[int, int, int, int] | str | None:
    """Return a box ``x,y,w,h`` (has a comma) or a mask image's path; empty gives ``None``."""
    if text is None or str(text).strip() == "":
        return None
    t = str(text).strip()
    if "," in t:
        box = parse_crop(t, where=where)
        return box
    if not t.lower().endswith((".png", ".bmp", ".tif", ".tiff")):
        raise InputError(
            f"{where}: roi must be a box 'x,y,w,h' (centre-view pixels) or a mask image "
            f"(.png, .bmp, .tif), got {text!r}"
        )
    return t


def _format_roi(roi: tuple[int, int, int, int] | str) -> str:
    return roi if isinstance(roi, str) else format_crop(roi)


def _read_csv_rows(path: Path, required: Iterable[str]) -> list[tuple[int, dict[str, str]]]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            reader = csv.DictReader(f)
            header = [h.strip() for h in (reader.fieldnames or [])]
            reader.fieldnames = header
            missing = [c for c in required if c not in header]
            if missing:
                raise InputError(
                    f"{path}: missing column(s) {', '.join(missing)}; header is {header!r}"
                )
            return [
                (
                    reader.line_num,
                    {k: unescape_cell(v or "") for k, v in r.items() if k is not None},
                )
                for r in reader
            ]
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text CSV file") from None
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file ({exc})") from None


def read_objects_csv(path: str | os.PathLike) -> list[ObjectInfo]:
    """Read ``objects.csv``; only the ``object`` column is required.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    list of ObjectInfo
        In file order.

    Raises
    ------
    InputError
        If the file is missing, a field is malformed, or an object id occurs twice
        (ids compare case-insensitively, as folder names do on some file systems).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: objects.csv not found")
    out: list[ObjectInfo] = []
    seen: dict[str, int] = {}
    for line, row in _read_csv_rows(path, ["object"]):
        if not any(v.strip() for v in row.values()):
            continue
        info = ObjectInfo.from_row(row, where=f"{path}, line {line}")
        key = info.object.lower()
        if key in seen:
            raise InputError(
                f"{path}, line {line}: duplicate object id {info.object!r} "
                f"(first on line {seen[key]})"
            )
        seen[key] = line
        out.append(info)
    return out


def write_objects_csv(objects: Iterable[ObjectInfo], path: str | os.PathLike) -> Path:
    """Write ``objects.csv`` with :data:`OBJECTS_COLUMNS`, atomically; return the path.

    The ``roi`` column is written only when an object has a region of interest, so a set
    without one keeps the file it had before the column existed.
    """
    rows = [o.to_row() for o in objects]
    cols = OBJECTS_COLUMNS if any("roi" in r for r in rows) else OBJECTS_COLUMNS[:-1]
    return write_table(path, [{"roi": ""} | r for r in rows], cols)


@dataclass(frozen=True)
class ManifestEntry:
    """The first ten columns of a ``manifest.csv`` row: which image, and its file.

    A stimulus set made by hand or by another tool needs only these; the experiment reads them
    (see the module docstring for the columns).
    """

    object: str
    role: str
    condition: str
    level: int
    window: int
    width: int
    height: int
    pixels: int
    path: str
    sha256: str


@dataclass(frozen=True)
class StimulusRecord(ManifestEntry):
    """One row of ``manifest.csv`` (see the module docstring for the columns)."""

    sobel_threshold: float | None
    edge_ratio: float | None
    source: str
    source_sha256: str
    mode: str
    crop: str = ""
    grey_levels: int | None = None
    threshold_source: str = ""

    def __post_init__(self) -> None:
        if self.condition not in CONDITIONS and not _METHOD_RE.match(self.condition):
            raise InputError(
                f"condition must be one of {CONDITIONS} or a de-clutter method's name, got "
                f"{self.condition!r}"
            )
        if self.pixels != self.width * self.height:
            raise InputError(
                f"pixels must equal width * height, got {self.pixels} for "
                f"{self.width}x{self.height}"
            )

    def to_row(self) -> dict[str, str]:
        """Return the manifest row as strings."""
        return {k: _fmt(v) for k, v in asdict(self).items()}


#: Manifest columns a reader may find missing (added after the first contract); defaults apply.
_OPTIONAL_COLUMNS = {"grey_levels", "threshold_source"}
_INT_FIELDS = {"level", "window", "width", "height", "pixels"}
_OPT_FLOAT_FIELDS = {"sobel_threshold", "edge_ratio"}


def read_manifest(path: str | os.PathLike) -> list[StimulusRecord]:
    """Read ``manifest.csv`` back into records (inverse of :func:`write_manifest`).

    Raises
    ------
    InputError
        If the file is missing, lacks a column or a numeric field is malformed.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: manifest.csv not found")
    names = [f.name for f in fields(StimulusRecord)]
    required = [n for n in MANIFEST_COLUMNS if n not in _OPTIONAL_COLUMNS]
    out = []
    for line, row in _read_csv_rows(path, required):
        kw: dict[str, object] = {}
        for n in names:
            v = row.get(n, "")
            where = f"{path}, line {line}: field {n}"
            if n in _INT_FIELDS:
                try:
                    kw[n] = int(v)
                except ValueError:
                    raise InputError(f"{where}: expected an integer, got {v!r}") from None
            elif n in _OPT_FLOAT_FIELDS:
                kw[n] = _parse_float(v, where=where)
            elif n == "grey_levels":
                kw[n] = int(v) if v.strip() else None
            else:
                kw[n] = v
        out.append(StimulusRecord(**kw))  # type: ignore[arg-type]
    return out


def write_manifest(records: Iterable[StimulusRecord], path: str | os.PathLike) -> Path:
    """Write ``manifest.csv`` with :data:`MANIFEST_COLUMNS`, atomically; return the path."""
    return write_table(path, [r.to_row() for r in records], MANIFEST_COLUMNS)
