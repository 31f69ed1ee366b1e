"""Running a writing command under the output contract of :mod:`experiment.outputs`.

:func:`guard_command` wraps each command listed in
:data:`experiment.outputs.WRITING_COMMANDS`. For every output of a run, in this order, before
the command's own work starts:

1. the path is **resolved once** (:func:`experiment.outputs.resolve_output`: links followed
   before ``..``, a link at the output itself or a loop of links refused) and that one path is
   used from then on;
2. an **exclusive lock** on that path is taken for the whole run (:func:`output_lock`): a second
   confocal command writing the same output meanwhile is refused with one line, exit status 2,
   and changes nothing;
3. leftovers of killed runs are cleaned and the path is **checked** against the contract
   (refusals: one line naming the path as typed, exit status 2);
4. an own earlier folder is **moved aside** by a rename (``.NAME.old-PID-*``), its device and
   inode recorded.

After the command: on success the manifest is written and the folder moved aside is removed,
but only while its device and inode are the ones recorded; on failure it is renamed back, never
over anything (a target that appeared meanwhile is left, and so is the folder aside). The guard
itself never removes an output by its path: it removes only a folder it made and recorded by
device and inode (the folder it creates for the commands that write straight into ``--out``:
``demo``, ``view --shots``, ``lightfield scan``), and only while they still match.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import logging
import os
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from experiment.outputs import (
    STAGING_MARKER,
    WRITING_COMMANDS,
    OutputFolderError,
    State,
    WritingCommand,
    _real,
    _shown,
    check_file,
    check_folder,
    clean_leftovers,
    folder_files,
    read_manifest,
    resolve_output,
    write_manifest,
)

__all__ = ["DIRECT_WRITERS", "guard_command", "lock_path", "output_lock"]

logger = logging.getLogger(__name__)

#: Commands whose body writes straight into ``--out`` rather than a staging folder of its own
#: (``lightfield scan`` of several captures: a staged folder for each inside it): the guard
#: makes the folder (recording its device and inode) and, if the command fails,
#: removes that folder only while it is still the one it made.
DIRECT_WRITERS = frozenset({"demo", "view", "lightfield scan"})


def lock_path(real: str | os.PathLike) -> Path:
    """Return the lock file that guards the output at the resolved path ``real``.

    Locks live in a private per-user folder (``$XDG_RUNTIME_DIR`` or the temporary folder),
    named by a hash of the path, so no file ever appears beside a user's output.
    """
    import hashlib  # not at import (--help)

    base = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    uid = os.getuid() if hasattr(os, "getuid") else 0
    digest = hashlib.sha256(os.fsencode(os.fspath(real))).hexdigest()[:32]
    return Path(base) / f"confocal-locks-{uid}" / f"{digest}.lock"


def _lock_folder(folder: Path) -> None:
    try:
        os.mkdir(folder, 0o700)
    except FileExistsError:
        pass
    st = os.lstat(folder)
    uid = os.getuid() if hasattr(os, "getuid") else st.st_uid
    if not os.path.isdir(folder) or os.path.islink(folder) or st.st_uid != uid:
        raise OutputFolderError(
            f"{folder}: the folder of confocal's output locks is not a private folder of this "
            "user; remove it or set XDG_RUNTIME_DIR"
        )


@contextlib.contextmanager
def output_lock(real: str | os.PathLike, shown: str, flag: str = "--out") -> Iterator[None]:
    """Hold the exclusive lock on the output ``real`` for the block.

    Parameters
    ----------
    real : path-like
        The resolved output path.
    shown : str
        The path as the user typed it, for the message.
    flag : str
        The option named in the message.

    Raises
    ------
    OutputFolderError
        Another process holds the lock (one line naming the path and that process).
    """
    try:
        import fcntl
    except ImportError:  # no flock on this system: the renames below still never replace
        yield
        return
    path = lock_path(real)
    try:
        _lock_folder(path.parent)
        while True:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 64, 0).decode("ascii", "replace").split()
                os.close(fd)
                who = f" (pid {holder[0]})" if holder else ""
                raise OutputFolderError(
                    f"{flag} {shown}: another confocal command{who} is writing it now; wait "
                    "for it to finish, or choose another path"
                ) from None
            st = os.fstat(fd)
            try:
                now = os.stat(path, follow_symlinks=False)
            except FileNotFoundError:
                now = None
            if now is not None and (now.st_dev, now.st_ino) == (st.st_dev, st.st_ino):
                break
            os.close(fd)  # its holder removed it as we opened it: take the new one
    except OSError as exc:
        raise OutputFolderError(
            f"{flag} {shown}: cannot take the lock of this output ({exc.strerror or exc})"
        ) from None
    try:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()} {os.fspath(real)}\n".encode(), 0)
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # still ours: nobody else holds it while we do
        os.close(fd)


class _Output:
    """One output of one run: resolved, locked, checked, moved aside, committed or rolled back."""

    def __init__(self, spec: WritingCommand, params: Mapping[str, Any], flag: str) -> None:
        self.spec = spec
        self.params = params
        self.flag = flag
        self.path = spec.path_of(params)
        self.kind = spec.kind_of(params) if self.path is not None else "file"
        self.real: Path | None = None
        self.shown = ""
        self.state: State | None = None
        self.before_id: tuple[int, int] | None = None
        self.aside: Path | None = None
        self.aside_id: tuple[int, int] | None = None
        self.claim_id: tuple[int, int] | None = None
        self.made: list = []

    @property
    def force(self) -> bool:
        return bool(self.spec.force and self.params.get(self.spec.force))

    @property
    def replaces(self) -> bool:
        return self.kind == "folder" and self.spec.mode == "replace"

    def inputs(self) -> list[Any]:
        return [self.params.get(name) for name in self.spec.inputs]

    def resolve(self) -> None:
        if self.path is None:
            return
        self.real = resolve_output(self.path, flag=self.flag, kind=self.kind)
        self.shown = _shown(self.path, self.real)

    def check(self) -> None:
        if self.path is None:
            return
        if self.kind == "file":
            own = self.spec.default_is_own and self.params.get(self.spec.out) is None
            check_file(
                self.path,
                inputs=self.inputs(),
                force=self.force,
                own=own,
                in_input=self.spec.mode == "update-in-place",
                flag=self.flag,
            )
            return
        clean_leftovers(self.path)
        self.state = check_folder(
            self.path,
            command=self.spec.name_of(self.params),
            inputs=self.inputs(),
            force=self.force,
            needs_force=self.spec.folder_needs_force,
            flag=self.flag,
            user_files=self.spec.user_files,
        )
        if _real(self.path) != self.real:
            raise OutputFolderError(
                f"{self.flag} {self.shown}: a link on the way changed while it was checked; "
                "nothing was written"
            )
        from stimuli.staging import identity

        self.before_id = identity(self.real)

    def prepare(self) -> Path | None:
        """Move an own folder aside and, for a direct writer, make the folder.

        Return the folder moved aside.
        """
        if not self.replaces or self.real is None:
            return None
        import secrets  # hashlib and hmac: not at import (--help)

        from stimuli.staging import identity, make_parents, rename_noreplace

        out = self.real
        if self.state == "own":
            # the pid in the name (no file to write: a full disk cannot stop it) tells a later
            # run whether this run still owns the folder
            aside = out.parent / f".{out.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
            rename_noreplace(out, aside)
            self.aside, self.aside_id = aside, identity(aside)
            if self.aside_id != self.before_id:  # not the folder checked: put it back, refuse
                self._restore()
                raise OutputFolderError(
                    f"{self.flag} {self.shown}: it changed while it was checked; left as it was"
                )
        if self.spec.command in DIRECT_WRITERS:
            self.made = make_parents(out.parent)
            if self.state == "empty":
                try:
                    os.rmdir(out)  # the kernel refuses a folder no longer empty
                except OSError:
                    return self.aside  # not ours to remove later: write into it as it is
            try:
                os.mkdir(out)
            except FileExistsError:
                self._restore()
                raise OutputFolderError(
                    f"{self.flag} {self.shown}: appeared while this command started; left as it was"
                ) from None
            self.claim_id = identity(out)
        return self.aside

    def _restore(self) -> None:
        """Rename the folder moved aside back onto the output path, never over anything."""
        from stimuli.staging import identity, rename_noreplace

        if self.aside is None or self.real is None:
            return
        if identity(self.aside) != self.aside_id:
            return
        with contextlib.suppress(OSError):
            (self.aside / STAGING_MARKER).unlink(missing_ok=True)
        try:
            rename_noreplace(self.aside, self.real)
        except FileExistsError:
            logger.warning(
                "%s: left the earlier output in %s, since something else is at %s now",
                self.shown,
                self.aside.name,
                self.real,
            )
            return
        self.aside = None

    def commit(self) -> None:
        try:
            self._commit()
        except OSError as exc:  # the manifest could not be written: undo, say where
            self.rollback()
            if exc.errno in (errno.ENOSPC, errno.EDQUOT):
                raise OutputFolderError(
                    f"{self.shown}: the disk is full ({exc.strerror or exc}) while finishing the "
                    f"output; the new output was removed and {self.shown} was left as it was"
                ) from None
            raise

    def _commit(self) -> None:
        from stimuli.staging import identity, remove_own_tree

        if self.path is None or self.real is None:
            return
        out = self.real
        if self.kind == "file":
            if self.spec.mode == "update-in-place":
                _adopt(out)
            return
        is_dir = out.is_dir() and not out.is_symlink()
        if is_dir and self.claim_id is not None and identity(out) == self.claim_id:
            is_dir = any(out.iterdir())  # the folder made for the command: still empty?
        if not is_dir:
            self.rollback()  # the command wrote nothing: as if it had not run
            return
        if self.spec.mode == "update-in-place" and self.state == "own":
            manifest = read_manifest(out) or {"files": []}
            files = set(manifest["files"]) | set(folder_files(out))
        else:
            files = set(folder_files(out))
        if self.spec.user_files is not None:  # a person's README is never the command's
            files = {f for f in files if not self.spec.user_files(f)}
        write_manifest(out, self.spec.name_of(self.params), files)
        self.claim_id = None
        if self.aside is not None:
            remove_own_tree(self.aside, self.aside_id)
            self.aside = None

    def rollback(self) -> None:
        from stimuli.staging import identity, remove_made, remove_own_tree

        if self.real is None or not self.replaces:
            return
        if self.claim_id is not None:  # only the folder this run made, while it is that one
            remove_own_tree(self.real, self.claim_id)
            self.claim_id = None
        else:  # a staging folder this process made and renamed into place, while it is there
            now = identity(self.real)
            if now is not None and now in _published_here(self.real):
                remove_own_tree(self.real, now)
        if self.state == "empty" and not os.path.lexists(self.real):
            with contextlib.suppress(OSError):
                os.mkdir(self.real)  # the user's empty folder, as it was
        self._restore()
        remove_made(self.made)


def _published_here(real: Path) -> set[tuple[int, int]]:
    """Identities of the staging folders this process renamed into place at ``real``."""
    from analysis import staging as analysis_staging
    from stimuli import staging

    return {i for i in (staging.published(real), analysis_staging.published(real)) if i}


def _adopt(path: Path) -> None:
    """List a file an update-in-place command wrote in the manifest of the folder holding it."""
    folder = path.parent
    manifest = read_manifest(folder)
    if manifest is None or not path.exists():
        return
    files = set(manifest["files"]) | {path.name}
    if files != set(manifest["files"]):
        write_manifest(folder, manifest["command"], files)


def _flag_of(cmd: Any, name: str) -> str:
    for p in getattr(cmd, "params", ()):
        if p.name == name:
            longs = [o for o in p.opts if o.startswith("--")]
            return longs[0] if longs else name
    return f"--{name}"


@functools.cache
def _force_option() -> Any:
    """Make a ``--force`` flag by typer itself (so help and parsing match the other options)."""
    import typer

    holder = typer.Typer()

    @holder.command()
    def _cmd(
        force: bool = typer.Option(
            False, "--force", help="Replace an existing output file (never an input)."
        ),
    ) -> None:
        """Hold the flag."""

    return typer.main.get_command(holder).params[0]


def guard_command(cmd: Any, command: str) -> Any:
    """Wrap the click command ``cmd`` (``command``, e.g. ``'analyze run'``) in the contract.

    Does nothing for a command not in :data:`experiment.outputs.WRITING_COMMANDS`. Adds
    ``--force`` where a row asks for it. Returns ``cmd``.
    """
    specs = [s for s in WRITING_COMMANDS if s.command == command]
    if not specs or getattr(cmd, "_confocal_outputs", False):
        return cmd
    names = {p.name for p in cmd.params}
    added = False
    if any(s.add_force for s in specs) and "force" not in names:
        cmd.params.append(_force_option())
        added = True
    original = cmd.callback
    flags = {s.out: _flag_of(cmd, s.out) for s in specs}
    accepts = names  # the parameters the command itself takes

    @functools.wraps(original)
    def callback(**kwargs: Any) -> Any:
        params = dict(kwargs)
        if added:
            kwargs.pop("force", None)
        outputs = [_Output(s, params, flags[s.out]) for s in specs]
        with contextlib.ExitStack() as stack:
            for o in outputs:
                o.resolve()  # once: every check and write below uses this path
            for o in outputs:
                if o.real is not None:
                    stack.enter_context(output_lock(o.real, o.shown, o.flag))
            for o in outputs:
                o.check()
            with _running(outputs):
                for o in outputs:
                    aside = o.prepare()
                    if o.spec.passes_aside and o.spec.passes_aside in accepts:
                        kwargs[o.spec.passes_aside] = aside
                return original(**kwargs)

    cmd.callback = callback
    cmd._confocal_outputs = True
    return cmd


def _succeeded(exc: BaseException) -> bool:
    code = getattr(exc, "exit_code", getattr(exc, "code", 1))
    return (
        type(exc).__name__ == "Exit"
        and code in (0, None)
        or (isinstance(exc, SystemExit) and exc.code in (0, None))
    )


@contextlib.contextmanager
def _running(outputs: list[_Output]) -> Iterator[None]:
    try:
        yield
    except BaseException as exc:
        if _succeeded(exc):
            for o in outputs:
                o.commit()
        else:
            for o in outputs:
                try:
                    o.rollback()
                except OSError as err:  # the original error matters more; say where it is
                    logger.error("could not restore %s: %s", o.path, err)
        raise
    for o in outputs:
        o.commit()
