"""Reading a protocol file: a path or the bare name of a shipped protocol in ``protocols/``.

:func:`shipped_or_path` and :func:`read_toml` serve the monitor profiles too.
"""

from __future__ import annotations

import hashlib
import tomllib
from pathlib import Path
from typing import Any

from experiment.protocol.fields import ProtocolError
from experiment.protocol.spec import ProtocolSpec
from stimuli.datadirs import PROTOCOLS_DIR

__all__ = ["PROTOCOLS_DIR", "load_protocol", "shipped_or_path", "read_toml"]


def shipped_or_path(name_or_path: str | Path, folder: Path) -> Path:
    """Return the shipped ``folder/NAME.toml`` for a bare ``NAME``, else the path as given.

    A bare ``NAME`` that is no file here but is shipped in ``folder`` gives ``folder/NAME.toml``.
    """
    p = Path(name_or_path)
    if not p.exists() and not p.suffix and (folder / f"{p.name}.toml").is_file():
        return folder / f"{p.name}.toml"
    return p


def read_toml(path: Path, error: type[Exception]) -> tuple[bytes, dict[str, Any]]:
    """Return a TOML file's bytes and its tables.

    Bad TOML raises ``error``, one line ``<file>: not valid TOML (...)``.
    """
    raw = path.read_bytes()
    try:
        return raw, tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise error(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested tables and arrays recursively
        raise error(f"{path}: not valid TOML (tables or arrays nested too deeply)") from None


def load_protocol(path: str | Path) -> ProtocolSpec:
    """Load and check a protocol TOML file.

    Parameters
    ----------
    path : str or Path
        A file, or the bare name of a shipped protocol (``"jung2015"``).

    Returns
    -------
    ProtocolSpec

    Raises
    ------
    ProtocolError
        One line ``<file>: <what is wrong>`` for a missing file, bad TOML, an unknown key, a
        missing field or a bad value.
    """
    p = shipped_or_path(path, PROTOCOLS_DIR)
    if not p.is_file():
        raise ProtocolError(f"{p}: protocol file not found")
    raw, data = read_toml(p, ProtocolError)
    try:
        return ProtocolSpec.from_dict(
            data, source_path=str(p), source_sha256=hashlib.sha256(raw).hexdigest()
        )
    except ProtocolError as exc:
        raise ProtocolError(f"{p}: {exc}") from None
