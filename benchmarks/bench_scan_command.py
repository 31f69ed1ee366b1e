"""Benchmark: ``confocal lightfield scan`` end to end, time to its answer and to its exit.

Each run is a fresh process with the command's default options (imports, reading the capture,
the plane scan and the plane choice all count), timed from its start to the line ``stimuli
build --plane auto would use ...`` (the answer) and to its exit (after the confocal, edge and
grid PNGs of every plane and ``scores.png`` are written); the process's CPU time (user + sys)
is read from the operating system at its exit, which a shared machine's load inflates far less
than the wall time. The baselines ``python -c pass`` and ``python -c "import numpy"`` run in the
same loop, interleaved, so the ratios compare across machines. The goal is an exit under 1 s
on a shared light field (the Lytro 7x7 capture by default:
``$CONFOCAL_DATA/lightfield/lytro_illum_2067_epinet``). The report also names the heavy modules
(numba, scipy, matplotlib) the scan process imported.

``--sweep compiled`` forces the compiled plane sweep (numba's start-up, about 0.75 s per
process, then comes before the answer) to show what the numpy sweep saves.

Run: ``python benchmarks/bench_scan_command.py [LIGHT_FIELD] [--repeat 5] [--sweep compiled]
[--no-plot]``.
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
    "try:\n"
    "    main()\n"
    "finally:\n"
    "    heavy = ('numba', 'scipy', 'matplotlib')\n"
    "    print('heavy modules:', ' '.join(m for m in heavy if m in sys.modules) or 'none')\n"
)


def _reap(proc: subprocess.Popen) -> tuple[int, float]:
    """Wait for ``proc``; return its exit status and CPU seconds (user + sys)."""
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, usage.ru_utime + usage.ru_stime


def time_scan(
    light_field: Path, out: Path, sweep: str, plot: bool = True
) -> tuple[float, float, float, str]:
    """Return seconds to the answer line, to exit, CPU seconds and the heavy modules imported."""
    shutil.rmtree(out, ignore_errors=True)
    argv = ["lightfield", "scan", str(light_field), "--out", str(out)]
    argv += [] if plot else ["--no-plot"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _RUNNER, sweep, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=AS_INSTALLED,
    )
    answer, heavy = None, "?"
    assert proc.stdout is not None
    for line in proc.stdout:
        if answer is None and line.startswith(ANSWER_PREFIX):
            answer = time.perf_counter() - t0
        if line.startswith("heavy modules:"):
            heavy = line.split(":", 1)[1].strip()
    status, cpu = _reap(proc)
    if status != 0 or answer is None:
        raise SystemExit(f"lightfield scan {light_field} failed or printed no answer")
    return answer, time.perf_counter() - t0, cpu, heavy


def _time_baseline(code: str) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -c CODE``."""
    t0 = time.perf_counter()
    status, cpu = _reap(subprocess.Popen([sys.executable, "-c", code], env=AS_INSTALLED))
    if status != 0:
        raise SystemExit(f"python -c {code!r} failed")
    return time.perf_counter() - t0, cpu


def main(argv: list[str] | None = None) -> int:
    """Print the median times and their ratios to the baselines; 1 if the exit misses 1 s."""
    data = Path(os.environ.get("CONFOCAL_DATA", "../shared/data"))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "light_field", nargs="?", type=Path, default=data / "lightfield/lytro_illum_2067_epinet"
    )
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--sweep", choices=("auto", "compiled", "numpy"), default="auto")
    ap.add_argument("--no-plot", dest="plot", action="store_false", help="Pass --no-plot.")
    args = ap.parse_args(argv)
    if not args.light_field.exists():
        raise SystemExit(f"{args.light_field}: not found (set CONFOCAL_DATA or give a path)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "scan"
        time_scan(args.light_field, out, args.sweep, args.plot)  # warm the caches
        runs, passes, numpys = [], [], []
        for _ in range(args.repeat):
            passes.append(_time_baseline("pass"))
            numpys.append(_time_baseline("import numpy"))
            runs.append(time_scan(args.light_field, out, args.sweep, args.plot))
    med = statistics.median
    p_wall, p_cpu = med(w for w, _ in passes), med(c for _, c in passes)
    n_wall, n_cpu = med(w for w, _ in numpys), med(c for _, c in numpys)
    answers, exits, cpus = ([r[i] for r in runs] for i in range(3))
    answer, end, cpu = med(answers), med(exits), med(cpus)
    plot = "" if args.plot else ", --no-plot"
    print(f"light field: {args.light_field.name}, sweep: {args.sweep}{plot}, {args.repeat} runs")
    print(f"load average: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"baseline python -c pass:           {p_wall:.3f} s wall, {p_cpu:.3f} s CPU")
    print(f"baseline python -c 'import numpy': {n_wall:.3f} s wall, {n_cpu:.3f} s CPU")
    print(
        f"answer: {answer:.3f} s wall median ({min(answers):.3f}-{max(answers):.3f}), "
        f"{answer / p_wall:.1f}x python -c pass"
    )
    spread = f"({min(exits):.3f}-{max(exits):.3f})"
    print(f"exit:   {end:.3f} s wall median {spread}, {end / p_wall:.1f}x python -c pass")
    print(
        f"CPU:    {cpu:.3f} s user+sys median ({min(cpus):.3f}-{max(cpus):.3f}), "
        f"{cpu / p_cpu:.1f}x python -c pass, {cpu / n_cpu:.1f}x import numpy"
    )
    print(f"heavy modules imported by the scan: {runs[-1][3]}")
    met = cpu < TARGET_S
    print(f"target exit < {TARGET_S:g} s of CPU: {'met' if met else 'MISSED'}")
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
