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
* ``session export`` merges into its own dataset, and ``stimuli tune`` writes ``objects.csv`` and
  ``tune_sheet.png`` into the PAIRS folder it reads: both update their own files in place, by
  design ("update-in-place"): they are checked the same way, but nothing is moved aside.
* Staging leftovers of killed runs beside an output (``.NAME.tmp-*``, ``.NAME.old-*``) are
  cleaned at the next run writing there: an ``.old-*`` folder whose original is missing is
  renamed back (never deleted); a ``.tmp-*`` folder is deleted only if its marker file
  (:data:`STAGING_MARKER`) names a process that is gone.

A refusal is one line and exit status 2 (:class:`OutputFolderError`). The root command
(:mod:`experiment.cli`) wraps each writing command listed in :data:`WRITING_COMMANDS` with
:func:`guard_command`: check, move an own folder aside (``.NAME.old-*``), run the command, write
the manifest, then delete the aside folder, or put it back if the command failed or wrote
nothing. The library functions are safe on their own too: they fill a staging folder and rename
it only onto a missing or empty folder (``stimuli.io.staged_folder``,
``analysis.report.atomic_folder``), never replacing a non-empty one.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import json
import logging
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from experiment.errors import ConfocalError

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
    "guard_command",
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
    return Path(os.path.realpath(os.path.abspath(path)))


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


def _refuse(flag: str, out: Path, reason: str) -> OutputFolderError:
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
    real = _real(out)
    here = _real(os.getcwd() if cwd is None else cwd)
    if real == here:
        raise _refuse(
            flag, Path(out), "is the current working folder; choose a new or empty folder"
        )
    if _inside(here, real):
        raise _refuse(
            flag,
            Path(out),
            f"holds the current working folder {here}; choose a new or empty folder",
        )
    for p in _paths(inputs):
        inp = _real(p)
        if real == inp:
            raise _refuse(flag, Path(out), f"is the input {p}; choose a new or empty folder")
        if _inside(real, inp):
            raise _refuse(flag, Path(out), f"is inside the input {p}; choose a new or empty folder")
        if _inside(inp, real):
            raise _refuse(flag, Path(out), f"holds the input {p}; choose a new or empty folder")
    if not real.exists():
        return "new"
    if not real.is_dir():
        raise _refuse(
            flag, Path(out), "exists and is a file, not a folder; expected a folder to write"
        )
    files = folder_files(real)
    manifest = read_manifest(real)
    if manifest is None:
        if not files:
            return "empty"
        raise _refuse(
            flag,
            Path(out),
            f"holds files confocal did not write: {_names(files)}; choose a new or empty folder",
        )
    if manifest["command"] != command:
        raise _refuse(
            flag,
            Path(out),
            f"was written by 'confocal {manifest['command']}', not 'confocal {command}'; "
            "choose a new or empty folder",
        )
    own = {str(f) for f in manifest["files"]}
    foreign = [f for f in files if f not in own and not (user_files and user_files(f))]
    if foreign:
        raise _refuse(
            flag,
            Path(out),
            f"holds files confocal did not write: {_names(foreign)}; choose a new or empty folder",
        )
    if needs_force and not force:
        raise _refuse(
            flag,
            Path(out),
            f"holds the output of an earlier 'confocal {command}'; use --force to replace it",
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
    real = _real(out)
    if real.is_dir():
        raise _refuse(flag, Path(out), "is a folder; expected a file path")
    for p in _paths(inputs):
        inp = _real(p)
        if real == inp:
            raise _refuse(flag, Path(out), "is an input of this command; choose another file")
        if _inside(real, inp) and not in_input:
            raise _refuse(
                flag, Path(out), f"is inside the input {p}; choose a file outside the input"
            )
    exists = real.exists() or real.is_symlink()
    if exists and not (force or own):
        raise _refuse(flag, Path(out), "exists; use --force to replace it")
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

    ``.NAME.old-*`` (an output moved aside): renamed back when ``NAME`` is missing; deleted only
    when ``NAME`` exists again and the aside folder holds nothing but its own manifest's files;
    left alone while the process in its marker runs. ``.NAME.tmp-*`` (a staging folder):
    deleted only when its marker names a process that is gone; without a marker it is left.
    """
    out = Path(os.path.abspath(out))
    parent = out.parent
    done: list[str] = []
    if not parent.is_dir():
        return done
    for entry in sorted(parent.iterdir()):
        name = entry.name
        if not entry.is_dir() or entry.is_symlink():
            continue
        if name.startswith(f".{out.name}.old-"):
            pid = _name_pid(name[len(f".{out.name}.old-") :]) or _marker_pid(entry)
            if pid is not None and _pid_alive(pid):
                continue
            if not out.exists() and not out.is_symlink():
                (entry / STAGING_MARKER).unlink(missing_ok=True)
                os.replace(entry, out)
                done.append(f"restored {out} from {name}, left by an interrupted run")
                logger.warning("restored %s from %s, left by an interrupted run", out, name)
            elif _all_own(entry):
                shutil.rmtree(entry)
                done.append(f"removed {name}, an earlier output already replaced")
        elif name.startswith(f".{out.name}.tmp-"):
            pid = _marker_pid(entry)
            if pid is None or _pid_alive(pid):
                continue
            shutil.rmtree(entry)
            done.append(f"removed {name}, a staging folder of an interrupted run")
    return done


def _all_own(folder: Path) -> bool:
    manifest = read_manifest(folder)
    if manifest is None:
        return False
    own = {str(f) for f in manifest["files"]} | {STAGING_MARKER}
    return all(f in own for f in folder_files(folder))


# -- wrapping the commands -----------------------------------------------------------------------


class _Output:
    """One output of one run: checked, moved aside, committed or rolled back."""

    def __init__(self, spec: WritingCommand, params: Mapping[str, Any], flag: str) -> None:
        self.spec = spec
        self.params = params
        self.flag = flag
        self.path = spec.path_of(params)
        self.kind = spec.kind_of(params) if self.path is not None else "file"
        self.state: State | None = None
        self.aside: Path | None = None
        self.before: list[str] = []

    @property
    def force(self) -> bool:
        return bool(self.spec.force and self.params.get(self.spec.force))

    def inputs(self) -> list[Any]:
        return [self.params.get(name) for name in self.spec.inputs]

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
        if self.spec.mode == "update-in-place" and self.state != "new":
            self.before = folder_files(self.path)

    def move_aside(self) -> Path | None:
        import secrets  # hashlib and hmac: not at import (--help)

        if self.kind != "folder" or self.state != "own" or self.spec.mode != "replace":
            return None
        out = Path(os.path.abspath(self.path))
        # the pid in the name (no file to write: a full disk cannot stop it) tells a later run
        # whether this run still owns the folder
        aside = out.parent / f".{out.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
        os.replace(out, aside)
        self.aside = aside
        return aside

    def commit(self) -> None:
        try:
            self._commit()
        except OSError as exc:  # the manifest could not be written: undo, say where
            self.rollback()
            if exc.errno in (errno.ENOSPC, errno.EDQUOT):
                raise OutputFolderError(
                    f"{self.path}: the disk is full ({exc.strerror or exc}) while finishing the "
                    f"output; the new output was removed and {self.path} was left as it was"
                ) from None
            raise

    def _commit(self) -> None:
        if self.path is None:
            return
        out = Path(self.path)
        if self.kind == "file":
            if self.spec.mode == "update-in-place":
                _adopt(out)
            return
        if out.is_dir():
            if self.spec.mode == "update-in-place" and self.state == "own":
                manifest = read_manifest(out) or {"files": []}
                files = set(manifest["files"]) | set(folder_files(out))
            else:
                files = set(folder_files(out))
            if self.spec.user_files is not None:  # a person's README is never the command's
                files = {f for f in files if not self.spec.user_files(f)}
            write_manifest(out, self.spec.name_of(self.params), files)
            if self.aside is not None:
                shutil.rmtree(self.aside, ignore_errors=True)
                self.aside = None
        else:
            self.rollback()

    def rollback(self) -> None:
        if self.path is None or self.kind != "folder" or self.spec.mode != "replace":
            return
        out = Path(self.path)
        if self.state in ("new", "own") and out.is_dir() and not out.is_symlink():
            shutil.rmtree(out, ignore_errors=True)  # made by this run: nothing else is there
        elif self.state == "empty" and out.is_dir() and any(out.iterdir()):
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir(exist_ok=True)
        if self.aside is not None and not out.exists():
            (self.aside / STAGING_MARKER).unlink(missing_ok=True)
            os.replace(self.aside, out)
            self.aside = None


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
    """Return a ``--force`` flag made by typer itself (help and parsing match the other options)."""
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

    Does nothing for a command not in :data:`WRITING_COMMANDS`. Adds ``--force`` where a row
    asks for it. Returns ``cmd``.
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
        for o in outputs:
            o.check()
        with _running(outputs):
            for o in outputs:
                aside = o.move_aside()
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
