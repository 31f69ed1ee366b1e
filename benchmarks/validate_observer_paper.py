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

Run: ``python benchmarks/validate_observer_paper.py [--seeds 0 1 2 3 4] [--observer calibrated]
[--keep DIR]``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.demos.study import run_demo  # noqa: E402

__all__ = ["PAPER", "main", "row_of"]

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
    args = ap.parse_args(argv)
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
