"""Coverage of each threshold interval the report prints, for the target it says it covers.

Simulates the paper's design (6 subjects x 20 objects x 8 levels x 2 conditions; Jung et al. 2015,
Sec. 3.1) from known Weibull observers with lapses, fits each condition's pooled data exactly as
``confocal analyze`` does (binomial ML start, batch posterior sampler, binomial likelihood by
default; two-way cluster-robust population interval; the pooled-curve interval of
:mod:`analysis.pooled_curve`), and counts how often each 95 % interval covers each target.

Settings:

* ``ideal``: every subject and object the same observer; every target is the observer's 50 %
  threshold.
* ``heterogeneous`` (the normal case): ``log10(alpha)`` shifted per subject (SD 0.15) and per
  object (SD 0.2), and each subject's lapse rate drawn uniformly in [0, 2 x lapse] (ours, near the
  spread of the paper's Fig. 9 and Fig. S3).

Targets (each study's subjects and objects reproduced from the same random stream):

* ``fitted Weibull``: the 50 % point of the Weibull that best fits the pooled responses of the
  subjects and objects tested (the ML Weibull fitted to their expected counts, the limit of the
  pooled fit with ever more trials of the same subjects and objects);
* ``these subjects and objects``: the 50 % point of their pooled curve (the mean of their
  curves), where they, taken together, recognise half the time;
* ``population``: the 50 % point of the population's curve (Gauss-Hermite, 64 nodes).

Prints a table -- interval, target, coverage, reps (fitted curves), binomial standard error --
for every interval against every target; the line the report prints for each interval is marked
``*``. A calibrated interval gives 0.93-0.97. Simulated data only (labelled so in the output).

Measured (seed 2015, binomial credible interval, 1 worker; on the shared 2-core machine 28 min
for 500 heterogeneous studies, 17 min for 250 ideal ones), coverage of each printed interval for
its stated target (reps = fitted curves, SE = binomial standard error):

================  ===========================  ===============  ===============
interval          stated target                heterogeneous    ideal
================  ===========================  ===============  ===============
credible          fitted Weibull               0.947 (1000,     0.948 (500,
                                               SE 0.007)        SE 0.010)
pooled curve      these subjects and objects   0.957 (0.006)    0.942 (0.010)
population        population                   0.954 (0.007)    0.940 (0.011)
================  ===========================  ===============  ===============

Heterogeneous, the other targets: the credible interval covers the pooled curve's 50 % point in
0.918 (the fitted Weibull's 50 % point is 1.046 times the pooled curve's, geometric mean) and the
population's in 0.564; the population interval covers the two sample targets in 0.999-1.000 (far
too wide for them); the pooled-curve interval covers the population's in 0.648.

Usage::

    python benchmarks/validate_weibull_coverage.py [--reps 500] [--seed 2015] [--workers 1]
        [--kind ideal|heterogeneous|both] [--overdispersion] [--chunk 25]
"""

from __future__ import annotations

import argparse
import copy
import math
import time
import warnings
from multiprocessing import Pool

import numpy as np
from scipy import optimize

from analysis.cluster import cluster_threshold_ci
from analysis.jung2015 import PIXEL_COUNTS
from analysis.pooled_curve import pooled_curve_threshold
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
#: Each printed interval and the target the report says it covers.
STATED = {
    "credible": "fitted Weibull",
    "pooled curve": "these subjects and objects",
    "population": "population",
}
TARGETS = ("fitted Weibull", "these subjects and objects", "population")


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


def sample_threshold(
    obs: WeibullObserver,
    rng: np.random.Generator,
    *,
    n_subjects: int = 6,
    n_objects: int = 20,
    subject_log10_sd: float = 0.0,
    object_log10_sd: float = 0.0,
    subject_lapse_spread: float = 0.0,
    pc: float = 0.5,
) -> tuple[float, float]:
    """Return the 50 % points of the pooled curve and of the fitted Weibull of one study's draws.

    The first is the pooled curve's (the mean curve of the subjects and objects drawn); the second
    that of the ML Weibull fitted to their expected pooled counts at the tested levels.

    ``rng`` must be in the state :func:`simulate_weibull_trials` is given: its first draws (the
    subject shifts, object shifts and subject lapses, in that order) are repeated here.
    """
    s_shift = 10 ** (subject_log10_sd * rng.standard_normal(n_subjects))
    o_shift = (
        10 ** (object_log10_sd * rng.standard_normal(n_objects))
        if object_log10_sd > 0
        else np.ones(n_objects)
    )
    lapse_u = rng.uniform(-1, 1, n_subjects) if subject_lapse_spread > 0 else np.zeros(n_subjects)
    lapse = np.clip(obs.lapse + subject_lapse_spread * lapse_u, 0.0, 1 - 1e-9)
    a = obs.alpha_px * s_shift[:, None] * o_shift[None, :]

    def f(log10_x: float) -> float:
        core = -np.expm1(-((10**log10_x / a) ** obs.beta))
        return float(np.mean((1 - lapse)[:, None] * core)) - pc

    pooled = 10 ** optimize.brentq(f, 0.0, 8.0, xtol=1e-12)
    lv = np.array(sorted(PIXEL_COUNTS), float)
    core = -np.expm1(-((lv[:, None, None] / a[None]) ** obs.beta))
    n = np.full(len(lv), float(n_subjects * n_objects))
    k = n * np.mean((1 - lapse)[None, :, None] * core, axis=(1, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = fit_mle(lv, k, n, prior=default_prior(lv))
    return pooled, float(threshold_at(pc, m.alpha, m.beta, m.lapse))


def _study(args: tuple[np.random.SeedSequence, str]) -> list[dict]:
    """Simulate one study; return per condition its trials' intervals and truths (no MCMC)."""
    seq, kind = args
    rng = np.random.default_rng(seq)
    hetero = kind == "heterogeneous"
    out = []
    for c, obs in TRUTH.items():
        kw = dict(HETERO, subject_lapse_spread=obs.lapse) if hetero else {}
        sample, weib = sample_threshold(obs, copy.deepcopy(rng), **kw)
        d = simulate_weibull_trials({c: obs}, rng=rng, **kw)
        lv, k, n = aggregate(d["pixels"], d["recognized"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mle = fit_mle(lv, k, n, prior=default_prior(lv))
            pop = cluster_threshold_ci(
                d["pixels"], d["recognized"], [d["subject"], d["object"]], mle
            )
            pooled = pooled_curve_threshold(d["pixels"], d["recognized"])
        out.append(
            {
                "condition": c,
                "data": (lv, k, n, mle),
                "truth": {"fitted Weibull": weib, "these subjects and objects": sample},
                "ci": {
                    "population": None if pop is None else pop[:2],
                    "pooled curve": None if pooled is None else pooled["ci95"],
                },
            }
        )
    return out


def run(
    reps: int,
    seed: int,
    kind: str,
    overdispersion: bool = False,
    workers: int = 1,
    chunk: int = 0,
    report=None,
) -> dict:
    """Return coverage of every interval for every target in ``reps`` studies of ``kind``.

    With ``chunk`` > 0 the studies run in chunks of that many, and ``report`` (if given) is
    called with the results so far after each chunk.
    """
    hetero = kind == "heterogeneous"
    sd = math.hypot(HETERO["subject_log10_sd"], HETERO["object_log10_sd"]) if hetero else 0.0
    population = {c: population_threshold(o, sd) for c, o in TRUTH.items()}
    t0 = time.perf_counter()
    seqs = np.random.SeedSequence(seed).spawn(reps)
    size = chunk if chunk > 0 else reps
    hits: dict[tuple[str, str], int] = {}
    per_cond: dict[tuple[str, str, str], int] = {}
    ratio: list[float] = []
    converged: list[bool] = []
    n = 0
    for start in range(0, reps, size):
        args = [(s, kind) for s in seqs[start : start + size]]
        if workers > 1:
            with Pool(workers) as pool:
                studies = pool.map(_study, args, chunksize=5)
        else:
            studies = [_study(a) for a in args]
        rows = [r for st in studies for r in st]
        jobs = [
            FitJob(
                r["condition"],
                *r["data"][:3],
                0.0,
                default_prior(r["data"][0]),
                r["data"][3],
                overdispersion,
            )
            for r in rows
        ]
        fits = fit_batch(jobs, rng=seed + start)
        for r, f in zip(rows, fits, strict=True):
            r["ci"]["credible"] = f.threshold(0.5).ci95
            r["truth"]["population"] = population[r["condition"]]
            converged.append(bool(f.converged))
            ratio.append(
                math.log10(r["truth"]["fitted Weibull"] / r["truth"]["these subjects and objects"])
            )
            for i, ci in r["ci"].items():
                for t, v in r["truth"].items():
                    ok = ci is not None and (ci[0] or 0.0) <= v <= (ci[1] or math.inf)
                    hits[i, t] = hits.get((i, t), 0) + int(ok)
                    key = (i, t, r["condition"])
                    per_cond[key] = per_cond.get(key, 0) + int(ok)
        n += len(rows)
        out = {
            "kind": kind,
            "overdispersion": overdispersion,
            "reps": n // len(TRUTH),
            "n": n,
            "coverage": {k: v / n for k, v in hits.items()},
            "by_condition": {k: v / (n // len(TRUTH)) for k, v in per_cond.items()},
            "weibull_vs_pooled": 10 ** float(np.mean(ratio)),
            "population_truth": population,
            "converged": float(np.mean(converged)),
            "seconds": time.perf_counter() - t0,
        }
        if report is not None and start + size < reps:
            report(out)
    return out


def print_table(r: dict) -> None:
    """Print one setting's coverage table (``*``: the target the report states)."""
    lik = "beta-binomial" if r["overdispersion"] else "binomial"
    print(
        f"{r['kind']}, {lik} credible interval: {r['reps']} studies x {len(TRUTH)} conditions "
        f"= {r['n']} fits ({r['seconds']:.0f} s); chains converged {100 * r['converged']:.1f} %; "
        f"fitted Weibull / pooled curve 50 % point: {r['weibull_vs_pooled']:.3f} (geometric mean)"
    )
    print(f"  {'interval':<13} {'target':<28} coverage  reps   SE     " + "  ".join(TRUTH))
    for i in STATED:
        for t in TARGETS:
            v = r["coverage"][i, t]
            se = math.sqrt(v * (1 - v) / r["n"])
            mark = "*" if STATED[i] == t else " "
            conds = "  ".join(f"{r['by_condition'][i, t, c]:.3f}".ljust(len(c)) for c in TRUTH)
            print(f"{mark} {i:<13} {t:<28} {v:.3f}  {r['n']:>5}  {se:.4f}  {conds}", flush=True)


def main() -> None:
    """Run the validation and print the coverage tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=500, help="simulated studies per setting")
    ap.add_argument("--seed", type=int, default=2015)
    ap.add_argument("--workers", type=int, default=1, help="processes (at most the cores)")
    ap.add_argument("--kind", choices=["ideal", "heterogeneous", "both"], default="both")
    ap.add_argument(
        "--overdispersion", action="store_true", help="beta-binomial credible intervals"
    )
    ap.add_argument("--chunk", type=int, default=0, help="print the table every CHUNK studies")
    a = ap.parse_args()
    kinds = ["ideal", "heterogeneous"] if a.kind == "both" else [a.kind]
    print("SIMULATED data (known observers), paper design 6 x 20 x 8 x 2")
    for kind in kinds:
        print_table(
            run(a.reps, a.seed, kind, a.overdispersion, a.workers, a.chunk, report=print_table)
        )


if __name__ == "__main__":
    main()
