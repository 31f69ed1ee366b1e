"""Kill test: thousands of SIGKILLs across ``session run`` and ``active run``, then a full check.

Each subject's command (``session run --headless --observer logistic`` or ``active run`` with a
simulated searcher) is killed with SIGKILL after a random delay drawn over the whole run,
including the commit that completes the session and the moments after it, and recovered with
the README's command (the same command again) until it ends by itself. Then every log is read:
trials lost, trials duplicated, extra sessions, sessions run again after they were complete and
locks left on completed sessions must all be 0, and a run that reports a session complete must
not change the log's bytes. The commands run in children forked from one warm process
(:mod:`experiment.kill_recovery`), so a kill costs the run's own work, not Python's start-up.

Run: ``python benchmarks/bench_kill_recovery.py --kills 10000 --workers 2 --seed 1``
(exit status 1 if anything was lost, duplicated or run again).
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
    """Run the kill test and print its figures; return 0 when everything checks out."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kills", type=int, default=10_000, help="SIGKILLs to deliver (at least)")
    ap.add_argument("--workers", type=int, default=2, help="commands at once (CPU cores)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the kill delays")
    ap.add_argument(
        "--active-share", type=float, default=0.25, help="fraction of active-search subjects"
    )
    ap.add_argument(
        "--workdir",
        type=Path,
        default=None,
        help="keep the logs here (default: a temporary folder in /dev/shm, removed after)",
    )
    options = vars(ap.parse_args(argv))  # run_kill_recovery's keyword arguments, and workdir
    workdir = options.pop("workdir")
    warnings.simplefilter("ignore", UserWarning)  # the small synthetic scene's depth warning
    from experiment.kill_recovery import run_kill_recovery

    tmp = None
    if workdir is None:
        # tmpfs: a SIGKILL keeps the page cache, so fsync is not what is tested (a power cut
        # would be), and on a disk the fsyncs would take most of the time
        shm = Path("/dev/shm")
        tmp = tempfile.mkdtemp(prefix="confocal-kill-", dir=shm if shm.is_dir() else None)
        workdir = Path(tmp)
    try:
        report = run_kill_recovery(
            workdir, **options, progress=lambda line: print(line, flush=True)
        )
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
    print("kill test:", *(f"--{name.replace('_', '-')} {v}" for name, v in options.items()))
    for line in report.lines():
        print(line)
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
