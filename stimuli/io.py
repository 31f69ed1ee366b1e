"""Image input and output: the one place where dtype and range conversion happens (house style H6).

Grey images inside the pipeline are ``float32`` arrays of shape ``(rows, cols)`` with values in
[0, 1]; binary stimuli are ``bool``. Files are read with Pillow (any format it reads, EXIF
orientation applied) and written atomically (temporary file, then rename).
"""

from __future__ import annotations

import errno
import hashlib
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from stimuli.errors import InputError
from stimuli.staging import STAGING_MARKER as _STAGING_MARKER
from stimuli.staging import (
    atomic_file,
    identity,
    is_link_loop,
    make_parents,
    new_staging,
    publish,
    remove_made,
    remove_own_tree,
    resolve,
)

__all__ = [
    "load_gray",
    "load_rgb",
    "load_float",
    "gray_of",
    "rgb_of",
    "image_shape_px",
    "save_png",
    "to_uint8",
    "sha256_file",
    "atomic_path",
    "staged_folder",
    "new_staging_folder",
    "swap_in",
    "check_missing_or_empty",
    "STAGING_MARKER",
    "current_umask",
    "default_mode",
    "check_gray",
    "to_float01",
    "luma",
]

#: Rec. 709 luma weights used for colour -> luminance (the same as skimage.color.rgb2gray).
_LUMA_WEIGHTS = np.array([0.2125, 0.7154, 0.0721], dtype=np.float32)


def luma(rgb: np.ndarray) -> np.ndarray:
    """Return the Rec. 709 luminance of RGB ``(..., 3)`` float32 values, clipped to [0, 1].

    ``R w_R + G w_G + B w_B`` with each product rounded to float32 and the three added in that
    order, pixel by pixel: a pixel's value does not depend on how many views are converted at
    once (a BLAS product of the whole array may round by its blocking), so a light field read
    view by view, or only some of its views, is the same to the bit.
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    g = rgb[..., 0] * _LUMA_WEIGHTS[0]
    g += rgb[..., 1] * _LUMA_WEIGHTS[1]
    g += rgb[..., 2] * _LUMA_WEIGHTS[2]
    return np.clip(g, 0.0, 1.0, out=g)


#: EXIF orientations (tag 0x0112) that swap rows and columns (transpose, rotate 90/270).
_EXIF_SWAPS_AXES = (5, 6, 7, 8)


def _open(path: str | os.PathLike, draft_shape_px: tuple[int, int] | None = None) -> Image.Image:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: image file not found")
    try:
        img = _open_checked(path)
        if draft_shape_px is not None and img.format == "JPEG":
            rows, cols = (int(v) for v in draft_shape_px)
            if img.getexif().get(0x0112) in _EXIF_SWAPS_AXES:
                rows, cols = cols, rows
            img.draft("RGB" if img.mode in ("RGB", "YCbCr") else img.mode, (cols, rows))
        img.load()
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise InputError(f"{path}: not a readable image ({exc})") from None
    except Image.DecompressionBombError as exc:
        raise InputError(f"{path}: refused as a decompression bomb ({exc})") from None
    try:  # in place: without a rotation to undo, no copy of the pixels
        ImageOps.exif_transpose(img, in_place=True)
    except (OSError, ValueError, SyntaxError):  # broken EXIF block: keep the pixels as stored
        pass
    return img


#: Bytes per pixel of a decoded image and its float32 copies (ours: RGBA uint8 + float32 RGB +
#: float32 grey, rounded up), for the memory check before decoding a very large image.
_DECODE_BYTES_PER_PX = 32


def _open_checked(path: Path) -> Image.Image:
    """Open an image lazily; a header larger than Pillow's bomb limit is decoded only if it fits.

    Pillow warns (``DecompressionBombWarning``) above ``Image.MAX_IMAGE_PIXELS`` and raises above
    twice that; the warning becomes a memory check and one log line instead of a multi-line
    Python warning.
    """
    import logging
    import warnings

    from stimuli.resources import check_memory

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", Image.DecompressionBombWarning)
        img = Image.open(path)
    if any(issubclass(w.category, Image.DecompressionBombWarning) for w in caught):
        cols, rows = img.size
        check_memory(rows * cols * _DECODE_BYTES_PER_PX, f"{path}: decoding {cols}x{rows} px")
        logging.getLogger(__name__).warning(
            "%s: very large image (%dx%d px, above Pillow's decompression-bomb limit)",
            path,
            cols,
            rows,
        )
    return img


def to_float01(array: np.ndarray) -> np.ndarray:
    """Convert an integer or float image array to ``float32`` in [0, 1].

    Parameters
    ----------
    array : ndarray
        Integer arrays are divided by their dtype's maximum; ``bool`` maps to {0, 1}; float arrays
        must already lie in [0, 1].

    Returns
    -------
    ndarray, float32
        The same shape, values in [0, 1].

    Raises
    ------
    InputError
        If a float array has values outside [0, 1] or NaNs.
    """
    a = np.asarray(array)
    if a.dtype == bool:
        return a.astype(np.float32)
    if np.issubdtype(a.dtype, np.integer):
        return (a.astype(np.float32) / np.float32(np.iinfo(a.dtype).max)).astype(np.float32)
    a = a.astype(np.float32, copy=False)
    if not np.all(np.isfinite(a)):
        raise InputError("image has NaN or infinite values; expected finite values in [0, 1]")
    if a.size and (a.min() < 0.0 or a.max() > 1.0):
        raise InputError(f"float image must be in [0, 1], got range [{a.min():.4g}, {a.max():.4g}]")
    return a


def _pil_to_array(img: Image.Image) -> np.ndarray:
    if img.mode in ("I;16", "I;16B", "I;16L"):
        return np.asarray(img, dtype=np.uint16)
    if img.mode == "I":
        a = np.asarray(img, dtype=np.int64)
        return (np.clip(a, 0, 65535)).astype(np.uint16)
    if img.mode == "F":
        return np.asarray(img, dtype=np.float32)
    if img.mode not in ("L", "RGB", "RGBA", "LA"):
        img = img.convert("RGBA" if "A" in img.getbands() else "RGB")
    return np.asarray(img)


def load_rgb(path: str | os.PathLike) -> np.ndarray:
    """Read an image file as ``float32`` RGB in [0, 1], EXIF orientation applied.

    Parameters
    ----------
    path : str or path-like
        Any format Pillow reads.

    Returns
    -------
    ndarray of shape (rows, cols, 3), float32 in [0, 1]
        Grey files are repeated on the three channels; alpha is dropped.

    Raises
    ------
    InputError
        If the file is missing, unreadable or truncated.
    """
    return rgb_of(load_float(path))


def load_float(
    path: str | os.PathLike, *, draft_shape_px: tuple[int, int] | None = None
) -> np.ndarray:
    """Decode an image file once, as stored: ``float32`` in [0, 1], EXIF orientation applied.

    :func:`gray_of` and :func:`rgb_of` make of it what :func:`load_gray` and :func:`load_rgb`
    return, to the bit, so a caller that needs both reads the file once.

    Parameters
    ----------
    path : str or path-like
        Any format Pillow reads.
    draft_shape_px : (rows, cols), optional
        JPEG only: decode at a reduced size (see :func:`load_gray`).

    Returns
    -------
    ndarray of shape (rows, cols) or (rows, cols, channels), float32 in [0, 1]

    Raises
    ------
    InputError
        If the file is missing, unreadable or truncated.
    """
    return to_float01(_pil_to_array(_open(path, draft_shape_px)))


def gray_of(image: np.ndarray) -> np.ndarray:
    """Return the luminance of a decoded image (:func:`load_float`), as :func:`load_gray` does.

    Parameters
    ----------
    image : ndarray of shape (rows, cols) or (rows, cols, channels), float32 in [0, 1]

    Returns
    -------
    ndarray of shape (rows, cols), float32 in [0, 1]
        Rec. 709 luma of the first three channels; a grey (or grey-and-alpha) image's grey.
    """
    a = image
    if a.ndim == 3:
        a = a[..., :3] @ _LUMA_WEIGHTS if a.shape[2] >= 3 else a[..., 0]
    return np.ascontiguousarray(np.clip(a, 0.0, 1.0).astype(np.float32))


def rgb_of(image: np.ndarray) -> np.ndarray:
    """Return a decoded image (:func:`load_float`) as RGB, as :func:`load_rgb` does.

    Parameters
    ----------
    image : ndarray of shape (rows, cols) or (rows, cols, channels), float32 in [0, 1]

    Returns
    -------
    ndarray of shape (rows, cols, 3), float32 in [0, 1]
        Grey repeated on the three channels; alpha dropped.
    """
    a = image
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])


def image_shape_px(path: str | os.PathLike) -> tuple[int, int]:
    """Return an image file's size ``(rows, cols)`` after EXIF orientation, reading the header only.

    Raises
    ------
    InputError
        If the file is missing or not an image.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: image file not found")
    try:
        with _open_checked(path) as img:
            cols, rows = img.size
            swap = img.getexif().get(0x0112) in _EXIF_SWAPS_AXES
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise InputError(f"{path}: not a readable image ({exc})") from None
    except Image.DecompressionBombError as exc:
        raise InputError(f"{path}: refused as a decompression bomb ({exc})") from None
    return (cols, rows) if swap else (rows, cols)


def load_gray(
    path: str | os.PathLike, *, draft_shape_px: tuple[int, int] | None = None
) -> np.ndarray:
    """Read an image file as luminance, ``float32`` in [0, 1], EXIF orientation applied.

    Colour is converted with Rec. 709 luma weights (as ``skimage.color.rgb2gray``).

    Parameters
    ----------
    path : str or path-like
        Any format Pillow reads (JPEG, PNG, TIFF, 16-bit PNG, ...).
    draft_shape_px : (rows, cols), optional
        JPEG only: let the decoder shrink the image by 1/2, 1/4 or 1/8 in the DCT domain
        (Pillow's ``Image.draft``) to the smallest such size that is still at least this size
        (after EXIF orientation). Much faster for a later down-sampling; the result differs
        slightly from a full decode followed by a resize. Ignored for other formats.

    Returns
    -------
    ndarray of shape (rows, cols), float32 in [0, 1]

    Raises
    ------
    InputError
        If the file is missing, unreadable or truncated.
    """
    return gray_of(load_float(path, draft_shape_px=draft_shape_px))


def check_gray(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Check that ``image`` is a 2-D finite float image in [0, 1]; return it as float32.

    Raises
    ------
    InputError
        Naming ``name``, if the array is not 2-D, not finite, or out of [0, 1].
    """
    a = np.asarray(image)
    if a.ndim != 2:
        raise InputError(f"{name} must be 2-D (rows, cols), got shape {a.shape}")
    if a.dtype == bool:
        return a.astype(np.float32)
    if not np.issubdtype(a.dtype, np.floating):
        raise InputError(f"{name} must be float in [0, 1] or bool, got dtype {a.dtype}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} has NaN or infinite values")
    if a.size and (a.min() < 0.0 or a.max() > 1.0):
        raise InputError(f"{name} must be in [0, 1], got range [{a.min():.4g}, {a.max():.4g}]")
    return a.astype(np.float32, copy=False)


def current_umask() -> int:
    """Return the process's umask (e.g. ``0o022``) without changing it.

    Read from ``/proc/self/status`` where the kernel offers it (thread-safe); elsewhere the
    umask is set and restored at once, the only portable way to read it.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def default_mode(*, directory: bool = False) -> int:
    """Return the mode a plain ``open()`` (or ``mkdir``) would give a new file (or folder).

    ``tempfile.mkstemp``/``mkdtemp`` create private ``0600``/``0700`` entries whatever the
    umask; atomic writes chmod their temporary file or folder to this mode before the rename,
    so shared lab accounts (umask ``0o002``) and servers (``0o022``) get ordinary files.
    """
    return (0o777 if directory else 0o666) & ~current_umask()


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only if the block succeeds.

    Readers never see a half-written file: on any exception (a full disk included) the temporary
    file is removed and ``path`` is left as it was; on success the file is flushed to disk
    (``fsync``) before the rename. The file gets the user's umask (:func:`default_mode`), not
    ``mkstemp``'s private ``0600``.

    Raises
    ------
    InputError
        ``path`` is a symbolic link (dangling or not): nothing is written through a link.
    """
    with atomic_file(path, refuse=InputError) as tmp:
        yield tmp


#: Name of the marker file inside a staging folder (``.NAME.tmp-*``): ``{"pid": N}``, the process
#: that fills it. It proves confocal made the folder, so a later run may delete it once that
#: process is gone (``experiment.outputs`` does); it is removed before the folder is renamed.
STAGING_MARKER = _STAGING_MARKER


def _refuse_link_or_loop(given: Path, real: Path) -> None:
    if os.path.islink(given):
        raise InputError(
            f"{given}: --out is a symbolic link; confocal never writes through a link: "
            "give the folder itself, or a new one"
        )
    if is_link_loop(real):
        raise InputError(f"{given}: --out is a loop of symbolic links; expected a folder path")


@contextmanager
def staged_folder(
    out_dir: str | os.PathLike, *, what: str = "the output", merge: bool = False
) -> Iterator[Path]:
    """Yield a staging folder beside ``out_dir``; move what it holds into ``out_dir`` on success.

    A command that writes several files (a scan's ``scan.json`` with its images) writes them
    here first, so a failure (a full disk, a stop signal, a bug) leaves ``out_dir`` as it was,
    and no folder when it did not exist: neither a ``scan.json`` without its images nor an empty
    folder. ``out_dir`` is resolved once (:func:`stimuli.staging.resolve`: links, then ``..``)
    and a link at ``out_dir`` itself is refused. Without ``merge``, ``out_dir`` must be missing
    or an empty folder: an existing non-empty folder is never replaced (checked before any work;
    the final rename never replaces anything but an empty folder: a target that appeared
    meanwhile is refused). With ``merge`` (a dataset that an export updates), each staged file is
    renamed into the existing folder and the folder's other files are kept. On failure only the
    staging folder this call made is removed (checked by device and inode), and the parent
    folders it made, if still empty.

    Parameters
    ----------
    out_dir : str or path-like
        The folder the command writes.
    what : str
        What is written, for the message (``"the scan"``).
    merge : bool
        Merge into an existing folder instead of refusing it.

    Raises
    ------
    InputError
        ``out_dir`` is a link, a file, or (without ``merge``) a folder that is not empty; or the
        disk filled up (ENOSPC, EDQUOT), with a message naming ``out_dir``.
    """
    given = Path(out_dir)
    real = resolve(given)
    _refuse_link_or_loop(given, real)
    if merge:
        if real.exists() and not real.is_dir():
            raise InputError(f"{given}: --out exists and is not a folder")
    else:
        _check_missing_or_empty(real, given)
    made = []
    tmp, ident = None, None
    try:
        made = make_parents(real.parent)  # removed again (rmdir, if still empty) on failure
        tmp, ident = new_staging(real)  # its marker file is the first write: inside the try
        yield tmp
        if merge and real.is_dir():
            (tmp / STAGING_MARKER).unlink(missing_ok=True)
            staged = sorted(p for p in tmp.rglob("*") if not p.is_dir())
            for f in staged:  # make every folder first (that needs space), then rename the files
                (real / f.relative_to(tmp)).parent.mkdir(parents=True, exist_ok=True)
            for f in staged:
                os.replace(f, real / f.relative_to(tmp))
        else:
            _publish(tmp, ident, real, given)
            tmp = None  # it is the output now
    except BaseException as exc:
        if tmp is not None:
            remove_own_tree(tmp, ident)
            tmp = None
        remove_made(made)
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise InputError(
                f"{given}: the disk is full ({exc.strerror or exc}) while writing {what}; the "
                f"partial output was removed and {given} was left as it was"
            ) from None
        raise
    finally:
        if tmp is not None:
            remove_own_tree(tmp, ident)


def _publish(tmp: Path, ident: tuple[int, int], real: Path, given: Path) -> None:
    try:
        publish(tmp, ident, real)
    except FileExistsError:
        _check_missing_or_empty(real, given)
        raise InputError(
            f"{given}: --out appeared while this command ran; it was left as it was: "
            "choose a new or empty folder"
        ) from None


def new_staging_folder(out_dir: str | os.PathLike) -> Path:
    """Create the private staging folder ``.NAME.tmp-*`` beside ``out_dir``, with its marker.

    ``out_dir`` is resolved once (links, then ``..``) and its missing parents are made. The
    marker (:data:`STAGING_MARKER`) names this process, so a later run can tell a folder left
    by a killed run from one still being filled.
    """
    real = resolve(out_dir)
    make_parents(real.parent)
    return new_staging(real)[0]


def swap_in(tmp: str | os.PathLike, out_dir: str | os.PathLike) -> None:
    """Rename the filled staging folder ``tmp`` onto ``out_dir``, a missing or empty folder.

    Raises
    ------
    InputError
        ``out_dir`` became a file or a non-empty folder meanwhile (``tmp`` is left in place
        for the caller to remove).
    """
    ident = identity(tmp)
    if ident is None:
        raise InputError(f"{tmp}: the staging folder is gone")
    _publish(Path(tmp), ident, resolve(out_dir), Path(out_dir))


def check_missing_or_empty(out_dir: str | os.PathLike) -> None:
    """Refuse an ``out_dir`` that is a file or a non-empty folder (confocal never replaces one).

    The path is resolved once (links, then ``..``) and checked there; messages name it as given.

    Raises
    ------
    InputError
        Naming the folder and what was expected.
    """
    given = Path(out_dir)
    real = resolve(given)
    if is_link_loop(real):
        raise InputError(f"{given}: --out is a loop of symbolic links; expected a folder path")
    _check_missing_or_empty(real, given)


def _check_missing_or_empty(real: Path, given: Path) -> None:
    if real.exists() and not real.is_dir():
        raise InputError(f"{given}: --out exists and is not a folder")
    if real.is_dir() and any(real.iterdir()):
        raise InputError(
            f"{given}: --out folder is not empty; confocal never replaces a folder's contents "
            "here: choose a new or empty folder"
        )


def to_uint8(image: np.ndarray) -> np.ndarray:
    """Return an image as :func:`save_png` writes its pixels: ``uint8``, ``True``/1.0 as 255.

    Parameters
    ----------
    image : ndarray of shape (rows, cols) or (rows, cols, 3|4), bool, uint8 or float in [0, 1]

    Returns
    -------
    ndarray of uint8
        What reading the PNG back gives.

    Raises
    ------
    InputError
        Another shape, or a float image outside [0, 1].
    """
    a = np.asarray(image)
    if a.ndim != 2 and not (a.ndim == 3 and a.shape[2] in (3, 4)):
        raise InputError(f"image must be (rows, cols) or (rows, cols, 3|4), got shape {a.shape}")
    if a.dtype == bool:
        return a.astype(np.uint8) * 255
    if a.dtype == np.uint8:
        return a
    return np.round(to_float01(a) * 255.0).astype(np.uint8)


def save_png(image: np.ndarray, path: str | os.PathLike, *, compress_level: int = 6) -> Path:
    """Write a grey or binary image as an 8-bit PNG, atomically.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), bool or float in [0, 1]
        ``True``/1.0 is written as 255.
    path : str or path-like
    compress_level : int in 0..9
        zlib's effort (Pillow's default 6). The pixels are the same at any level; 1 writes a
        grey image about 4x faster and about 15 % larger (ours, 491x359 confocal images).

    Returns
    -------
    Path
        The written file.
    """
    u8 = to_uint8(image)
    path = Path(path)
    with atomic_path(path) as tmp:
        Image.fromarray(u8).save(tmp, format="PNG", compress_level=compress_level)
    return path


def sha256_file(path: str | os.PathLike, chunk_bytes: int = 1 << 20) -> str:
    """Return the hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(chunk_bytes):
            h.update(chunk)
    return h.hexdigest()
