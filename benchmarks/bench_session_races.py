"""Race test: the same subject started twice at the same moment, for ``session run`` and
``active run``; then a full check of the logs.

Each race starts one new subject's command twice, both children forked from one warm process
and released together from a pipe (:mod:`experiment.session_races`), so the two starts are
milliseconds apart. Every subject must end with exactly one session, complete, every planned
trial answered once (0 lost, 0 duplicated), no lock left on a completed session, and the second
command either refused with one line ("already open") or reporting the session complete.

Run: ``python benchmarks/bench_session_races.py --races 50``
(exit status 1 if any subject got two sessions, lost a trial or a command ended otherwise).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Run the races and print their figures; return 0 when everything checks out."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--races", type=int, default=50, help="races per command")
    ap.add_argument(
        "--kinds",
        default="static,active",
        help="commands to race: static (session run), active (active run), comma-separated",
    )
    ap.add_argument(
        "--workdir",
        type=Path,
        default=None,
        help="keep the logs here (default: a temporary folder in /dev/shm, removed after)",
    )
    options = ap.parse_args(argv)
    warnings.simplefilter("ignore", UserWarning)  # the small synthetic scene's depth warning
    from experiment.session_races import run_session_races

    tmp = None
    workdir = options.workdir
    if workdir is None:
        shm = Path("/dev/shm")
        tmp = tempfile.mkdtemp(prefix="confocal-races-", dir=shm if shm.is_dir() else None)
        workdir = Path(tmp)
    kinds = tuple(k.strip() for k in options.kinds.split(",") if k.strip())
    try:
        report = run_session_races(
            workdir, races=options.races, kinds=kinds, progress=lambda x: print(x, flush=True)
        )
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    print(f"race test: --races {options.races} --kinds {','.join(kinds)}")
    for line in report.lines():
        print(line)
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
