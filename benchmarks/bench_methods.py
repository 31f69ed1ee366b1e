"""Benchmark: every de-clutter method scored against the synthetic objects' true masks, and timed.

Writes ``--objects`` synthetic photo pairs (``stimuli synth``, which writes each object's true
mask), builds one stimulus set with every photo method as a condition (cluttered, sobel, mask,
segment, saliency; ``depth`` needs light fields and is left out) through the real builder, and
scores each condition's stimuli at L8 (full resolution, window 1) and L3 (window 13) against the
true mask taken to the same grid:

- **on object**: the share of the stimulus's white pixels (cells) that lie on the object (the
  mask dilated by 2 px at L8; at L3 cells that hold any object pixel);
- **outline kept**: the share of the object's outline (mask minus its erosion) with a white
  pixel within 2 px (L8), or the share of outline cells that are white (L3).

Means over the objects, and for each method the number of objects where it keeps less of the
outline than Sobel. Each method is also timed on every object in this process against the Sobel
method (best of ``--repeat`` runs; the ratio is the method's time over Sobel's).

Run: ``python benchmarks/bench_methods.py [--objects 20] [--repeat 3] [--seed 0]``.

Seen (20 objects, seed 0, best of 3, shared 2-core machine), on object / outline kept (objects
keeping less of the outline than Sobel), L8 then L3, time per object and its ratio to Sobel::

    cluttered  0.24 / 0.94 (12)  0.25 / 0.83 ( 0)
    sobel      1.00 / 0.95 ( 0)  1.00 / 0.77 ( 0)     0.2 ms     1
    mask       1.00 / 0.95 ( 6)  1.00 / 0.79 ( 9)    21.0 ms    99
    segment    0.78 / 0.84 (16)  0.82 / 0.78 ( 6)   358.0 ms  1696
    saliency   0.78 / 0.49 (20)  0.80 / 0.50 (18)   128.6 ms   609

On these synthetic pairs the narrow photo's defocus already removes all the clutter, so Sobel's
edges all lie on the object; the mask cannot do better there, and segment and saliency keep
less of the object than Sobel on most objects (saliency on all 20 at L8).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stimuli.io import load_gray  # noqa: E402
from stimuli.methods import MethodInput, get_method  # noqa: E402
from stimuli.stimset import BuildParams, build_stimulus_set  # noqa: E402
from stimuli.synth import write_pairs  # noqa: E402

__all__ = ["score", "main"]

CONDITIONS = ("cluttered", "sobel", "mask", "segment", "saliency")
LEVELS = {8: 1, 3: 13}


def _cells(a: np.ndarray, shape: tuple[int, int], how) -> np.ndarray:
    """Reduce a working-size bool image to a grid of ``shape`` cells (as compress windows)."""
    rows, cols = a.shape
    ri = (np.arange(rows) * shape[0]) // rows
    ci = (np.arange(cols) * shape[1]) // cols
    out = np.zeros(shape, bool)
    for r in range(shape[0]):
        block = a[ri == r]
        for c in range(shape[1]):
            out[r, c] = how(block[:, ci == c])
    return out


def score(stim: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """Return (share of white on the object, share of the outline kept) of one stimulus."""
    from scipy.ndimage import binary_dilation, binary_erosion

    outline = mask & ~binary_erosion(mask)
    if stim.shape == mask.shape:
        on = binary_dilation(mask, iterations=2)
        near = binary_dilation(stim, iterations=2)
        white = int(stim.sum())
        return (
            float((stim & on).sum() / white) if white else float("nan"),
            float((near & outline).sum() / max(int(outline.sum()), 1)),
        )
    obj_cells = _cells(mask, stim.shape, np.any)
    out_cells = _cells(outline, stim.shape, np.any)
    white = int(stim.sum())
    return (
        float((stim & obj_cells).sum() / white) if white else float("nan"),
        float((stim & out_cells).sum() / max(int(out_cells.sum()), 1)),
    )


def _time(name: str, inputs: list[MethodInput], repeat: int) -> float:
    m = get_method(name)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for inp in inputs:
            m.run(inp)
        best = min(best, time.perf_counter() - t0)
    return best / len(inputs)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print the table (and ``--json`` the numbers)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        pairs = write_pairs(Path(tmp) / "pairs", n_objects=a.objects, n_training=0, seed=a.seed)
        out = Path(tmp) / "set"
        build_stimulus_set(pairs, out, params=BuildParams(conditions=CONDITIONS))
        meta = json.loads((out / "stimulus_set.json").read_text())
        objects = [o["object"] for o in meta["objects"]]
        scores: dict[str, dict[int, list[tuple[float, float]]]] = {
            c: {lv: [] for lv in LEVELS} for c in CONDITIONS
        }
        inputs = []
        for oid in objects:
            mask = load_gray(pairs / oid / "mask.png") >= 0.5
            for c in CONDITIONS:
                for lv, w in LEVELS.items():
                    stim = np.asarray(Image.open(out / oid / f"{c}_L{lv}_w{w:02d}.png")) > 0
                    scores[c][lv].append(score(stim, mask))
            threshold = meta["conditions"]["sobel"]["measured"][oid]["threshold"]
            wide = load_gray(pairs / oid / "wide.png")
            narrow = load_gray(pairs / oid / "narrow.png")
            inputs.append(MethodInput(oid, wide, narrow, threshold, mask=mask))
    seconds = {c: _time(c, inputs, a.repeat) for c in CONDITIONS if c != "cluttered"}
    rows = []
    for c in CONDITIONS:
        row = {"condition": c}
        for lv in LEVELS:
            s = np.asarray(scores[c][lv], float)
            row[f"L{lv}_on_object"] = float(np.nanmean(s[:, 0]))
            row[f"L{lv}_outline_kept"] = float(np.nanmean(s[:, 1]))
            sob = np.asarray(scores["sobel"][lv], float)
            row[f"L{lv}_objects_less_outline_than_sobel"] = int((s[:, 1] < sob[:, 1] - 1e-9).sum())
        if c in seconds:
            row["ms_per_object"] = 1000 * seconds[c]
            row["time_vs_sobel"] = seconds[c] / seconds["sobel"]
        rows.append(row)
    print(
        f"{a.objects} synthetic objects (seed {a.seed}), 492x327, best of {a.repeat}; "
        "on object / outline kept (objects keeping less outline than sobel)"
    )
    print(f"{'condition':<10} {'L8':>22} {'L3 (w13)':>22} {'ms/object':>10} {'x sobel':>8}")
    for r in rows:
        cells = [
            f"{r[f'L{lv}_on_object']:.2f} / {r[f'L{lv}_outline_kept']:.2f} "
            f"({r[f'L{lv}_objects_less_outline_than_sobel']:>2})"
            for lv in LEVELS
        ]
        t = f"{r['ms_per_object']:10.1f} {r['time_vs_sobel']:8.1f}" if "ms_per_object" in r else ""
        print(f"{r['condition']:<10} {cells[0]:>22} {cells[1]:>22} {t}")
    if a.json:
        print(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
