"""Benchmark: ``confocal lightfield scan`` end to end, time to its answer and to its exit.

Each run is a fresh process (imports, reading the capture, the plane scan and the plane choice
all count), timed from its start to the line ``stimuli build --plane auto would use ...`` (the
answer) and to its exit (after the confocal, edge and grid PNGs of every plane are written).
The baseline ``python -c "import numpy"`` runs in the same loop, interleaved, so the ratio
compares across machines. The goal is an answer under 1 s on a shared light field (the
Lytro 7x7 capture by default: ``$CONFOCAL_DATA/lightfield/lytro_illum_2067_epinet``).

``--sweep compiled`` forces the compiled plane sweep (numba's start-up, about 0.75 s per
process, then comes before the answer) to show what the numpy sweep saves.

Run: ``python benchmarks/bench_scan_command.py [LIGHT_FIELD] [--repeat 5] [--sweep compiled]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = ["time_scan", "main"]

TARGET_S = 1.0

#: The environment of the timed runs: this one, with Python's bytecode cache on as in any
#: installed copy (the warm-up run writes it).
AS_INSTALLED = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
ANSWER_PREFIX = "stimuli build --plane auto"

#: Runs the command in a fresh interpreter, with the sweep forced when asked.
_RUNNER = (
    "import sys\n"
    "import stimuli.agreementscan as agreementscan\n"
    "agreementscan.SWEEP_PATH = sys.argv[1]\n"
    "from experiment.cli import main\n"
    "sys.argv = ['confocal', *sys.argv[2:]]\n"
    "main()\n"
)


def time_scan(light_field: Path, out: Path, sweep: str) -> tuple[float, float]:
    """Return (seconds to the answer line, seconds to exit) of one fresh scan process."""
    shutil.rmtree(out, ignore_errors=True)
    argv = ["lightfield", "scan", str(light_field), "--out", str(out), "--no-plot"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _RUNNER, sweep, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=AS_INSTALLED,
    )
    answer = None
    assert proc.stdout is not None
    for line in proc.stdout:
        if answer is None and line.startswith(ANSWER_PREFIX):
            answer = time.perf_counter() - t0
    if proc.wait() != 0 or answer is None:
        raise SystemExit(f"lightfield scan {light_field} failed or printed no answer")
    return answer, time.perf_counter() - t0


def _time_baseline() -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import numpy"], check=True, env=AS_INSTALLED)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    """Print the median times and their ratio to the baseline; 1 if the answer misses 1 s."""
    data = Path(os.environ.get("CONFOCAL_DATA", "../shared/data"))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "light_field", nargs="?", type=Path, default=data / "lightfield/lytro_illum_2067_epinet"
    )
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--sweep", choices=("auto", "compiled", "numpy"), default="auto")
    args = ap.parse_args(argv)
    if not args.light_field.exists():
        raise SystemExit(f"{args.light_field}: not found (set CONFOCAL_DATA or give a path)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scan"
        time_scan(args.light_field, out, args.sweep)  # warm the file cache and numba's cache
        answers, exits, bases = [], [], []
        for _ in range(args.repeat):
            bases.append(_time_baseline())
            a, e = time_scan(args.light_field, out, args.sweep)
            answers.append(a)
            exits.append(e)
    base = statistics.median(bases)
    answer, end = statistics.median(answers), statistics.median(exits)
    print(f"light field: {args.light_field.name}, sweep: {args.sweep}, {args.repeat} runs")
    print(f"baseline python -c 'import numpy': {base:.3f} s")
    print(
        f"answer: {answer:.3f} s median ({min(answers):.3f}-{max(answers):.3f}), "
        f"{answer / base:.1f}x baseline"
    )
    spread = f"({min(exits):.3f}-{max(exits):.3f})"
    print(f"exit:   {end:.3f} s median {spread}, {end / base:.1f}x baseline")
    met = answer < TARGET_S
    print(f"target answer < {TARGET_S:g} s: {'met' if met else 'MISSED'}")
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
