"""Output contract under generated path shapes and races: harms found must be 0.

Three parts, each counted:

1. ``--cases`` generated cases (``tests/output_contract_cases.py``): random layouts of folders,
   files and links (to folders, files, inputs, a parent, dangling, loops), ``..`` after links,
   relative and absolute paths, ``--force`` or not, a body that fails midway or not, for every
   command in ``WRITING_COMMANDS``, run by a stand-in body with the command's own library writer
   under the real guard. Every file, folder and link is hashed before and after each run.
2. ``--real-cases`` generated cases for each real command (the real body runs).
3. ``--races`` races for each real command: two writers forked from one warm process, started
   together on one ``--out``; a finished output lost, or a loser that does not refuse with one
   line and exit status 2, is a harm.

Run: ``python benchmarks/bench_output_contract.py --cases 2000 --real-cases 4 --races 50``
(exit status 1 if any harm was found). Cases are laid out in ``/dev/shm`` where it exists.
"""

from __future__ import annotations

import argparse
import collections
import os
import random
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

__all__ = ["main"]


def _root() -> Path:
    shm = Path("/dev/shm")
    base = shm if shm.is_dir() and os.access(shm, os.W_OK) else None
    return Path(tempfile.mkdtemp(prefix="confocal-bench-contract-", dir=base))


def _generated(n: int, seed: int, top: Path) -> tuple[collections.Counter, list[str]]:
    from tests.output_contract_cases import check_case, generate, run_stub

    rng = random.Random(seed)
    counts: collections.Counter = collections.Counter()
    harms: list[str] = []
    for i in range(n):
        case = generate(rng)
        root = top / f"g{i}"
        root.mkdir()
        o = check_case(case, root, run_stub)
        shutil.rmtree(root, ignore_errors=True)
        counts["cases"] += 1
        counts["failed midway" if "stub failure" in o.message else f"exit {o.code}"] += 1
        counts[f"command {case.command}"] += 1
        if o.problems:
            harms.append(f"{case.label()} -> {o.code} {o.message}: {o.problems}")
    return counts, harms


def _real(n: int, seed: int, top: Path, world: dict) -> tuple[collections.Counter, list[str]]:
    from tests.output_contract_cases import REAL, check_case, real_cases, run_real, tiny_demo

    tiny_demo()
    counts: collections.Counter = collections.Counter()
    harms: list[str] = []
    for command, kind in sorted(REAL):
        for i, case in enumerate(real_cases(command, kind, n, seed)):
            root = top / f"r-{command.replace(' ', '-')}-{kind}-{i}"
            root.mkdir()
            o = check_case(case, root, lambda c, r: run_real(c, r, world), world["root"])
            shutil.rmtree(root, ignore_errors=True)
            counts["cases"] += 1
            counts[f"exit {o.code}"] += 1
            if o.problems:
                harms.append(f"{case.label()} -> {o.code} {o.message}: {o.problems}")
    return counts, harms


def _races(n: int, top: Path, world: dict) -> tuple[collections.Counter, list[str]]:
    from tests.output_contract_cases import REAL, judge_race, race, tiny_demo

    counts: collections.Counter = collections.Counter()
    harms: list[str] = []
    for command, kind in sorted(REAL):
        name = (
            ("lf.npz" if command == "lightfield synth" else "out.png") if kind == "file" else "out"
        )
        line = REAL[(command, kind)]
        if kind == "file":
            line += " --force" if command in ("lightfield refocus", "lightfield synth") else ""
        mine: collections.Counter = collections.Counter(harms=0)
        for i in range(n):
            cwd = top / f"race-{command.replace(' ', '-')}-{kind}-{i}"
            cwd.mkdir()
            argv = [w.format(out=name, **world) for w in line.split()]
            if command in ("view", "present", "stimuli tune"):
                argv.append("--force")
            gl = command in ("view", "present")  # a GL context: not in a forked child
            results = race(
                [argv, argv],
                cwd,
                setup=tiny_demo if command == "demo" else None,
                start="spawn" if gl else "fork",
            )
            problems = judge_race(results, cwd / name, kind)
            codes = sorted(c for c, _ in results)
            counts["races"] += 1
            outcome = "one refused" if codes == [0, 2] else f"exits {codes}"
            counts[outcome] += 1
            mine[outcome] += 1
            if problems:
                harms.append(f"{command} ({kind}) race {i}: {problems} {results}")
                mine["harms"] += 1
            shutil.rmtree(cwd, ignore_errors=True)
        print(f"  races {command} ({kind}): {dict(mine)}", file=sys.stderr, flush=True)
    return counts, harms


def main(argv: list[str] | None = None) -> int:
    """Run the three parts and print their figures; return 0 when no harm was found."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=2000, help="generated stand-in cases")
    ap.add_argument("--real-cases", type=int, default=4, help="generated cases per real command")
    ap.add_argument("--races", type=int, default=50, help="races per real command")
    ap.add_argument("--seed", type=int, default=1, help="seed of the generated cases")
    opts = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ.setdefault("COLUMNS", "250")
    top = _root()
    all_harms: list[str] = []
    try:
        t0 = time.perf_counter()
        counts, harms = _generated(opts.cases, opts.seed, top)
        all_harms += harms
        shown = {k: v for k, v in counts.items() if not k.startswith("command ")}
        print(
            f"generated (stand-in bodies): {dict(shown)}; harms found: {len(harms)} "
            f"({time.perf_counter() - t0:.0f} s)"
        )
        per = sorted((k[8:], v) for k, v in counts.items() if k.startswith("command "))
        print("  per command: " + ", ".join(f"{k} {v}" for k, v in per))
        if opts.real_cases or opts.races:
            from tests.output_contract_cases import make_world

            world = make_world(top / "inputs")
        if opts.real_cases:
            t0 = time.perf_counter()
            counts, harms = _real(opts.real_cases, opts.seed, top, world)
            all_harms += harms
            print(
                f"generated (real commands): {dict(counts)}; harms found: {len(harms)} "
                f"({time.perf_counter() - t0:.0f} s)"
            )
        if opts.races:
            t0 = time.perf_counter()
            counts, harms = _races(opts.races, top, world)
            all_harms += harms
            print(
                f"races (two writers, one --out): {dict(counts)}; harms found: {len(harms)} "
                f"({time.perf_counter() - t0:.0f} s)"
            )
    finally:
        shutil.rmtree(top, ignore_errors=True)
    for h in all_harms[:20]:
        print("HARM:", h)
    print(f"total harms found: {len(all_harms)}")
    return 1 if all_harms else 0


if __name__ == "__main__":
    sys.exit(main())
