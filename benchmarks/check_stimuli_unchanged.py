"""Check that a refactor of ``stimuli/`` writes the same stimuli, byte for byte.

Writes, in a temporary folder and with fixed seeds:

* a PAIRS set of all 26 object kinds (23 main + 3 training objects, the Python API of
  ``confocal stimuli synth --objects 23``) at a reduced photo size;
* the paper's simulated three-plane light field (``confocal lightfield synth``) as a lens-array
  elemental image (``.png`` + ``.toml``), a camera-array folder of views and an ``.npz``;
* a ``confocal lightfield scan`` of the camera array (planes, edges, grids) and one
  ``confocal lightfield refocus`` with its edge and grid images;

then loads each light field and runs the plane detection on it (agreement scan, the paper's
Haar scan, the range estimate and the confocal plane chosen for the stimulus builder), and builds
stimulus sets with ``confocal stimuli build`` from a PAIRS CSV of six synthetic pairs (one a
training object, one with a crop box, one with its own threshold in ``objects.csv``, one saved as
JPEG) and two light-field objects (the camera-array ``.npz`` at the plane the builder picks, the
folder at a given disparity): Sobel edges and grey mode, each with and without ``--implant``, the
depth de-cluttering with the bokeh guard and Otsu's threshold, and a global threshold with
``--fast-decode`` at a smaller working size. ``confocal stimuli tune --dry-run`` on the same input
adds its contact sheet and the table it prints.

Prints one JSON object: the sha256 of every file written (by path relative to the temporary
folder) and the detected planes. ``--compare FILE`` compares with an earlier output and exits 1
on any difference, naming each. The ``scores.png`` plot is left out of the file hashes: it is
drawn by matplotlib, whose output is not ours to keep stable. Each ``stimulus_set.json`` is
hashed without its ``built_utc`` (the time of the build) and ``software`` (package version and git
commit) entries, which legitimately change from one run or commit to the next.

Run: ``python benchmarks/check_stimuli_unchanged.py > /tmp/stimuli_before.json``, change the
code, then ``python benchmarks/check_stimuli_unchanged.py --compare /tmp/stimuli_before.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from stimuli.cli import stimuli_app
from stimuli.confocal import confocal_plane
from stimuli.lightfield import load_lightfield
from stimuli.lightfield_cli import lightfield_app
from stimuli.planes import estimate_disparity_range, find_object_planes
from stimuli.synth import write_pairs

#: Photo size of the PAIRS set, (rows, cols): small enough for a shared 2-core machine, large
#: enough that every object's details are drawn (ours).
PAIRS_SHAPE_PX = (327, 492)
#: Light-field view size, COLSxROWS as the CLI takes it (ours, small for speed).
LF_SIZE = "192x160"
SEED = 7
#: Pair folders of the PAIRS set that the stimulus-set builds use (ours: six, for speed).
BUILD_OBJECTS = 6
#: ``confocal stimuli build`` options of each stimulus set built, by the set's folder name.
BUILD_SETS: dict[str, tuple[str, ...]] = {
    "set_edges": (),
    "set_edges_implants": ("--implant", "argus2", "--implant", "alpha_ims"),
    "set_grey": ("--mode", "grey", "--grey-levels", "4"),
    "set_grey_implant": ("--mode", "grey", "--implant", "brainport", "--implant-px", "8"),
    # 'depth' is refused for photo pairs, so this mixed set asks for 'auto' (depth on 1-D
    # light fields, Sobel elsewhere); its photo pairs are built exactly as before
    "set_depth": (
        "--declutter",
        "auto",
        "--bokeh-guard",
        "--threshold-method",
        "otsu",
        "--edge-ratio",
        "0.08",
    ),  # fmt: skip
    "set_fast": ("--threshold", "0.15", "--fast-decode", "--working-size", "246x164"),
}
#: Entries of ``stimulus_set.json`` that record when and by which software version it was built.
_BUILD_TIME_AND_VERSION = ("built_utc", "software")


def _cli(args: list[str]) -> None:
    result = CliRunner().invoke(lightfield_app, args)
    if result.exit_code != 0:
        raise SystemExit(f"lightfield {' '.join(args)} failed:\n{result.output}")


def _stimuli_cli(args: list[str]) -> str:
    result = CliRunner().invoke(stimuli_app, args)
    if result.exit_code != 0:
        raise SystemExit(f"stimuli {' '.join(args)} failed:\n{result.output}")
    return result.stdout  # not stderr: Python prints a warning only the first time it is given


def _build_input(root: Path) -> Path:
    """Write a PAIRS CSV (and ``objects.csv``) of synthetic pairs and light fields; return it."""
    from PIL import Image

    folders = sorted(p for p in (root / "pairs").iterdir() if p.is_dir())
    main = [p for p in folders if not p.name.startswith("train")][: BUILD_OBJECTS - 1]
    chosen = [*main, next(p for p in folders if p.name.startswith("train"))]
    jpeg = root / "jpeg_pair"
    jpeg.mkdir()
    for role in ("wide", "narrow"):
        Image.open(chosen[1] / f"{role}.png").convert("RGB").save(jpeg / f"{role}.jpg", quality=90)
    rows = ["object,wide,narrow,lightfield,crop"]
    for i, p in enumerate(chosen):
        crop = '"40,30,400,266"' if i == 0 else ""
        rows.append(f"{p.name},pairs/{p.name}/wide.png,pairs/{p.name}/narrow.png,,{crop}")
    rows.append("jpeg_pair,jpeg_pair/wide.jpg,jpeg_pair/narrow.jpg,,")
    rows.append("lf_npz,,,camera.npz,")
    rows.append("lf_folder,,,camera,")
    (root / "build_pairs.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    objects = ["object,name,role,sobel_threshold,plane_disparity_px"]
    objects += [f"{p.name},{p.name.split('_', 1)[1]},main,," for p in chosen[:-1]]
    objects[2] = objects[2].replace(",main,,", ",main,0.2,")
    objects.append(f"{chosen[-1].name},{chosen[-1].name.split('_', 1)[1]},training,,")
    objects.append("lf_folder,bust,main,,1.5")
    (root / "objects.csv").write_text("\n".join(objects) + "\n", encoding="utf-8")
    return root / "build_pairs.csv"


def _hash_stimulus_set_json(path: Path) -> str:
    d = json.loads(path.read_text(encoding="utf-8"))
    for key in _BUILD_TIME_AND_VERSION:
        d.pop(key)
    # in the order written: a reordered file is a different file
    return hashlib.sha256(json.dumps(d, indent=2).encode()).hexdigest()


def _scan_summary(scan) -> dict:
    return {
        "method": scan.method,
        "disparities_px_sha256": hashlib.sha256(
            np.ascontiguousarray(scan.disparities_px, dtype=np.float64).tobytes()
        ).hexdigest(),
        "scores_sha256": hashlib.sha256(
            np.ascontiguousarray(scan.scores, dtype=np.float64).tobytes()
        ).hexdigest(),
        "peaks": [
            {
                "disparity_px": repr(p.disparity_px),
                "depth_m": repr(p.depth_m),
                "score": repr(p.score),
                "prominence": repr(p.prominence),
                "index": p.index,
            }
            for p in scan.peaks
        ],
    }


def run(root: Path) -> dict:
    """Write every output under ``root`` and return the hashes and detected planes."""
    root = Path(root)
    write_pairs(root / "pairs", n_objects=23, n_training=3, seed=SEED, shape_px=PAIRS_SHAPE_PX)
    _cli(["synth", "--out", str(root / "lens.png"), "--size", LF_SIZE, "--seed", str(SEED)])
    _cli(["synth", "--out", str(root / "camera"), "--kind", "camera", "--size", LF_SIZE,
          "--seed", str(SEED)])  # fmt: skip
    _cli(["synth", "--out", str(root / "camera.npz"), "--kind", "camera", "--size", LF_SIZE,
          "--seed", str(SEED)])  # fmt: skip
    _cli(["scan", str(root / "camera"), "--out", str(root / "scan"), "--planes", "60",
          "--grid", "19x13"])  # fmt: skip
    _cli(["refocus", str(root / "camera"), "--disparity", "1.5", "--grid", "19x13",
          "--out", str(root / "refocus.png")])  # fmt: skip

    planes = {}
    for name in ("lens.png", "camera", "camera.npz"):
        lf = load_lightfield(root / name, gray=True).gray()
        agreement = find_object_planes(lf, n_planes=80)
        haar = find_object_planes(lf, n_planes=80, method="haar")
        lo, hi = estimate_disparity_range(lf)
        chosen = confocal_plane(lf, focus_mask=True)
        planes[name] = {
            "shape": list(lf.views.shape),
            "agreement": _scan_summary(agreement),
            "haar": _scan_summary(haar),
            "range_px": [repr(float(lo)), repr(float(hi))],
            "confocal_plane": chosen.describe(),
            "confocal_sha256": hashlib.sha256(chosen.confocal_image.tobytes()).hexdigest(),
            "focus_mask_sha256": hashlib.sha256(chosen.focus_mask.tobytes()).hexdigest(),
        }

    pairs_csv = _build_input(root)
    for name, options in BUILD_SETS.items():
        _stimuli_cli(["build", str(pairs_csv), "--out", str(root / name), *options])
    tune_table = _stimuli_cli(
        ["tune", str(pairs_csv), "--dry-run", "--sheet", str(root / "tune_sheet.png")]
    )

    files = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.name != "scores.png":
            rel = p.relative_to(root).as_posix()
            if p.name == "stimulus_set.json":
                files[rel] = _hash_stimulus_set_json(p)
            else:
                files[rel] = hashlib.sha256(p.read_bytes()).hexdigest()
    return {"files": files, "planes": planes, "tune_output": tune_table}


def _differences(before: dict, after: dict, where: str = "") -> list[str]:
    if isinstance(before, dict) and isinstance(after, dict):
        out = []
        for k in sorted(set(before) | set(after)):
            if k not in before:
                out.append(f"{where}/{k}: new")
            elif k not in after:
                out.append(f"{where}/{k}: missing")
            else:
                out += _differences(before[k], after[k], f"{where}/{k}")
        return out
    return [] if before == after else [f"{where}: {before!r} -> {after!r}"]


def main(argv: list[str] | None = None) -> int:
    """Write the outputs, print their hashes as JSON, and compare with ``--compare FILE``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", type=Path, help="JSON written by an earlier run")
    args = ap.parse_args(argv)
    # Paths are relative to the temporary folder: scan.json records the light field's source.
    with tempfile.TemporaryDirectory(prefix="stimuli_unchanged_") as tmp, contextlib.chdir(tmp):
        result = run(Path("."))
    print(json.dumps(result, indent=1, sort_keys=True))
    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text(encoding="utf-8"))
    diffs = _differences(before, result)
    for d in diffs:
        print(f"DIFFERENT {d}", file=sys.stderr)
    n = len(result["files"])
    print(
        f"{'MATCH' if not diffs else 'MISMATCH'}: {n} files and the planes of "
        f"{len(result['planes'])} light fields compared, {len(diffs)} differences",
        file=sys.stderr,
    )
    return 0 if not diffs else 1


if __name__ == "__main__":
    sys.exit(main())
