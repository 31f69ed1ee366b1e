"""Parameter recovery: coverage of the 95 % credible interval of the 50 % threshold.

Simulates the paper's design (6 subjects x 20 objects x 8 levels x 2 conditions; Jung et al. 2015,
Sec. 3.1) from known Weibull observers in two settings, fits each condition's pooled data exactly
as ``confocal analyze`` does (binomial ML start, batch posterior sampler, beta-binomial
overdispersion unless ``--no-overdispersion``), and counts how often the 95 % interval covers the
true 50 % threshold:

* ``ideal``: every subject and object the same observer (binomial data);
* ``heterogeneous``: as a real study, ``log10(alpha)`` shifted per subject (SD 0.15) and per object
  (SD 0.2), and each subject's lapse rate drawn uniformly in [0, 2 x lapse] (ours, near the spread
  of the paper's Fig. 9 and Fig. S3). The true value is the 50 % point of the population's
  psychometric function, averaged over those random effects (Gauss-Hermite, 64 nodes).

Prints the coverage with a Clopper-Pearson 95 % interval; a calibrated method gives about 0.95.
Simulated data only (labelled so in the output).

Usage::

    python benchmarks/validate_weibull_coverage.py [--reps 100] [--seed 2015] [--compare]
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import numpy as np
from scipy import optimize, stats

from analysis.cluster import cluster_threshold_ci
from analysis.simulate import WeibullObserver, simulate_weibull_trials
from analysis.weibull import aggregate, default_prior, fit_mle, threshold_at
from analysis.weibull.batch import FitJob, fit_batch

#: True observers (ours): chosen near fits to the paper's Fig. 8 (50 % points ~8,700 and ~3,500 px
#: with lapses of a few percent).
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}
#: Heterogeneity of the 'heterogeneous' setting (ours; see the module docstring).
HETERO = {"subject_log10_sd": 0.15, "object_log10_sd": 0.2}


def population_threshold(obs: WeibullObserver, log10_sd: float, pc: float = 0.5) -> float:
    """Return the 50 % point of the population curve E_w[P(x; alpha 10^w)], w ~ N(0, log10_sd)."""
    if log10_sd == 0:
        return float(threshold_at(pc, obs.alpha_px, obs.beta, obs.lapse))
    z, wts = np.polynomial.hermite_e.hermegauss(64)
    wts = wts / wts.sum()

    def f(log10_x: float) -> float:
        a = obs.alpha_px * 10 ** (log10_sd * z)
        core = -np.expm1(-((10**log10_x / a) ** obs.beta))
        # Mean lapse: the subject lapses are uniform around obs.lapse, and P is linear in them.
        return float(obs.guess + (1 - obs.guess - obs.lapse) * np.sum(wts * core)) - pc

    return 10 ** optimize.brentq(f, 0.0, 8.0, xtol=1e-12)


def run(reps: int, seed: int, kind: str, overdispersion: bool = True) -> dict:
    """Return coverage per condition and overall for ``reps`` simulated studies of ``kind``."""
    hetero = kind == "heterogeneous"
    kw = (
        dict(HETERO, subject_lapse_spread=0.0)
        if hetero
        else {"subject_log10_sd": 0.0, "object_log10_sd": 0.0}
    )
    sd = math.hypot(HETERO["subject_log10_sd"], HETERO["object_log10_sd"]) if hetero else 0.0
    truth = {c: population_threshold(o, sd) for c, o in TRUTH.items()}
    t0 = time.perf_counter()
    jobs, conds, pop = [], [], []
    for child in np.random.SeedSequence(seed).spawn(reps):
        rng = np.random.default_rng(child)
        # Lapse spread per condition = that condition's lapse (uniform in [0, 2 lapse]).
        parts = []
        for c, obs in TRUTH.items():
            extra = {"subject_lapse_spread": obs.lapse} if hetero else {}
            parts.append(
                simulate_weibull_trials({c: obs}, rng=rng, **{**kw, **extra}).assign(condition=c)
            )
        for d in parts:
            c = d["condition"].iloc[0]
            lv, k, n = aggregate(d["pixels"], d["recognized"])
            prior = default_prior(lv)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mle = fit_mle(lv, k, n, prior=prior)
            jobs.append(FitJob(c, lv, k, n, 0.0, prior, mle, overdispersion))
            conds.append(c)
            pop.append(
                cluster_threshold_ci(d["pixels"], d["recognized"], [d["subject"], d["object"]], mle)
            )
    fits = fit_batch(jobs, rng=seed)
    hits = {c: 0 for c in TRUTH}
    pop_hits = {c: 0 for c in TRUTH}
    widths = {c: [] for c in TRUTH}
    for c, f, pi in zip(conds, fits, pop, strict=True):
        lo, hi = f.threshold(0.5).ci95
        hits[c] += lo <= truth[c] <= hi
        widths[c].append(math.log10(hi / lo) if lo > 0 and math.isfinite(hi) else math.inf)
        pop_hits[c] += pi is not None and pi[0] <= truth[c] <= pi[1]
    n = len(fits)
    k = sum(hits.values())
    return {
        "kind": kind,
        "overdispersion": overdispersion,
        "reps": reps,
        "truth": truth,
        "coverage": {c: hits[c] / reps for c in TRUTH},
        "overall": k / n,
        "overall_ci95": clopper_pearson(k, n),
        "population": sum(pop_hits.values()) / n,
        "population_ci95": clopper_pearson(sum(pop_hits.values()), n),
        "converged": float(np.mean([f.converged for f in fits])),
        "median_log10_width": {c: float(np.median(w)) for c, w in widths.items()},
        "seconds": time.perf_counter() - t0,
    }


def clopper_pearson(k: int, n: int) -> tuple[float, float]:
    """Return the Clopper-Pearson 95 % interval of k successes in n."""
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return float(lo), float(hi)


def main() -> None:
    """Run the validation and print the coverage."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=100, help="simulated studies per setting")
    ap.add_argument("--seed", type=int, default=2015)
    ap.add_argument("--kind", choices=["ideal", "heterogeneous", "both"], default="both")
    ap.add_argument("--no-overdispersion", action="store_true", help="binomial posteriors")
    ap.add_argument("--compare", action="store_true", help="also run the other likelihood")
    a = ap.parse_args()
    kinds = ["ideal", "heterogeneous"] if a.kind == "both" else [a.kind]
    ods = [not a.no_overdispersion] + ([a.no_overdispersion] if a.compare else [])
    print("SIMULATED data (known observers), paper design 6 x 20 x 8 x 2")
    for kind in kinds:
        for od in ods:
            r = run(a.reps, a.seed, kind, od)
            lik = "beta-binomial" if od else "binomial"
            print(
                f"{kind}, {lik}: {r['reps']} studies x {len(TRUTH)} conditions "
                f"({r['seconds']:.0f} s)"
            )
            for c, v in r["coverage"].items():
                print(
                    f"  coverage of the true 50% threshold ({r['truth'][c]:,.0f} px), {c}: {v:.3f} "
                    f"(median CrI width {r['median_log10_width'][c]:.3f} log10 units)"
                )
            lo, hi = r["overall_ci95"]
            print(
                f"  overall coverage: {r['overall']:.3f} (95% Clopper-Pearson {lo:.3f}-{hi:.3f})"
                f"; chains converged: {100 * r['converged']:.1f}%"
            )
            lo, hi = r["population_ci95"]
            print(
                "  population interval (two-way cluster-robust ML, subjects x objects): "
                f"coverage {r['population']:.3f} (95% Clopper-Pearson {lo:.3f}-{hi:.3f})"
            )


if __name__ == "__main__":
    main()
