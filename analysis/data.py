"""Read trial logs (SQLite session databases, CSV and Parquet trial tables) into one tidy table.

Columns of the tidy table (one row per answered trial):

==============  ========  ==========================================================
column          dtype     meaning
==============  ========  ==========================================================
``subject``     str       subject identifier
``object``      str       object identifier (``"1"`` .. ``"20"`` in Jung et al. 2015)
``condition``   str       ``"cluttered"`` or ``"decluttered"`` (or a de-clutter method)
``pixels``      float     stimulus resolution, pixels (> 0)
``recognized``  int       1 = recognised, 0 = not
``source``      str       the file the row came from
``level``       optional  resolution level index, as logged
``session``     optional  session identifier
``response``    optional  the subject's words
``score``       optional  the rater's score (``named``, ``use``, ``shape``, ...)
``rt_s``        optional  response time, seconds
``part``        optional  ``"main"`` or ``"training"``; only ``main`` rows are kept
``simulated``   optional  1 if a simulated observer answered (no person), else 0
``observer``    optional  the simulated observer's name, or ``human``
``rater``       optional  who gave the score (``sim:<observer>`` for a simulated observer)
``trial_index`` optional  the trial's position in its session's schedule
==============  ========  ==========================================================

Simulated and human sessions are not pooled unless asked (``include_simulated=True``,
``confocal analyze --include-simulated``): a dry run's simulated subject written into a real
study's file would otherwise count as a subject. A row is simulated when its ``simulated`` column
says 1, *or* its ``rater`` starts with ``sim:``, *or* its ``observer`` names anything but
``human``: provenance survives a spreadsheet that dropped the ``simulated`` and ``observer``
columns. A file with none of these columns counts as human data.

CSV cells that were written formula-safe (a leading ``'`` before ``=``, ``+``, ``-``, ``@``;
see ``analysis/tables.py``) are read back as the original text.

SQLite files (recognised by their ``SQLite format 3`` header) are identified as confocal trial
logs and read from their base tables, never through a view the file brings
(:mod:`analysis.logreader`); the result has the columns of the engine's ``tidy_trials`` view.
Nothing here imports the experiment engine (the packages stay independent): the schema is the
contract.

Hostile or mistaken input is bounded and refused with one line naming the file: more than
:data:`analysis.logreader.MAX_INPUT_BYTES` on disk or :data:`analysis.logreader.MAX_INPUT_ROWS`
rows; ``pixels`` that are not a finite number in (0, :data:`MAX_PIXELS`] (no display shows
more); the same trial twice -- a repeated (subject, session, trial_index), within a file or
across the files pooled (the same file given twice, say).
"""

from __future__ import annotations

import math
import sqlite3
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.errors import DataError
from analysis.logreader import (
    MAX_INPUT_BYTES,
    MAX_INPUT_ROWS,
    check_input_size,
    open_log,
    read_log_trials,
)
from analysis.tables import unescape_frame

__all__ = [
    "REQUIRED_COLUMNS",
    "OPTIONAL_COLUMNS",
    "SIMULATED_RATER_PREFIX",
    "CONDITIONS",
    "MAX_PIXELS",
    "METHOD_CONDITIONS",
    "plugin_conditions",
    "TrialTable",
    "json_safe",
    "read_trial_file",
    "read_trials",
    "check_trials",
    "object_order",
    "connect_readonly",
    "file_record",
]

#: Columns every trial table must have (the data contract with the experiment engine).
REQUIRED_COLUMNS: tuple[str, ...] = ("subject", "object", "condition", "pixels", "recognized")
#: Columns read when present.
OPTIONAL_COLUMNS: tuple[str, ...] = (
    "level",
    "session",
    "response",
    "score",
    "rt_s",
    "part",
    "simulated",
    "observer",
    "rater",
    "trial_index",
)
#: Rater names that mark a simulated observer's score (``sim:<observer>``, the engine's
#: responder name for a headless session).
SIMULATED_RATER_PREFIX = "sim:"
#: Background conditions, reference first. Source: Jung et al. 2015, Sec. 3.2.2 (reference:
#: background cluttered).
CONDITIONS: tuple[str, str] = ("cluttered", "decluttered")
#: Most pixels a stimulus can have (ours: a gigapixel, 7.5 times a 16K display's 15360 x 8640;
#: a larger value is a typo or a hostile file, and would stretch every fitted pixel axis).
MAX_PIXELS: float = 1e9

#: Conditions of a method comparison beyond the paper's two: the built-in de-clutter methods
#: (``confocal stimuli methods``), analysed by :mod:`analysis.conditions`.
METHOD_CONDITIONS: tuple[str, ...] = ("sobel", "depth", "mask", "segment", "saliency")


def plugin_conditions() -> tuple[str, ...]:
    """Return the names of the de-clutter methods installed as plug-ins; nothing is imported.

    The plug-ins are those of the entry point group ``confocal.declutter``; a stimulus set may
    hold these methods as conditions.
    """
    from importlib.metadata import entry_points

    return tuple(sorted(ep.name for ep in entry_points(group="confocal.declutter")))


_SQLITE_MAGIC = b"SQLite format 3\x00"
_PARQUET_MAGIC = b"PAR1"


@dataclass(frozen=True)
class TrialTable:
    """Pooled trials from one or more files.

    Parameters
    ----------
    trials : pandas.DataFrame
        The tidy table (see the module docstring); only ``part == "main"`` rows.
    sources : tuple of str
        The files read, in order.
    n_training_excluded : int
        Rows dropped because their ``part`` was not ``"main"``.
    simulated_sessions : tuple of str
        The sessions a simulated observer answered, as ``"<file> session <id> (<subject>,
        <observer>)"``; empty for human data.
    """

    trials: pd.DataFrame
    sources: tuple[str, ...]
    n_training_excluded: int = 0
    simulated_sessions: tuple[str, ...] = ()


def _magic(path: Path) -> bytes:
    with open(path, "rb") as fh:
        return fh.read(16)


def _read_raw(path: Path) -> pd.DataFrame:
    if not path.exists():
        raise DataError(f"{path}: file not found")
    if path.is_dir():
        raise DataError(f"{path}: is a folder, expected a trial file (SQLite, CSV or Parquet)")
    if path.stat().st_size == 0:
        raise DataError(f"{path}: file is empty (no trials)")
    head = _magic(path)
    if head.startswith(_SQLITE_MAGIC):
        # identified as a trial log, then read from its base tables, never through a view the
        # file brings (a view may recurse without end), within bounds
        return read_log_trials(path)
    check_input_size(path)
    if head.startswith(_PARQUET_MAGIC) or path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path)
    try:
        raw = pd.read_csv(
            path,
            dtype=str,
            keep_default_na=False,
            skipinitialspace=True,
            nrows=MAX_INPUT_ROWS + 1,
        )
    except pd.errors.EmptyDataError as exc:
        raise DataError(f"{path}: file is empty (no trials)") from exc
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a readable CSV trial table ({_line(exc)})") from exc
    _check_rows(path, len(raw))
    return unescape_frame(raw)


def _check_rows(path: Path, n: int) -> None:
    if n > MAX_INPUT_ROWS:
        raise DataError(
            f"{path}: more than {MAX_INPUT_ROWS:,} rows, the most one input may have; split the "
            "trials into several files"
        )


def _read_parquet(path: Path) -> pd.DataFrame:
    """Read a Parquet trial table after checking its footer: rows and unpacked size bounded."""
    try:
        import pyarrow.parquet as pq
    except ImportError as exc:
        raise DataError(
            f"{path}: reading Parquet needs pyarrow "
            "(python -m pip install 'active-confocal[parquet]')"
        ) from exc
    try:
        meta = pq.read_metadata(path)
        _check_rows(path, meta.num_rows)
        unpacked = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
        if unpacked > MAX_INPUT_BYTES:
            raise DataError(
                f"{path}: unpacks to {unpacked / 2**30:.1f} GiB, more than the "
                f"{MAX_INPUT_BYTES / 2**30:g} GiB an input may be"
            )
        return pd.read_parquet(path)
    except DataError:
        raise
    except Exception as exc:  # noqa: BLE001 - any parser failure is a data error here
        raise DataError(f"{path}: not a readable Parquet file ({_line(exc)})") from exc


def _line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def connect_readonly(path: Path) -> sqlite3.Connection:
    """Open an SQLite trial log read-only, leaving nothing beside it, trusting nothing in it.

    Without a ``-wal`` file no writer has the log open, and it is opened ``immutable``
    (``mode=ro`` alone would create ``-wal``/``-shm`` files beside a WAL-mode log); the
    connection is bounded as :func:`analysis.logreader.open_log` says.
    """
    return open_log(path)


def _blank(s: pd.Series) -> pd.Series:
    return s.isna() | (s.astype(str).str.strip().isin(["", "nan", "NaN", "NA", "None", "null"]))


def _first_bad(mask: pd.Series, df: pd.DataFrame, col: str) -> str:
    i = int(np.flatnonzero(mask.to_numpy())[0])
    return f"row {i + 1} (value {df[col].iloc[i]!r})"


def check_trials(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """Validate and normalise a raw trial table; return the tidy table.

    Parameters
    ----------
    df : pandas.DataFrame
        Raw rows with at least :data:`REQUIRED_COLUMNS`.
    source : str
        File name used in error messages and in the ``source`` column.

    Returns
    -------
    pandas.DataFrame
        Tidy rows (``part == "main"`` only when a ``part`` column exists; the number dropped is
        ``df.attrs["n_training_excluded"]``).

    Raises
    ------
    DataError
        Missing columns, no rows, missing values, non-numeric, non-positive or more than
        :data:`MAX_PIXELS` pixels, ``recognized`` not 0/1, or an unknown condition; the message
        names file, column and row.
    """
    df = df.copy()
    df.columns = [str(c).strip() for c in df.columns]
    if "rt" in df.columns and "rt_s" not in df.columns:
        df = df.rename(columns={"rt": "rt_s"})
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise DataError(
            f"{source}: missing required column(s) {', '.join(missing)} "
            f"(need {', '.join(REQUIRED_COLUMNS)}; found {', '.join(map(str, df.columns))})"
        )
    if len(df) == 0:
        raise DataError(f"{source}: no trials (header only)")
    if "part" in df.columns:
        # Training rows (e.g. full-resolution 'photo' trials) need not follow the main design, so
        # they are dropped before the values are checked.
        df["part"] = df["part"].astype(str).str.strip()
        n_all = len(df)
        df = df[df["part"] == "main"]
        if len(df) == 0:
            raise DataError(f"{source}: no main-part trials (all {n_all} rows are training)")
    for col in REQUIRED_COLUMNS:
        blank = _blank(df[col])
        if blank.any():
            raise DataError(
                f"{source}: column '{col}' has a missing value (NaN/empty) at "
                f"{_first_bad(blank, df, col)}"
            )
    pixels = pd.to_numeric(df["pixels"], errors="coerce")
    bad = pixels.isna() | ~np.isfinite(pixels.astype(float))
    if bad.any():
        raise DataError(
            f"{source}: column 'pixels' must be numeric, got non-numeric "
            f"{_first_bad(bad, df, 'pixels')}"
        )
    if (pixels <= 0).any():
        raise DataError(
            f"{source}: column 'pixels' must be > 0, got {_first_bad(pixels <= 0, df, 'pixels')}"
        )
    if (pixels > MAX_PIXELS).any():
        raise DataError(
            f"{source}: column 'pixels' must be at most {MAX_PIXELS:.0e} (no display shows "
            f"more), got {_first_bad(pixels > MAX_PIXELS, df, 'pixels')}"
        )
    rec = pd.to_numeric(df["recognized"].map(_bool_word), errors="coerce")
    bad = rec.isna() | ~rec.isin([0, 1])
    if bad.any():
        raise DataError(
            f"{source}: column 'recognized' must be 0 or 1, got {_first_bad(bad, df, 'recognized')}"
        )
    cond = df["condition"].astype(str).str.strip().str.lower().str.replace("-", "", regex=False)
    bad = ~cond.isin(CONDITIONS + METHOD_CONDITIONS + plugin_conditions())
    if bad.any():
        raise DataError(
            f"{source}: column 'condition' must be 'cluttered' or 'decluttered' (or a de-clutter "
            f"method: {', '.join(METHOD_CONDITIONS)}), got {_first_bad(bad, df, 'condition')}"
        )
    out = pd.DataFrame(
        {
            "subject": df["subject"].map(_id_text),
            "object": df["object"].map(_id_text),
            "condition": cond.to_numpy(),
            "pixels": pixels.astype(float).to_numpy(),
            "recognized": rec.astype(int).to_numpy(),
        },
        index=df.index,
    )
    for col in OPTIONAL_COLUMNS:
        if col in df.columns:
            out[col] = df[col].to_numpy()
    if "rt_s" in out.columns:
        out["rt_s"] = pd.to_numeric(out["rt_s"], errors="coerce")
    marked = _marked_simulated(out)
    if "simulated" in out.columns or marked.any():
        out["simulated"] = marked.astype(int).to_numpy()
    if "observer" not in out.columns and "rater" in out.columns and marked.any():
        rater = out["rater"].astype(str).str.strip()
        out["observer"] = np.where(
            rater.str.startswith(SIMULATED_RATER_PREFIX),
            rater.str[len(SIMULATED_RATER_PREFIX) :],
            "human",
        )
    out["source"] = source
    out = out.reset_index(drop=True)
    out.attrs["n_training_excluded"] = int(n_all - len(df)) if "part" in df.columns else 0
    return out


def _marked_simulated(df: pd.DataFrame) -> pd.Series:
    """Return True for rows whose simulated, rater or observer column says no person answered."""
    flag = pd.Series(False, index=df.index)
    if "simulated" in df.columns:
        flag |= pd.to_numeric(df["simulated"], errors="coerce").fillna(0).astype(int) == 1
    if "rater" in df.columns:
        flag |= df["rater"].astype(str).str.strip().str.startswith(SIMULATED_RATER_PREFIX)
    if "observer" in df.columns:
        obs = df["observer"].astype(str).str.strip().str.lower()
        flag |= ~obs.isin(["human", "", "nan", "none", "n/a"])
    return flag


def _bool_word(v: Any) -> Any:
    s = str(v).strip().lower()
    return {"true": 1, "false": 0, "yes": 1, "no": 0}.get(s, s if isinstance(v, str) else v)


def _id_text(v: Any) -> str:
    """Return an identifier as text; '3', 3 and 3.0 are the same object."""
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    s = str(v).strip()
    try:
        f = float(s)
    except ValueError:
        return s
    return str(int(f)) if f.is_integer() and "." in s else s


def read_trial_file(path: str | Path) -> tuple[pd.DataFrame, int]:
    """Read one trial file; return the tidy main-part rows and the number of training rows dropped.

    Parameters
    ----------
    path : str or Path
        A SQLite session database, a CSV or a Parquet trial table.

    Returns
    -------
    trials : pandas.DataFrame
    n_training_excluded : int

    Raises
    ------
    DataError
        Unreadable, empty or invalid file (one line naming the file and the column).
    """
    path = Path(path)
    raw = _read_raw(path)
    tidy = check_trials(raw, str(path))
    return tidy, int(tidy.attrs.get("n_training_excluded", 0))


def _sessions(df: pd.DataFrame, source: str, simulated: bool) -> list[str]:
    """Label the simulated (or human) sessions of one file's rows."""
    flag = _marked_simulated(df)
    rows = df[flag] if simulated else df[~flag]
    if len(rows) == 0:
        return []
    name = Path(source).name
    out = []
    cols = [c for c in ("session", "subject") if c in rows.columns]
    for _, g in rows.groupby(cols, sort=True):
        first = g.iloc[0]
        who = str(first["subject"])
        if simulated and "observer" in g.columns:
            who += f", {first['observer']}"
        where = f"{name} session {first['session']}" if "session" in g.columns else name
        out.append(f"{where} ({who})")
    return out


def read_trials(paths: Iterable[str | Path], *, include_simulated: bool = False) -> TrialTable:
    """Read and pool several trial files.

    Parameters
    ----------
    paths : iterable of str or Path
        Trial files (SQLite, CSV, Parquet); at least one.
    include_simulated : bool
        Pool simulated sessions with human ones. Without it, a mix is refused; files that hold
        only simulated sessions (a dry run, the demo) are read, and labelled either way in
        :attr:`TrialTable.simulated_sessions`.

    Returns
    -------
    TrialTable

    Raises
    ------
    DataError
        No files, any file invalid, or simulated and human sessions mixed without
        ``include_simulated`` (the message names the simulated sessions).
    """
    paths = [Path(p) for p in paths]
    if not paths:
        raise DataError("no trial files given")
    seen: dict[Path, Path] = {}
    for p in paths:
        if p.resolve() in seen:
            raise DataError(
                f"{p}: given twice (as {seen[p.resolve()]} too); each file may be analysed once"
            )
        seen[p.resolve()] = p
    frames, dropped, simulated, human = [], 0, [], []
    for p in paths:
        df, d = read_trial_file(p)
        frames.append(df)
        dropped += d
        simulated += _sessions(df, str(p), simulated=True)
        human += _sessions(df, str(p), simulated=False)
    if simulated and human and not include_simulated:
        raise DataError(
            f"refusing to pool simulated session(s) {'; '.join(simulated)} with human "
            f"session(s) {'; '.join(human)}: analyse them apart, or pass `include_simulated=True`"
        )
    trials = pd.concat(frames, ignore_index=True)
    _check_no_repeats(trials)
    return TrialTable(trials, tuple(str(p) for p in paths), dropped, tuple(simulated))


def _check_no_repeats(trials: pd.DataFrame) -> None:
    """Refuse the same trial twice: a repeated (subject, session, trial_index).

    A repeat is refused within a file or across files (a file given twice would count every
    trial twice).
    """
    key = [c for c in ("subject", "session", "trial_index") if c in trials.columns]
    if "trial_index" not in key:
        return  # a table without trial numbers: repeated conditions are not repeated trials
    numbered = trials.dropna(subset=key)  # rows of a table without these columns: not checked
    k = numbered[key].astype(str)
    dup = k.duplicated(keep=False)
    if not dup.any():
        return
    first = k[dup].iloc[0]
    same = numbered[(k == first).all(axis=1)]
    files = list(dict.fromkeys(same["source"]))
    what = ", ".join(f"{c} {first[c]}" for c in key)
    raise DataError(
        f"{files[0]}: the same trial ({what}) appears {len(same)} times, in "
        f"{' and '.join(files)}; each trial may be analysed once"
    )


def file_record(path: str | Path) -> dict[str, str | None]:
    """Return ``{"file": <name>, "sha256": <hex>}`` for a shared report: no host path in it.

    The folder a file was read from says nothing about the data and names the analyst's machine
    (and often the analyst); its name and content hash identify it. ``sha256`` is None when the
    file is no longer there.

    Examples
    --------
    >>> file_record("/nowhere/study.sqlite")
    {'file': 'study.sqlite', 'sha256': None}
    """
    import hashlib

    p = Path(path)
    if not p.is_file():
        return {"file": p.name, "sha256": None}
    h = hashlib.sha256()
    with open(p, "rb") as fh:
        while chunk := fh.read(1 << 20):
            h.update(chunk)
    return {"file": p.name, "sha256": h.hexdigest()}


def object_order(objects: Iterable[str]) -> list[str]:
    """Return object identifiers in natural order (numeric when all are numbers).

    The first is the logistic model's reference ("object 1", Jung et al. 2015, Sec. 3.2.2).

    Examples
    --------
    >>> object_order(["10", "2", "1"])
    ['1', '2', '10']
    """
    uniq = sorted(set(map(str, objects)))

    def key(s: str) -> tuple[int, float, str]:
        try:
            return (0, float(s), s)
        except ValueError:
            return (1, 0.0, s)

    return sorted(uniq, key=key)


def json_safe(v: Any) -> Any:
    """Return ``v`` as strict JSON values: inf/NaN -> None, numpy scalars -> Python, keys str."""
    if isinstance(v, dict):
        return {str(k): json_safe(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [json_safe(x) for x in v]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v
