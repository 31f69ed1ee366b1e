"""Speed of the full analysis: 1,920 trials, 2 pooled + 12 per-subject posteriors, logistic
model, figures (issue 4: under 30 s on 2 cores, every pooled chain converged).

Also times, in the same process, a baseline posterior sampler for the two pooled fits: emcee as
used out of the box (default stretch move, a scalar log-probability called once per walker,
32 walkers started in a ball at the centre of the prior box), run to the same convergence rule
(chain >= 50 tau). The ratio baseline / ours is what the speed-ups (vectorised log-probability,
differential-evolution moves, 12 walkers, MLE start) buy on this machine, whatever its load.

Usage::

    python benchmarks/bench_analysis.py [--seed 1] [--out /tmp/bench_report]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings
from pathlib import Path

import emcee
import numpy as np

from analysis.data import read_trials
from analysis.pipeline import AnalysisOptions, analyze
from analysis.report import write_report
from analysis.simulate import WeibullObserver, simulate_weibull_trials
from analysis.weibull import _log_likelihood, aggregate, default_prior

#: Simulated observers (ours), near the paper's Fig. 8 curves, with subjects spread by 0.15 log10.
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}
LIMIT_S = 30.0


def baseline_fit(levels, k, n, seed: int) -> tuple[float, int, float]:
    """Out-of-the-box emcee to 50 tau; return (seconds, steps, tau_max)."""
    prior = default_prior(levels)

    def log_prob(theta):
        lp = float(prior.log_prob(theta))
        if not np.isfinite(lp):
            return -np.inf
        return lp + float(_log_likelihood(theta[None, :], levels, k, n, 0.0, "weibull")[0])

    rng = np.random.default_rng(seed)
    box = np.array(prior.bounds())
    centre = np.array([box[0].mean(), box[1].mean(), 0.05])
    p0 = centre + 1e-2 * (box[:, 1] - box[:, 0]) * rng.standard_normal((32, 3))
    p0[:, 2] = np.abs(p0[:, 2])
    sampler = emcee.EnsembleSampler(32, 3, log_prob)
    t0 = time.perf_counter()
    state, steps, tau_max = p0, 0, np.inf
    while steps < 40_000:
        state = sampler.run_mcmc(state, 500, progress=False)
        steps += 500
        tau_max = float(np.max(emcee.autocorr.integrated_time(sampler.get_chain(), tol=0)))
        if steps >= 50 * tau_max:
            break
    return time.perf_counter() - t0, steps, tau_max


def main() -> None:
    """Run the benchmark and print times, the ratio to the baseline and convergence."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=None, help="report folder (default: temporary)")
    a = ap.parse_args()
    print(f"cpus available: {len(os.sched_getaffinity(0))}; load average: {os.getloadavg()}")
    trials = simulate_weibull_trials(TRUTH, subject_log10_sd=0.15, rng=a.seed)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "trials.csv"
        trials.to_csv(csv, index=False)
        out = a.out or Path(tmp) / "report"

        t0, c0 = time.perf_counter(), time.process_time()
        table = read_trials([csv])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            steps = list(analyze(table, AnalysisOptions(seed=a.seed)))
        t_fit = time.perf_counter() - t0
        result = steps[-1].result
        write_report(result, out)
        total, cpu = time.perf_counter() - t0, time.process_time() - c0
        n_post = len(result.thresholds) + sum(len(v) for v in result.subject_thresholds.values())
        print(
            f"full analysis: {len(trials)} trials, {n_post} posteriors + logistic + figures: "
            f"{total:.1f} s wall ({cpu:.1f} s CPU; fits {t_fit:.1f} s, "
            f"report {total - t_fit:.1f} s)"
        )
        pooled_ok = all(f.converged for f in result.thresholds.values())
        subj_ok = sum(f.converged for v in result.subject_thresholds.values() for f in v.values())
        for c, f in result.thresholds.items():
            print(
                f"  pooled {c}: converged={f.converged} steps={f.n_steps} tau_max={f.tau_max:.1f}"
            )
        print(f"  per-subject chains converged: {subj_ok}/{n_post - len(result.thresholds)}")
        print(f"limit {LIMIT_S:.0f} s: {'PASS' if total < LIMIT_S and pooled_ok else 'FAIL'}")

        base_t, ours_t = 0.0, 0.0
        for c in result.thresholds:
            sel = trials[trials["condition"] == c]
            lv, k, n = aggregate(sel["pixels"], sel["recognized"])
            bt, bs, btau = baseline_fit(lv, k, n, a.seed)
            from analysis.weibull import fit_weibull

            t1 = time.perf_counter()
            f = fit_weibull(sel["pixels"], sel["recognized"], rng=a.seed)
            ot = time.perf_counter() - t1
            print(
                f"  {c}: baseline emcee {bt:.2f} s ({bs} steps x 32 walkers, tau {btau:.0f}); "
                f"ours {ot:.2f} s ({f.n_steps} steps x {f.n_walkers} walkers, tau {f.tau_max:.0f})"
            )
            base_t += bt
            ours_t += ot
        print(
            f"pooled posteriors: baseline {base_t:.2f} s, ours {ours_t:.2f} s, "
            f"speed-up x{base_t / ours_t:.1f}"
        )


if __name__ == "__main__":
    main()
