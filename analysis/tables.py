"""Formula-safe CSV cells for the analysis package (the same rule as ``stimuli/tables.py``).

A text cell beginning with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return that is not a
plain decimal number is written with a leading single quote, so a spreadsheet shows it as text
(OWASP "CSV injection"); so is such a trigger right after a separator inside the cell (``;``,
``,``, a tab or ``|``: ``cup;=1+1`` is written ``cup;'=1+1``), because a spreadsheet whose list
separator is ``;`` splits the cell there. Reading takes the quotes off again. The analysis
package may not import ``stimuli`` (the packages stay independent), so the two functions live
here too; ``tests/test_tables.py`` checks both copies against one table of cases.
"""

from __future__ import annotations

import csv
import io
import re
from typing import Any

import pandas as pd

__all__ = [
    "FORMULA_TRIGGERS",
    "SEPARATORS",
    "escape_cell",
    "unescape_cell",
    "escape_frame",
    "unescape_frame",
    "frame_csv_text",
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
    """Return ``value`` as a spreadsheet shows it as text; non-text values are returned as is.

    Examples
    --------
    >>> escape_cell("=1+1"), escape_cell("-1.5")
    ("'=1+1", '-1.5')
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
    """Return the value :func:`escape_cell` was given (inverse of it); non-text as is."""
    if not isinstance(value, str) or "'" not in value:
        return value
    parts, last = [], 0
    for p in _cell_starts(value):
        if _ESCAPED.match(value, p):
            parts.append(value[last:p])
            last = p + 1
    return "".join(parts) + value[last:] if parts else value


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
            mask = s.str.contains("'", regex=False, na=False)
            if mask.any():
                out[col] = s.where(~mask, s[mask].map(unescape_cell))
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
