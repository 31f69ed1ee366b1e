"""Where the ``calibrated`` observer's seed-to-seed spread comes from: a measured decomposition.

For demo folders written by ``confocal demo --seed N --out DIR`` (their test set, seed N, and
knowledge set, seed N + 1), the noise-free normalised responses of every main stimulus are
computed once; then, for each (test set, knowledge set) pairing, including crossed ones:

* **expected**: each stimulus' recognition probability over the internal noise (Monte Carlo)
  times ``1 - lapse``, averaged per level and fitted with an ML Weibull (guess 0, lapse free):
  the threshold of infinitely many simulated subjects. Its spread over pairings is the part
  that comes from the stimulus set and the knowledge set; crossing them separates the two.
* **sampled**: ``subjects`` simulated subjects answer each stimulus once (Bernoulli with those
  probabilities: internal noise, lapses and trial sampling together), ML Weibull on the pooled
  counts, repeated; the spread of that threshold is the part a single demo run adds.
* **floor**: the same binomial sampling of a Weibull curve itself (the paper's cluttered curve,
  or the observer's expected one) with the demo's design: the spread no observer can go below
  with that many trials.
* **open set**: the share of stimuli named (wrongly) when their own kind is removed from the
  knowledge, i.e. an unknown kind; 1 minus it is the "don't know" rate.

Spreads are given as the median and 90th percentile of max/min over three independent runs,
the statistic the seed criterion (within 1.6x over seeds 0, 1, 2) uses.

Run: ``python benchmarks/observer_spread.py DEMO_DIR [DEMO_DIR ...] [--subjects 6] [--reps 200]``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.observers.calibration import (  # noqa: E402
    PAPER_CLUTTERED_BETA,
    PAPER_CLUTTERED_X50_PX,
    CalibratedParams,
    decision_variable,
    stimulus_responses,
)

__all__ = ["main", "expected_rates", "x50_ml", "spread_of_three", "sampled_x50"]


def x50_ml(levels: np.ndarray, k: np.ndarray, n: np.ndarray) -> float:
    """ML Weibull (guess 0, lapse free) 50 % threshold, px (inf when the curve stays below)."""
    from analysis.weibull.mle import fit_mle
    from analysis.weibull.model import threshold_at

    fit = fit_mle(levels, k, n)
    return float(threshold_at(0.5, fit.alpha, fit.beta, fit.lapse))


def expected_rates(
    d: dict[str, np.ndarray], params: CalibratedParams, *, repeats: int = 400, rng: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """Per-stimulus recognition probability, and per-stimulus unknown-kind naming probability."""
    gen = np.random.default_rng(rng)
    crit, sd, lapse = float(params.criterion), float(params.noise_sd), float(params.lapse)

    def decide(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        noisy = z[:, None, :] + sd * gen.standard_normal((z.shape[0], repeats, z.shape[1]))
        return decision_variable(noisy, params.decision)

    choice, v = decide(d["known"])
    p = ((choice == d["correct"][:, None]) & (v > crit)).mean(axis=1) * (1 - lapse)
    _, v_u = decide(d["unknown"])
    pu = (v_u > crit).mean(axis=1) * (1 - lapse)
    return p, pu


def sampled_x50(
    px: np.ndarray, p: np.ndarray, subjects: int, reps: int, gen: np.random.Generator
) -> np.ndarray:
    """ML thresholds of ``reps`` simulated demos: each subject answers each stimulus once."""
    levels = np.unique(px)
    idx = [px == lv for lv in levels]
    n = np.array([i.sum() for i in idx], float) * subjects
    out = np.empty(reps)
    for r in range(reps):
        hits = gen.binomial(subjects, p)
        k = np.array([hits[i].sum() for i in idx], float)
        out[r] = x50_ml(levels, k, n)
    return out


def spread_of_three(x50s: np.ndarray, gen: np.random.Generator, draws: int = 2000) -> dict:
    """Median and 90th percentile of max/min over three thresholds drawn from ``x50s``."""
    t = gen.choice(x50s, size=(draws, 3))
    r = t.max(axis=1) / t.min(axis=1)
    return {"median": float(np.median(r)), "p90": float(np.quantile(r, 0.9))}


def _k(lapse: float) -> float:
    """Weibull scale constant so that (1 - lapse)(1 - exp(-k)) = 0.5 at x50."""
    return -math.log(1 - 0.5 / (1 - lapse))


def main(argv: list[str] | None = None) -> int:
    """Print the decomposition as JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("demos", type=Path, nargs="+")
    ap.add_argument("--subjects", type=int, default=6)
    ap.add_argument("--reps", type=int, default=200)
    ap.add_argument("--cross", action="store_true", help="Also pair each test set with the "
                    "other demos' knowledge sets (never its own seed).")  # fmt: skip
    ap.add_argument("--blur", type=float, default=None)
    ap.add_argument("--noise", type=float, default=None)
    ap.add_argument("--criterion", type=float, default=None)
    ap.add_argument("--decision", choices=("margin", "standout"), default=None)
    ap.add_argument("--samples-per-deg", type=float, default=None)
    ap.add_argument("--cell", type=float, default=None)
    ap.add_argument("--knowledge", type=Path, nargs="*", default=None,
                    help="Knowledge sets to use for every test set (pooled).")  # fmt: skip
    args = ap.parse_args(argv)
    gen = np.random.default_rng(0)
    over = {k: v for k, v in (("blur_deg", args.blur), ("noise_sd", args.noise),
                              ("criterion", args.criterion), ("decision", args.decision),
                              ("samples_per_deg", args.samples_per_deg),
                              ("cell_deg", args.cell)) if v is not None}  # fmt: skip
    params = CalibratedParams(knowledge="unused", **over)
    seeds = {}
    for d in args.demos:
        info = json.loads((d / "demo.json").read_text())
        ks = info.get("knowledge_seeds") or [info["knowledge_seed"]]
        if (d / "knowledge" / "stimuli").is_dir():  # one rendering
            know = [d / "knowledge" / "stimuli"]
        else:
            know = [d / "knowledge" / f"seed{k}" / "stimuli" for k in ks]
        seeds[info["seed"]] = (d / "stimuli", know, tuple(ks))
    pairs = []
    for s, (test, know, ks) in seeds.items():
        if args.knowledge:
            pairs.append((s, "+".join(p.name for p in args.knowledge), test, args.knowledge))
            continue
        pairs.append((s, list(ks), test, know))
        if args.cross:
            for _, know2, ks2 in seeds.values():
                if s not in ks2 and ks2 != ks:
                    pairs.append((s, list(ks2), test, know2))
    out: dict = {"params": {k: getattr(params, k) for k in ("samples_per_deg", "blur_deg",
                                                             "cell_deg", "noise_sd", "criterion",
                                                             "decision", "lapse")},
                 "subjects": args.subjects, "pairings": []}  # fmt: skip
    by_cond: dict[str, list[float]] = {"cluttered": [], "decluttered": []}
    for s, ks, test, know in pairs:
        row: dict = {"test_seed": s, "knowledge_seed": ks}
        for cond in ("cluttered", "decluttered"):
            d = stimulus_responses(test, know, params, cond)
            p, pu = expected_rates(d, params)
            px = d["pixels"]
            levels = np.unique(px)
            rate = np.array([p[px == lv].mean() for lv in levels])
            big = 100000.0
            x50 = x50_ml(levels, rate * big, np.full(len(levels), big))
            samp = sampled_x50(px, p, args.subjects, args.reps, gen)
            row[cond] = {
                "rate": {
                    f"{lv:.0f}": round(float(r), 3) for lv, r in zip(levels, rate, strict=True)
                },
                "expected_x50_px": x50,
                "sampled_x50_px_q05_50_95": [
                    float(q) for q in np.quantile(samp, [0.05, 0.5, 0.95])
                ],
                "sampling_spread_of_three": spread_of_three(samp, gen),
                "unknown_kind_named": float(pu.mean()),
            }
            by_cond[cond].append(x50)
        c, dd = row["cluttered"]["expected_x50_px"], row["decluttered"]["expected_x50_px"]
        row["expected_ratio"] = c / dd
        out["pairings"].append(row)
        print(json.dumps(row), flush=True)
    out["expected_x50_max_over_min"] = {k: max(v) / min(v) for k, v in by_cond.items()}
    # the floor: binomial sampling of the paper's own cluttered curve with the demo's design
    levels = np.array([96, 486, 950, 3290, 6370, 17876, 40344, 160884], float)
    for lapse in (0.0, 0.05):
        k = _k(lapse)
        pc = (1 - lapse) * (
            1 - np.exp(-k * (levels / PAPER_CLUTTERED_X50_PX) ** PAPER_CLUTTERED_BETA)
        )
        n = 20 * args.subjects
        samp = np.array(
            [x50_ml(levels, gen.binomial(n, pc), np.full(8, n)) for _ in range(args.reps)]
        )
        out[f"floor_paper_curve_lapse{lapse}"] = {
            "trials_per_level": n,
            "x50_q05_50_95": [float(q) for q in np.quantile(samp, [0.05, 0.5, 0.95])],
            "spread_of_three": spread_of_three(samp, gen),
        }
    print(json.dumps({k: v for k, v in out.items() if k != "pairings"}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
