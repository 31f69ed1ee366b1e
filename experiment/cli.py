"""The ``confocal`` command: root of the command line; each package adds its own sub-commands.

Every sub-command module exposes ``register(app)``, which adds its commands or groups to the root
:class:`typer.Typer`. Errors that carry ``exit_code = 2`` (``stimuli.InputError``,
``analysis.DataError``, ``experiment.ConfocalError`` and their subclasses) are user errors: they
are printed as one line on stderr, without a traceback, and the command exits with status 2.

Start-up is lazy: the sub-command modules import numpy, scipy, pandas and friends, so
the root lists them from :data:`SUBCOMMANDS` (name, module, one-line help) and imports a module
only when one of its commands runs. ``confocal --help`` and ``--version`` import none of them
(``benchmarks/bench_startup.py`` measures it; a test checks the table against the modules).
"""

from __future__ import annotations

import contextlib
import errno
import importlib
import logging
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path

import typer
from typer.core import TyperCommand, TyperGroup, TyperOption

__all__ = ["SUBCOMMANDS", "app", "load_subcommand", "main"]

#: The root's sub-commands, in help order: name -> (module whose ``register(app)`` adds it, the
#: one-line help ``confocal --help`` shows without importing the module).
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "stimuli": (
        "stimuli.cli",
        "Build stimulus sets (Jung et al. 2015, Sec. 3.1) from photo pairs or light fields.",
    ),
    "lightfield": (
        "stimuli.lightfield_cli",
        "Light fields (Jung et al. 2015, Sec. 4): scan depth planes, refocus, zoom, synthesise.",
    ),
    "session": (
        "experiment.commands.session",
        "Run recognition sessions and inspect or export the study's trial log.",
    ),
    "present": (
        "experiment.commands.present",
        "Show one stimulus as the subject would see it, or render it offscreen (--screenshot).",
    ),
    "score": (
        "experiment.commands.score",
        "Score logged responses as a second rater, blind to the first rater's scores.",
    ),
    "analyze": (
        "analysis.cli",
        "Analyse trial logs (Jung et al. 2015, Sec. 3.2.2) or plan a study.",
    ),
    "active": (
        "experiment.commands.active",
        "Active search (Jung et al. 2015, Sec. 5): a subject drives the confocal viewer to "
        "find and name objects; every key and displayed state is logged.",
    ),
    "view": (
        "experiment.commands.view",
        "Scan depth, jump to object planes, zoom and see the implant's view, live.",
    ),
    "demo": (
        "experiment.demos.study",
        "Run the whole study on synthetic data: scenes, stimuli, sessions, analysis, report.",
    ),
}


class _Unloaded(TyperCommand):
    """Stands in for a sub-command in the root's listing until the command runs."""


def _no_type_label(param: object) -> object:
    if isinstance(param, TyperOption) and param.is_flag and param.metavar is None:
        param.metavar = ""  # an empty metavar: no type column for this option
    return param


def _tidy_flags(cmd: object) -> None:
    """Drop the ``<bool>`` type label that typer prints beside every on/off flag and --help."""
    for param in getattr(cmd, "params", ()):
        _no_type_label(param)
    make_help = getattr(cmd, "get_help_option", None)
    if make_help is not None and not getattr(make_help, "_tidy", False):

        def get_help_option(ctx, _make=make_help):
            return _no_type_label(_make(ctx))

        get_help_option._tidy = True  # type: ignore[attr-defined]
        cmd.get_help_option = get_help_option  # type: ignore[attr-defined]
    for sub in getattr(cmd, "commands", {}).values():
        _tidy_flags(sub)


def load_subcommand(name: str) -> object:
    """Import the module of sub-command ``name`` and return its click command.

    Raises
    ------
    KeyError
        ``name`` is not in :data:`SUBCOMMANDS`.
    """
    module_name, _ = SUBCOMMANDS[name]
    holder = typer.Typer(add_completion=False)
    importlib.import_module(module_name).register(holder)
    group = typer.main.get_group(holder)
    cmd = group.commands[name]
    _guard_outputs(cmd, name)
    _tidy_flags(cmd)
    return cmd


def _guard_outputs(cmd: object, path: str) -> None:
    """Wrap each command that writes a folder or file in the contract of experiment.outputs."""
    from experiment.output_guard import guard_command

    for sub_name, sub in getattr(cmd, "commands", {}).items():
        _guard_outputs(sub, f"{path} {sub_name}")
    if not hasattr(cmd, "commands"):
        guard_command(cmd, path)


class _LazyGroup(TyperGroup):
    """The root group: sub-commands are listed from :data:`SUBCOMMANDS`, imported when run."""

    def __init__(self, **kwargs: object) -> None:
        super().__init__(**kwargs)
        for name, (_, short_help) in SUBCOMMANDS.items():
            self.commands.setdefault(name, _Unloaded(name=name, help=short_help))
        _tidy_flags(self)

    def resolve_command(self, ctx, args):  # noqa: D102 - click API
        name = args[0] if args else None
        if name in SUBCOMMANDS and isinstance(self.commands.get(name), _Unloaded):
            self.commands[name] = load_subcommand(name)
        return super().resolve_command(ctx, args)


app = typer.Typer(
    name="confocal",
    cls=_LazyGroup,
    help="Active confocal imaging for visual prostheses (Jung et al. 2015): build stimulus sets, "
    "refocus light fields, run recognition sessions and analyse them.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
)


def _version_callback(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:  # not ``stimuli.__version__``: importing stimuli loads numpy (same lookup)
            v = version("active-confocal")
        except PackageNotFoundError:
            v = "0+unknown"
        typer.echo(f"confocal {v}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True, help="Print the version."
    ),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log progress details."),
) -> None:
    """Active confocal imaging for visual prostheses."""
    logging.basicConfig(
        level=logging.INFO if verbose else logging.WARNING,
        format="confocal: %(levelname)s: %(message)s",
    )


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


#: The packages whose warnings are meant for the user (a scan that hit its range, a fit on its
#: prior bound): shown as one line each, never as Python's ``path:line: UserWarning`` report.
_OWN_PACKAGES = ("stimuli", "experiment", "analysis")


@contextlib.contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """Show the project's warnings as ``warning: MESSAGE`` lines on stderr while a command runs.

    Warnings raised from third-party code keep Python's default handling (most are filtered out
    unless ``-W`` asks for them).
    """
    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        module = Path(filename).as_posix()
        own = any(f"/{pkg}/" in module for pkg in _OWN_PACKAGES) and issubclass(
            category, UserWarning
        )
        if not own:
            shown(message, category, filename, lineno, file, line)
            return
        text = " ".join(str(message).split())
        print(f"warning: {text}", file=file or sys.stderr)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = shown


def main(argv: list[str] | None = None) -> None:
    """Run the ``confocal`` command; user errors end with one line and exit status 2.

    SIGTERM and SIGINT stop a running command through :class:`experiment.signals.Stopped`, so
    its ``finally:`` blocks close the trial log and remove temporary folders; it ends with one
    line and status 128 + the signal number (143, 130).
    """
    from experiment.signals import Stopped, report_stop, stop_on_signals

    try:
        with stop_on_signals(), _warnings_as_lines():
            app(args=argv, prog_name="confocal")
    except Stopped as stop:
        report_stop(stop)
        sys.exit(stop.exit_code)
    except Exception as exc:  # noqa: BLE001 - classified just below
        if getattr(exc, "exit_code", None) == 2:
            from stimuli.flagnames import flag_text  # library messages name parameters

            typer.echo(f"confocal: error: {_one_line(flag_text(str(exc)))}", err=True)
            sys.exit(2)
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            where = f"{exc.filename}: " if exc.filename is not None else ""
            typer.echo(
                f"confocal: error: {where}the disk is full ({exc.strerror or exc}); the command "
                "stopped; free space and run it again",
                err=True,
            )
            sys.exit(2)
        if isinstance(exc, OSError) and exc.filename is not None:
            typer.echo(f"confocal: error: {exc.filename}: {exc.strerror or exc}", err=True)
            sys.exit(2)
        raise


if __name__ == "__main__":
    main()
