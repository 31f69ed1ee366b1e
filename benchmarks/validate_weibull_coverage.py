"""Parameter recovery: coverage of the 95 % credible interval of the 50 % threshold.

Simulates the paper's design (6 subjects x 20 objects x 8 levels x 2 conditions; Jung et al. 2015,
Sec. 3.1) from known Weibull observers, fits each condition's pooled data, and counts how often
the 95 % interval covers the true 50 % threshold. Prints the coverage with a Clopper-Pearson
interval; a calibrated method gives about 0.95.

Usage::

    python benchmarks/validate_weibull_coverage.py [--reps 200] [--seed 2015]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from scipy import stats

from analysis.simulate import WeibullObserver, simulate_weibull_trials
from analysis.weibull import fit_weibull, threshold_at

#: True observers (ours): chosen near fits to the paper's Fig. 8 (50 % points ~8,700 and ~3,500 px
#: with lapses of a few percent).
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}


def run(reps: int, seed: int) -> dict:
    """Return coverage per condition and overall for ``reps`` replications."""
    ss = np.random.SeedSequence(seed)
    hits = {c: 0 for c in TRUTH}
    conv = 0
    widths = {c: [] for c in TRUTH}
    t0 = time.perf_counter()
    for i, child in enumerate(ss.spawn(reps)):
        rng = np.random.default_rng(child)
        d = simulate_weibull_trials(TRUTH, rng=rng)
        for c, obs in TRUTH.items():
            true = float(threshold_at(0.5, obs.alpha_px, obs.beta, obs.lapse))
            sel = d[d["condition"] == c]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_weibull(sel["pixels"], sel["recognized"], rng=rng, label=c)
            lo, hi = fit.threshold(0.5).ci95
            hits[c] += lo <= true <= hi
            conv += fit.converged
            widths[c].append(np.log10(hi / lo))
        if (i + 1) % 20 == 0:
            print(f"  {i + 1}/{reps} replications, {time.perf_counter() - t0:.0f} s", flush=True)
    n = reps * len(TRUTH)
    k = sum(hits.values())
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return {
        "reps": reps,
        "coverage": {c: hits[c] / reps for c in TRUTH},
        "overall": k / n,
        "overall_ci95": (float(lo), float(hi)),
        "converged": conv / n,
        "median_log10_width": {c: float(np.median(w)) for c, w in widths.items()},
        "seconds": time.perf_counter() - t0,
    }


def main() -> None:
    """Run the validation and print the coverage."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=200, help="replications (>= 100 for the claim)")
    ap.add_argument("--seed", type=int, default=2015)
    a = ap.parse_args()
    r = run(a.reps, a.seed)
    print(f"replications: {r['reps']} x {len(TRUTH)} conditions ({r['seconds']:.0f} s)")
    for c, v in r["coverage"].items():
        print(
            f"coverage of the true 50% threshold, {c}: {v:.3f} "
            f"(median CrI width {r['median_log10_width'][c]:.3f} log10 units)"
        )
    lo, hi = r["overall_ci95"]
    print(f"overall coverage: {r['overall']:.3f} (95% Clopper-Pearson {lo:.3f}-{hi:.3f})")
    print(f"chains converged: {100 * r['converged']:.1f}%")


if __name__ == "__main__":
    main()
