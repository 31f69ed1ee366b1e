"""Recorded light fields as active-search scenes: a small TOML file names the targets.

A protocol's ``task.scene`` may name a *scene description* (a ``.toml`` file, resolved from the
protocol's folder, or a light-field folder holding ``scene.toml``). It says where the light
field is and, for each target, its name, the disparity of its plane and its box in the centre
view, so that a recorded capture can be searched, scored and searched by the simulated
searcher (whose model observer learns each target's look from its plane and box)::

    [scene]
    lightfield = "${CONFOCAL_DATA}/lightfield/lytro_illum_2067_epinet"  # or relative to this file
    crop_xywh = [40, 40, 472, 303]   # optional: search this part of every view (vignette off)
    scan_px = [1.5, -0.5]            # optional: nearest and farthest disparity of the depth scan

    [[targets]]
    name = "stegosaurus"
    disparity_px = 0.79              # px per view step (positive = near)
    box_xywh = [32, 51, 495, 318]    # in the recorded view's pixels (before crop_xywh)
    synonyms = ["dinosaur", "toy"]   # optional: words the scorer also accepts
    uses = []                        # optional

``${CONFOCAL_DATA}`` (or ``$CONFOCAL_DATA``) is replaced by that environment variable. Every
field is checked when the session opens; a bad one ends with one line naming the file and field.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiment.protocol import ProtocolError

__all__ = [
    "SCENE_FILE_NAME",
    "SceneTarget",
    "SceneFile",
    "read_scene_file",
    "scene_file_for",
]

#: The description a light-field folder may hold to make it a scene with targets.
SCENE_FILE_NAME = "scene.toml"

_VAR = re.compile(r"\$\{CONFOCAL_DATA\}|\$CONFOCAL_DATA\b")


@dataclass(frozen=True)
class SceneTarget:
    """One target of a recorded scene.

    Parameters
    ----------
    name : str
        What the subject is asked to find (the cue) and should say.
    disparity_px : float
        Disparity of its plane, px per view step (positive = near).
    box_xywh : (x, y, w, h)
        Where it is in the recorded centre view, pixels.
    synonyms, uses : tuple of str
        Other words the scorer counts as naming it, and its uses.
    """

    name: str
    disparity_px: float
    box_xywh: tuple[int, int, int, int]
    synonyms: tuple[str, ...] = ()
    uses: tuple[str, ...] = ()


@dataclass(frozen=True)
class SceneFile:
    """A checked scene description.

    Parameters
    ----------
    path : Path
        The description file.
    lightfield : Path
        The light field it describes (variables replaced, resolved from the file's folder).
    targets : tuple of SceneTarget
    crop_xywh : (x, y, w, h) or None
        Part of every view that is searched (boxes are shifted into it).
    scan_px : (nearest, farthest) or None
        Disparity range of the depth scan, px per view step.
    """

    path: Path
    lightfield: Path
    targets: tuple[SceneTarget, ...]
    crop_xywh: tuple[int, int, int, int] | None = None
    scan_px: tuple[float, float] | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The targets' names, in file order."""
        return tuple(t.name for t in self.targets)


def scene_file_for(name: str, base_dir: str | Path | None = None) -> Path | None:
    """Return the scene description a ``task.scene`` entry names, or None.

    A ``.toml`` entry is a description (resolved from ``base_dir``, the protocol's folder, when
    relative); a folder holding :data:`SCENE_FILE_NAME` has one; anything else (a synthetic
    scene, a plain light field) has none.
    """
    if name.startswith("synthetic:"):
        return None
    p = Path(os.path.expanduser(name))
    if not p.is_absolute() and base_dir is not None and not p.exists():
        p = Path(base_dir) / p
    if p.suffix.lower() == ".toml":
        return p
    if p.is_dir() and (p / SCENE_FILE_NAME).is_file():
        return p / SCENE_FILE_NAME
    return None


def _fail(path: Path, field: str, expected: str, got: Any) -> ProtocolError:
    return ProtocolError(f"{path}: {field} must be {expected}, got {got!r}")


def _ints4(path: Path, field: str, value: Any, *, minimum: int) -> tuple[int, int, int, int]:
    ok = (
        isinstance(value, list)
        and len(value) == 4
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
        and value[0] >= 0
        and value[1] >= 0
        and value[2] >= minimum
        and value[3] >= minimum
    )
    if not ok:
        raise _fail(path, field, f"[x, y, w, h]: 4 integers, x, y >= 0, w, h >= {minimum}", value)
    return tuple(value)  # type: ignore[return-value]


def _number(path: Path, field: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(path, field, "a finite number (px per view step)", value)
    return float(value)


def _words(path: Path, field: str, value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v.strip() for v in value):
        raise _fail(path, field, "a list of non-empty strings", value)
    return tuple(v.strip() for v in value)


def _refuse_unknown(path: Path, table: dict, known: tuple[str, ...], where: str) -> None:
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ProtocolError(
            f"{path}: unknown key {unknown[0]!r} in {where} (expected one of {', '.join(known)})"
        )


def read_scene_file(path: str | Path) -> SceneFile:
    """Read and check a scene description (module docstring); the light field is not loaded.

    Raises
    ------
    ProtocolError
        One line naming the file and the field: a missing or unreadable file, an unknown key,
        a missing or malformed field, a target listed twice, a box outside the crop, a light
        field that is not there.
    """
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ProtocolError(f"{path}: scene description not found") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ProtocolError(f"{path}: not a readable TOML scene description ({exc})") from None
    _refuse_unknown(path, data, ("scene", "targets"), "the file")
    head = data.get("scene")
    if not isinstance(head, dict):
        raise ProtocolError(f"{path}: missing table [scene] (with lightfield = PATH)")
    _refuse_unknown(path, head, ("lightfield", "crop_xywh", "scan_px"), "[scene]")
    raw = head.get("lightfield")
    if not isinstance(raw, str) or not raw.strip():
        raise _fail(path, "scene.lightfield", "the light field's path", raw)
    data_dir = os.environ.get("CONFOCAL_DATA")
    text = _VAR.sub(lambda _m: data_dir if data_dir else "${CONFOCAL_DATA}", raw)
    lf = Path(os.path.expanduser(text))
    if not lf.is_absolute():
        lf = path.parent / lf
    if not lf.exists():
        hint = " (set CONFOCAL_DATA to the shared data folder)" if "CONFOCAL_DATA" in raw else ""
        raise ProtocolError(f"{path}: scene.lightfield {lf}: light field not found{hint}")
    crop = head.get("crop_xywh")
    if crop is not None:
        crop = _ints4(path, "scene.crop_xywh", crop, minimum=16)
    scan = head.get("scan_px")
    if scan is not None:
        if not isinstance(scan, list) or len(scan) != 2:
            raise _fail(path, "scene.scan_px", "[nearest, farthest] disparity", scan)
        scan = (
            _number(path, "scene.scan_px[0]", scan[0]),
            _number(path, "scene.scan_px[1]", scan[1]),
        )
        if not scan[0] > scan[1]:
            raise _fail(
                path, "scene.scan_px", "[nearest, farthest] with nearest > farthest", list(scan)
            )
    rows = data.get("targets")
    if not isinstance(rows, list) or not rows:
        raise ProtocolError(
            f"{path}: needs at least one [[targets]] entry (name, disparity_px, box_xywh)"
        )
    targets = []
    for i, row in enumerate(rows):
        where = f"targets[{i}]"
        if not isinstance(row, dict):
            raise _fail(path, where, "a table", row)
        _refuse_unknown(path, row, ("name", "disparity_px", "box_xywh", "synonyms", "uses"), where)
        for need in ("name", "disparity_px", "box_xywh"):
            if need not in row:
                raise ProtocolError(f"{path}: {where} is missing field {need}")
        name = row["name"]
        if not isinstance(name, str) or not name.strip():
            raise _fail(path, f"{where}.name", "a non-empty string", name)
        box = _ints4(path, f"{where}.box_xywh", row["box_xywh"], minimum=2)
        if crop is not None:
            x, y, w, h = box
            cx, cy, cw, ch = crop
            if x < cx or y < cy or x + w > cx + cw or y + h > cy + ch:
                # a target cut by the crop cannot be shown whole, nor learnt by the model observer
                raise _fail(
                    path, f"{where}.box_xywh", f"inside scene.crop_xywh {list(crop)}", list(box)
                )
        targets.append(
            SceneTarget(
                name.strip(),
                _number(path, f"{where}.disparity_px", row["disparity_px"]),
                box,
                _words(path, f"{where}.synonyms", row.get("synonyms", [])),
                _words(path, f"{where}.uses", row.get("uses", [])),
            )
        )
    names = [t.name for t in targets]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise ProtocolError(f"{path}: targets lists {dup!r} twice")
    return SceneFile(path, lf, tuple(targets), crop, scan)
