"""Reading a protocol file: a path or the bare name of a shipped protocol in ``protocols/``."""

from __future__ import annotations

import hashlib
import tomllib
from pathlib import Path

from experiment.protocol.fields import ProtocolError
from experiment.protocol.spec import ProtocolSpec
from stimuli.datadirs import PROTOCOLS_DIR

__all__ = ["PROTOCOLS_DIR", "load_protocol"]


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
    p = Path(path)
    if not p.exists() and not p.suffix and (PROTOCOLS_DIR / f"{p.name}.toml").is_file():
        p = PROTOCOLS_DIR / f"{p.name}.toml"
    if not p.is_file():
        raise ProtocolError(f"{p}: protocol file not found")
    raw = p.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProtocolError(f"{p}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested tables and arrays recursively
        raise ProtocolError(f"{p}: not valid TOML (tables or arrays nested too deeply)") from None
    try:
        return ProtocolSpec.from_dict(
            data, source_path=str(p), source_sha256=hashlib.sha256(raw).hexdigest()
        )
    except ProtocolError as exc:
        raise ProtocolError(f"{p}: {exc}") from None
