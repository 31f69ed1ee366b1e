"""One contract for every ``confocal`` command that writes a folder or a file.

The rule, in plain words:

* A command writes into a **new folder, an empty folder, or a folder that the same command
  wrote before**. Such a folder carries a small manifest, :data:`MANIFEST_NAME`, listing the
  command and every file it wrote (relative paths; no timestamps, no host paths).
* Writing again into a folder of one's own **replaces only that folder's own files**; where the
  command has a ``--force`` flag for this (``stimuli synth``, ``demo``) it needs the flag, as
  before. A folder holding any file not in its manifest (a user's file, a hidden file) is
  refused, as is a folder written by a different command, the current working folder (or one
  holding it), a folder holding an input, and a folder equal to or inside an input. Paths are
  compared after resolving symlinks and ``..``.
* A single-file output (``--screenshot``, ``lightfield refocus --out x.png``) is never an input
  file nor inside an input folder, and an existing file is replaced only with ``--force``.
* Every path is resolved **once** (:func:`resolve_output`: ``os.path.realpath`` on the path as
  given, so ``link/../x`` is the ``x`` beside the link's target, as the kernel sees it) and
  every check and write uses that path. An output that is itself a symbolic link (dangling or
  not) is refused, for every command, before the work; a path through a link is written where
  it leads, and messages name it as typed (and where it leads).
* ``session export`` merges into its own dataset, and ``stimuli tune`` writes ``objects.csv`` and
  ``tune_sheet.png`` into the PAIRS folder it reads: both update their own files in place, by
  design ("update-in-place"): they are checked the same way, but nothing is moved aside.
* Staging leftovers of killed runs beside an output (``.NAME.tmp-*``, ``.NAME.old-*``) are
  cleaned at the next run writing there: an ``.old-*`` folder whose original is missing is
  renamed back (never deleted); a ``.tmp-*`` folder is deleted only if its marker file
  (:data:`STAGING_MARKER`) names a process that is gone; a leftover name that is a link is
  removed as a link, never followed.

A refusal is one line and exit status 2 (:class:`OutputFolderError`). The root command
(:mod:`experiment.cli`) wraps each writing command listed in :data:`WRITING_COMMANDS` with
:func:`experiment.output_guard.guard_command`: resolve, lock (a second writer to the same output
is refused), check, move an own folder aside (``.NAME.old-*``), run the command, write the
manifest, then delete the aside folder, or put it back if the command failed or wrote nothing.
Nothing is removed by a path resolved again: only folders this run made, identified by device
and inode (:mod:`stimuli.staging`). The library functions are safe on their own too: they fill
a staging folder and rename it only onto a missing or empty folder
(``stimuli.io.staged_folder``, ``analysis.report.atomic_folder``), never replacing anything
else.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from experiment.errors import ConfocalError
from stimuli.flagnames import param

__all__ = [
    "MANIFEST_NAME",
    "STAGING_MARKER",
    "OutputFolderError",
    "WritingCommand",
    "WRITING_COMMANDS",
    "check_folder",
    "check_file",
    "clean_leftovers",
    "folder_files",
    "resolve_output",
    "read_manifest",
    "require_missing_or_empty",
    "write_manifest",
]

logger = logging.getLogger(__name__)

#: The manifest a command leaves in every folder it writes: ``{"command": ..., "files": [...]}``.
MANIFEST_NAME = ".confocal-output.json"
#: The marker inside a staging or aside folder: ``{"pid": N}``, the process that made it (the
#: same name as ``stimuli.io.STAGING_MARKER`` and ``analysis.report.STAGING_MARKER``).
STAGING_MARKER = ".confocal-staging.json"

Kind = Literal["folder", "file"]
Mode = Literal["replace", "update-in-place"]
State = Literal["new", "empty", "own"]


class OutputFolderError(ConfocalError):
    """An output folder or file the command refuses to write (one line, exit status 2)."""


@dataclass(frozen=True)
class WritingCommand:
    """One output of a ``confocal`` command, and how the contract applies to it.

    Attributes
    ----------
    command : str
        Command path as typed after ``confocal``, e.g. ``'analyze run'``.
    out : str
        Name of the command's parameter holding the output path.
    inputs : tuple of str
        Names of the parameters holding input paths (a path, a list of paths, or None).
    kind : {'folder', 'file'} or callable(params) -> kind
        What the output is; a callable decides from the parameters (``--stack``, a suffix).
    mode : {'replace', 'update-in-place'}
        ``replace``: an own folder is moved aside and replaced; ``update-in-place``: the
        command merges into its own folder (or file), which is only checked.
    force : str or None
        The parameter of the command's ``--force`` flag; ``add_force`` adds the flag when the
        command has none. None: the output has no flag.
    folder_needs_force : bool
        Replacing an own folder needs ``--force`` (the command's flag behaviour before).
    add_force : bool
        Add a ``--force`` flag to the command (it had none).
    default_out : callable(params) -> Path or None, optional
        The output path the command uses when ``out`` is left at its default (``demo``,
        ``stimuli tune``).
    default_is_own : bool
        A file at ``default_out`` belongs to the command by design and is replaced without
        ``--force`` (``stimuli tune``'s ``tune_sheet.png``).
    name : callable(params) -> str, optional
        The command name written to the manifest, when it depends on the options
        (``demo --lightfield``); default: ``command``.
    passes_aside : str or None
        A parameter of the command that receives the folder moved aside (``stimuli build``
        refuses a different stimulus set there without ``--force``).
    user_files : callable(relative path) -> bool, optional
        Files a person may add to the own folder (a dataset's README): kept, never the command's.
    """

    command: str
    out: str
    inputs: tuple[str, ...] = ()
    kind: Kind | Callable[[Mapping[str, Any]], Kind] = "folder"
    mode: Mode = "replace"
    force: str | None = None
    folder_needs_force: bool = False
    add_force: bool = False
    default_out: Callable[[Mapping[str, Any]], Path | None] | None = None
    default_is_own: bool = False
    name: Callable[[Mapping[str, Any]], str] | None = None
    passes_aside: str | None = None
    user_files: Callable[[str], bool] | None = None

    def kind_of(self, params: Mapping[str, Any]) -> Kind:
        """Return ``'folder'`` or ``'file'`` for these parameters."""
        return self.kind(params) if callable(self.kind) else self.kind

    def name_of(self, params: Mapping[str, Any]) -> str:
        """Return the command name recorded in the manifest for these parameters."""
        return self.name(params) if self.name is not None else self.command

    def path_of(self, params: Mapping[str, Any]) -> Path | None:
        """Return the output path for these parameters (None: the command writes none)."""
        if self.default_out is not None:
            return self.default_out(params)
        value = params.get(self.out)
        return None if value is None else Path(value)


def _stack(params: Mapping[str, Any]) -> Kind:
    return "folder" if params.get("stack") else "file"


def _synth_kind(params: Mapping[str, Any]) -> Kind:
    return "file" if Path(params["out"]).suffix.lower() in (".npz", ".png") else "folder"


def _demo_mode(params: Mapping[str, Any]) -> str:
    return "active" if params.get("active") else "lightfield" if params.get("lightfield") else ""


def _demo_out(params: Mapping[str, Any]) -> Path:
    out = Path(params["out"])
    mode = _demo_mode(params)
    # the same defaults as ``confocal demo``: each demo has its own default folder
    return Path(f"confocal-demo-{mode}") if mode and out == Path("confocal-demo") else out


def _demo_name(params: Mapping[str, Any]) -> str:
    mode = _demo_mode(params)
    return f"demo --{mode}" if mode else "demo"


def _dataset_user_file(relpath: str) -> bool:
    from experiment.data.psychds import is_optional_file  # not at start-up

    return is_optional_file(relpath)


def _tune_sheet(params: Mapping[str, Any]) -> Path:
    if params.get("sheet") is not None:
        return Path(params["sheet"])
    pairs = Path(params["pairs"])
    return (pairs if pairs.is_dir() else pairs.parent) / "tune_sheet.png"


#: Every command that writes a folder or a file, with its output and input parameters.
#: ``tests/test_output_folders.py`` checks that every ``--out``/``--screenshot`` option of the
#: command tree is listed here, and runs each row against every refusal.
WRITING_COMMANDS: tuple[WritingCommand, ...] = (
    WritingCommand("analyze run", "out", ("trials",)),
    WritingCommand("analyze fit", "out", ("table",)),
    WritingCommand("analyze power", "out"),
    WritingCommand("stimuli build", "out", ("pairs",), force="force", passes_aside="replaces"),
    WritingCommand("stimuli synth", "out", force="force", folder_needs_force=True),
    # tune edits the PAIRS folder it reads, by design: objects.csv and its contact sheet
    WritingCommand(
        "stimuli tune",
        "sheet",
        ("pairs",),
        kind="file",
        mode="update-in-place",
        force="force",
        add_force=True,
        default_out=_tune_sheet,
        default_is_own=True,
    ),
    WritingCommand("lightfield scan", "out", ("lightfield",)),
    WritingCommand(
        "lightfield refocus", "out", ("lightfield",), kind=_stack, force="force", add_force=True
    ),
    WritingCommand("lightfield synth", "out", kind=_synth_kind, force="force", add_force=True),
    WritingCommand(
        "session export", "out", ("data",), mode="update-in-place", user_files=_dataset_user_file
    ),
    WritingCommand(
        "demo",
        "out",
        force="force",
        folder_needs_force=True,
        default_out=_demo_out,
        name=_demo_name,
    ),
    WritingCommand(
        "view",
        "screenshot",
        ("lightfield", "script"),
        kind="file",
        force="force",
        add_force=True,
    ),
    WritingCommand("view", "shots", ("lightfield", "script")),
    WritingCommand(
        "present",
        "screenshot",
        ("stimulus", "protocol"),
        kind="file",
        force="force",
        add_force=True,
    ),
)


# -- the rule ------------------------------------------------------------------------------------


def _real(path: str | os.PathLike) -> Path:
    """Return the one real path of ``path``: links followed before ``..``, as the kernel does."""
    return Path(os.path.realpath(os.fspath(path)))


def _is_link(path: str | os.PathLike) -> bool:
    """Whether ``path`` itself (trailing slashes ignored) is a symbolic link, dangling or not."""
    text = os.fspath(path).rstrip("/" + os.sep) or os.sep
    return os.path.islink(text)


def _shown(path: str | os.PathLike, real: Path) -> str:
    """Show the path as the user typed it, and where it leads when links or ``..`` change that."""
    lexical = os.path.normpath(os.path.abspath(os.fspath(path)))
    return os.fspath(path) if lexical == os.fspath(real) else f"{os.fspath(path)} (= {real})"


def resolve_output(out: str | os.PathLike, *, flag: str = "--out", kind: str = "folder") -> Path:
    """Resolve an output path once and refuse a link at it or a loop of links on the way.

    Every check and write then uses the returned path (``os.path.realpath`` on the path as
    given: ``link/../x`` is the ``x`` beside the link's target, as the kernel sees it).

    Raises
    ------
    OutputFolderError
        ``out`` itself is a symbolic link (dangling or not), a loop of links, or a path with
        ``..`` after a folder that does not exist.
    """
    real = _real(out)
    if _is_link(out):
        target = os.readlink(os.fspath(out).rstrip("/" + os.sep) or os.sep)
        raise OutputFolderError(
            f"{flag} {os.fspath(out)}: is a symbolic link (to {target}); confocal never writes "
            f"through a link: give the {kind} itself, or a new path"
        )
    from stimuli.staging import is_link_loop, missing_before_dotdot

    if is_link_loop(real):
        raise OutputFolderError(
            f"{flag} {os.fspath(out)}: is a loop of symbolic links; expected a {kind} path"
        )
    missing = missing_before_dotdot(out)
    if missing is not None:
        raise OutputFolderError(
            f"{flag} {os.fspath(out)}: {missing} is not an existing folder, so '..' after it "
            f"leads nowhere; expected a {kind} path"
        )
    return real


def _inside(child: Path, parent: Path) -> bool:
    return child != parent and parent in child.parents


def _paths(values: Iterable[Any]) -> list[Path]:
    out: list[Path] = []
    for v in values:
        if v is None or isinstance(v, bool):
            continue
        if isinstance(v, str | os.PathLike):
            out.append(Path(v))
        elif isinstance(v, Iterable):
            out.extend(_paths(v))
    return out


def folder_files(folder: str | os.PathLike) -> list[str]:
    """List every file under ``folder`` (hidden ones too, not the manifest), relative, sorted.

    Symbolic links are listed, not followed; an empty sub-folder is listed as ``name/``.
    """
    root = Path(folder)
    found: list[str] = []
    for dirpath, dirnames, filenames in os.walk(root):
        d = Path(dirpath)
        for name in list(dirnames):
            if (d / name).is_symlink():
                filenames.append(name)
                dirnames.remove(name)
        for name in filenames:
            rel = (d / name).relative_to(root).as_posix()
            if rel != MANIFEST_NAME:
                found.append(rel)
        if d != root and not dirnames and not filenames:
            found.append(d.relative_to(root).as_posix() + "/")
    return sorted(found)


def read_manifest(folder: str | os.PathLike) -> dict[str, Any] | None:
    """Return the manifest of ``folder`` (``command``, ``files``), or None if it has none."""
    path = Path(folder) / MANIFEST_NAME
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if (
        not isinstance(data, dict)
        or not isinstance(data.get("command"), str)
        or not isinstance(data.get("files"), list)
    ):
        return None
    return data


def write_manifest(folder: str | os.PathLike, command: str, files: Iterable[str]) -> Path:
    """Write ``folder``'s manifest atomically: the command and the files it wrote there."""
    folder = Path(folder)
    text = json.dumps({"command": command, "files": sorted(set(files))}, indent=1) + "\n"
    fd, tmp = tempfile.mkstemp(prefix=f"{MANIFEST_NAME}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, folder / MANIFEST_NAME)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return folder / MANIFEST_NAME


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _refuse_below_a_file(real: Path, flag: str, shown: str, kind: str) -> None:
    """Refuse a path whose nearest existing folder on the way is a file (nothing can go there)."""
    above = real.parent
    while not os.path.lexists(above) and above != above.parent:
        above = above.parent
    if not os.path.isdir(above):
        raise _refuse(flag, shown, f"{above} is a file, not a folder; expected a {kind} path")


def _refuse(flag: str, out: Path | str, reason: str) -> OutputFolderError:
    return OutputFolderError(f"{flag} {out}: {reason}")


def check_folder(
    out: str | os.PathLike,
    *,
    command: str,
    inputs: Iterable[str | os.PathLike] = (),
    cwd: str | os.PathLike | None = None,
    force: bool = False,
    needs_force: bool = False,
    flag: str = "--out",
    user_files: Callable[[str], bool] | None = None,
) -> State:
    """Check an output folder against the contract; return what it is now.

    Parameters
    ----------
    out : path-like
        The output folder.
    command : str
        The writing command's name, as recorded in manifests (``'analyze run'``).
    inputs : iterable of path-like
        The command's input files and folders.
    cwd : path-like, optional
        The current working folder (default: ``os.getcwd()``).
    force : bool
        The user gave ``--force``.
    needs_force : bool
        Replacing an own folder needs ``force``.
    flag : str
        The option named in messages.
    user_files : callable(relative path) -> bool, optional
        As :attr:`WritingCommand.user_files`.

    Returns
    -------
    {'new', 'empty', 'own'}
        Missing, an empty folder, or a folder this command wrote before (all files its own).

    Raises
    ------
    OutputFolderError
        The folder is the working folder or holds it, is or holds an input or lies inside one,
        is a file, holds files confocal did not write, was written by another command, or is an
        own folder to be replaced without ``--force`` where that is needed.
    """
    real = resolve_output(out, flag=flag)
    shown = _shown(out, real)
    here = _real(os.getcwd() if cwd is None else cwd)
    if real == here:
        raise _refuse(flag, shown, "is the current working folder; choose a new or empty folder")
    if _inside(here, real):
        raise _refuse(
            flag, shown, f"holds the current working folder {here}; choose a new or empty folder"
        )
    for p in _paths(inputs):
        inp = _real(p)
        if real == inp:
            raise _refuse(flag, shown, f"is the input {p}; choose a new or empty folder")
        if _inside(real, inp):
            raise _refuse(flag, shown, f"is inside the input {p}; choose a new or empty folder")
        if _inside(inp, real):
            raise _refuse(flag, shown, f"holds the input {p}; choose a new or empty folder")
    _refuse_below_a_file(real, flag, shown, "folder")
    if not real.exists():
        return "new"
    if not real.is_dir():
        raise _refuse(flag, shown, "exists and is a file, not a folder; expected a folder to write")
    files = folder_files(real)
    manifest = read_manifest(real)
    if manifest is None:
        if not files:
            return "empty"
        raise _refuse(
            flag,
            shown,
            f"holds files confocal did not write: {_names(files)}; choose a new or empty folder",
        )
    if manifest["command"] != command:
        raise _refuse(
            flag,
            shown,
            f"was written by 'confocal {manifest['command']}', not 'confocal {command}'; "
            "choose a new or empty folder",
        )
    own = {str(f) for f in manifest["files"]}
    foreign = [f for f in files if f not in own and not (user_files and user_files(f))]
    if foreign:
        raise _refuse(
            flag,
            shown,
            f"holds files confocal did not write: {_names(foreign)}; choose a new or empty folder",
        )
    if needs_force and not force:
        raise _refuse(
            flag,
            shown,
            f"holds the output of an earlier 'confocal {command}'; use {param('force', True)} "
            "to replace it",
        )
    return "own"


def _names(files: list[str], most: int = 5) -> str:
    shown = ", ".join(files[:most])
    return shown + (f" and {len(files) - most} more" if len(files) > most else "")


def check_file(
    out: str | os.PathLike,
    *,
    inputs: Iterable[str | os.PathLike] = (),
    force: bool = False,
    own: bool = False,
    in_input: bool = False,
    flag: str = "--out",
) -> bool:
    """Check a single output file against the contract; return whether it exists.

    Parameters
    ----------
    out : path-like
        The output file.
    inputs : iterable of path-like
        The command's input files and folders: the output is none of them and lies in none.
    force : bool
        The user gave ``--force``: an existing file may be replaced.
    own : bool
        The file belongs to the command by design (``stimuli tune``'s default sheet): an
        existing one is replaced without ``force``.
    in_input : bool
        The command edits its input folder by design (``stimuli tune``): the file may lie
        inside an input folder (never be an input file).

    Raises
    ------
    OutputFolderError
        The path is a folder, an input file or inside an input folder, or an existing file
        without ``force``.
    """
    real = resolve_output(out, flag=flag, kind="file")
    shown = _shown(out, real)
    if real.is_dir():
        raise _refuse(flag, shown, "is a folder; expected a file path")
    for p in _paths(inputs):
        inp = _real(p)
        if real == inp:
            raise _refuse(flag, shown, "is an input of this command; choose another file")
        if _inside(real, inp) and not in_input:
            raise _refuse(flag, shown, f"is inside the input {p}; choose a file outside the input")
    _refuse_below_a_file(real, flag, shown, "file")
    exists = real.exists()
    if exists and not (force or own):
        raise _refuse(flag, shown, f"exists; use {param('force', True)} to replace it")
    return exists


def require_missing_or_empty(out: str | os.PathLike) -> None:
    """Refuse an ``out`` that is a file or a non-empty folder (library writers never replace one).

    The rule and its message are those of :func:`stimuli.io.check_missing_or_empty`.

    Raises
    ------
    OutputFolderError
        Naming the folder and what was expected.
    """
    from stimuli.errors import InputError
    from stimuli.io import check_missing_or_empty  # numpy and PIL: not at import (--help)

    try:
        check_missing_or_empty(out)
    except InputError as exc:
        raise OutputFolderError(str(exc)) from None


# -- staging leftovers -----------------------------------------------------------------------------


def _pid_alive(pid: int) -> bool:
    """Whether process ``pid`` (from a marker or a folder name) runs: the session locks' check."""
    from experiment.log.locks import pid_alive

    return pid > 0 and pid_alive(pid, None)


def _marker_pid(folder: Path) -> int | None:
    try:
        pid = json.loads((folder / STAGING_MARKER).read_text(encoding="utf-8")).get("pid")
    except (OSError, ValueError, AttributeError):
        return None
    return pid if isinstance(pid, int) and not isinstance(pid, bool) else None


def _name_pid(suffix: str) -> int | None:
    """Return the pid in an aside folder's name suffix ``PID-TOKEN``, or None."""
    head, sep, _ = suffix.partition("-")
    return int(head) if sep and head.isdigit() else None


def clean_leftovers(out: str | os.PathLike) -> list[str]:
    """Clean staging leftovers of killed runs beside ``out``; return what was done, one per line.

    ``out`` is resolved once (links, then ``..``) and its folder listed. ``.NAME.old-*`` (an
    output moved aside): renamed back when ``NAME`` is missing; deleted only when ``NAME``
    exists again and the aside folder holds nothing but its own manifest's files; left alone
    while the process in its marker runs. ``.NAME.tmp-*`` (a staging folder): deleted only when
    its marker names a process that is gone; without a marker it is left. A leftover name that
    is a symbolic link is removed as a link (its target is never followed nor touched).
    """
    from stimuli.staging import identity, remove_own_tree, rename_noreplace

    out = _real(out)
    parent = out.parent
    done: list[str] = []
    if not parent.is_dir():
        return done
    old, tmp = f".{out.name}.old-", f".{out.name}.tmp-"
    for entry in sorted(parent.iterdir()):
        name = entry.name
        if not name.startswith((old, tmp)):
            continue
        if entry.is_symlink():
            with contextlib.suppress(OSError):
                entry.unlink()  # the link only, never what it points to
                done.append(f"removed {name}, a link where confocal keeps its staging folders")
            continue
        if not entry.is_dir():
            continue
        ident = identity(entry)
        if name.startswith(old):
            pid = _name_pid(name[len(old) :]) or _marker_pid(entry)
            if pid is not None and _pid_alive(pid):
                continue
            if not os.path.lexists(out):
                (entry / STAGING_MARKER).unlink(missing_ok=True)
                try:
                    rename_noreplace(entry, out)
                except FileExistsError:
                    continue
                done.append(f"restored {out} from {name}, left by an interrupted run")
                logger.warning("restored %s from %s, left by an interrupted run", out, name)
            elif _all_own(entry) and remove_own_tree(entry, ident):
                done.append(f"removed {name}, an earlier output already replaced")
        else:
            pid = _marker_pid(entry)
            if pid is None or _pid_alive(pid):
                continue
            if remove_own_tree(entry, ident):
                done.append(f"removed {name}, a staging folder of an interrupted run")
    return done


def _all_own(folder: Path) -> bool:
    manifest = read_manifest(folder)
    if manifest is None:
        return False
    own = {str(f) for f in manifest["files"]} | {STAGING_MARKER}
    return all(f in own for f in folder_files(folder))
