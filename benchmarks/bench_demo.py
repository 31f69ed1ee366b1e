"""Benchmark: ``confocal demo`` end to end. Goal: under 30 s on 2 cores.

Runs the whole demo (synthesise 23 photo pairs, and the observer's exemplars -- eight
renderings of the 23 kinds for the calibrated observer -- in two more processes; build the
stimulus set; 6 simulated subjects through the session engine; analysis with figures) and
reports each stage's wall time, and the CPU time of this process and its children (on a busy
shared machine the wall time is inflated by other work; the CPU time is not). Because machines
are noisy, it also reports the total as a ratio to a baseline measured in the same process
right after: decoding every PNG the demo wrote once
(``PIL.Image.open(...).load()``), the least work any pipeline over these files could do.

Run: ``python benchmarks/bench_demo.py [--subjects 6] [--repeat 1] [--observer calibrated]``
(run ``k`` uses seed ``k``); the minimum over the runs is printed too.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

from PIL import Image

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.demos.study import run_demo, summary_lines  # noqa: E402

__all__ = ["main"]


def _decode_all(root: Path) -> tuple[float, int]:
    files = sorted(root.rglob("*.png"))
    t0 = time.perf_counter()
    for f in files:
        with Image.open(f) as im:
            im.load()
    return time.perf_counter() - t0, len(files)


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process and its finished children."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main(argv: list[str] | None = None) -> None:
    """Run the demo ``--repeat`` times and print stage times and the ratio to the baseline."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--subjects", type=int, default=6)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--observer", default="calibrated")
    args = ap.parse_args(argv)
    totals, bases, cpus = [], [], []
    for k in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            cpu0 = _cpu_s()
            result = run_demo(
                Path(tmp) / "demo",
                n_subjects=args.subjects,
                seed=k,
                observer=args.observer,
                show_progress=False,
            )
            total = time.perf_counter() - t0
            cpu = _cpu_s() - cpu0
            base, n_files = _decode_all(Path(tmp) / "demo")
            totals.append(total)
            bases.append(base)
            cpus.append(cpu)
            stages = ", ".join(
                f"{s} {v:.1f} s (CPU {result.cpu_seconds.get(s, float('nan')):.1f} s)"
                for s, v in result.seconds.items()
            )
            print(
                f"run {k + 1}: total {total:.1f} s ({stages}); CPU {cpu:.1f} s (this process "
                f"and children); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} "
                f"cores; baseline: decode {n_files} PNGs {base:.2f} s",
                flush=True,
            )
            if k == 0:
                print("\n".join("  " + line for line in summary_lines(result)[:9]))
    total, base = statistics.median(totals), statistics.median(bases)
    print(
        f"demo total (median of {args.repeat}): {total:.1f} s; goal < 30 s: "
        f"{'met' if total < 30 else 'NOT met'}; ratio to decoding its own PNGs: "
        f"{total / base:.0f}x"
    )
    print(
        f"minimum of {args.repeat}: {min(totals):.1f} s wall, {min(cpus):.1f} s CPU (this process "
        f"and children); load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )


if __name__ == "__main__":
    main()
