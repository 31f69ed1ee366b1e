"""Errors that mean "the user's input is wrong" (one line, exit status 2 at the command line)."""

from __future__ import annotations

__all__ = ["InputError"]


class InputError(ValueError):
    """Bad input to the image pipeline: a missing or corrupt file, wrong sizes, a bad parameter.

    The message is one line that names the file or field and what was expected. The command line
    prints it without a traceback and exits with status 2.
    """

    exit_code = 2
