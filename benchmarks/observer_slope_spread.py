"""Why the ``calibrated`` observer's slope spreads from study to study: a measured diagnosis.

On the fast path of ``benchmarks/design_observer.py`` (cached responses to the design seeds'
stimulus sets, never demo seeds 0-4; whole 1,920-trial studies through the decision stage; the
paper's regression by the report's rule), for the observer as calibrated and for decision-stage
variants, each with its criterion refitted to the paper's *cluttered* curve only
(:func:`benchmarks.design_observer.fit_criterion`):

* the sampling distribution of both odds ratios (median, 2.5 and 97.5 % points, share inside
  the paper's intervals), and the SD of the log odds ratio per log10 pixels split into the part
  *within* a stimulus set (root mean within-seed variance) and the part *between* sets;
* **chance**: the same SD for observers whose true odds ratios are known (the paper's logistic
  observer of ``validate_observer_paper.py``, object spread N(0, 1.5), at several true slopes),
  interpolated at the variant's median slope (a steeper slope is estimated less precisely, so a
  variant is compared with chance *at its own slope*), and the ratio of the two;
* **transitional cells**: (object, condition, level) cells of a study with some but not all of
  the six subjects right, the cells that carry the information on the slope, and the objects
  never recognised in a study;
* **object slopes**: each object's own slope (:func:`object_slopes`), their median and
  coefficient of variation (SD / median) under each decision stage;
* per design seed: the calibrated observer's median slope and the number of objects whose
  expected recognition at the finest level (100 simulated subjects) stays below 0.85 in either
  condition (objects that level off);
* each object's own slope under the calibrated observer (:func:`object_slopes`), and a
  logistic observer with the paper's odds ratios whose objects are fixed per set and share one
  slope or differ in slope by the calibrated observer's SD (:func:`set_chance`): how much
  between-set spread objects that differ in slope alone give.

The variants (``VARIANTS``): internal noise lower or higher, priming off or stronger, criterion
noise (the criterion varied from trial to trial), a criterion per subject, a criterion per
subject and kind; see :func:`benchmarks.design_observer.simulate_study`.

Run: ``python benchmarks/observer_slope_spread.py [--work DIR] [--seeds 10 ... 16]
[--studies 20] [--variants NAME ...]`` (about 20 s a variant at 20 studies per seed).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks.design_observer import (  # noqa: E402
    DESIGN_SEEDS,
    fit_criterion,
    odds_ratios,
    responses,
    simulate_study,
)
from benchmarks.validate_observer_paper import PAPER, paper_logistic_study  # noqa: E402
from experiment.observers.calibration import CalibratedParams  # noqa: E402

__all__ = [
    "VARIANTS",
    "decompose",
    "cell_counts",
    "chance_curve",
    "object_slopes",
    "set_chance",
    "main",
]

_F = CalibratedParams.__dataclass_fields__
#: The observer as calibrated (its criterion kept, not refitted).
OBSERVER: dict[str, float] = {k: float(_F[k].default)
                              for k in ("noise_sd", "priming", "lapse")}  # fmt: skip
#: Decision-stage variants: name -> changes to :data:`OBSERVER` (criterion refitted).
VARIANTS: dict[str, dict[str, float]] = {
    "noise 0.1": {"noise_sd": 0.1},
    "noise 0.4": {"noise_sd": 0.4},
    "no priming": {"priming": 0.0},
    "priming 1.0": {"priming": 1.0},
    "criterion noise 0.1": {"criterion_jitter": 0.1},
    "criterion noise 0.25": {"criterion_jitter": 0.25},
    "criterion noise 0.5": {"criterion_jitter": 0.5},
    "criterion per subject 0.25": {"subject_sd": 0.25},
    "criterion per subject and kind 0.25": {"kind_sd": 0.25},
    "noise 0.3, criterion noise 0.2, priming 1.0": {
        "noise_sd": 0.3,
        "criterion_jitter": 0.2,
        "priming": 1.0,
    },
}
#: True slopes of the chance curve (odds ratio per log10 pixels).
CHANCE_SLOPES = (10.0, 20.0, 35.0, 50.0, 74.5, 120.0, 170.0, 300.0)


def decompose(draws: list[tuple[int, float, float]]) -> dict[str, Any]:
    """Summarise ``(seed, log OR background, log OR per log10 px)`` draws.

    Returns
    -------
    dict
        For ``or_background`` and ``or_per_log10_px``: median and 2.5 / 97.5 % points (odds
        ratios), ``inside`` (share inside the paper's interval), ``sd_log`` (all draws),
        ``sd_within`` (root mean within-seed variance), ``sd_between`` (the rest:
        ``sqrt(max(sd_log**2 - sd_within**2, 0))``); ``both`` (both inside); ``seed_median_px``.

    Examples
    --------
    >>> d = decompose([(1, 0.0, 1.0), (1, 0.0, 3.0), (2, 0.0, 5.0), (2, 0.0, 7.0)])
    >>> d["or_per_log10_px"]["sd_within"], round(d["or_per_log10_px"]["sd_between"], 6)
    (1.0, 2.0)
    """
    a = np.asarray(draws, dtype=float)
    seeds = np.unique(a[:, 0])
    out: dict[str, Any] = {}
    both = np.ones(len(a), bool)
    for col, key in ((1, "or_background"), (2, "or_per_log10_px")):
        v = a[:, col]
        lo, hi = PAPER[key][1]  # type: ignore[misc]
        ins = (v >= math.log(lo)) & (v <= math.log(hi))
        both &= ins
        sd = float(v.std())
        within = float(np.sqrt(np.mean([v[a[:, 0] == s].var() for s in seeds])))
        q = np.exp(np.quantile(v, [0.025, 0.5, 0.975]))
        out[key] = {"q025": float(q[0]), "median": float(q[1]), "q975": float(q[2]),
                    "inside": float(ins.mean()), "sd_log": sd, "sd_within": within,
                    "sd_between": math.sqrt(max(sd**2 - within**2, 0.0))}  # fmt: skip
    out["both"] = float(both.mean())
    out["seed_median_px"] = {int(s): float(np.exp(np.median(a[a[:, 0] == s, 2]))) for s in seeds}
    return out


def cell_counts(rows: list[tuple[str, str, str, float, int]]) -> tuple[int, int]:
    """Return (transitional cells, objects never recognised) of one study's trials.

    A transitional cell is an (object, condition, level) cell with some but not all trials
    right.

    Examples
    --------
    >>> cell_counts([("S1", "a", "c", 1.0, 1), ("S2", "a", "c", 1.0, 0),
    ...              ("S1", "b", "c", 1.0, 0), ("S2", "b", "c", 1.0, 0)])
    (1, 1)
    """
    cells: dict[tuple[str, str, float], list[int]] = defaultdict(list)
    for _, o, c, px, ok in rows:
        cells[(o, c, px)].append(ok)
    mixed = sum(1 for v in cells.values() if 0 < sum(v) < len(v))
    hits: dict[str, int] = defaultdict(int)
    for (o, _, _), v in cells.items():
        hits[o] += sum(v)
    return mixed, sum(1 for h in hits.values() if h == 0)


def chance_curve(
    objects: list[str], pixels: list[float], n: int
) -> list[tuple[float, float, float]]:
    """``(median estimated OR per log10 px, SD of its log, mean transitional cells)`` of ``n``
    studies of the paper's logistic observer at each true slope of :data:`CHANCE_SLOPES`."""
    curve = []
    for k, slope in enumerate(CHANCE_SLOPES):
        v, cells = [], []
        for i in range(n):
            rows = paper_logistic_study(objects, pixels, rng=500_000 + 1000 * k + i,
                                        or_per_log10_px=slope)  # fmt: skip
            v.append(math.log(odds_ratios(rows)["or_per_log10_px"]))
            cells.append(cell_counts(rows)[0])
        curve.append((float(np.exp(np.median(v))), float(np.std(v)), float(np.mean(cells))))
    return curve


def object_slopes(resp: dict, kw: dict[str, Any], n_subjects: int = 60) -> np.ndarray:
    """Each object's own slope, log odds per log10 px: Firth's fit of intercept, background and
    log10 pixels to that object's trials of ``n_subjects`` simulated subjects (NaN for an
    object never recognised)."""
    from analysis.firth import firth_logit

    cells: dict[tuple[str, int, float], list[int]] = defaultdict(list)
    for _, o, c, px, ok in simulate_study(resp, n_subjects=n_subjects, rng=9, **kw):
        cells[(o, int(c == "decluttered"), math.log10(px))].append(ok)
    out = []
    for obj in sorted({key[0] for key in cells}):
        keys = [key for key in cells if key[0] == obj]
        k = np.array([sum(cells[key]) for key in keys], float)
        n = np.array([len(cells[key]) for key in keys], float)
        if k.sum() == 0:
            out.append(np.nan)
            continue
        x = np.array([[1.0, key[1], key[2]] for key in keys])
        out.append(float(firth_logit(k / n, x, weights=n)[0][2]))
    return np.asarray(out)


def set_chance(
    objects: list[str], pixels: list[float], slope_sd: float, sets: int, n: int
) -> dict[str, Any]:
    """:func:`decompose` of ``n`` studies on each of ``sets`` object sets of a logistic observer
    with the paper's odds ratios on average whose objects may differ in slope: per set, each
    object's slope (log odds per log10 px) drawn once N(log 74.5, ``slope_sd``) (at least 0.5)
    and its effect N(0, 1.5), the cluttered 50 % point of the average object at 8,695 px; six
    subjects, every object at every level in both conditions."""
    b_bg = math.log(PAPER["or_background"][0])
    draws = []
    for s in range(sets):
        gs = np.random.default_rng(700_000 + s)
        b = np.maximum(gs.normal(math.log(PAPER["or_per_log10_px"][0]), slope_sd, len(objects)),
                       0.5)  # fmt: skip
        u = gs.normal(0.0, 1.5, len(objects))
        for i in range(n):
            g = np.random.default_rng(800_000 + 1000 * s + i)
            rows = []
            for j in range(6):
                for px in pixels:
                    for bg, cond in ((0, "cluttered"), (1, "decluttered")):
                        eta = b_bg * bg + b * (math.log10(px) - math.log10(8695.0)) + u
                        ok = g.random(len(objects)) < 1.0 / (1.0 + np.exp(-eta))
                        rows += [(f"S{j + 1:02d}", o, cond, float(px), int(y))
                                 for o, y in zip(objects, ok, strict=True)]  # fmt: skip
            q = odds_ratios(rows)
            draws.append((s, math.log(q["or_background"]), math.log(q["or_per_log10_px"])))
    return decompose(draws)


def _chance_at(curve: list[tuple[float, float, float]], median: float) -> float:
    """The chance SD interpolated (on log median) at ``median``."""
    x = np.log([c[0] for c in curve])
    return float(np.interp(math.log(median), x, [c[1] for c in curve]))


def _run(resps: list, seeds: list[int], kw: dict[str, Any], n: int) -> dict[str, Any]:
    """``n`` studies per seed of one decision stage: decomposition and cell counts."""
    draws, mixed, never = [], [], []
    for s, r in zip(seeds, resps, strict=True):
        for i in range(n):
            rows = simulate_study(r, rng=100_000 + 7 * i + s, **kw)
            q = odds_ratios(rows)
            draws.append((s, math.log(q["or_background"]), math.log(q["or_per_log10_px"])))
            m, z = cell_counts(rows)
            mixed.append(m)
            never.append(z)
    out = decompose(draws)
    out["transitional_cells"] = float(np.mean(mixed))
    out["never_recognised"] = float(np.mean(never))
    return out


def _levelling_off(resp: dict, kw: dict[str, Any], threshold: float = 0.85) -> int:
    """Objects whose recognition at the finest level (100 subjects) is below ``threshold`` in
    either condition."""
    rows = simulate_study(resp, n_subjects=100, rng=5, **kw)
    top = max(r[3] for r in rows)
    acc: dict[tuple[str, str], list[int]] = defaultdict(list)
    for _, o, c, px, ok in rows:
        if px == top:
            acc[(o, c)].append(ok)
    return len({o for (o, _), v in acc.items() if np.mean(v) < threshold})


def _fmt(r: dict[str, Any], f: str = ".1f") -> str:
    return f"{r['median']:{f}} ({r['q025']:{f}}-{r['q975']:{f}})"


def main(argv: list[str] | None = None) -> int:
    """Print the diagnosis (tables, then one JSON line)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(DESIGN_SEEDS))
    ap.add_argument("--studies", type=int, default=20, help="Studies per seed and variant.")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--work", type=Path, default=None)
    args = ap.parse_args(argv)
    work = args.work or Path(tempfile.mkdtemp(prefix="confocal-design-"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    resps = [responses(work, s) for s in args.seeds]
    objs = sorted({str(o) for o in resps[0]["cluttered"]["objects"]})
    pixels = sorted({float(x) for x in resps[0]["cluttered"]["pixels"]})
    n_chance = args.studies * len(args.seeds)
    curve = chance_curve(objs, pixels, n_chance)
    print(f"chance (paper's logistic observer, object spread 1.5, {n_chance} studies a slope): "
          + ", ".join(f"true {t:g} -> median {m:.1f}, SD log {s:.3f}, {c:.0f} transitional cells"
                      for t, (m, s, c) in zip(CHANCE_SLOPES, curve, strict=True)))  # fmt: skip
    base = {**OBSERVER, "criterion": float(_F["criterion"].default)}
    stages = {"calibrated observer": base}
    grid = np.round(np.arange(3.0, 4.01, 0.05), 2)
    results: dict[str, Any] = {}
    for name in args.variants:
        kw = {**OBSERVER, **VARIANTS[name]}
        core = {k: kw.pop(k) for k in ("noise_sd", "priming", "lapse")}
        crit, _ = fit_criterion(resps, **core, grid=grid, **kw)
        stages[name] = {**core, **kw, "criterion": crit}
    print(
        f"{args.studies} studies per seed on seeds {', '.join(map(str, args.seeds))} "
        "(simulated data); criterion refitted to the paper's cluttered curve for each variant"
    )
    print(
        "decision stage | criterion | OR background (SD log) | OR per log10 px | SD log slope "
        "(within, between) | chance SD | ratio | both inside | transitional cells | never "
        "recognised | object slopes: median, CV"
    )
    for name, kw in stages.items():
        r = _run(resps, args.seeds, kw, args.studies)
        px = r["or_per_log10_px"]
        chance = _chance_at(curve, px["median"])
        r["chance_sd"], r["ratio"], r["stage"] = chance, px["sd_log"] / chance, kw
        slopes = np.concatenate([object_slopes(x, kw) for x in resps])
        r["object_slope_median"] = float(np.nanmedian(slopes))
        r["object_slope_cv"] = float(np.nanstd(slopes) / np.nanmedian(slopes))
        results[name] = r
        bg = r["or_background"]
        print(
            f"{name} | {kw['criterion']:.2f} | {_fmt(bg, '.2f')} ({bg['sd_log']:.3f}) | "
            f"{_fmt(px)} | "
            f"{px['sd_log']:.3f} ({px['sd_within']:.3f}, {px['sd_between']:.3f}) | "
            f"{chance:.3f} | {r['ratio']:.2f} | {r['both']:.2f} | "
            f"{r['transitional_cells']:.0f} | {r['never_recognised']:.1f} | "
            f"{r['object_slope_median']:.2f}, {r['object_slope_cv']:.2f}",
            flush=True,
        )
    seedrow = results["calibrated observer"]["seed_median_px"]
    off = {s: _levelling_off(r, base) for s, r in zip(args.seeds, resps, strict=True)}
    print(
        "seed | calibrated observer's median OR per log10 px | objects levelling off (< 0.85 "
        "at the finest level)"
    )
    for s in args.seeds:
        print(f"{s} | {seedrow[s]:.1f} | {off[s]}")
    x, y = np.array([off[s] for s in args.seeds]), np.log([seedrow[s] for s in args.seeds])
    corr = float(np.corrcoef(x, y)[0, 1]) if x.std() > 0 else float("nan")
    print(f"correlation over seeds (objects levelling off, log median slope): {corr:.2f}")
    slopes = np.concatenate([object_slopes(r, base) for r in resps])
    sd = float(np.nanstd(slopes))
    q = np.nanquantile(slopes, [0.1, 0.5, 0.9])
    print(f"calibrated observer's own slope per object (log odds per log10 px, 60 subjects): "
          f"10/50/90 % {q[0]:.1f} / {q[1]:.1f} / {q[2]:.1f}, SD {sd:.2f} (the paper's common "
          f"slope: {math.log(PAPER['or_per_log10_px'][0]):.2f}); never recognised "
          f"{np.isnan(slopes).sum()} of {slopes.size}")  # fmt: skip
    sets = {}
    for name, s_sd in (("one slope", 0.0), ("object slopes differ", sd)):
        d = sets[name] = set_chance(objs, pixels, s_sd, len(args.seeds), args.studies)
        px = d["or_per_log10_px"]
        bg = _fmt(d["or_background"], ".2f")
        print(f"logistic observer, paper's odds ratios, {name} (SD {s_sd:.2f}), objects fixed "
              f"per set, {len(args.seeds)} sets x {args.studies} studies: OR per log10 px "
              f"{_fmt(px)}, SD log {px['sd_log']:.3f} (within {px['sd_within']:.3f}, between "
              f"{px['sd_between']:.3f}); OR background {bg}")  # fmt: skip
    print(f"{time.perf_counter() - t0:.0f} s")
    print(json.dumps({"chance": curve, "variants": results, "levelling_off": off,
                      "correlation": corr, "object_slope_sd": sd, "sets": sets}))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
