"""Reading a stimulus set written by ``confocal stimuli build`` (house style H1, H15).

A stimulus set is a folder with

``manifest.csv`` (one row per image; the columns read here):

============== ======= ===============================================================
column         unit    meaning
============== ======= ===============================================================
object         --      object id (matches ``objects.csv``)
role           --      ``main`` or ``training``
condition      --      ``cluttered``, ``decluttered`` or ``photo`` (full-resolution grey)
level          --      1 = fewest pixels (window 40 px, 12x8) ... 8 = full 492x327
window         px      compression window side
width, height  px      stimulus size (cols, rows)
pixels         px      width x height
path           --      PNG path relative to the folder
sha256         --      SHA-256 of the PNG's bytes, checked before a session starts
============== ======= ===============================================================

``objects.csv`` (``object, name, synonyms, uses, role``; synonyms and uses ``;``-separated) and
``stimulus_set.json`` (provenance; optional for reading).
"""

from __future__ import annotations

import csv
import hashlib
import json
from collections.abc import Iterable
from dataclasses import fields
from pathlib import Path

import numpy as np

from experiment.errors import ConfocalError
from stimuli.errors import InputError
from stimuli.manifest import ManifestEntry, ObjectInfo
from stimuli.tables import unescape_row

__all__ = [
    "StimulusSetError",
    "ObjectInfo",
    "StimulusSet",
    "PHOTO_CONDITIONS",
    "COLOUR_CONDITIONS",
    "decode_stimulus",
]

#: Conditions whose stimuli are photos (float32 in [0, 1]), not binary edge images.
PHOTO_CONDITIONS: tuple[str, ...] = ("photo", "colour_wide", "colour_confocal")
#: Photo conditions shown in colour, (rows, cols, 3) (Jung et al. 2015, Sec. 3.1 training).
COLOUR_CONDITIONS: tuple[str, ...] = ("colour_wide", "colour_confocal")


def decode_stimulus(path: str | Path, condition: str) -> np.ndarray:
    """Read a stimulus file as the presenter takes it, by condition.

    Returns ``bool`` (rows, cols) for edge stimuli, ``float32`` (rows, cols) in [0, 1] for the
    grey photo, ``float32`` (rows, cols, 3) in [0, 1] for colour photos.
    """
    from stimuli.io import load_gray, load_rgb

    if condition in COLOUR_CONDITIONS:
        return load_rgb(path)
    img = load_gray(path)
    return img if condition in PHOTO_CONDITIONS else img >= 0.5


#: Columns the engine requires in ``manifest.csv``: those of :class:`ManifestEntry`, the builder's
#: first ten (the rest are the builder's provenance, which the engine carries but does not need,
#: so stimulus sets made by hand or by other tools need only these).
MANIFEST_COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(ManifestEntry))
OBJECT_COLUMNS = ("object", "name", "synonyms", "uses", "role")


class StimulusSetError(ConfocalError):
    """A stimulus set is missing, malformed or does not match its manifest."""


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def _read_csv(path: Path, required: tuple[str, ...]) -> list[dict[str, str]]:
    if not path.is_file():
        raise StimulusSetError(f"{path}: file not found (is this a stimulus set folder?)")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            cols = reader.fieldnames or []
            missing = [c for c in required if c not in cols]
            if missing:
                raise StimulusSetError(f"{path}: missing column {missing[0]!r}")
            return [unescape_row(r) for r in reader]
    except (UnicodeDecodeError, csv.Error) as exc:
        raise StimulusSetError(f"{path}: not a readable CSV file ({exc})") from None


def _split(text: str) -> tuple[str, ...]:
    return tuple(t.strip() for t in (text or "").split(";") if t.strip())


class StimulusSet:
    """A stimulus set folder: its manifest, objects and images.

    Use :meth:`load`; ``records`` are in manifest order.
    """

    def __init__(
        self,
        root: Path,
        records: tuple[ManifestEntry, ...],
        objects: dict[str, ObjectInfo],
        manifest_sha256: str,
        info: dict,
    ) -> None:
        self.root = Path(root)
        self.records = records
        self.objects = objects
        self.manifest_sha256 = manifest_sha256
        self.info = info
        self._index = {(r.object, r.condition, r.level): r for r in records}

    @classmethod
    def load(cls, root: str | Path) -> StimulusSet:
        """Read ``manifest.csv``, ``objects.csv`` and ``stimulus_set.json`` from ``root``.

        Raises
        ------
        StimulusSetError
            The folder or a file is missing, a column is missing, a value is malformed or an
            object of the manifest is not in ``objects.csv``.
        """
        root = Path(root)
        if not root.is_dir():
            raise StimulusSetError(f"{root}: stimulus set folder not found")
        manifest = root / "manifest.csv"
        rows = _read_csv(manifest, MANIFEST_COLUMNS)
        records = []
        for i, row in enumerate(rows, start=2):
            try:
                rec = ManifestEntry(
                    object=row["object"].strip(),
                    role=row["role"].strip(),
                    condition=row["condition"].strip(),
                    level=int(row["level"]),
                    window=int(row["window"]),
                    width=int(row["width"]),
                    height=int(row["height"]),
                    pixels=int(row["pixels"]),
                    path=row["path"].strip(),
                    sha256=row["sha256"].strip().lower(),
                )
            except (TypeError, ValueError):
                raise StimulusSetError(
                    f"{manifest}: line {i}: level/window/width/height/pixels must be integers"
                ) from None
            records.append(rec)
        if not records:
            raise StimulusSetError(f"{manifest}: no stimuli listed")
        inside = root.resolve()
        for i, rec in enumerate(records, start=2):
            # paths may not reach outside the set: no absolute paths, '..' or symlinks out
            if Path(rec.path).is_absolute() or not (inside / rec.path).resolve().is_relative_to(
                inside
            ):
                raise StimulusSetError(
                    f"{manifest}: line {i}: field path {rec.path!r} points outside the stimulus "
                    f"set {root}; expected a file inside the set folder"
                )
        objects = {}
        for row in _read_csv(root / "objects.csv", OBJECT_COLUMNS):
            try:
                o = ObjectInfo(
                    object=row["object"].strip(),
                    name=row["name"].strip(),
                    synonyms=_split(row["synonyms"]),
                    uses=_split(row["uses"]),
                    role=row["role"].strip(),
                )
            except InputError as exc:  # the record's own check names the column
                where = str(root / "objects.csv")
                raise StimulusSetError(str(exc).replace("objects.csv", where, 1)) from None
            objects[o.object] = o
        for r in records:
            if r.object not in objects:
                raise StimulusSetError(
                    f"{root / 'objects.csv'}: object {r.object!r} of the manifest is not listed"
                )
        info: dict = {}
        info_path = root / "stimulus_set.json"
        if info_path.is_file():
            try:
                info = json.loads(info_path.read_text(encoding="utf-8"))
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise StimulusSetError(f"{info_path}: not valid JSON ({exc})") from None
        return cls(root.resolve(), tuple(records), objects, _sha256(manifest), info)

    def object_ids(self, role: str) -> tuple[str, ...]:
        """Return the ids of the objects with ``role`` in ``objects.csv``, in file order."""
        return tuple(o.object for o in self.objects.values() if o.role == role)

    def levels(self) -> tuple[int, ...]:
        """Return the levels present in the manifest, ascending."""
        return tuple(sorted({r.level for r in self.records}))

    def get(self, object_id: str, condition: str, level: int) -> ManifestEntry:
        """Return the record of one image.

        Raises
        ------
        StimulusSetError
            No such image in the manifest (names object, condition and level).
        """
        try:
            return self._index[(object_id, condition, level)]
        except KeyError:
            raise StimulusSetError(
                f"{self.root / 'manifest.csv'}: no stimulus for object {object_id!r}, "
                f"condition {condition!r}, level {level}"
            ) from None

    def verify(self, records: Iterable[ManifestEntry] | None = None) -> int:
        """Check every file's SHA-256 against the manifest; return how many were checked.

        Raises
        ------
        StimulusSetError
            A file is missing or changed (names the file, expected and found hashes).
        """
        n = 0
        for r in self.records if records is None else records:
            p = self.root / r.path
            if not p.is_file():
                raise StimulusSetError(f"{p}: stimulus file listed in manifest.csv is missing")
            found = _sha256(p)
            if found != r.sha256:
                raise StimulusSetError(
                    f"{p}: stimulus file changed: sha256 {found[:12]}... does not match "
                    f"manifest.csv ({r.sha256[:12]}...); refusing to start"
                )
            n += 1
        return n

    def load_image(self, record: ManifestEntry) -> np.ndarray:
        """Return the image (see :func:`decode_stimulus`)."""
        return decode_stimulus(self.root / record.path, record.condition)
