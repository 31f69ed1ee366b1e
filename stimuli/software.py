"""Which software made a file: the package version and the git commit of its source.

The one reader of the git commit for every record that names it (a stimulus set's
``stimulus_set.json``, a trial log's ``sessions`` row, the observer calibration file). It lives in
``stimuli``, the tower the other two may import.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

__all__ = ["git_commit"]


def git_commit(where: str | Path | None = None) -> str | None:
    """Return the commit checked out in the git work tree holding ``where``, or None.

    Parameters
    ----------
    where : str or Path, optional
        A folder inside the work tree; by default this package's own folder, so the commit is
        that of the code running (not of the current directory).

    Returns
    -------
    str or None
        The full 40-hex commit id, or None when ``where`` is in no work tree (an installed
        wheel), git is missing, or it does not answer within 5 s.
    """
    folder = Path(__file__).resolve().parent if where is None else Path(where)
    try:
        r = subprocess.run(
            ["git", "-C", str(folder), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return (r.stdout.strip() or None) if r.returncode == 0 else None
