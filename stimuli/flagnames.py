"""Library errors name Python parameters; the command line names its flags.

A message raised by library code is read by a Python caller as often as by a command-line user,
so it names the *parameter* (``force=True``), never a flag (``--force``). It writes each one as a
code span made by :func:`param`: ``use `force=True` to replace it``. A command maps the spans to
its flags where it catches the error (:func:`cli_flags`, with the flags whose spelling is not
the parameter's), and the root command prints any span left with the default spelling
(:func:`flag_text`): ``use --force to replace it``.

The spans, and what the command line prints for them:

========================  ===========================
``param("force")``        ``--force``
``param("force", True)``  ``--force``
``param("mode", "grey")`` ``--mode grey``
``param("seed", 3)``      ``--seed 3``
========================  ===========================
"""

from __future__ import annotations

import ast
import re
import shlex
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

__all__ = ["FLAG_SPELLINGS", "param", "flag_of", "flag_text", "cli_flags"]

#: The flags not spelled as their parameter (``--`` and the name with dashes), the same in
#: every command that takes them. A tower that may not import this module (``analysis``) writes
#: its spans literally; the root command maps them with this table.
FLAG_SPELLINGS: dict[str, str] = {
    "implants": "--implant",
    "implant_px_per_electrode": "--implant-px",
    "working_shape_px": "--working-size",
    "out_dir": "--out",
    "pcs": "--pc",
    "n_subjects": "--subjects",
}

_NO_VALUE = object()

#: A parameter span: `name` or `name=value` (a Python literal).
_SPAN = re.compile(r"`([A-Za-z_][A-Za-z0-9_.]*)(?:=([^`]*))?`")


def param(name: str, value: object = _NO_VALUE) -> str:
    """Return how a library message names a parameter: ```name``` or ```name=value```.

    Parameters
    ----------
    name : str
        The Python parameter (or field, ``params.threshold``).
    value : optional
        A value to show, written as its ``repr``.

    Examples
    --------
    >>> param("force", True)
    '`force=True`'
    >>> param("mode", "grey")
    "`mode='grey'`"
    """
    return f"`{name}`" if value is _NO_VALUE else f"`{name}={value!r}`"


def flag_of(name: str, flags: Mapping[str, str] | None = None) -> str:
    """Return the flag of a parameter: from ``flags``, :data:`FLAG_SPELLINGS`, else ``--name``.

    The default is ``--`` and the parameter's name with dashes for underscores.

    Examples
    --------
    >>> flag_of("allow_resize")
    '--allow-resize'
    >>> flag_of("implant_px_per_electrode")
    '--implant-px'
    >>> flag_of("seed", {"seed": "--knowledge-seed"})
    '--knowledge-seed'
    """
    if flags and name in flags:
        return flags[name]
    if name in FLAG_SPELLINGS:
        return FLAG_SPELLINGS[name]
    return "--" + name.rsplit(".", 1)[-1].replace("_", "-")


def flag_text(message: str, flags: Mapping[str, str] | None = None) -> str:
    """Return a library message with every parameter span written as its command-line flag.

    Parameters
    ----------
    message : str
        A message whose parameters are :func:`param` spans.
    flags : mapping of str to str, optional
        Parameter name -> flag, for this command's flags not spelled as the parameter
        (:func:`flag_of`).

    Examples
    --------
    >>> flag_text("a different set; use `force=True` to replace it")
    'a different set; use --force to replace it'
    >>> flag_text("`declutter='depth'` needs light fields")
    '--declutter depth needs light fields'
    >>> flag_text("e.g. `new_session='re-test after new glasses'`")
    "e.g. --new-session 're-test after new glasses'"
    """

    def one(m: re.Match) -> str:
        flag = flag_of(m.group(1), flags)
        value = m.group(2)
        if value is None or value == "True":
            return flag
        try:
            shown = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            shown = value
        if isinstance(shown, (list, tuple)):
            shown = ",".join(str(v) for v in shown)
        return f"{flag} {shlex.quote(str(shown))}"

    return _SPAN.sub(one, str(message))


@contextmanager
def cli_flags(flags: Mapping[str, str] | None = None) -> Iterator[None]:
    """Rewrite the parameter spans of a user error raised inside as the command's flags.

    For a command: ``with cli_flags({"seed": "--knowledge-seed"}): make(...)``.
    The error keeps its type (and ``exit_code``); only its message changes. Errors that are
    not user errors (no ``exit_code`` of 2) pass unchanged.
    """
    try:
        yield
    except Exception as exc:
        if getattr(exc, "exit_code", None) == 2 and exc.args and isinstance(exc.args[0], str):
            exc.args = (flag_text(exc.args[0], flags), *exc.args[1:])
        raise
