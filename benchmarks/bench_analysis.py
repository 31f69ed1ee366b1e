"""Speed of the full analysis: 1,920 trials, 2 pooled + 12 per-subject posteriors, logistic
model, results.json, report.md and figures (goal: under 10 s on 2 cores, every chain
converged). Simulated data (labelled so in the output).

Also times, in the same process, a baseline for the 14 posteriors: emcee as used out of the box
(default stretch move, a scalar log-probability called once per walker, 32 walkers started in a ball
at the centre of the prior box), run to the same convergence rule (chain >= 50 tau), one posterior
after another. Ours samples all 14 at once (analysis.weibull.batch: one vectorised step for every
fit's walkers, differential-evolution moves, ML start). The ratio baseline / ours is what that buys
on this machine, whatever its load; the load average is printed too.

It also reports the CPU time (user + system, this process and its child processes: the figure
workers) of the default analysis with figures, in this process (``--repeat`` times, the minimum
too) and as the whole ``confocal analyze`` command in a subprocess (its imports included), each
beside the load average: CPU time is inflated less than wall time by other work on a shared
machine, but not immune to it (shared caches and cores).

Usage::

    python benchmarks/bench_analysis.py [--seed 1] [--repeat 3] [--out /tmp/bench_report]
        [--no-baseline]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
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
from analysis.weibull import default_prior
from analysis.weibull.kernel import log_likelihood

#: Simulated observers (ours), near the paper's Fig. 8 curves, with subjects spread by 0.15 log10.
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}
LIMIT_S = 10.0
#: Goal for the CPU time of the default analysis with figures (ours, from the study's plan).
CPU_GOAL_S = 3.0


def cpu_s() -> float:
    """CPU seconds (user + system) of this process and its finished child processes."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime + c.ru_utime + c.ru_stime


def _load() -> str:
    return f"load average {os.getloadavg()[0]:.1f} on {len(os.sched_getaffinity(0))} cores"


def command_cpu(csv: Path, out: Path, seed: int) -> tuple[float, float]:
    """Run ``confocal analyze CSV --out OUT --seed SEED`` (figures on); return (wall s, CPU s).

    The CPU time is the subprocess's and its children's, imports included.
    """
    exe = shutil.which("confocal")
    cmd = [exe] if exe else [sys.executable, "-c", "from experiment.cli import main; main()"]
    shutil.rmtree(out, ignore_errors=True)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    c0 = c.ru_utime + c.ru_stime
    t0 = time.perf_counter()
    subprocess.run(
        [*cmd, "analyze", str(csv), "--out", str(out), "--seed", str(seed)],
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter() - t0, c.ru_utime + c.ru_stime - c0


def baseline_fit(levels, k, n, seed: int) -> tuple[float, int, float]:
    """Out-of-the-box emcee to 50 tau; return (seconds, steps, tau_max)."""
    prior = default_prior(levels)

    def log_prob(theta):
        lp = float(prior.log_prob(theta))
        if not np.isfinite(lp):
            return -np.inf
        return lp + float(log_likelihood(theta[None, :], levels, k, n, 0.0, "weibull")[0])

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
    ap.add_argument("--repeat", type=int, default=3, help="analyses timed (the minimum is kept)")
    ap.add_argument(
        "--no-baseline", action="store_true", help="skip the emcee baseline (minutes when busy)"
    )
    a = ap.parse_args()
    print(f"cpus available: {len(os.sched_getaffinity(0))}; load average: {os.getloadavg()}")
    trials = simulate_weibull_trials(TRUTH, subject_log10_sd=0.15, rng=a.seed)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "trials.csv"
        trials.to_csv(csv, index=False)
        out = a.out or Path(tmp) / "report"

        cpus, walls, fit_walls = [], [], []
        for k in range(max(1, a.repeat)):
            shutil.rmtree(out, ignore_errors=True)
            t0, c0 = time.perf_counter(), cpu_s()
            table = read_trials([csv])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                steps = list(analyze(table, AnalysisOptions(seed=a.seed)))
            t_fit, c_fit = time.perf_counter() - t0, cpu_s() - c0
            result = steps[-1].result
            write_report(result, out)
            total, cpu = time.perf_counter() - t0, cpu_s() - c0
            cpus.append(cpu)
            walls.append(total)
            fit_walls.append(t_fit)
            print(
                f"  analysis {k + 1}: {total:.1f} s wall, {cpu:.2f} s CPU (fits {c_fit:.2f} s, "
                f"report and figures {cpu - c_fit:.2f} s); {_load()}"
            )
        cmd_runs = []
        for k in range(max(1, a.repeat)):
            w, c = command_cpu(csv, Path(tmp) / "cmd_report", a.seed)
            cmd_runs.append(c)
            print(f"  confocal analyze {k + 1}: {w:.1f} s wall, {c:.2f} s CPU; {_load()}")
        total, cpu, t_fit = min(walls), min(cpus), min(fit_walls)
        n_post = len(result.thresholds) + sum(len(v) for v in result.subject_thresholds.values())
        print(
            f"full analysis: {len(trials)} trials, {n_post} posteriors + logistic + figures: "
            f"{total:.1f} s wall ({cpu:.1f} s CPU incl. child processes; fits {t_fit:.1f} s, "
            f"report {total - t_fit:.1f} s)"
        )
        fits = list(result.thresholds.values()) + [
            f for v in result.subject_thresholds.values() for f in v.values()
        ]
        all_ok = all(f.converged for f in fits)
        for c, f in result.thresholds.items():
            print(
                f"  pooled {c}: converged={f.converged} steps={f.n_steps} tau_max={f.tau_max:.1f}"
            )
        print(f"  chains converged: {sum(f.converged for f in fits)}/{len(fits)}")
        print(f"limit {LIMIT_S:.0f} s: {'PASS' if total < LIMIT_S and all_ok else 'FAIL'}")
        print(
            f"CPU of the default analysis with figures (minimum of {len(cpus)}): {cpu:.2f} s in "
            f"this process, {min(cmd_runs):.2f} s as the whole command (imports included); goal "
            f"{CPU_GOAL_S:g} s: {'met' if cpu < CPU_GOAL_S else 'NOT met'} (in this process)"
        )

        if a.no_baseline:
            print(f"load average after: {os.getloadavg()}")
            return
        base_t, n_base, base_ok, base_c0 = 0.0, 0, 0, cpu_s()
        for f in fits:
            lv, k, n = np.asarray(f.pixels), np.asarray(f.k), np.asarray(f.n)
            bt, bs, btau = baseline_fit(lv, k, n, a.seed)
            base_t += bt
            n_base += 1
            base_ok += bs >= 50 * btau
        print(
            f"14 posteriors: baseline emcee {base_t:.2f} s ({base_ok}/{n_base} converged, "
            f"binomial); ours {t_fit:.2f} s for the whole fitting stage (ML starts included, "
            f"the default binomial fits); speed-up x{base_t / t_fit:.1f}"
        )
        base_cpu = cpu_s() - base_c0
        print(
            f"CPU: baseline emcee {base_cpu:.2f} s for the 14 posteriors alone; the whole default "
            f"analysis with figures {cpu:.2f} s, x{base_cpu / cpu:.1f} less"
        )
        print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
