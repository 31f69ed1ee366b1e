"""Errors meaning "the data given to the analysis is wrong" (exit status 2 at the command line)."""

from __future__ import annotations

__all__ = ["DataError", "OptionError"]


class DataError(ValueError):
    """Data that cannot be analysed: missing columns, empty files, non-numeric values, ...

    The message is one line naming the file or column and what was expected; the command line
    prints it without a traceback and exits with status 2.
    """

    exit_code = 2


class OptionError(ValueError):
    """A command-line option with a bad value; printed as one line, exit status 2."""

    exit_code = 2
