"""Where the shipped data files are: ``protocols/`` in a source checkout, or a wheel's data folder.

The protocols, monitor profiles and implant layouts ship beside the packages in a source checkout
(or an editable install) and as data files under ``<sys.prefix>/share/confocal/protocols`` in a
wheel (``pyproject.toml``, ``[tool.setuptools.data-files]``). ``stimuli`` looks them up here so
that it never imports ``experiment`` (house style H1); ``experiment.protocol`` imports
:data:`PROTOCOLS_DIR` from this module.
"""

from __future__ import annotations

import sys
from pathlib import Path

__all__ = ["PROTOCOLS_DIR", "protocols_dir"]


def protocols_dir() -> Path:
    """Return the folder of the shipped protocols (``jung2015.toml``, ``implants/``, ...).

    A source checkout (or an editable install) has ``protocols/`` beside the packages; a wheel
    installs them as data files under ``<sys.prefix>/share/confocal/protocols``.
    """
    source = Path(__file__).resolve().parents[1] / "protocols"
    if source.is_dir():
        return source
    return Path(sys.prefix) / "share" / "confocal" / "protocols"


#: Folder of the shipped protocol files (``jung2015.toml``, ...), monitors and implant layouts.
PROTOCOLS_DIR: Path = protocols_dir()
