"""Benchmark: start-up time of ``confocal --help`` and ``confocal --version`` (issue 15).

Each case runs as a fresh subprocess, in the same run as the baseline ``python -c pass`` (the
interpreter's own start-up on this machine), so the ratio compares across machines. The
target is under 0.5 s wall time for ``--help`` and ``--version``; before issue 15, when every
sub-command module (numpy, scipy, pandas, emcee, ...) was imported by the root, they took
2.7-4 s. A sub-command that does work (``confocal session --help``) imports its own module
and is shown for comparison.

Run: ``python benchmarks/bench_startup.py [--repeat 7]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

__all__ = ["time_command", "main"]

CASES: dict[str, list[str]] = {
    "python -c pass (baseline)": [sys.executable, "-c", "pass"],
    "confocal --version": [sys.executable, "-m", "experiment.cli", "--version"],
    "confocal --help": [sys.executable, "-m", "experiment.cli", "--help"],
    "confocal session --help": [sys.executable, "-m", "experiment.cli", "session", "--help"],
}


def time_command(argv: list[str], repeat: int) -> float:
    """Return the median wall time (s) of running ``argv`` to completion ``repeat`` times."""
    subprocess.run(argv, capture_output=True, check=True)  # warm the file cache
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        runs.append(time.perf_counter() - t0)
    return statistics.median(runs)


def main(argv: list[str] | None = None) -> int:
    """Print the median start-up time of each case and its ratio to the baseline."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    times = {name: time_command(cmd, args.repeat) for name, cmd in CASES.items()}
    base = times["python -c pass (baseline)"]
    print(f"{'case':<28} {'median s':>9} {'x baseline':>11}")
    for name, t in times.items():
        print(f"{name:<28} {t:>9.3f} {t / base:>11.1f}")
    slow = [n for n in ("confocal --version", "confocal --help") if times[n] >= 0.5]
    print("target < 0.5 s: " + ("met" if not slow else "MISSED by " + ", ".join(slow)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
