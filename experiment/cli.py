"""The ``confocal`` command: root of the command line; each package adds its own sub-commands.

Every sub-command module exposes ``register(app)``, which adds its commands or groups to the root
:class:`typer.Typer`. Errors that carry ``exit_code = 2`` (``stimuli.InputError``,
``analysis.DataError``, ``experiment.ConfocalError`` and their subclasses) are user errors: they
are printed as one line on stderr, without a traceback, and the command exits with status 2.
"""

from __future__ import annotations

import logging
import sys

import typer

__all__ = ["app", "main"]

app = typer.Typer(
    name="confocal",
    help="Active confocal imaging for visual prostheses (Jung et al. 2015): build stimulus sets, "
    "refocus light fields, run recognition sessions and analyse them.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_show_locals=False,
)


def _version_callback(value: bool) -> None:
    if value:
        from stimuli import __version__

        typer.echo(f"confocal {__version__}")
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


def _register_all() -> None:
    from analysis import cli as analysis_cli
    from experiment import demo, present_cli, session_cli
    from stimuli import cli as stimuli_cli
    from stimuli import lightfield_cli

    for module in (stimuli_cli, lightfield_cli, session_cli, present_cli, analysis_cli, demo):
        module.register(app)
    from experiment.active import cli as active_cli

    active_cli.register(app)


_register_all()


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv: list[str] | None = None) -> None:
    """Run the ``confocal`` command; user errors end with one line and exit status 2."""
    try:
        app(args=argv, prog_name="confocal")
    except Exception as exc:  # noqa: BLE001 - classified just below
        if getattr(exc, "exit_code", None) == 2:
            typer.echo(f"confocal: error: {_one_line(exc)}", err=True)
            sys.exit(2)
        if isinstance(exc, OSError) and exc.filename is not None:
            typer.echo(f"confocal: error: {exc.filename}: {exc.strerror or exc}", err=True)
            sys.exit(2)
        raise


if __name__ == "__main__":
    main()
