"""Measure light-field stimuli and plane scans against ground-truth disparity.

For every light field under ``$CONFOCAL_DATA/lightfield`` (SOURCES.md) that has a disparity map
(Middlebury Baby1 and Aloe: ``disp1.png``, structured light; HCI antinous: ``gt_disp_lowres.pfm``,
exact; Lytro 2067: EPINET's *estimate*, labelled as such), prints one block per capture:

* the plane ``confocal stimuli build`` chooses (default rule, default de-clutter) and the
  object's ground-truth plane: the median ground-truth disparity of the object, defined from the
  ground truth alone (the Otsu foreground of the known disparities; on Baby1 the doll, the
  foreground above the first row where it spans half the image, not the drum it sits on);
* the L8 on-plane share: of the de-cluttered level-8 image's white pixels on known pixels, the
  share within 2 working pixels of a pixel whose ground truth is within 1.5 px per view step of
  the chosen plane, and the same against the object's plane;
* the build's own record: its visibility (on-plane share from the depth evidence, L1-L3
  coverage) and warnings;
* the default scan's planes against the *textured* ground-truth planes: the modes of the
  ground-truth histogram holding at least 5 % of the known pixels whose hill has textured
  pixels (centre-view Sobel magnitude, 5 px box, above :data:`TEXTURE_MIN`) making at least
  1 % of the known pixels. Recall: the share of those modes with a scanned plane within 0.5 px
  per view step; precision: the share of scanned planes within 1 px of a mode holding at
  least 1 %; *no support*: scanned planes with under 1 % of the
  known pixels within 0.5 px of them.

Run: ``python benchmarks/check_lightfield_planes.py [--captures NAME ...] [--json FILE]``.
Needs ``$CONFOCAL_DATA`` (default ``../shared/data``). Exit status 0 (it measures; it does not
judge), 2 when the data folder is missing.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: Captures with a disparity map, and whether it is measured (True) or a network's estimate.
CAPTURES: dict[str, bool] = {
    "hci_antinous_3x3_gt": True,
    "lytro_illum_2067_epinet": False,
    "middlebury_Aloe": True,
    "middlebury_Baby1": True,
}
#: "On the plane": ground truth within this many px per view step of it.
ON_PLANE_PX = 1.5
#: A pixel has texture when its centre view's 5 px box-mean Sobel magnitude exceeds this (ours:
#: about 8 grey levels of 8-bit data per pixel across an edge, well above sensor noise).
TEXTURE_MIN = 0.03
#: Ground-truth planes that count for recall (share of textured known pixels), and for precision.
BIG_MODE, ANY_MODE = 0.05, 0.01


def truth(root: Path) -> np.ndarray:
    """Return the centre view's disparity, px per view step, NaN unknown (full capture size)."""
    from stimuli.io import load_gray
    from stimuli.pfm import read_pfm

    if root.name.startswith("middlebury"):
        disp = load_gray(root / "disp1.png").astype(np.float64) * 255.0 / 8.0
        out = np.full(disp.shape, -np.inf)
        ys, xs = np.nonzero(disp > 0)
        d = disp[ys, xs]
        xc = np.round(xs - 2.0 * d).astype(int)  # view 1 -> centre view 3 (SOURCES.md)
        ok = (xc >= 0) & (xc < disp.shape[1])
        np.maximum.at(out, (ys[ok], xc[ok]), d[ok])
        out[~np.isfinite(out)] = np.nan
        return out
    if root.name.startswith("lytro"):
        est = read_pfm(next(root.glob("*.pfm"))).astype(np.float64)
        return np.pad(est, 11, constant_values=np.nan)  # 11 px border cropped (SOURCES.md)
    return read_pfm(root / "gt_disp_lowres.pfm").astype(np.float64)


def object_mask(name: str, gt: np.ndarray) -> np.ndarray:
    """The object, from the ground truth alone (module notes)."""
    from skimage.filters import threshold_otsu

    known = np.isfinite(gt)
    fg = known & (np.nan_to_num(gt, nan=-np.inf) > threshold_otsu(gt[known]))
    if name == "middlebury_Baby1":
        top = int(np.argmax(fg.mean(axis=1) > 0.5))  # the drum's top
        fg[top:] = False
    return fg


def truth_modes(values: np.ndarray, bin_px: float = 0.25, sigma_px: float = 0.5):
    """Modes of a disparity histogram: ``(disparity, share, (low, high))`` of each mode's hill."""
    from scipy.ndimage import gaussian_filter1d
    from scipy.signal import find_peaks

    edges = np.arange(values.min() - 1.0, values.max() + 1.0 + bin_px, bin_px)
    h, _ = np.histogram(values, edges)
    centres = (edges[:-1] + edges[1:]) / 2
    hs = gaussian_filter1d(h.astype(float), sigma_px / bin_px)
    peaks, _ = find_peaks(np.r_[0.0, hs, 0.0])
    peaks -= 1
    cuts = [0, *(a + int(np.argmin(hs[a:b])) for a, b in itertools.pairwise(peaks)), len(hs)]
    return [
        (
            float(centres[p]),
            float(h[cuts[k] : cuts[k + 1]].sum() / h.sum()),
            (float(edges[cuts[k]]), float(edges[cuts[k + 1]])),
        )
        for k, p in enumerate(peaks)
    ]


def textured(centre: np.ndarray) -> np.ndarray:
    """Pixels with texture in the centre view (:data:`TEXTURE_MIN`)."""
    from scipy import ndimage

    from stimuli.declutter import sobel_magnitude

    return ndimage.uniform_filter(sobel_magnitude(centre), 5) > TEXTURE_MIN


def scan_against_truth(planes: list[float], gt: np.ndarray, tex: np.ndarray) -> dict:
    """Recall, precision and unsupported planes of a scan against the textured truth.

    The truth's modes are those of all known pixels; a mode is *textured* when the textured
    pixels on its hill are at least :data:`ANY_MODE` of the known pixels (the views can measure
    it), and it counts for recall when its hill holds :data:`BIG_MODE` of them.
    """
    known = np.isfinite(gt)
    vals, tvals = gt[known], gt[known & tex]
    modes = truth_modes(vals)
    big = [
        d
        for d, s, (a, b) in modes
        if s >= BIG_MODE and np.count_nonzero((tvals >= a) & (tvals < b)) >= ANY_MODE * vals.size
    ]
    anym = [d for d, s, _ in modes if s >= ANY_MODE]
    found = [d for d in big if planes and min(abs(p - d) for p in planes) <= 0.5]
    precise = [p for p in planes if anym and min(abs(p - d) for d in anym) <= 1.0]
    unsupported = [p for p in planes if np.mean(np.abs(vals - p) <= 0.5) < ANY_MODE]
    return {
        "truth_planes": [(round(d, 2), round(s, 3)) for d, s, _ in modes if s >= BIG_MODE],
        "textured_truth_planes": [round(d, 2) for d in big],
        "found": len(found),
        "recall": len(found) / len(big) if big else None,
        "precision": len(precise) / len(planes) if planes else None,
        "unsupported": [round(p, 2) for p in unsupported],
    }


def _working(mask: np.ndarray, rec: dict, shape: tuple[int, int]) -> np.ndarray:
    from stimuli.stimset.prepare import to_working_size

    box = rec.get("aspect_crop")
    x, y, w, h = box if box is not None else (0, 0, mask.shape[1], mask.shape[0])
    t, b, left, right = rec.get("aspect_pad") or (0, 0, 0, 0)
    m = np.pad(mask[y : y + h, x : x + w], ((t, b), (left, right)))
    return to_working_size(m.astype(np.float32), shape) >= 0.5


def l8_on_plane(out: Path, rec: dict, gt: np.ndarray, d: float) -> float | None:
    """Share of the L8 white pixels (on known pixels) within 2 px of the truth's plane ``d``."""
    from PIL import Image
    from scipy.ndimage import binary_dilation

    l8 = np.asarray(Image.open(next((out / "obj").glob("decluttered_L8_*.png")))) > 0
    known = np.isfinite(gt)
    with np.errstate(invalid="ignore"):
        plane = known & (np.abs(gt - d) <= ON_PLANE_PX)
    on = binary_dilation(_working(plane, rec, l8.shape), iterations=2)
    white = l8 & _working(known, rec, l8.shape)
    return float((white & on).sum() / white.sum()) if white.any() else None


def measure(root: Path, *, build_args: tuple[str, ...] = ()) -> dict:
    """Build the capture with the defaults and measure it (module notes)."""
    from stimuli.lightfield import load_lightfield
    from stimuli.planes import find_object_planes
    from stimuli.stimset import build_stimulus_set
    from stimuli.vignette import apply_view_crop

    name = root.name
    gt_full = truth(root)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "pairs.csv").write_text(f"object,lightfield\nobj,{root}\n")
        from stimuli.stimset import BuildParams

        params = BuildParams(**dict(a.split("=", 1) for a in build_args))
        build_stimulus_set(tmp / "pairs.csv", tmp / "set", params=params, workers=1)
        rec = json.loads((tmp / "set" / "stimulus_set.json").read_text())["objects"][0]
        crop = rec["plane"].get("view_crop")
        gt = gt_full
        if crop is not None:
            x, y, w, h = crop
            gt = gt_full[y : y + h, x : x + w]
        obj = object_mask(name, gt)
        d_obj = float(np.median(gt[obj]))
        d = float(rec["plane"]["disparity_px"])
        share = l8_on_plane(tmp / "set", rec, gt, d)
        share_obj = l8_on_plane(tmp / "set", rec, gt, d_obj)
    t_build = time.perf_counter() - t0
    lf = apply_view_crop(load_lightfield(root).gray(), "auto")
    scan = find_object_planes(lf)
    planes = [p.disparity_px for p in scan.peaks]
    tex = textured(lf.centre_view())
    vis = rec.get("visibility") or {}
    levels = {r["level"]: r for r in vis.get("levels", [])}
    return {
        "capture": name,
        "truth": "measured" if CAPTURES.get(name, True) else "estimate (EPINET)",
        "chosen_plane": round(d, 3),
        "rule": rec["plane"]["rule"],
        "marginal": rec["plane"].get("marginal", ""),
        "object_plane": round(d_obj, 3),
        "l8_on_chosen_plane": share,
        "l8_on_object_plane": share_obj,
        "build_on_plane_l8": levels.get(8, {}).get("on_plane"),
        "build_coverage_l1_l3": [levels.get(k, {}).get("object_coverage") for k in (1, 2, 3)],
        "warnings": rec.get("warnings", []),
        "edge_depth": rec["plane"].get("edge_depth"),
        "scan_planes": [round(p, 2) for p in planes],
        "scan_range": [
            round(float(scan.disparities_px[0]), 2),
            round(float(scan.disparities_px[-1]), 2),
        ],
        **scan_against_truth(planes, gt, tex),
        "seconds": round(t_build, 1),
    }


def _fmt(v):
    return "-" if v is None else f"{v:.2f}" if isinstance(v, float) else str(v)


def main(argv: list[str] | None = None) -> int:
    """Run the measurement (module notes)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--captures", nargs="*", default=list(CAPTURES), help="folder names")
    ap.add_argument("--json", type=Path, help="also write the records to this file")
    ap.add_argument(
        "--param", action="append", default=[], help="BuildParams field=value (strings only)"
    )
    args = ap.parse_args(argv)
    data = Path(os.environ.get("CONFOCAL_DATA", "../shared/data")) / "lightfield"
    if not data.is_dir():
        print(
            f"CONFOCAL_DATA: no folder {data}; expected the shared data (SOURCES.md)",
            file=sys.stderr,
        )
        return 2
    out = []
    for name in args.captures:
        root = data / name
        if not root.is_dir():
            print(f"{name}: not in {data}, skipped")
            continue
        r = measure(root, build_args=tuple(args.param))
        out.append(r)
        print(
            f"{name} [{r['truth']}]: chosen {r['chosen_plane']} px ({r['rule']}"
            f"{', marginal' if r['marginal'] else ''}), object {r['object_plane']} px; "
            f"L8 on chosen plane {_fmt(r['l8_on_chosen_plane'])}, on object plane "
            f"{_fmt(r['l8_on_object_plane'])}; build's L8 on-plane {_fmt(r['build_on_plane_l8'])}"
            f", L1-L3 coverage {' '.join(_fmt(c) for c in r['build_coverage_l1_l3'])}"
        )
        print(
            f"  scan {r['scan_planes']} over {r['scan_range']}; truth planes "
            f"{r['truth_planes']}, textured {r['textured_truth_planes']}; recall "
            f"{_fmt(r['recall'])}, precision {_fmt(r['precision'])}"
            f", no support {r['unsupported']}; build {r['seconds']} s"
        )
        for w in r["warnings"]:
            print(f"  warning: {w}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
