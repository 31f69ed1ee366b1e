"""Benchmark: start-up time of ``confocal --help``, ``--version`` and every ``--help``.

Each case runs as a fresh subprocess, in the same run as the baseline ``python -c pass`` (the
interpreter's own start-up on this machine), so the ratio compares across machines. The target
is under 0.5 s wall time for every ``--help``: the root lists its sub-commands without importing
them, and each sub-command imports numpy, scipy, pandas, emcee, matplotlib, moderngl or textual
only inside the command that runs (``tests/experiment/test_cli_startup.py`` checks the imports;
this script measures the time). Every command in the tree is found by walking it, so a new
sub-command is measured without editing this file.

Run: ``python benchmarks/bench_startup.py [--repeat 5]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time

__all__ = ["command_paths", "time_command", "main"]

TARGET_S = 0.5

#: The environment of the timed runs: this one, but with Python's bytecode cache on (a shell
#: with ``PYTHONDONTWRITEBYTECODE`` set would recompile every module of ours on every run, which
#: no installed copy does; the warm-up run writes the cache).
AS_INSTALLED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def command_paths() -> list[list[str]]:
    """Every command of ``confocal`` as its words, groups and their sub-commands alike."""
    from experiment import cli

    out: list[list[str]] = []

    def walk(path: list[str], cmd) -> None:
        out.append(path)
        for name, sub in getattr(cmd, "commands", {}).items():
            walk([*path, name], sub)

    for name in cli.SUBCOMMANDS:
        walk([name], cli.load_subcommand(name))
    return out


def time_command(argv: list[str], repeat: int) -> tuple[float, float]:
    """Return the median wall time and CPU time (user + system, s) of ``repeat`` runs of argv.

    CPU time is reported beside wall time because on a shared machine other processes stretch
    the wall time but not the CPU time the command itself needs.
    """
    subprocess.run(argv, capture_output=True, check=True, env=AS_INSTALLED)  # warm the caches
    walls, cpus = [], []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True, env=AS_INSTALLED)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def main(argv: list[str] | None = None) -> int:
    """Print each case's median start-up time and its ratio to the baseline; 1 if one misses."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    confocal = [sys.executable, "-m", "experiment.cli"]
    cases: dict[str, list[str]] = {
        "python -c pass (baseline)": [sys.executable, "-c", "pass"],
        "confocal --version": [*confocal, "--version"],
        "confocal --help": [*confocal, "--help"],
    }
    for path in command_paths():
        cases[f"confocal {' '.join(path)} --help"] = [*confocal, *path, "--help"]
    times = {name: time_command(cmd, args.repeat) for name, cmd in cases.items()}
    base_wall, base_cpu = times["python -c pass (baseline)"]
    width = max(len(n) for n in times)
    print(f"{'case':<{width}} {'wall s':>7} {'x base':>7} {'cpu s':>7} {'x base':>7}")
    for name, (wall, cpu) in times.items():
        print(
            f"{name:<{width}} {wall:>7.3f} {wall / base_wall:>7.1f} {cpu:>7.3f} "
            f"{cpu / max(base_cpu, 1e-3):>7.1f}"
        )
    measured = {n: t for n, t in times.items() if n.startswith("confocal")}
    slowest = max(measured, key=lambda n: measured[n][0])
    print(f"slowest: {slowest} {measured[slowest][0]:.3f} s wall, {measured[slowest][1]:.3f} s CPU")
    slow = [n for n, (wall, _) in measured.items() if wall >= TARGET_S]
    print(f"target < {TARGET_S} s wall: " + ("met" if not slow else "MISSED by " + ", ".join(slow)))
    return 1 if slow else 0


if __name__ == "__main__":
    sys.exit(main())
