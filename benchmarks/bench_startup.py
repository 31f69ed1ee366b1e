"""Benchmark: start-up time of ``confocal --help`` and ``confocal --version``.

Each case runs as a fresh subprocess, in the same run as the baseline ``python -c pass`` (the
interpreter's own start-up on this machine), so the ratio compares across machines. The
target is under 0.5 s wall time for ``--help`` and ``--version``; before start-up was made
lazy, when every sub-command module (numpy, scipy, pandas, emcee, ...) was imported by the
root, they took 2.7-4 s. A sub-command that does work (``confocal session --help``) imports its own module
and is shown for comparison.

Run: ``python benchmarks/bench_startup.py [--repeat 7]``.
"""

from __future__ import annotations

import argparse
import resource
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


def time_command(argv: list[str], repeat: int) -> tuple[float, float]:
    """Return the median wall time and CPU time (user + system, s) of ``repeat`` runs of argv.

    CPU time is reported beside wall time because on a shared machine other processes stretch
    the wall time but not the CPU time the command itself needs.
    """
    subprocess.run(argv, capture_output=True, check=True)  # warm the file cache
    walls, cpus = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def main(argv: list[str] | None = None) -> int:
    """Print the median start-up time of each case and its ratio to the baseline."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    times = {name: time_command(cmd, args.repeat) for name, cmd in CASES.items()}
    base_wall, base_cpu = times["python -c pass (baseline)"]
    print(f"{'case':<28} {'wall s':>7} {'x base':>7} {'cpu s':>7} {'x base':>7}")
    for name, (wall, cpu) in times.items():
        print(
            f"{name:<28} {wall:>7.3f} {wall / base_wall:>7.1f} {cpu:>7.3f} "
            f"{cpu / max(base_cpu, 1e-3):>7.1f}"
        )
    slow = [n for n in ("confocal --version", "confocal --help") if times[n][0] >= 0.5]
    print("target < 0.5 s wall: " + ("met" if not slow else "MISSED by " + ", ".join(slow)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
