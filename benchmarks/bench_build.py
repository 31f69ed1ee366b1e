"""Benchmark: build a 20-object stimulus set from 1536x1024 photos.

Goal: the whole set in under 10 s on 2 cores. Reported as time per object and as a ratio to
plain decoding of the same files (``PIL.Image.open(...).load()``, one process, same run), so the
numbers compare across machines.

Input: the six real 1536x1024 JPEG pairs in ``$CONFOCAL_DATA/dof_pairs`` (VABD, EBB!) cycled to
20 objects (each object its own copy of the files, so no decode is cached by the builder); if the
data are absent, 20 synthetic pairs saved as JPEG (quality 92) at 1536x1024.

Run: ``python benchmarks/bench_build.py [--objects 20] [--workers 2] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stimuli.io import load_gray  # noqa: E402
from stimuli.stimset import BuildParams, build_stimulus_set  # noqa: E402

__all__ = ["make_input", "main"]

_REAL = [
    ("vabd", "input", "1_8", ".JPG", ("0001", "0002", "0003")),
    ("ebb", "input", "target", ".jpg", ("2977", "2978", "2979")),
]


def make_input(root: Path, n_objects: int) -> str:
    """Write ``n_objects`` pair folders under ``root``; return a description of the source."""
    data = Path(os.environ.get("CONFOCAL_DATA", REPO.parent / "shared" / "data"))
    real = [
        (
            data / "dof_pairs" / name / "train" / w / (i + ext),
            data / "dof_pairs" / name / "train" / n / (i + ext),
        )
        for name, w, n, ext, ids in _REAL
        for i in ids
    ]
    if all(a.is_file() and b.is_file() for a, b in real):
        for k in range(n_objects):
            wide, narrow = real[k % len(real)]
            d = root / f"obj{k:02d}"
            d.mkdir(parents=True)
            shutil.copyfile(wide, d / "wide.jpg")
            shutil.copyfile(narrow, d / "narrow.jpg")
        return f"{len(real)} real VABD/EBB! JPEG pairs (1536x1024) cycled to {n_objects} objects"
    sys.path.insert(0, str(REPO))
    from tests.stimuli._build_fixtures import make_pair

    for k in range(n_objects):
        wide, narrow, _ = make_pair(k, (1024, 1536), blur_px=8.0)
        d = root / f"obj{k:02d}"
        d.mkdir(parents=True)
        for name, img in (("wide", wide), ("narrow", narrow)):
            Image.fromarray(np.round(img * 255).astype(np.uint8)).save(
                d / f"{name}.jpg", quality=92
            )
    return f"{n_objects} synthetic JPEG pairs (1536x1024)"


def _decode_all(files: list[Path]) -> float:
    t = time.perf_counter()
    for f in files:
        with Image.open(f) as im:
            im.load()
    return time.perf_counter() - t


def _load_gray_all(files: list[Path]) -> float:
    t = time.perf_counter()
    for f in files:
        load_gray(f)
    return time.perf_counter() - t


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print a table; return 0 if the 10 s goal is met."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=20)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        source = make_input(root / "pairs", args.objects)
        files = sorted((root / "pairs").rglob("*.jpg"))
        variants = {
            "build, 1 worker": (1, BuildParams()),
            f"build, {args.workers} workers": (args.workers, BuildParams()),
            f"build, {args.workers} workers, --fast-decode": (
                args.workers,
                BuildParams(fast_decode=True),
            ),
        }
        times: dict[str, list[float]] = {k: [] for k in variants}
        decode, gray, ratios = [], [], {}
        for r in range(args.repeat):
            decode.append(_decode_all(files))
            gray.append(_load_gray_all(files))
            for label, (workers, params) in variants.items():
                out = root / f"set{r}"
                t = time.perf_counter()
                result = build_stimulus_set(root / "pairs", out, workers=workers, params=params)
                times[label].append(time.perf_counter() - t)
                ratios[label] = result.edge_ratio
                shutil.rmtree(out)
        med = statistics.median
        n = args.objects
        print(
            f"input: {source}; {len(files)} files; cpus: {os.cpu_count()}; median of {args.repeat}"
        )
        print(
            f"{'plain decode (PIL open+load)':42s}: {med(decode):6.2f} s "
            f"({1000 * med(decode) / n:6.1f} ms per object)"
        )
        print(
            f"{'load_gray (decode + luminance)':42s}: {med(gray):6.2f} s "
            f"({1000 * med(gray) / n:6.1f} ms per object, {med(gray) / med(decode):5.2f}x decode)"
        )
        for label, acc in times.items():
            print(
                f"{label:42s}: {med(acc):6.2f} s ({1000 * med(acc) / n:6.1f} ms per object, "
                f"{med(acc) / med(decode):5.2f}x plain decode; edge ratio {ratios[label]:.4f})"
            )
        best = min(med(acc) for acc in times.values())
        ok = best < 10.0
        print(f"goal (< 10 s for {n} objects): {'met' if ok else 'NOT met'} (best {best:.2f} s)")
        return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
