"""PAIRS input of a build: discover the object folders or read the CSV, and hash the sources.

A PAIRS input is a folder with one sub-folder per object (``wide.*`` and ``narrow.*`` photos, or
a light field ``lightfield/`` or ``lightfield.npz``) or a CSV ``object,wide,narrow[,crop]`` (or
``object,lightfield``), with an optional ``objects.csv`` beside it.
"""

from __future__ import annotations

import csv
import hashlib
import json
import logging
import os
from dataclasses import dataclass, replace
from pathlib import Path

from stimuli.errors import InputError
from stimuli.io import sha256_file
from stimuli.manifest import ObjectInfo, check_object_id, parse_crop, read_objects_csv
from stimuli.tables import unescape_cell

__all__ = [
    "PairSource",
    "PairsInput",
    "read_pairs",
    "source_hashes",
    "path_in_pairs",
    "pairs_record",
]

logger = logging.getLogger(__name__)

_LIGHTFIELD_NAMES = ("lightfield", "lightfield.npz")


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
        Light-field folder or ``.npz`` file, read by ``stimuli.confocal.confocal_pair``.
    crop : (x, y, w, h) or None
        Crop box from the PAIRS CSV (``objects.csv`` wins when both give one).
    roi_mask : Path or None
        Mask image of the region of interest (``objects.csv`` field ``roi``, resolved).
    """

    object: str
    wide: Path | None = None
    narrow: Path | None = None
    lightfield: Path | None = None
    crop: tuple[int, int, int, int] | None = None
    roi_mask: Path | None = None

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
    from stimuli.lfbatch import discover_captures, is_capture_folder

    subs = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith((".", "_")))
    arrays = sorted(
        p for p in root.iterdir() if p.is_file() and p.suffix.lower() in (".npz", ".npy")
    )
    if is_capture_folder(root) and (arrays or not any(_find_named(s, "wide") for s in subs)):
        try:
            captures = discover_captures(root)
        except InputError:
            captures = []
        # A folder of light-field captures: each sub-folder of views or .npz/.npy file is an
        # object, named after it (object folders with lightfield/ inside are handled below).
        if captures and all(_find_lightfield(c) is None for c in captures if c.is_dir()):
            out = []
            for c in captures:
                oid = c.stem if c.is_file() else c.name
                check_object_id(oid, where=f"{c}: capture name")
                out.append(PairSource(oid, lightfield=c))
            return out
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
    sources = [
        replace(s, roi_mask=root / o.roi) if isinstance(o.roi, str) else s
        for s, o in zip(sources, objects, strict=True)
    ]
    return PairsInput(root=root, sources=tuple(sources), objects=objects, objects_csv=objects_csv)


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


def source_hashes(src: PairSource) -> dict[str, str]:
    """Return the sha256 of an object's sources.

    ``{"wide": ..., "narrow": ...}`` or ``{"lightfield": ...}`` (a folder's hash covers every file's
    name and sha256).

    Raises
    ------
    InputError
        If a source is missing, or a light-field folder is empty.
    """
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
                f"{role} depth-of-field image file)"
            )
        out[role] = sha256_file(p)
    return out


def path_in_pairs(path: Path, root: Path) -> str:
    """Return ``path`` relative to the PAIRS root; outside it, the file name.

    The sha256 recorded beside it identifies a file outside the root; an absolute path would
    name the builder's machine in a shared set.
    """
    try:
        return Path(os.path.abspath(path)).relative_to(os.path.abspath(root)).as_posix()
    except ValueError:
        return Path(path).name


def pairs_record(pairs: Path) -> dict:
    """Return ``stimulus_set.json``'s ``pairs`` entry: where the PAIRS input came from.

    The input's name, kind, sha256 (a CSV) and, for ``stimuli synth`` output, its generator,
    seed and version; never a host path.
    """
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
