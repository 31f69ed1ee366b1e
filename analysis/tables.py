"""Formula-safe CSV cells for the analysis package (the same rule as ``stimuli/tables.py``).

A text cell beginning with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return that is not a
plain decimal number is written with a leading single quote, so a spreadsheet shows it as text
(OWASP "CSV injection"); reading takes the quote off again. The analysis package may not import
``stimuli`` (house style H1), so the two functions live here too; ``tests/test_tables.py``
checks that both copies agree.
"""

from __future__ import annotations

import csv
import io
import re
from typing import Any

import pandas as pd

__all__ = [
    "FORMULA_TRIGGERS",
    "escape_cell",
    "unescape_cell",
    "escape_frame",
    "unescape_frame",
    "frame_csv_text",
]

#: First characters that make a spreadsheet read a cell as a formula (OWASP, "CSV Injection").
FORMULA_TRIGGERS: str = "=+-@\t\r"

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_ESCAPED = re.compile(r"'+[" + re.escape(FORMULA_TRIGGERS) + "]", re.S)


def escape_cell(value: Any) -> Any:
    """Return ``value`` as a spreadsheet shows it as text; non-text values are returned as is.

    Examples
    --------
    >>> escape_cell("=1+1"), escape_cell("-1.5")
    ("'=1+1", '-1.5')
    """
    if not isinstance(value, str) or not value:
        return value
    if value[0] in FORMULA_TRIGGERS and not _NUMBER.fullmatch(value):
        return "'" + value
    if _ESCAPED.match(value):
        return "'" + value
    return value


def unescape_cell(value: Any) -> Any:
    """Return the value :func:`escape_cell` was given (inverse of it); non-text as is."""
    if isinstance(value, str) and _ESCAPED.match(value):
        return value[1:]
    return value


def escape_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Return a copy of ``df`` whose text cells (and column names) are formula-safe."""
    out = df.copy()
    for col in out.columns:
        if out[col].dtype == object or pd.api.types.is_string_dtype(out[col]):
            out[col] = out[col].map(escape_cell)
    out.columns = [escape_cell(str(c)) for c in out.columns]
    return out


def unescape_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Return ``df`` (read from a CSV as text) with every escaped cell and column name restored."""
    out = df.copy()
    for col in out.columns:
        s = out[col]
        if s.dtype == object or pd.api.types.is_string_dtype(s):
            mask = s.str.match(_ESCAPED, na=False)
            if mask.any():
                out[col] = s.where(~mask, s[mask].str[1:])
    out.columns = [unescape_cell(c) if isinstance(c, str) else c for c in out.columns]
    return out


def frame_csv_text(df: pd.DataFrame) -> str:
    r"""Return ``df`` as CSV text (header, no index) with formula-safe cells.

    Missing values are empty cells. A cell with a carriage return is quoted (pandas' and the
    csv module's writers leave it bare when the line terminator is ``\n``, which ends the row
    in every reader).
    """
    esc = escape_frame(df)
    rows = esc.astype(object).where(esc.notna(), None).to_numpy().tolist()
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(list(esc.columns))
    for cells in rows:
        cells = ["" if c is None else c for c in cells]
        if any(isinstance(c, str) and "\r" in c for c in cells):
            one = io.StringIO()
            csv.writer(one, lineterminator="\r\n").writerow(cells)
            buf.write(one.getvalue()[:-2] + "\n")
        else:
            w.writerow(cells)
    return buf.getvalue()
