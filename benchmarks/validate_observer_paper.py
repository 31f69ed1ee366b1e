"""Validation: does the demo's simulated observer give the paper's numbers, seed by seed?

Runs ``confocal demo`` (the whole simulated study: synthesis, stimulus set, six simulated
subjects through the session engine, the analysis) for each seed and prints one row per seed:
the two 50 % thresholds with their 95 % credible intervals, both logistic odds ratios with their
95 % intervals (as ``results.json`` gives them), the cluttered fit's deviance and posterior
predictive p, and whether each odds ratio lies inside the paper's 95 % interval (Jung et al.
2015, Sec. 3.2.2: background 5.6, 3.9-8.1; per log10 pixels 74.5, 48.9-113.5; thresholds 8,695
and 3,532 px, for which the paper gives no interval: the row says whether the paper's value lies
inside the demo's interval).

Slow: one demo per seed (30-60 s each on 2 idle cores, longer on a busy machine).

``--spread N`` instead draws N whole simulated studies by the fast path of
``benchmarks/design_observer.py`` (the calibrated observer's decision stage on cached responses
to the design seeds' stimulus sets, never seeds 0-4; the paper's regression by the report's
rule) and prints the sampling distribution of both odds ratios (median, 2.5 and 97.5 % points)
and the share of studies inside the paper's intervals; beside it the same for a simulated
observer whose true odds ratios ARE the paper's (a logistic observer: background 5.6, 74.5 per
log10 px, cluttered 50 % point 8,695 px, object effects drawn N(0, ``--object-sd``)), the share
that chance alone allows with a study of the paper's size. About 0.1-0.3 s a study.

Run: ``python benchmarks/validate_observer_paper.py [--seeds 0 1 2 3 4] [--observer calibrated]
[--keep DIR]`` or ``... --spread 140 [--work DIR] [--design-seeds 10 ... 16]``.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

__all__ = ["PAPER", "main", "paper_logistic_study", "row_of", "spread"]

#: The paper's numbers (Jung et al. 2015, Sec. 3.2.2): estimate and 95 % interval (None: the
#: paper gives none).
PAPER: dict[str, tuple[float, tuple[float, float] | None]] = {
    "x50_cluttered_px": (8695.0, None),
    "x50_decluttered_px": (3532.0, None),
    "or_background": (5.6, (3.9, 8.1)),
    "or_per_log10_px": (74.5, (48.9, 113.5)),
}


def row_of(results: dict[str, Any]) -> dict[str, Any]:
    """Return one seed's numbers from a demo's ``results.json`` content.

    Parameters
    ----------
    results : dict
        The analysis' ``results.json``.

    Returns
    -------
    dict
        ``x50_cluttered_px``, ``x50_decluttered_px`` (each ``(median, (lo, hi))``),
        ``or_background``, ``or_per_log10_px`` (each ``(or, (lo, hi))``), ``deviance``,
        ``deviance_df``, ``ppp`` (the cluttered fit's) and ``inside`` (term -> bool: the
        odds ratio inside the paper's interval, the paper's threshold inside the demo's).
    """
    th = results.get("thresholds", {})
    ors = results.get("logistic", {}).get("odds_ratios", {})
    out: dict[str, Any] = {}
    for key, cond in (("x50_cluttered_px", "cluttered"), ("x50_decluttered_px", "decluttered")):
        t = th.get(cond) or {}
        out[key] = (t.get("p50_pixels"), tuple(t.get("ci95") or (None, None)))
    for key, term in (("or_background", "background"), ("or_per_log10_px", "log10_pixels")):
        o = ors.get(term) or {}
        out[key] = (o.get("or"), tuple(o.get("ci95") or (None, None)))
    g = (th.get("cluttered") or {}).get("goodness_of_fit") or {}
    out["deviance"], out["deviance_df"], out["ppp"] = (
        g.get("deviance"),
        g.get("deviance_df"),
        g.get("ppp"),
    )
    inside = {}
    for key, (value, interval) in PAPER.items():
        est, ci = out[key]
        if interval is not None:
            inside[key] = est is not None and interval[0] <= est <= interval[1]
        else:
            inside[key] = None not in ci and ci[0] <= value <= ci[1]
    out["inside"] = inside
    return out


def paper_logistic_study(
    objects: list[str],
    pixels: list[float],
    *,
    n_subjects: int = 6,
    object_sd: float = 1.5,
    rng: int = 0,
    or_per_log10_px: float | None = None,
) -> list[tuple[str, str, str, float, int]]:
    """One simulated study of an observer whose true odds ratios are the paper's.

    ``logit p = a + log(5.6) * decluttered + log(74.5) * log10(px) + u_object``, ``a`` putting
    the cluttered 50 % point at 8,695 px, ``u`` drawn N(0, object_sd) once per study; each
    subject sees every object at every level in both conditions once.

    Parameters
    ----------
    objects : list of str
    pixels : list of float
        The levels, px.
    n_subjects : int
    object_sd : float
        Spread of the objects' log odds (the paper does not give it; 14 of its 19 object
        dummies were significant).
    rng : int
        Seed.
    or_per_log10_px : float, optional
        Another true slope (odds ratio per log10 pixels) instead of the paper's 74.5, the
        cluttered 50 % point kept at 8,695 px: the chance spread of observers with other
        slopes (``benchmarks/observer_slope_spread.py``).

    Returns
    -------
    list of (subject, object, condition, pixels, recognised)
    """
    g = np.random.default_rng(rng)
    b_bg = math.log(PAPER["or_background"][0])
    b_px = math.log(or_per_log10_px or PAPER["or_per_log10_px"][0])
    a = -b_px * math.log10(PAPER["x50_cluttered_px"][0])
    u = g.normal(0.0, object_sd, len(objects))
    rows = []
    for j in range(n_subjects):
        for px in pixels:
            for bg, cond in ((0, "cluttered"), (1, "decluttered")):
                eta = a + b_bg * bg + b_px * math.log10(px) + u
                ok = g.random(len(objects)) < 1.0 / (1.0 + np.exp(-eta))
                rows += [(f"S{j + 1:02d}", o, cond, float(px), int(y))
                         for o, y in zip(objects, ok, strict=True)]  # fmt: skip
    return rows


def spread(
    n: int, work: Path, design_seeds: list[int], *, object_sd: float = 1.5
) -> dict[str, dict[str, Any]]:
    """Sampling distribution of both odds ratios over ``n`` simulated studies.

    Parameters
    ----------
    n : int
        Studies per observer (drawn in turn from the design seeds' stimulus sets).
    work : Path
        The fast path's cache folder (``benchmarks/design_observer.py --work``).
    design_seeds : list of int
    object_sd : float
        The paper-odds observer's object spread (:func:`paper_logistic_study`).

    Returns
    -------
    dict
        ``calibrated`` and ``paper_odds`` -> ``{term: {median, q025, q975, inside}, both}``
        (``inside``: share of studies inside the paper's interval).
    """
    from benchmarks.design_observer import odds_ratios, responses, simulate_study
    from experiment.observers.calibration import CalibratedParams

    resps = [responses(work, s) for s in design_seeds]
    p = CalibratedParams.__dataclass_fields__
    noise, crit = p["noise_sd"].default, p["criterion"].default
    priming, lapse = p["priming"].default, p["lapse"].default
    objs = sorted({str(o) for o in resps[0]["cluttered"]["objects"]})
    pixels = sorted({float(x) for x in resps[0]["cluttered"]["pixels"]})
    draws: dict[str, list[dict[str, float]]] = {"calibrated": [], "paper_odds": []}
    for i in range(n):
        rows = simulate_study(resps[i % len(resps)], noise_sd=noise, criterion=crit,
                              priming=priming, lapse=lapse, rng=100_000 + i)  # fmt: skip
        draws["calibrated"].append(odds_ratios(rows))
        rows = paper_logistic_study(objs, pixels, object_sd=object_sd, rng=200_000 + i)
        draws["paper_odds"].append(odds_ratios(rows))
    out: dict[str, dict[str, Any]] = {}
    for who, ds in draws.items():
        res: dict[str, Any] = {}
        both = np.ones(len(ds), bool)
        for key in ("or_background", "or_per_log10_px"):
            v = np.array([d[key] for d in ds])
            lo, hi = PAPER[key][1]  # type: ignore[misc]
            ins = (v >= lo) & (v <= hi)
            both &= ins
            q = np.quantile(v, [0.025, 0.5, 0.975])
            res[key] = {"q025": q[0], "median": q[1], "q975": q[2], "inside": ins.mean()}
        res["both"] = float(both.mean())
        res["firth"] = float(np.mean([d["firth"] for d in ds]))
        out[who] = res
    return out


def _rates(d: Any) -> Any:
    return d.groupby(["condition", "pixels"])["recognized"].mean()


def check_demo(demo: Path, work: Path, n: int) -> dict[str, Any]:
    """Set one kept demo (folder ``<observer>-seed<N>``) against ``n`` fast-path studies of N.

    Returns the demo's odds ratios from ``results.json`` and recomputed from its trials by the
    fast path's regression (they must agree), the share of fast-path studies below the demo's
    values (its percentile), and the largest difference between the demo's recognition rate and
    the fast path's mean, level by level and condition by condition.
    """
    import pandas as pd

    from analysis.data import read_trials
    from benchmarks.design_observer import odds_ratios, responses, simulate_study
    from experiment.observers.calibration import CalibratedParams

    seed = int(demo.name.rsplit("seed", 1)[1])
    results = json.loads(next(demo.rglob("results.json")).read_text(encoding="utf-8"))
    shown = row_of(results)
    t = read_trials([demo / "study.sqlite"], include_simulated=True).trials
    rows = [(r.subject, str(r.object), r.condition, float(r.pixels), int(r.recognized))
            for r in t.itertuples()]  # fmt: skip
    again = odds_ratios(rows)
    p = CalibratedParams.__dataclass_fields__
    resp = responses(work, seed)
    cols = ["subject", "object", "condition", "pixels", "recognized"]
    sims, rates = [], []
    for i in range(n):
        sim = simulate_study(resp, noise_sd=p["noise_sd"].default, criterion=p["criterion"].default,
                             priming=p["priming"].default, lapse=p["lapse"].default,
                             rng=300_000 + i)  # fmt: skip
        sims.append(odds_ratios(sim))
        rates.append(
            pd.DataFrame(sim, columns=cols).groupby(["condition", "pixels"])["recognized"].mean()
        )
    demo_rate = (
        pd.DataFrame(rows, columns=cols).groupby(["condition", "pixels"])["recognized"].mean()
    )
    out: dict[str, Any] = {"demo": str(demo), "seed": seed, "fast_path_studies": n}
    for key in ("or_background", "or_per_log10_px"):
        v = np.array([s[key] for s in sims])
        out[key] = {
            "results_json": shown[key][0],
            "recomputed": again[key],
            "fast_path_median": float(np.median(v)),
            "fast_path_q025_q975": [float(x) for x in np.quantile(v, [0.025, 0.975])],
            "demo_percentile": float((v < again[key]).mean()),
        }
    out["max_rate_difference"] = float((demo_rate - sum(rates) / n).abs().max())
    return out


def _print_spread(n: int, design_seeds: list[int], s: dict[str, dict[str, Any]]) -> None:
    print(f"{n} simulated studies per observer (1,920 trials each; fast path on design seeds "
          f"{', '.join(map(str, design_seeds))}; simulated data)")  # fmt: skip
    print("observer | OR background: median (2.5-97.5 %) | in 3.9-8.1 | "
          "OR per log10 px: median (2.5-97.5 %) | in 48.9-113.5 | both | Firth used")  # fmt: skip
    for who, r in s.items():
        bg, px = r["or_background"], r["or_per_log10_px"]
        print(f"{who} | {bg['median']:.2f} ({bg['q025']:.2f}-{bg['q975']:.2f}) | "
              f"{bg['inside']:.2f} | {px['median']:.1f} ({px['q025']:.1f}-{px['q975']:.1f}) | "
              f"{px['inside']:.2f} | {r['both']:.2f} | {r['firth']:.2f}")  # fmt: skip
    print(json.dumps(s))


def _fmt(v: Any, f: str) -> str:
    return "n/a" if v is None else format(float(v), f)


def _cell(pair: tuple[Any, tuple[Any, Any]], f: str) -> str:
    est, (lo, hi) = pair
    return f"{_fmt(est, f)} ({_fmt(lo, f)}-{_fmt(hi, f)})"


def main(argv: list[str] | None = None) -> int:
    """Run the demo for each seed and print the table (and a JSON line per seed)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    ap.add_argument("--observer", default="calibrated")
    ap.add_argument("--keep", type=Path, default=None, help="Keep the demo folders here.")
    ap.add_argument(
        "--spread",
        type=int,
        default=None,
        metavar="N",
        help="Fast path: N simulated studies per observer instead of demos.",
    )
    ap.add_argument("--work", type=Path, default=None, help="Fast-path cache folder.")
    ap.add_argument("--design-seeds", type=int, nargs="+", default=None)
    ap.add_argument("--object-sd", type=float, default=1.5)
    ap.add_argument("--check-demo", type=Path, nargs="+", default=None, metavar="DIR",
                    help="With --spread: set kept demo folders (<observer>-seed<N>) against N "
                    "fast-path studies of their seed.")  # fmt: skip
    args = ap.parse_args(argv)
    if args.spread is not None:
        from benchmarks.design_observer import DESIGN_SEEDS

        work = args.work or Path(tempfile.mkdtemp(prefix="confocal-design-"))
        work.mkdir(parents=True, exist_ok=True)
        seeds = args.design_seeds or list(DESIGN_SEEDS)
        if args.check_demo:
            for d in args.check_demo:
                print(json.dumps(check_demo(d, work, args.spread)), flush=True)
            return 0
        _print_spread(args.spread, seeds, spread(args.spread, work, seeds,
                                                 object_sd=args.object_sd))  # fmt: skip
        return 0
    from experiment.demos.study import run_demo

    root = args.keep or Path(tempfile.mkdtemp(prefix="confocal-validate-"))
    rows = []
    for seed in args.seeds:
        out = root / f"{args.observer}-seed{seed}"
        t0 = time.perf_counter()
        demo = run_demo(out, seed=seed, observer=args.observer, show_progress=False)
        r = row_of(demo.results)
        r["seed"], r["wall_s"] = seed, round(time.perf_counter() - t0, 1)
        rows.append(r)
        print(json.dumps(r), flush=True)
        if args.keep is None:
            shutil.rmtree(out, ignore_errors=True)
    print(f"\nobserver {args.observer}; paper: 8,695 / 3,532 px, OR background 5.6 (3.9-8.1), "
          "OR per log10 px 74.5 (48.9-113.5)")  # fmt: skip
    head = ("seed", "x50 cluttered px", "x50 de-cluttered px", "OR background",
            "OR per log10 px", "dev (df)", "PPC p", "ORs in paper's CI")  # fmt: skip
    print(" | ".join(head))
    print(" | ".join("---" for _ in head))
    for r in rows:
        ins = r["inside"]
        both = ins["or_background"] and ins["or_per_log10_px"]
        print(" | ".join([
            str(r["seed"]),
            _cell(r["x50_cluttered_px"], ",.0f"),
            _cell(r["x50_decluttered_px"], ",.0f"),
            _cell(r["or_background"], ".2f"),
            _cell(r["or_per_log10_px"], ".1f"),
            f"{_fmt(r['deviance'], '.1f')} ({r['deviance_df']})",
            _fmt(r["ppp"], ".2f"),
            "both" if both else ("bg only" if ins["or_background"] else
                                 "px only" if ins["or_per_log10_px"] else "neither"),
        ]))  # fmt: skip
    n_both = sum(r["inside"]["or_background"] and r["inside"]["or_per_log10_px"] for r in rows)
    print(f"\nboth odds ratios inside the paper's intervals on {n_both} of {len(rows)} seeds")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
