"""Light-field loaders by format: a folder of views, an array file, or an elemental image.

Inputs
------
* a folder of views named by grid position: ``..._{row}_{col}.png`` (e.g. Lytro/EPINET
  ``2067_05_05.png``), a 1-D row ``view0.png .. viewN.png`` (Middlebury; one row, ``n_u = 1``),
  HCI's ``input_CamNNN.png`` (``NNN = 9 * row + col``), or any name pattern given as a format
  string with fields ``{row}``, ``{col}`` or ``{index}`` (``index`` needs ``grid_cols``); a
  width (``{row:02d}``) matches exactly that many digits and ``*`` matches anything;
* an ``.npy`` file holding the 4-D (or 5-D) array, or an ``.npz`` with key ``views``; the shape
  is checked against ``(n_u, n_v, rows, cols[, C])`` (``axes`` reads other orders);
* a lens-array elemental image (one picture) with its lenslet pitch in pixels, an optional
  invalid border per lenslet and the offset of the first whole lenslet (partial lenslets at
  the far edges are dropped); :meth:`LightField.view_binned` averages neighbouring views.

16-bit images are scaled by their bit depth (the smallest that holds the largest value, or
``bit_depth``), and an alpha channel is composited over ``background``. Every error names the
file.

An optional TOML file beside the input (``<name>.toml`` or ``lightfield.toml`` in the folder;
for a folder of views, ``lightfield.toml`` inside it) gives the geometry and loader options::

    [geometry]                # camera array ...
    kind = "camera_array"
    focal_length_px = 600.0
    baseline_m = 0.01         # distance between neighbouring views
    near_m = 0.5              # optional: range of depths the geometry allows
    far_m = 20.0
    [geometry]                # ... or lens array
    kind = "lens_array"
    lens_pitch_mm = 1.0
    lens_focal_mm = 3.0
    relay_minification = 40.0
    pixel_mm = 0.1
    [views]
    pattern = "scene_{row:02d}_{col:02d}.png"
    grid_cols = 9             # for {index} patterns
    [elemental]
    pitch_px = 10
    border_px = 0
"""

from __future__ import annotations

import json
import logging
import math
import os
import re
import tomllib
import zipfile
import zlib
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from stimuli.elemental import views_from_elemental
from stimuli.errors import InputError
from stimuli.io import luma
from stimuli.lfviews import Geometry, LightField

__all__ = ["load_lightfield", "as_lightfield", "ARRAY_AXES", "HCI_GRID_COLS"]

log = logging.getLogger(__name__)

_IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".ppm", ".pgm"}

#: Built-in view-name patterns tried in order on a folder (ours): (regex on the file stem, kind).
_DEFAULT_PATTERNS: tuple[tuple[str, str], ...] = (
    (r"^input_Cam(?P<index>\d+)$", "hci"),
    (r"^view(?P<index>\d+)$", "row"),
    (r"^(?:.*[_-])?(?P<row>\d+)[_-](?P<col>\d+)$", "grid"),
)

#: HCI 4D light-field benchmark: cameras numbered row by row on a 9x9 grid (Honauer et al. 2016).
HCI_GRID_COLS = 9


def _read_toml(path: Path) -> dict:
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8; a Latin-1 or UTF-16 file is not
        bad = exc.object[exc.start : exc.start + 1]
        raise InputError(
            f"{path}: not valid TOML (not UTF-8 text: byte {exc.start} is {bad!r}); save it as "
            "UTF-8"
        ) from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except RecursionError:  # tomllib parses nested tables and arrays recursively
        raise InputError(f"{path}: not valid TOML (tables or arrays nested too deeply)") from None


def _find_toml(path: Path) -> Path | None:
    candidates = (
        [path / "lightfield.toml"]
        if path.is_dir()
        else [path.with_suffix(".toml"), path.parent / "lightfield.toml"]
    )
    for c in candidates:
        if c.is_file():
            return c
    return None


def _pattern_to_regex(pattern: str) -> re.Pattern:
    """Turn ``"img_{row:02d}_{col}_*.png"`` into a regex with named integer groups.

    A format width (``{row:02d}``) matches exactly that many digits, so ``{row:02d}{col:02d}``
    reads ``0101``; ``*`` matches any run of characters (``out_{row}_{col}_*`` reads
    ``out_09_08_-12.3_45.6_``).
    """
    stem = Path(pattern).stem if Path(pattern).suffix.lower() in _IMAGE_SUFFIXES else pattern
    out, pos = "", 0
    fields = set()

    def literal(text: str) -> str:
        return ".*?".join(re.escape(part) for part in text.split("*"))

    for m in re.finditer(r"\{(\w+)(?::([^}]*))?\}", stem):
        out += literal(stem[pos : m.start()])
        name, spec = m.group(1), m.group(2) or ""
        if name not in ("row", "col", "index"):
            raise InputError(
                f"view name pattern {pattern!r}: unknown field {{{name}}}; "
                "use {row} and {col}, or {index}"
            )
        width = re.fullmatch(r"0?(\d*)d?", spec)
        if width is None:
            raise InputError(
                f"view name pattern {pattern!r}: field {{{m.group(0)[1:-1]}}} must be an integer "
                "format such as {row}, {row:d} or {row:02d}"
            )
        fields.add(name)
        digits = f"\\d{{{int(width.group(1))}}}" if width.group(1) else "\\d+"
        out += f"(?P<{name}>{digits})"
        pos = m.end()
    out += literal(stem[pos:])
    if not (fields == {"row", "col"} or fields == {"index"}):
        raise InputError(
            f"view name pattern {pattern!r} must contain {{row}} and {{col}}, or {{index}}"
        )
    return re.compile(f"^{out}$")


def _match_views(
    files: list[Path], pattern: str | None, grid_cols: int | None
) -> dict[tuple[int, int], Path]:
    """Map grid positions (row, col) to files."""
    if pattern is not None:
        candidates = [(_pattern_to_regex(pattern), "custom")]
    else:
        candidates = [(re.compile(rx), kind) for rx, kind in _DEFAULT_PATTERNS]
    for rx, kind in candidates:
        found: dict[tuple[int, int], Path] = {}
        for f in files:
            m = rx.match(f.stem)
            if not m:
                continue
            g = m.groupdict()
            if "index" in g and g["index"] is not None:
                idx = int(g["index"])
                if kind == "row":
                    pos = (0, idx)
                else:
                    cols = (
                        grid_cols
                        if grid_cols is not None
                        else (HCI_GRID_COLS if kind == "hci" else None)
                    )
                    if cols is None:
                        pos = (0, idx)
                    else:
                        pos = divmod(idx, cols)
            else:
                pos = (int(g["row"]), int(g["col"]))
            if pos in found:
                raise InputError(f"two views at grid position {pos}: {found[pos].name}, {f.name}")
            found[pos] = f
        if found:
            return found
    return {}


def _check_grid(found: dict[tuple[int, int], Path], where: Path) -> tuple[list[int], list[int]]:
    rows = sorted({p[0] for p in found})
    cols = sorted({p[1] for p in found})
    for name, idx in (("row", rows), ("column", cols)):
        gaps = sorted(set(range(idx[0], idx[-1] + 1)) - set(idx))
        if gaps:
            raise InputError(
                f"{where}: the view grid has holes: no view at {name} index {gaps} "
                f"(found {name}s {idx[0]}..{idx[-1]})"
            )
    missing = [(r, c) for r in rows for c in cols if (r, c) not in found]
    if missing:
        shown = ", ".join(f"({r}, {c})" for r, c in missing[:5])
        more = f" and {len(missing) - 5} more" if len(missing) > 5 else ""
        raise InputError(
            f"{where}: missing views at grid positions {shown}{more} "
            f"(grid {len(rows)}x{len(cols)}, {len(found)} views found)"
        )
    return rows, cols


def _read_raw(path: Path) -> np.ndarray:
    """One view as stored: uint8, uint16 or float32; (rows, cols[, C]) with C in 1..4."""
    from stimuli.io import _open, _pil_to_array

    return _pil_to_array(_open(path))


def _on_threads(fn, items: list) -> list:
    """Return ``[fn(x) for x in items]``, on up to 8 threads.

    No more threads than the CPUs this process may use; PIL and numpy release the GIL while they
    decode and convert views.
    """
    n = min(len(items), len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)
    if n < 2:
        return [fn(x) for x in items]
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(min(n, 8)) as ex:
        return list(ex.map(fn, items))


def _read_all(paths: list[Path]) -> list[np.ndarray]:
    """:func:`_read_raw` of every path, in order, decoded on threads."""
    return _on_threads(_read_raw, paths)


#: Image modes whose samples are 8-bit: their scale to [0, 1] is 1/255 whatever the other
#: views hold, so some views can be read without the others.
_EIGHT_BIT_MODES = frozenset({"1", "L", "LA", "P", "PA", "RGB", "RGBA", "RGBX"})


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _eight_bit_size(path: Path) -> tuple[int, int] | None:
    """``(cols, rows)`` of an 8-bit image from its header, or None (other depths, unreadable).

    A PNG's header chunk is read directly (33 bytes); other formats are opened by Pillow,
    which reads their header without decoding.
    """
    from stimuli.io import _open_checked

    try:
        with open(path, "rb") as f:
            head = f.read(26)
        if head[:8] == _PNG_SIGNATURE and head[12:16] == b"IHDR":
            cols, rows = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
            return (cols, rows) if head[24] <= 8 else None
        with _open_checked(path) as img:
            return img.size if img.mode in _EIGHT_BIT_MODES else None
    except Exception:  # noqa: BLE001 - any unreadable header: the whole read reports it
        return None


def _headers_allow_some(paths: list[Path]) -> bool:
    """Whether every view is 8-bit and of one size, by the files' headers (no decoding)."""
    sizes = {_eight_bit_size(f) for f in paths}
    return len(sizes) == 1 and None not in sizes


def _scale_raw(
    raws: list[np.ndarray], names: list[str], bit_depth: int | None, where: Path
) -> tuple[float, int | None]:
    """Return the divisor that maps the raw views to [0, 1], and the bit depth used.

    8-bit data is divided by 255. 16-bit data is divided by ``2**bits - 1``, with ``bits`` the
    given ``bit_depth`` or the smallest depth that holds the largest value in any view (at least
    8): 12-bit data in 16-bit PNGs would otherwise come out 16 times too dark.
    """
    kinds = {r.dtype for r in raws}
    if any(k.kind == "f" for k in kinds):
        return 1.0, None
    if bit_depth is not None and (
        isinstance(bit_depth, bool) or not isinstance(bit_depth, int) or not 1 <= bit_depth <= 16
    ):
        raise InputError(f"--bit-depth must be an integer in 1..16, got {bit_depth!r}")
    tops = [int(r.max()) if r.size else 0 for r in raws]
    top = max(tops)
    if all(k == np.uint8 for k in kinds) and bit_depth is None:
        return 255.0, 8
    bits = bit_depth if bit_depth is not None else max(8, int(top).bit_length())
    if top > 2**bits - 1:
        worst = names[int(np.argmax(tops))]
        raise InputError(
            f"{where / worst}: value {top} does not fit --bit-depth {bits} (max {2**bits - 1})"
        )
    return float(2**bits - 1), bits


def _to_views(raw: np.ndarray, scale: float, background: float) -> np.ndarray:
    """Scale a raw view to [0, 1] RGB, compositing an alpha channel over ``background``."""
    a = raw.astype(np.float32)
    a /= np.float32(scale)
    if a.ndim == 2:
        a = a[..., None]
    if a.shape[2] in (2, 4):
        alpha = a[..., -1:]
        a = a[..., :-1] * alpha + np.float32(background) * (1.0 - alpha)
    if a.shape[2] == 1:
        a = np.repeat(a, 3, axis=2)
    a = a[..., :3]
    return np.clip(a, 0.0, 1.0, out=a).astype(np.float32, copy=False)


def _load_folder(
    folder: Path,
    pattern: str | None,
    grid_cols: int | None,
    gray: bool,
    bit_depth: int | None = None,
    background: float = 0.0,
    only_views: Callable[[tuple[int, int]], Iterable[tuple[int, int]]] | None = None,
    box: tuple[int, int, int, int] | None = None,
) -> tuple[np.ndarray, dict]:
    files = sorted(
        f for f in folder.iterdir() if f.is_file() and f.suffix.lower() in _IMAGE_SUFFIXES
    )
    if not files:
        raise InputError(f"{folder}: missing views: no image files in the folder")
    found = _match_views(files, pattern, grid_cols)
    if not found:
        hint = f"pattern {pattern!r}" if pattern else "{row}_{col}, view{index} or input_Cam{index}"
        raise InputError(f"{folder}: missing views: no file name matches {hint}; give --pattern")
    rows, cols = _check_grid(found, folder)
    items = sorted(found.items())
    some = None
    if only_views is not None and bit_depth is None and _headers_allow_some(list(found.values())):
        some = {(int(u), int(v)) for u, v in only_views((len(rows), len(cols)))}
    shown = [(p, f) for p, f in items if some is None or (p[0] - rows[0], p[1] - cols[0]) in some]
    raws = _read_all([f for _, f in shown])
    first = raws[0].shape[:2]
    for (_, f), r in zip(shown, raws, strict=True):
        if r.shape[:2] != first:
            raise InputError(
                f"{folder}: views of different sizes: {shown[0][1].name} is "
                f"{first[0]}x{first[1]} px, {f.name} is {r.shape[0]}x{r.shape[1]} px"
            )
    scale, bits = _scale_raw(raws, [f.name for _, f in shown], bit_depth, folder)
    has_alpha = any(r.ndim == 3 and r.shape[2] in (2, 4) for r in raws)
    channels = () if gray else (3,)
    keep = (slice(None), slice(None))
    if box is not None:  # each view cropped as it is converted: no copy of the whole field
        x, y, w, h = box
        if w < 2 or h < 2 or x < 0 or y < 0 or x + w > first[1] or y + h > first[0]:
            raise InputError(
                f"{folder}: crop box {x},{y},{w},{h} must be at least 2x2 px inside the "
                f"{first[1]}x{first[0]} views"
            )
        keep, first = (slice(y, y + h), slice(x, x + w)), (h, w)
    out = (np.empty if some is None else np.zeros)(
        (len(rows), len(cols), *first, *channels), dtype=np.float32
    )

    def convert(item) -> None:
        ((r, c), _), raw = item
        view = _to_views(raw[keep], scale, background)
        out[r - rows[0], c - cols[0]] = luma(view) if gray else view

    _on_threads(convert, list(zip(shown, raws, strict=True)))
    meta: dict = {}
    if some is not None:
        meta["views_read"] = sorted((p[0] - rows[0], p[1] - cols[0]) for p, _ in shown)
    if bits is not None:
        meta["bit_depth"] = bits
    if has_alpha:
        meta["alpha_background"] = background
    if box is not None:
        meta["crop"] = [int(v) for v in box]
    return out, meta


#: Axis orders accepted for array files (``u``, ``v``: view grid; ``h``, ``w``: pixel rows and
#: columns; ``c``: colour channels).
ARRAY_AXES: tuple[str, ...] = ("uvhw", "uvhwc", "hwuv", "hwuvc", "uvchw", "cuvhw")


def _order_axes(a: np.ndarray, axes: str | None, path: Path) -> np.ndarray:
    """Return the array as (n_u, n_v, rows, cols[, C]); refuse an implausible axis order."""
    if axes is not None:
        if axes not in ARRAY_AXES:
            raise InputError(f"--axes must be one of {', '.join(ARRAY_AXES)}, got {axes!r}")
        if len(axes) != a.ndim:
            raise InputError(f"{path}: --axes {axes!r} names {len(axes)} axes, array has {a.ndim}")
        return np.ascontiguousarray(np.transpose(a, [axes.index(k) for k in "uvhwc" if k in axes]))
    if a.ndim not in (4, 5):
        raise InputError(
            f"{path}: a light-field array must be 4-D (n_u, n_v, rows, cols) or 5-D with colour "
            f"last, got shape {a.shape}"
        )
    n_u, n_v, rows, cols = a.shape[:4]
    # A view grid is small and its views large: a grid bigger than its views, or views of a
    # few pixels, means the axes are in another order, e.g. (rows, cols, n_u, n_v).
    if n_u * n_v > rows * cols or min(rows, cols) < 8:
        raise InputError(
            f"{path}: shape {a.shape} does not look like (n_u, n_v, rows, cols[, C]) "
            f"(a {n_u}x{n_v} grid of {rows}x{cols} px views); store the array in that order "
            "or give --axes (e.g. hwuv)"
        )
    return a


def _check_npy_header(f, stored_bytes: int, where: str) -> None:
    """Refuse an ``.npy`` stream whose header claims more data than is stored or fits in memory.

    ``np.load`` allocates the array the header describes before reading it, so a corrupt or
    hostile header (``shape`` of 10^14 values) would end in a ``MemoryError`` traceback, or in
    the kernel killing the process. ``stored_bytes`` is the file's (or zip member's) size.
    """
    from numpy.lib import format as npy_format

    from stimuli.resources import check_memory

    try:
        version = npy_format.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = npy_format.read_array_header_1_0(f)
        else:
            shape, _, dtype = npy_format.read_array_header_2_0(f)
    except (ValueError, EOFError, SyntaxError, TypeError) as exc:
        raise InputError(f"{where}: not a readable .npy array header ({exc})") from None
    n_values = math.prod(int(d) for d in shape)
    need = n_values * dtype.itemsize
    have = stored_bytes - f.tell()
    if need > have:
        raise InputError(
            f"{where}: the header claims shape {tuple(shape)} ({need} bytes of data) but the "
            f"file holds {max(have, 0)} bytes; the file is truncated or damaged"
        )
    # float32 working copy on top of the stored array (uint16 and bool light fields convert)
    check_memory(need + 4 * n_values, f"{where} (shape {tuple(shape)})")


def _load_array_file(
    path: Path, bit_depth: int | None = None, axes: str | None = None
) -> tuple[np.ndarray, dict]:
    meta: dict = {}
    try:
        if path.suffix.lower() == ".npy":
            with open(path, "rb") as f:
                _check_npy_header(f, os.fstat(f.fileno()).st_size, str(path))
            a = np.load(path, allow_pickle=False)
        else:
            with np.load(path, allow_pickle=False) as z:
                keys = list(z.keys())
                key = "views" if "views" in keys else (keys[0] if len(keys) == 1 else None)
                if key is None:
                    raise InputError(f"{path}: .npz must hold an array 'views' (found keys {keys})")
                member = f"{key}.npy"
                with z.zip.open(member) as f:
                    _check_npy_header(f, z.zip.getinfo(member).file_size, f"{path} ({key})")
                a = z[key]
                if "geometry" in keys:
                    meta["geometry"] = json.loads(str(z["geometry"]))
    except InputError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        # a truncated .npz is a BadZipFile; a damaged member a zlib.error or EOFError
        raise InputError(f"{path}: not a readable light-field array ({exc})") from None
    a = _order_axes(a, axes, path)
    if a.dtype == np.uint16:
        scale, bits = _scale_raw([a], [path.name], bit_depth, path.parent)
        a = a.astype(np.float32) / np.float32(scale)
        meta["bit_depth"] = bits
    elif np.issubdtype(a.dtype, np.integer) or a.dtype == bool:
        from stimuli.io import to_float01

        a = to_float01(a)
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise InputError(f"{path}: light field has NaN or infinite values")
    if a.dtype.kind == "f" and a.size and (a.min() < 0 or a.max() > 1):
        raise InputError(
            f"{path}: float light field must be in [0, 1], got [{a.min():.4g}, {a.max():.4g}]"
        )
    return a, meta


def load_lightfield(
    path: str | os.PathLike,
    *,
    pattern: str | None = None,
    grid_cols: int | None = None,
    pitch_px: int | None = None,
    border_px: int | None = None,
    offset_px: tuple[int, int] | None = None,
    geometry: Geometry | None = None,
    gray: bool = False,
    bit_depth: int | None = None,
    axes: str | None = None,
    background: float = 0.0,
    only_views: Callable[[tuple[int, int]], Iterable[tuple[int, int]]] | None = None,
    view_box: tuple[int, int, int, int] | None = None,
) -> LightField:
    """Load a light field from a folder of views, an array file or an elemental image.

    Parameters
    ----------
    path : str or path-like
        A folder of view images, an ``.npy``/``.npz`` array, or one elemental image.
    pattern : str, optional
        View file-name pattern, e.g. ``"scene_{row:02d}_{col:02d}.png"`` or ``"cam{index}"``.
    grid_cols : int, optional
        Columns of the camera grid, for ``{index}`` patterns (HCI ``input_CamNNN``: 9).
    pitch_px, border_px, offset_px
        For an elemental image: lenslet pitch, invalid border per lenslet and the offset of
        the first whole lenslet, pixels (see :func:`views_from_elemental`).
    geometry : Geometry, optional
        Overrides the ``[geometry]`` table of a ``lightfield.toml`` found beside ``path``.
    gray : bool
        Convert views to luminance while loading (saves memory on large colour grids).
    bit_depth : int in 1..16, optional
        Bits used by 16-bit data (e.g. 12); default: the smallest depth holding the largest
        value found.
    axes : str, optional
        Axis order of an array file (:data:`ARRAY_AXES`); default ``uvhw[c]``, checked against
        the shape.
    background : float in [0, 1]
        Grey level an alpha channel is composited over (the protocol's background).
    only_views : callable, optional
        For work that looks at some views only (the agreement scan: the centre row and
        column): given the grid ``(n_u, n_v)``, returns the grid positions ``(u, v)`` to read.
        A folder of 8-bit views of one size (checked from the headers) is then read at those
        positions only; the other views are left black and ``meta["views_read"]`` lists the
        read ones. Other inputs are read whole. Not for refocusing: it needs every view.
    view_box : (x, y, w, h), optional
        Crop every view to this box (:meth:`LightField.cropped`); a folder of views is cropped
        view by view as it is read, without a copy of the whole light field.

    Returns
    -------
    LightField

    Raises
    ------
    InputError
        Missing views, views of different sizes, a grid with holes, an implausible axis order,
        values beyond ``bit_depth``, no whole lenslet, NaNs, or an unreadable file; the message
        names the file.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: light field not found")
    toml_path = _find_toml(path)
    cfg = _read_toml(toml_path) if toml_path else {}
    views_cfg = cfg.get("views", {})
    elem_cfg = cfg.get("elemental", {})
    pattern = pattern if pattern is not None else views_cfg.get("pattern")
    grid_cols = grid_cols if grid_cols is not None else views_cfg.get("grid_cols")
    meta: dict = {}
    if not (isinstance(background, (int, float)) and 0.0 <= background <= 1.0):
        raise InputError(f"background must be a grey level in [0, 1], got {background!r}")
    if path.is_dir():
        views, meta = _load_folder(
            path, pattern, grid_cols, gray, bit_depth, background, only_views, view_box
        )
        meta["kind"] = "views"
        view_box = None  # cropped already
    elif path.suffix.lower() in (".npy", ".npz"):
        views, meta = _load_array_file(path, bit_depth, axes)
        meta["kind"] = "array"
    elif path.suffix.lower() in _IMAGE_SUFFIXES:
        pitch = pitch_px if pitch_px is not None else elem_cfg.get("pitch_px")
        if pitch is None:
            raise InputError(
                f"{path}: a single image is read as a lens-array elemental image and needs its "
                "lenslet pitch (--pitch, or [elemental] pitch_px in lightfield.toml)"
            )
        border = border_px if border_px is not None else elem_cfg.get("border_px", 0)
        offset = offset_px if offset_px is not None else tuple(elem_cfg.get("offset_px", (0, 0)))
        raw = _read_raw(path)
        scale, _ = _scale_raw([raw], [path.name], bit_depth, path.parent)
        img = _to_views(raw, scale, background)
        if gray:
            img = luma(img)
        try:
            views = views_from_elemental(img, pitch, border_px=border, offset_px=offset)
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        meta.update(kind="elemental", pitch_px=pitch, border_px=border, offset_px=list(offset))
    else:
        raise InputError(
            f"{path}: unknown light-field input (expected a folder of views, .npy, .npz or an "
            "elemental image)"
        )
    if views.ndim == 5 and gray:
        views = luma(views)
    if geometry is None:
        gdict = cfg.get("geometry") or meta.pop("geometry", None)
        geometry = Geometry.from_dict(gdict) if gdict else None
    meta.pop("geometry", None)
    if toml_path:
        meta["toml"] = str(toml_path)
    if meta.get("kind") == "views" and "bit_depth" in meta:  # integer samples, scaled, clipped
        lf = LightField.checked_already(views, geometry, str(path), meta)  # no pass to check
    else:
        lf = LightField(views, geometry, str(path), meta)
    return lf if view_box is None else lf.cropped(view_box)


def as_lightfield(lf: LightField | np.ndarray | str | os.PathLike) -> LightField:
    """Return ``lf`` as a LightField: as it is, wrapped (an array) or loaded (a path)."""
    if isinstance(lf, LightField):
        return lf
    if isinstance(lf, np.ndarray):
        return LightField(lf)
    return load_lightfield(lf)
