"""Writing an output so that a failure can remove only what this process made.

The rules, in plain words:

* A path is resolved **once**, with :func:`os.path.realpath` on the path as given (links are
  followed before ``..`` is applied, as the kernel does: ``link/../x`` is the ``x`` beside the
  link's target, not beside the link); every check and every write then uses that one path.
* A folder is written into a staging folder this process makes with :func:`tempfile.mkdtemp`
  beside the target; its device and inode are recorded. On failure only that folder is removed,
  and only while its device and inode still match (:func:`remove_own_tree`).
* The staging folder is renamed into place with "no replace" semantics (:func:`rename_noreplace`):
  a target that appeared meanwhile is refused, never removed. An empty target folder is removed
  with :func:`os.rmdir` first, which the kernel refuses for a folder that is no longer empty.
* Parent folders this process creates are removed again with :func:`os.rmdir` only (never a
  tree), and only while their device and inode match (:func:`make_parents`, :func:`remove_made`).
* A file is written to a temporary file beside it, flushed to disk (``fsync``) and renamed onto
  the target (:func:`atomic_file`); a symbolic link at the target, dangling or not, is refused:
  nothing is ever written through a link.

This module has a twin, ``analysis/staging.py`` (the analysis package imports nothing from
``stimuli``, nor ``stimuli`` from ``analysis``); ``tests/test_output_contract.py`` checks that
the two are the same code.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

__all__ = [
    "STAGING_MARKER",
    "Identity",
    "resolve",
    "is_link_loop",
    "missing_before_dotdot",
    "identity",
    "rename_noreplace",
    "make_parents",
    "remove_made",
    "remove_own_tree",
    "new_staging",
    "publish",
    "atomic_file",
    "published",
]

#: Name of the marker file inside a staging folder (``.NAME.tmp-*``): ``{"pid": N}``, the process
#: that fills it; removed before the folder is renamed into place.
STAGING_MARKER = ".confocal-staging.json"

#: ``(st_dev, st_ino)`` of a file or folder: what it is, whatever path leads to it.
Identity = tuple[int, int]


def resolve(path: str | os.PathLike) -> Path:
    """Return the one real path of ``path`` as the kernel sees it (links followed, then ``..``).

    ``os.path.realpath`` on the path as given, never on ``os.path.abspath`` of it (which drops
    ``link/..`` before the link is followed).
    """
    return Path(os.path.realpath(os.fspath(path)))


def missing_before_dotdot(path: str | os.PathLike) -> str | None:
    """Return the part of ``path`` up to its last ``..`` when that part does not exist, else None.

    The kernel cannot take ``..`` from a folder that is not there (``new/../x`` fails), whereas
    :func:`os.path.realpath` drops both words; such a path is refused rather than guessed.
    """
    parts = os.fspath(path).split(os.sep)
    if ".." not in parts:
        return None
    last = len(parts) - 1 - parts[::-1].index("..")
    prefix = os.sep.join(parts[: last + 1]) or os.sep
    return None if os.path.isdir(prefix) else prefix


def is_link_loop(path: str | os.PathLike) -> bool:
    """Return whether ``path`` (or a folder on the way to it) is a loop of symbolic links."""
    try:
        os.stat(path)
    except OSError as exc:
        return exc.errno == errno.ELOOP
    return False


def identity(path: str | os.PathLike, *, dir_fd: int | None = None) -> Identity | None:
    """Return ``(st_dev, st_ino)`` of ``path`` itself (a link is not followed), None if missing."""
    try:
        st = os.stat(path, dir_fd=dir_fd, follow_symlinks=False)
    except (FileNotFoundError, NotADirectoryError):
        return None
    return (st.st_dev, st.st_ino)


_RENAME_NOREPLACE = 1
_AT_FDCWD = -100
_renameat2: object = None  # the libc function, False where there is none, None: not looked up


def _libc_renameat2():
    global _renameat2
    if _renameat2 is None:
        try:
            import ctypes

            fn = ctypes.CDLL(None, use_errno=True).renameat2
            fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p]
            fn.argtypes += [ctypes.c_uint]
            fn.restype = ctypes.c_int
            _renameat2 = fn
        except (OSError, AttributeError, ImportError):
            _renameat2 = False
    return _renameat2 or None


def rename_noreplace(src: str | os.PathLike, dst: str | os.PathLike) -> None:
    """Rename ``src`` to ``dst``, which must not exist (not even as an empty folder or a link).

    Atomic where the kernel offers ``renameat2(RENAME_NOREPLACE)`` (Linux); elsewhere the target
    is checked just before an ordinary rename, which still never replaces a non-empty folder.

    Raises
    ------
    FileExistsError
        ``dst`` exists.
    """
    fn = _libc_renameat2()
    if fn is not None:
        import ctypes

        if fn(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), _RENAME_NOREPLACE) == 0:
            return
        err = ctypes.get_errno()
        if err not in (errno.ENOSYS, errno.EINVAL):  # EINVAL: a file system without the flag
            raise OSError(err, os.strerror(err), os.fspath(dst))
    if os.path.lexists(dst):
        raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), os.fspath(dst))
    os.rename(src, dst)


def make_parents(folder: str | os.PathLike) -> list[tuple[Path, Identity]]:
    """Create ``folder`` and its missing parents; return those this call made, top-most first.

    Each is returned with its identity, for :func:`remove_made`.
    """
    folder = Path(folder)
    missing: list[Path] = []
    p = folder
    while not os.path.lexists(p) and p != p.parent:
        missing.append(p)
        p = p.parent
    made: list[tuple[Path, Identity]] = []
    try:
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except FileExistsError:
                continue  # made by someone else meanwhile: not ours
            ident = identity(d)
            if ident is not None:
                made.append((d, ident))
    except BaseException:
        remove_made(made)
        raise
    return made


def remove_made(made: list[tuple[Path, Identity]]) -> None:
    """Remove the folders :func:`make_parents` made, deepest first.

    Each is removed only while it is empty and still the same folder (``os.rmdir``: never a
    tree).
    """
    for d, ident in reversed(made):
        if identity(d) == ident:
            with contextlib.suppress(OSError):
                os.rmdir(d)


def remove_own_tree(path: str | os.PathLike, ident: Identity | None) -> bool:
    """Remove the folder ``path`` only if it is still the folder ``ident`` names; return whether.

    The folder's parent is opened once and the tree removed relative to it without following
    links (``shutil.rmtree`` with ``dir_fd``), so a link planted on the way is not followed.
    """
    if ident is None:
        return False
    if not shutil.rmtree.avoids_symlink_attacks or os.rmdir not in os.supports_dir_fd:
        if identity(path) != ident or not os.path.isdir(path):  # no dir_fd here (Windows)
            return False
        shutil.rmtree(path, ignore_errors=True)
        return True
    parent, name = os.path.split(os.fspath(path))
    try:
        pfd = os.open(parent or ".", os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return False
    try:
        try:
            st = os.stat(name, dir_fd=pfd, follow_symlinks=False)
        except OSError:
            return False
        if (st.st_dev, st.st_ino) != ident or not stat.S_ISDIR(st.st_mode):
            return False
        shutil.rmtree(name, dir_fd=pfd, ignore_errors=True)
        return True
    finally:
        os.close(pfd)


def new_staging(target: str | os.PathLike) -> tuple[Path, Identity]:
    """Make the private staging folder ``.NAME.tmp-*`` beside ``target`` (a resolved path).

    Its marker (:data:`STAGING_MARKER`) names this process. Returns the folder and its identity.
    """
    target = Path(target)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.tmp-", dir=target.parent))
    ident = identity(tmp)
    try:
        (tmp / STAGING_MARKER).write_text(json.dumps({"pid": os.getpid()}) + "\n", "utf-8")
    except BaseException:
        remove_own_tree(tmp, ident)
        raise
    assert ident is not None
    return tmp, ident


def _folder_mode() -> int:
    return 0o777 & ~_umask()


#: Every folder :func:`publish` renamed into place in this process: resolved path -> identity.
_PUBLISHED: dict[str, Identity] = {}


def published(target: str | os.PathLike) -> Identity | None:
    """Return the identity of the staging folder this process published at ``target``, or None.

    ``target`` is the resolved path and the folder the last one published there; a caller
    rolling back may remove that folder, and only while it is still there.
    """
    return _PUBLISHED.get(os.fspath(target))


def publish(tmp: str | os.PathLike, ident: Identity, target: str | os.PathLike) -> None:
    """Rename the filled staging folder ``tmp`` onto ``target``, a missing or empty folder.

    An empty folder at ``target`` is removed with ``os.rmdir`` first (the kernel refuses one
    that is no longer empty); anything else at ``target`` is refused and left as it is.

    Raises
    ------
    FileExistsError
        ``target`` exists and is not an empty folder (it appeared meanwhile); ``tmp`` is left
        for the caller to remove.
    """
    tmp, target = Path(tmp), Path(target)
    if identity(tmp) != ident:
        raise FileNotFoundError(errno.ENOENT, "the staging folder was replaced", os.fspath(tmp))
    (tmp / STAGING_MARKER).unlink(missing_ok=True)
    os.chmod(tmp, _folder_mode())  # mkdtemp makes it private
    st = None
    with contextlib.suppress(OSError):
        st = os.lstat(target)
    if st is not None and stat.S_ISDIR(st.st_mode):
        try:
            os.rmdir(target)  # only an empty folder: the kernel checks
        except OSError as exc:
            raise FileExistsError(errno.EEXIST, os.strerror(exc.errno), os.fspath(target)) from None
    try:
        rename_noreplace(tmp, target)
        _PUBLISHED[os.fspath(target)] = ident
    except BaseException:
        if st is not None and stat.S_ISDIR(st.st_mode):
            with contextlib.suppress(OSError):
                os.mkdir(target)  # put the empty folder back
        raise


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, *, refuse: type[Exception] = ValueError) -> Iterator[Path]:
    """Yield a temporary file beside ``path``, to be renamed onto ``path`` on success.

    On success the file is flushed to disk and renamed onto ``path``. On any exception the
    temporary file is removed and ``path`` left as it was.

    The folder is resolved once; the file gets the user's umask, not ``mkstemp``'s ``0600``.

    Raises
    ------
    refuse
        ``path`` is a symbolic link (dangling or not): confocal never writes through a link.
    """
    path = Path(path)
    if os.path.islink(path):
        raise refuse(
            f"{path}: is a symbolic link; confocal never writes through a link: "
            "give a new file path or remove the link"
        )
    folder = resolve(path.parent)
    made = make_parents(folder)  # removed again (rmdir, if still empty) on failure
    final = folder / path.name
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=folder)
    except BaseException:
        remove_made(made)
        raise
    os.close(fd)
    tmp = Path(name)
    done = False
    try:
        yield tmp
        if os.path.lexists(tmp):
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            os.chmod(tmp, 0o666 & ~_umask())
        if os.path.islink(final):
            raise refuse(f"{path}: became a symbolic link meanwhile; it was left as it was")
        os.replace(tmp, final)
        done = True
    finally:
        if os.path.lexists(tmp):
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if not done:
            remove_made(made)


def _umask() -> int:
    """Return the process's umask: from ``/proc`` where the kernel offers it (thread-safe)."""
    with contextlib.suppress(OSError, ValueError, IndexError):
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
