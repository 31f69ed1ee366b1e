"""Formula-safe CSV/TSV cells: what a spreadsheet opens is shown as text, never run.

A text cell that begins with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return is a formula
to Excel, LibreOffice and Google Sheets (``=HYPERLINK("http://...","cup")`` as an object name
would become a live link in everyone's copy of the data). Such a cell is written with a leading
single quote, which spreadsheets show as text (the OWASP "CSV injection" rule); a cell that is a
plain decimal number (``-1.5``, ``+3``, ``1e-3``) is left alone. The same holds after each
separator inside a cell (:data:`SEPARATORS`: ``;``, ``,``, a tab, ``|``): a spreadsheet whose
list separator is ``;`` (German or French settings) splits ``cup;=1+1`` into ``cup`` and a
formula, so it is written ``cup;'=1+1``. The project's readers take the quotes off again, so a
value read back is the value written. A text that itself has quotes before one of those
characters (at its start or after a separator) gets one more quote, so the round trip is exact.

``analysis/tables.py`` holds the same two functions for the analysis package, which may not
import this one (the packages stay independent); ``tests/test_tables.py`` checks both copies
against one table of cases.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = [
    "FORMULA_TRIGGERS",
    "SEPARATORS",
    "escape_cell",
    "unescape_cell",
    "unescape_row",
    "table_text",
    "write_table",
]

#: First characters that make a spreadsheet read a cell as a formula (OWASP, "CSV Injection").
FORMULA_TRIGGERS: str = "=+-@\t\r"

#: Characters after which a spreadsheet may begin a new cell: its list separator (``;`` under
#: German or French settings, ``,``), a tab, or ``|`` (a common choice in import dialogs).
SEPARATORS: str = ";,\t|"

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_ESCAPED = re.compile(r"'+[" + re.escape(FORMULA_TRIGGERS) + "]", re.S)
_TRIGGERED = re.compile(r"'*[" + re.escape(FORMULA_TRIGGERS) + "]", re.S)
_ANY_TRIGGER = re.compile("[" + re.escape(FORMULA_TRIGGERS) + "]")


def _cell_starts(value: str) -> list[int]:
    """Where a spreadsheet may begin a cell in ``value``: 0 and after each separator."""
    return [0] + [i + 1 for i, c in enumerate(value) if c in SEPARATORS and i + 1 < len(value)]


def escape_cell(value: Any) -> Any:
    r"""Return ``value`` as a spreadsheet shows it as text; non-text values are returned as is.

    Examples
    --------
    >>> escape_cell('=HYPERLINK("http://x","cup")')
    '\'=HYPERLINK("http://x","cup")'
    >>> escape_cell("-1.5"), escape_cell("cup")
    ('-1.5', 'cup')
    """
    if not isinstance(value, str) or not _ANY_TRIGGER.search(value):
        return value
    parts, last = [], 0
    for p in _cell_starts(value):
        m = _TRIGGERED.match(value, p)
        if m is None or (m.end() - p == 1 and _NUMBER.fullmatch(value, p)):
            continue  # no trigger here, or a plain number to the end of the cell
        parts += [value[last:p], "'"]
        last = p
    return "".join(parts) + value[last:] if parts else value


def unescape_cell(value: Any) -> Any:
    """Return the value :func:`escape_cell` was given (inverse of it); non-text as is.

    Examples
    --------
    >>> unescape_cell("'=1+1"), unescape_cell("'quoted")
    ('=1+1', "'quoted")
    """
    if not isinstance(value, str) or "'" not in value:
        return value
    parts, last = [], 0
    for p in _cell_starts(value):
        if _ESCAPED.match(value, p):
            parts.append(value[last:p])
            last = p + 1
    return "".join(parts) + value[last:] if parts else value


def unescape_row(row: Mapping[str, Any]) -> dict[str, Any]:
    """Return a row read by :class:`csv.DictReader` with every cell unescaped."""
    return {k: unescape_cell(v) for k, v in row.items()}


def table_text(
    rows: Iterable[Mapping[str, Any]], columns: Sequence[str], *, delimiter: str = ","
) -> str:
    r"""Return a CSV (or TSV, ``delimiter="\t"``) with a header and formula-safe cells.

    Parameters
    ----------
    rows : iterable of mapping
        One mapping per row; missing keys and ``None`` are written as empty cells, keys not in
        ``columns`` are ignored.
    columns : sequence of str
        The header, in order.
    delimiter : {',', '\t'}
    """
    buf = io.StringIO()
    w = csv.writer(buf, delimiter=delimiter, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        cells = [escape_cell("" if r.get(c) is None else r[c]) for c in columns]
        if any(isinstance(c, str) and "\r" in c for c in cells):
            # the csv module quotes a field only for characters of its line terminator, so an
            # unquoted carriage return would end the row in every reader: quote it via "\r\n"
            one = io.StringIO()
            csv.writer(one, delimiter=delimiter, lineterminator="\r\n").writerow(cells)
            buf.write(one.getvalue()[:-2] + "\n")
        else:
            w.writerow(cells)
    return buf.getvalue()


def write_table(
    path: str | os.PathLike,
    rows: Iterable[Mapping[str, Any]],
    columns: Sequence[str],
    *,
    delimiter: str = ",",
) -> Path:
    """Write :func:`table_text` to ``path`` atomically (temporary file, then rename)."""
    from stimuli.io import atomic_path

    text = table_text(rows, columns, delimiter=delimiter)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
