"""What the ``calibrated`` observer knows, varied: does it make the slope spread less?

``benchmarks/observer_slope_spread.py`` found that the observer's odds ratio per log10 pixels
spreads about twice as widely over simulated studies as chance gives, because each object's
evidence rises with its own slope and some objects level off below ceiling, and that no change
to the decision stage helps. This benchmark varies the other side, what the observer knows and
how a kind's evidence is formed from it, and measures the same things:

* **renderings per kind**: the observer knows ``n`` other renderings of the 23 kinds (seeds
  s + 1 .. s + n for test seed s; the demo used 3, now 8), as a subject who knows the objects
  well has seen more views of them;
* **pooling over a kind's exemplars**: the kind's similarity is its best exemplar's (``max``,
  the observer's earlier rule, an exemplar model with a max rule), the mean over its exemplars
  (``mean``, prototype-like), or the summed similarity of Nosofsky's (1986) generalised context
  model, ``tau * log(mean(exp(r / tau)))`` over the kind's exemplars (``soft tau``: ``max`` as
  tau -> 0, ``mean`` as tau -> infinity);
* **exemplar condition**: the de-cluttered exemplars only (the observer's), or also the
  cluttered ones (the objects seen in their own clutter);
* **HOG cell**: the front end's 0.4 deg cells, 0.2 deg cells, or both averaged (two spatial
  scales).

For each configuration, on the design seeds only (10-16 by default, never demo seeds 0-4): the
noise-free normalised responses are computed as :func:`experiment.observers.calibration.
stimulus_responses` computes them (a check reproduces its ``max``, 3-rendering responses to
1e-12), the criterion is refitted to the paper's *cluttered* curve only
(:func:`benchmarks.design_observer.fit_criterion`, noise 0.25, priming 0.6, lapse 0.02 kept),
and ``--studies`` simulated 1,920-trial studies per seed give the odds ratios' medians and
2.5-97.5 % ranges, the SD of the log slope (within and between seeds) against chance at the
same slope (:func:`benchmarks.observer_slope_spread.chance_curve`), the share of studies with
both odds ratios inside the paper's intervals, the objects levelling off (expected recognition
below 0.85 at the finest level), the objects' own slopes (median and coefficient of variation)
and the recognition at the finest level. Simulated data.

Run: ``python benchmarks/observer_knowledge.py [--work DIR] [--seeds 10 ... 16] [--studies 30]
[--configs NAME ...]`` (about 20-60 s a configuration at 30 studies per seed, after the sets
are built and their features computed once, a few minutes).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks import observer_slope_spread as oss  # noqa: E402
from benchmarks.design_observer import (  # noqa: E402
    DESIGN_SEEDS,
    fit_criterion,
    simulate_study,
)
from experiment.observers.calibration import (  # noqa: E402
    CalibratedParams,
    normalized_responses,
)

__all__ = [
    "CONFIGS",
    "pool",
    "knowledge_folder",
    "design_set_folder",
    "set_features",
    "config_responses",
    "responses_by_condition",
    "measure",
    "main",
]

#: Configurations: name -> (renderings, pooling, exemplar conditions, HOG cells in deg).
CONFIGS: dict[str, tuple[int, str, tuple[str, ...], tuple[float, ...]]] = {
    "3 renderings, max (earlier observer)": (3, "max", ("decluttered",), (0.4,)),
    "5 renderings, max": (5, "max", ("decluttered",), (0.4,)),
    "8 renderings, max": (8, "max", ("decluttered",), (0.4,)),
    "3 renderings, mean": (3, "mean", ("decluttered",), (0.4,)),
    "8 renderings, mean": (8, "mean", ("decluttered",), (0.4,)),
    "3 renderings, soft 0.02": (3, "soft 0.02", ("decluttered",), (0.4,)),
    "5 renderings, soft 0.02": (5, "soft 0.02", ("decluttered",), (0.4,)),
    "8 renderings, soft 0.01": (8, "soft 0.01", ("decluttered",), (0.4,)),
    "8 renderings, soft 0.02 (the observer)": (8, "soft 0.02", ("decluttered",), (0.4,)),
    "8 renderings, soft 0.03": (8, "soft 0.03", ("decluttered",), (0.4,)),
    "8 renderings, soft 0.05": (8, "soft 0.05", ("decluttered",), (0.4,)),
    "8 renderings, max, cluttered exemplars too": (
        8,
        "max",
        ("decluttered", "cluttered"),
        (0.4,),
    ),  # fmt: skip
    "3 renderings, max, HOG 0.4 + 0.2 deg": (3, "max", ("decluttered",), (0.4, 0.2)),
    "3 renderings, max, HOG 0.2 deg": (3, "max", ("decluttered",), (0.2,)),
}


def pool(r: np.ndarray, rule: str) -> np.ndarray:
    """Pool correlations ``r`` (images x exemplars of one kind) into one similarity per image.

    Parameters
    ----------
    r : ndarray of shape (n_images, n_exemplars)
    rule : str
        ``max``, ``mean`` or ``soft TAU`` (``TAU * log(mean(exp(r / TAU)))``).

    Examples
    --------
    >>> r = np.array([[0.2, 0.4]])
    >>> pool(r, "max").tolist(), pool(r, "mean").round(6).tolist()
    ([0.4], [0.3])
    >>> pool(r, "soft 0.001").round(3).tolist(), pool(r, "soft 100").round(3).tolist()
    ([0.399], [0.3])
    """
    if rule == "max":
        return r.max(1)
    if rule == "mean":
        return r.mean(1)
    if rule.startswith("soft "):
        tau = float(rule.split()[1])
        m = r.max(1, keepdims=True)
        return m[:, 0] + tau * np.log(np.exp((r - m) / tau).mean(1))
    raise ValueError(f"pooling must be max, mean or 'soft TAU', got {rule!r}")


def knowledge_folder(work: Path, k: int) -> Path:
    """Build (once) knowledge rendering ``k`` under ``work`` and return its folder."""
    from experiment.demos.study import make_knowledge_set

    for built in sorted(work.glob(f"cal*/knowledge{k}")):  # built with a test set
        if (built / "manifest.csv").exists():
            return built
    out = work / "knowledge" / f"knowledge{k}"
    if not (out / "manifest.csv").exists():
        make_knowledge_set(work / "knowledge" / f"kpairs{k}", out, k)
    return out


def design_set_folder(work: Path, seed: int) -> Path:
    """Build (once) test set ``seed`` under ``work`` as the calibration's are built (20 main
    and 3 training objects, every level) and return its folder."""
    from stimuli.stimset import build_stimulus_set
    from stimuli.synth import write_pairs

    root = work / f"cal{seed}"
    test = root / "test"
    if not (test / "manifest.csv").exists():
        write_pairs(root / "pairs", n_objects=20, n_training=3, seed=seed)
        build_stimulus_set(root / "pairs", test, workers=1)
    return test


def set_features(work: Path, seed: int, n: int, cells: tuple[float, ...]) -> dict[str, Any]:
    """Front-end features (cached under ``work``) of test set ``seed``'s main stimuli and of
    knowledge renderings ``seed + 1 .. seed + n`` (full resolution, both exemplar conditions
    and their mirror images), per HOG cell size."""
    from experiment.session.scoring import normalize
    from experiment.session.stimset import StimulusSet

    test = design_set_folder(work, seed)
    out: dict[str, Any] = {"know": {}}
    for cell in cells:
        p = CalibratedParams(knowledge="unused", cell_deg=cell)
        cache = work / f"features_test{seed}_cell{cell}.npz"
        if not cache.exists():
            ts = StimulusSet.load(test)
            f, px, obj, cond, name = [], [], [], [], []
            for rec in ts.records:
                if rec.condition not in ("cluttered", "decluttered"):
                    continue
                if ts.objects[rec.object].role != "main":
                    continue
                ts.verify([rec])
                f.append(p.features(ts.load_image(rec)))
                px.append(rec.pixels)
                obj.append(str(rec.object))
                cond.append(rec.condition)
                name.append(normalize(ts.objects[rec.object].name))
            np.savez(cache, F=np.vstack(f), pixels=np.array(px, float), objects=np.array(obj),
                     cond=np.array(cond), name=np.array(name))  # fmt: skip
        out[cell] = dict(np.load(cache))
        for k in range(seed + 1, seed + 1 + n):
            kc = work / f"features_knowledge{k}_cell{cell}.npz"
            if not kc.exists():
                ks = StimulusSet.load(knowledge_folder(work, k))
                level = max(ks.levels())
                d = {}
                for c in ("decluttered", "cluttered"):
                    f, name = [], []
                    for oid, info in ks.objects.items():
                        rec = ks.get(oid, c, level)
                        ks.verify([rec])
                        img = ks.load_image(rec)
                        for view in (img, img[:, ::-1]):
                            f.append(p.features(view))
                            name.append(normalize(info.name))
                    d[f"{c}_F"], d[f"{c}_name"] = np.vstack(f), np.array(name)
                np.savez(kc, **d)
            out["know"][(k, cell)] = dict(np.load(kc))
    return out


def config_responses(
    feats: dict[str, Any], seed: int, config: tuple[int, str, tuple[str, ...], tuple[float, ...]]
) -> dict[str, dict[str, np.ndarray]]:
    """Noise-free normalised responses of one test set under one knowledge configuration, in
    :func:`benchmarks.design_observer.responses`' form."""
    n, rule, conds, cells = config
    r_sum, names = None, None
    for cell in cells:
        parts = [feats["know"][(k, cell)] for k in range(seed + 1, seed + 1 + n)]
        kf = np.vstack([kk[f"{c}_F"] for kk in parts for c in conds])
        kn = np.concatenate([kk[f"{c}_name"] for kk in parts for c in conds])
        r = feats[cell]["F"] @ kf.T / len(cells)
        r_sum = r if r_sum is None else r_sum + r
        names = kn
    return responses_by_condition(feats[cells[0]], r_sum, names, rule)


def responses_by_condition(
    test: dict[str, np.ndarray], similarity: np.ndarray, names: np.ndarray, rule: str
) -> dict[str, dict[str, np.ndarray]]:
    """Per condition, the normalised responses of a test set's images to every known kind.

    ``similarity`` holds each test image's (row) similarity to each exemplar (column), whose
    kinds are ``names``; a kind's exemplars are pooled by ``rule`` (:func:`pool`). The form is
    :func:`benchmarks.design_observer.responses`': ``known`` (every kind), ``unknown`` (the
    true kind left out), ``correct`` (the true kind's column), ``pixels`` and ``objects``.
    """
    cats = list(dict.fromkeys(names))
    s = np.column_stack([pool(similarity[:, names == c], rule) for c in cats])
    out = {}
    for cond in ("cluttered", "decluttered"):
        m = test["cond"] == cond
        correct = np.array([cats.index(x) for x in test["name"][m]])
        sm = s[m]
        out[cond] = {
            "pixels": test["pixels"][m],
            "known": normalized_responses(sm),
            "correct": correct,
            "unknown": np.vstack(
                [normalized_responses(np.delete(sm[i], correct[i])) for i in range(len(sm))]
            ),  # fmt: skip
            "objects": test["objects"][m],
        }
    return out


def _check_against_observer(work: Path, seed: int, resp: dict) -> float:
    """Largest difference between ``resp`` (3 renderings, max) and the observer's own
    :func:`experiment.observers.calibration.stimulus_responses`."""
    from experiment.observers.calibration import stimulus_responses

    test = design_set_folder(work, seed)
    know = [knowledge_folder(work, k) for k in range(seed + 1, seed + 4)]
    p = CalibratedParams(knowledge=tuple(str(k) for k in know), exemplar_tau=0.0)
    diff = 0.0
    for cond in ("cluttered", "decluttered"):
        ref = stimulus_responses(test, know, p, cond)
        for key in ("known", "unknown"):
            diff = max(diff, float(np.abs(ref[key] - resp[cond][key]).max()))
        if not np.array_equal(ref["correct"], resp[cond]["correct"]):
            diff = math.inf
    return diff


def measure(resps: list, seeds: list[int], curve: list, studies: int) -> dict[str, Any]:
    """Refit the criterion to the cluttered curve; the slope-spread measures of ``studies``
    simulated studies per seed (see the module docstring)."""
    core = {"noise_sd": 0.25, "priming": 0.6, "lapse": 0.02}
    crit, misfit = fit_criterion(resps, **core, grid=np.round(np.arange(2.5, 4.51, 0.05), 2))
    kw = {**core, "criterion": crit}
    r = oss._run(resps, seeds, kw, studies)
    px = r["or_per_log10_px"]
    r["criterion"], r["misfit"] = crit, misfit[crit]
    r["chance_sd"] = oss._chance_at(curve, px["median"])
    r["ratio"] = px["sd_log"] / r["chance_sd"]
    r["levelling_off"] = {s: oss._levelling_off(x, kw) for s, x in zip(seeds, resps, strict=True)}
    slopes = np.concatenate([oss.object_slopes(x, kw) for x in resps])
    r["object_slope_median"] = float(np.nanmedian(slopes))
    r["object_slope_cv"] = float(np.nanstd(slopes) / np.nanmedian(slopes))
    top = []
    for x in resps:
        rows = simulate_study(x, n_subjects=30, rng=3, **kw)
        mx = max(q[3] for q in rows)
        top.append([np.mean([q[4] for q in rows if q[3] == mx and q[2] == c])
                    for c in ("cluttered", "decluttered")])  # fmt: skip
    r["finest_level_rate"] = [float(v) for v in np.mean(top, axis=0)]
    return r


def main(argv: list[str] | None = None) -> int:
    """Print one row per knowledge configuration (then one JSON line)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(DESIGN_SEEDS))
    ap.add_argument("--studies", type=int, default=30, help="Studies per seed and configuration.")
    ap.add_argument("--configs", nargs="*", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--work", type=Path, default=None)
    args = ap.parse_args(argv)
    if set(args.seeds) & set(range(5)):
        ap.error("--seeds: demo seeds 0-4 are the check's, not the design's")
    work = args.work or Path(tempfile.mkdtemp(prefix="confocal-knowledge-"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    n_max = max(CONFIGS[c][0] for c in args.configs)
    cells = tuple(sorted({x for c in args.configs for x in CONFIGS[c][3]}, reverse=True))
    feats = {s: set_features(work, s, n_max, cells) for s in args.seeds}
    first = config_responses(
        feats[args.seeds[0]], args.seeds[0], (3, "max", ("decluttered",), (0.4,))
    )
    check = _check_against_observer(work, args.seeds[0], first)
    print(f"3 renderings, max: largest difference from the observer's own responses "
          f"(stimulus_responses) on seed {args.seeds[0]}: {check:.1e}")  # fmt: skip
    objs = sorted({str(o) for o in first["cluttered"]["objects"]})
    pixels = sorted({float(x) for x in first["cluttered"]["pixels"]})
    curve = oss.chance_curve(objs, pixels, max(20, args.studies * len(args.seeds) // 4))
    seeds_txt = ", ".join(map(str, args.seeds))
    print(f"{args.studies} studies per seed on seeds {seeds_txt} (simulated data); criterion "
          "refitted to the paper's cluttered curve for each configuration")  # fmt: skip
    print("knowledge | criterion (misfit) | OR background | OR per log10 px | SD log slope "
          "(within, between) | ratio to chance | both inside | objects levelling off | object "
          "slopes: median, CV | finest level: cluttered, de-cluttered")  # fmt: skip
    results = {}
    for name in args.configs:
        resps = [config_responses(feats[s], s, CONFIGS[name]) for s in args.seeds]
        r = results[name] = measure(resps, args.seeds, curve, args.studies)
        px, bg = r["or_per_log10_px"], r["or_background"]
        print(
            f"{name} | {r['criterion']:.2f} ({r['misfit']:.4f}) | {oss._fmt(bg, '.2f')} | "
            f"{oss._fmt(px)} | {px['sd_log']:.3f} ({px['sd_within']:.3f}, "
            f"{px['sd_between']:.3f}) | {r['ratio']:.2f} | {r['both']:.2f} | "
            f"{sum(r['levelling_off'].values())} | {r['object_slope_median']:.2f}, "
            f"{r['object_slope_cv']:.2f} | {r['finest_level_rate'][0]:.2f}, "
            f"{r['finest_level_rate'][1]:.2f}",
            flush=True,
        )
    print(f"{time.perf_counter() - t0:.0f} s")
    print(json.dumps({"chance": curve, "configs": results}, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
