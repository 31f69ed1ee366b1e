"""Coverage of each reported interval for the question it answers, and of odds-ratio intervals.

Simulates the paper's design (6 subjects x 20 objects x 8 levels x 2 conditions; Jung et al. 2015,
Sec. 3.1) from known Weibull observers in two settings, fits each condition's pooled data exactly
as ``confocal analyze`` does (binomial ML start, batch posterior sampler, binomial or
beta-binomial likelihood), and counts how often each 95 % interval covers the truth of each
question:

* ``ideal``: every subject and object the same observer (binomial data); both questions have the
  same answer, the observer's 50 % threshold;
* ``heterogeneous``: as a real study, ``log10(alpha)`` shifted per subject (SD 0.15) and per object
  (SD 0.2), and each subject's lapse rate drawn uniformly in [0, 2 x lapse] (ours, near the spread
  of the paper's Fig. 9 and Fig. S3). Two truths:

  - "these subjects and objects": the 50 % point of the pooled curve of the subjects and objects
    drawn in that study (their random effects reproduced from the same random stream);
  - "the population of subjects and objects": the 50 % point of the population's curve, averaged
    over the random effects (Gauss-Hermite, 64 nodes).

The credible interval (binomial or beta-binomial) and the two-way cluster-robust population
interval are each scored against both truths; the report's default for each question is the
interval whose coverage is 0.93-0.97 for it.

``--odds-ratios`` also simulates the paper's logistic model (fixed effects: background OR 5.6,
OR 74.5 per log10 pixels, 19 object effects; Jung et al. 2015, Sec. 3.2.2) and scores the Wald,
profile-likelihood and Firth profile-likelihood 95 % intervals of both odds ratios.

Prints each coverage with a Clopper-Pearson 95 % interval; a calibrated method gives about 0.95.
Simulated data only (labelled so in the output).

Usage::

    python benchmarks/validate_weibull_coverage.py [--reps 200] [--seed 2015] [--compare]
        [--odds-ratios]
"""

from __future__ import annotations

import argparse
import copy
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
) -> float:
    """Return the 50 % point of the pooled curve of the subjects and objects one study draws.

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
    jobs, conds, pop, sample_truth = [], [], [], []
    for child in np.random.SeedSequence(seed).spawn(reps):
        rng = np.random.default_rng(child)
        # Lapse spread per condition = that condition's lapse (uniform in [0, 2 lapse]).
        parts = []
        for c, obs in TRUTH.items():
            extra = {"subject_lapse_spread": obs.lapse} if hetero else {}
            sample_truth.append(sample_threshold(obs, copy.deepcopy(rng), **{**kw, **extra}))
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
    widths = {c: [] for c in TRUTH}
    # (interval, question) -> number of studies x conditions covered
    cover = {(i, q): 0 for i in ("credible", "population") for q in ("sample", "population")}
    for c, f, pi, st in zip(conds, fits, pop, sample_truth, strict=True):
        lo, hi = f.threshold(0.5).ci95
        hits[c] += lo <= truth[c] <= hi
        widths[c].append(math.log10(hi / lo) if lo > 0 and math.isfinite(hi) else math.inf)
        for q, t in (("sample", st), ("population", truth[c])):
            cover["credible", q] += lo <= t <= hi
            cover["population", q] += pi is not None and pi[0] <= t <= pi[1]
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
        "population": cover["population", "population"] / n,
        "population_ci95": clopper_pearson(cover["population", "population"], n),
        "by_question": {
            f"{i} interval, {q} truth": (v / n, clopper_pearson(v, n))
            for (i, q), v in cover.items()
        },
        "converged": float(np.mean([f.converged for f in fits])),
        "median_log10_width": {c: float(np.median(w)) for c, w in widths.items()},
        "seconds": time.perf_counter() - t0,
    }


#: Object effects of the simulated logistic model, log odds vs object 1 (ours: SD 1, the spread
#: of the paper's Fig. S3 difficulties), fixed across simulated studies.
OBJECT_LOG_ODDS = np.concatenate([[0.0], np.random.default_rng(25).normal(0.0, 1.0, 19)])


def run_odds_ratios(reps: int, seed: int) -> dict:
    """Return coverage of Wald, profile and Firth-profile 95 % intervals of both odds ratios.

    Data: the paper's design from its fixed-effects logistic model (background OR 5.6, OR 74.5 per
    log10 pixels; Jung et al. 2015, Sec. 3.2.2), object effects :data:`OBJECT_LOG_ODDS`, and an
    intercept putting the cluttered 50 % point at 8,695 px.
    """
    import statsmodels.api as sm
    from scipy import special

    from analysis.logistic import design_frame, firth_logit, profile_interval
    from analysis.simulate import design

    d = design()
    f = design_frame(d.assign(recognized=0))
    obj = f["object"].astype(int).to_numpy() - 1
    dummies = (obj[:, None] == np.arange(1, 20)[None, :]).astype(float)
    X = np.column_stack([np.ones(len(f)), f["background"], dummies, f["log10_pixels"]])
    b_bg, b_px = math.log(5.6), math.log(74.5)
    eta = -b_px * math.log10(8695.0) + b_bg * X[:, 1] + OBJECT_LOG_ODDS[obj] + b_px * X[:, -1]
    p = special.expit(eta)
    truth = {"background": (1, b_bg), "log10_pixels": (X.shape[1] - 1, b_px)}
    hits = {(m, t): 0 for m in ("wald", "profile", "firth profile") for t in truth}
    bias = {t: [] for t in truth}
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    done = 0
    for _ in range(reps):
        y = (rng.random(len(p)) < p).astype(float)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = sm.Logit(y, X).fit(method="newton", tol=1e-12, maxiter=200, disp=False)
        b, se = np.asarray(res.params), np.asarray(res.bse)
        if not np.all(np.isfinite(se)):
            continue
        done += 1
        bf, sef, _ = firth_logit(y, X)
        for t, (j, true) in truth.items():
            bias[t].append(b[j] / true - 1)
            z = 1.959963984540054
            hits["wald", t] += b[j] - z * se[j] <= true <= b[j] + z * se[j]
            lo, hi = profile_interval(y, X, j, params=b, bse=se)
            hits["profile", t] += lo <= true <= hi
            lo, hi = profile_interval(y, X, j, params=bf, bse=sef, penalized=True)
            hits["firth profile", t] += lo <= true <= hi
    return {
        "reps": done,
        "coverage": {
            f"{m}, {t}": (v / done, clopper_pearson(v, done)) for (m, t), v in hits.items()
        },
        "ml_bias": {t: float(np.mean(v)) for t, v in bias.items()},
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
    ap.add_argument("--reps", type=int, default=200, help="simulated studies per setting")
    ap.add_argument("--seed", type=int, default=2015)
    ap.add_argument("--kind", choices=["ideal", "heterogeneous", "both", "none"], default="both")
    ap.add_argument("--no-overdispersion", action="store_true", help="binomial posteriors")
    ap.add_argument("--compare", action="store_true", help="also run the other likelihood")
    ap.add_argument("--odds-ratios", action="store_true", help="also score odds-ratio intervals")
    a = ap.parse_args()
    kinds = {"both": ["ideal", "heterogeneous"], "none": []}.get(a.kind, [a.kind])
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
            for name, (v, (lo, hi)) in r["by_question"].items():
                print(f"  {name}: coverage {v:.3f} (95% Clopper-Pearson {lo:.3f}-{hi:.3f})")
    if a.odds_ratios:
        r = run_odds_ratios(a.reps, a.seed)
        print(
            f"logistic model (fixed effects, OR 5.6 and 74.5): {r['reps']} studies "
            f"({r['seconds']:.0f} s); mean ML bias of the log odds ratio: "
            + ", ".join(f"{t} {100 * v:+.1f} %" for t, v in r["ml_bias"].items())
        )
        for name, (v, (lo, hi)) in r["coverage"].items():
            print(f"  {name}: coverage {v:.3f} (95% Clopper-Pearson {lo:.3f}-{hi:.3f})")


if __name__ == "__main__":
    main()
