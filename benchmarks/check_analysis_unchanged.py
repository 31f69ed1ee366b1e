"""Check that a refactor of ``analysis/`` leaves its numbers unchanged, to the last bit.

Fits fixed data with fixed seeds through the public entry points -- the psychometric function,
``fit_mle``, ``fit_counts``/``fit_weibull`` (binomial and beta-binomial, log and linear axes),
``sample_posterior`` (emcee), ``fit_table`` (``confocal analyze fit``), the pipeline's
``analyze`` and ``confocal analyze`` itself on a small simulated trial table, the cluster-robust
interval and a tiny power simulation -- and prints every number as JSON. Floats are written with
``repr`` precision and posterior samples as sha256 digests of their bytes, so two runs agree
only if every number agrees exactly.

Usage::

    python benchmarks/check_analysis_unchanged.py > before.json     # before the change
    python benchmarks/check_analysis_unchanged.py --compare before.json   # after it

``--compare`` exits 1 and lists the differing entries when anything changed, 0 when all match.
The run takes about a minute on 2 cores.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import math
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from analysis import weibull
from analysis.cluster import cluster_threshold_ci
from analysis.data import read_trials
from analysis.pipeline import AnalysisOptions, analyze
from analysis.power import power_analysis
from analysis.psychometric import FitSpec, fit_table
from analysis.simulate import WeibullObserver, simulate_weibull_trials

__all__ = ["collect", "compare"]

#: Simulated observers (ours), near the paper's Fig. 8 curves (as tests/analysis/conftest.py).
TRUTH = {
    "cluttered": WeibullObserver(alpha_px=10_500.0, beta=1.3, lapse=0.06),
    "decluttered": WeibullObserver(alpha_px=4_300.0, beta=1.1, lapse=0.04),
}
#: Fixed counts (ours): a rising curve with a lapse, eight levels from 100 to 60,000 px.
LEVELS_PX = (100.0, 300.0, 1_000.0, 2_500.0, 5_000.0, 10_000.0, 25_000.0, 60_000.0)
K = (0.0, 1.0, 3.0, 6.0, 10.0, 13.0, 17.0, 18.0)
N = (20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0, 20.0)


def _plain(v: Any) -> Any:
    """Return ``v`` as JSON data; floats keep full precision, NaN/inf become strings."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        v = float(v)
        return v if math.isfinite(v) else repr(v)
    return v


def _digest(a: np.ndarray) -> str:
    a = np.ascontiguousarray(np.asarray(a, dtype=float))
    return f"{a.shape} sha256:{hashlib.sha256(a.tobytes()).hexdigest()}"


def _fit(fit: weibull.WeibullFit, pc: float = 0.75) -> dict[str, Any]:
    d = fit.to_dict()
    d["samples"] = _digest(fit.samples)
    d["summary"] = fit.summary(pc)
    d["threshold_pc"] = fit.threshold(pc).to_dict()
    d["threshold_text"] = fit.threshold(0.5).text(unit="px")
    band = fit.curve_band(np.array(LEVELS_PX))
    d["curve_band"] = [list(b) for b in band]
    return d


def _warned(fn, *args, **kwargs) -> tuple[Any, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args, **kwargs)
    return out, [f"{w.category.__name__}: {w.message}" for w in caught]


def collect(seed: int = 11) -> dict[str, Any]:
    """Return every checked number, keyed by what produced it."""
    out: dict[str, Any] = {}
    x = np.array(LEVELS_PX)
    k, n = np.array(K), np.array(N)

    # The model: curve, thresholds, aggregation, default priors, ML fits on every sigmoid.
    for sigmoid in weibull.SIGMOIDS:
        xs = x if sigmoid in ("weibull", "loglogistic", "lognormal") else np.log10(x)
        out[f"psychometric/{sigmoid}"] = weibull.psychometric(xs, xs[3], 1.7, 0.05, sigmoid=sigmoid)
        out[f"threshold_at/{sigmoid}"] = weibull.threshold_at(
            0.6, [xs[2], xs[4]], [1.2, 3.0], [0.0, 0.1], guess=0.1, sigmoid=sigmoid
        )
        prior = weibull.default_prior(xs, guess=0.1, sigmoid=sigmoid, lapse_a=1.5, lapse_b=12.0)
        out[f"default_prior/{sigmoid}"] = prior.to_dict()
        out[f"prior_log_prob/{sigmoid}"] = prior.log_prob(
            np.array([[np.mean(prior.loc_range), np.mean(prior.log_beta_range), 0.03, 0.1]])
        )
        out[f"fit_mle/{sigmoid}"] = weibull.fit_mle(xs, k, n, guess=0.1, sigmoid=sigmoid).to_dict()
    trials_x = np.repeat(x, 3)
    trials_c = (np.arange(len(trials_x)) % 3 < np.repeat([0, 0, 1, 1, 2, 2, 3, 3], 3)).astype(int)
    out["aggregate"] = weibull.aggregate(trials_x, trials_c)

    # Posteriors through the public fitting functions (the batch sampler behind them).
    fit, w = _warned(weibull.fit_counts, x, k, n, label="counts", rng=seed)
    out["fit_counts/weibull"] = {**_fit(fit), "warnings": w}
    fit = weibull.fit_counts(x, k, n, overdispersion=True, label="od", rng=seed + 1)
    out["fit_counts/weibull_overdispersion"] = {
        **_fit(fit),
        "goodness_of_fit_seed3": fit.goodness_of_fit(n_draws=500, rng=3),
    }
    fit = weibull.fit_counts(np.log10(x), k, n, sigmoid="logistic", guess=0.05, rng=seed + 2)
    out["fit_counts/logistic"] = _fit(fit)
    fit, w = _warned(weibull.fit_weibull, trials_x, trials_c, label="few trials", rng=seed + 3)
    out["fit_weibull/few_trials"] = {**_fit(fit), "warnings": w}
    fit, w = _warned(weibull.fit_counts, x[:2], n[:2], n[:2], label="all correct", rng=seed + 4)
    out["fit_counts/all_correct"] = {**_fit(fit), "warnings": w}
    out["fit_weibull/round_trip"] = _fit(weibull.WeibullFit.from_dict(fit.to_dict()))

    # emcee posterior, chunk by chunk.
    steps = []
    for prog in weibull.sample_posterior(x, k, n, overdispersion=True, max_steps=1_000, rng=seed):
        chain = prog.sampler.get_chain()
        steps.append([prog.n_steps, prog.tau_max, prog.converged, _digest(chain)])
    out["sample_posterior"] = steps

    # confocal analyze fit: a table, grouped, overdispersed, two thresholds.
    trials = simulate_weibull_trials(TRUTH, n_subjects=2, subject_log10_sd=0.1, rng=7)
    spec = FitSpec(x="pixels", y="recognized", group=("condition",), pcs=(0.5, 0.8), seed=seed)
    table = fit_table(trials, spec, source="simulated")
    out["fit_table"] = {
        "sigmoid": table.sigmoid,
        "warnings": list(table.warnings),
        "groups": [
            {"group": g.group, "warnings": list(g.warnings), "fit": _fit(g.fit)}
            for g in table.groups
        ],
    }

    # The pipeline (confocal analyze run) in process and through the command line.
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "small.csv"
        trials.to_csv(csv, index=False)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            steps = list(analyze(read_trials([csv]), AnalysisOptions(seed=3, pc=0.7)))
        result = steps[-1].result
        out["analyze/results_json"] = result.results_json()
        out["analyze/samples"] = {
            label: _digest(f.samples)
            for label, f in [
                *result.thresholds.items(),
                *[
                    (f"{s}/{c}", f)
                    for s, fits in result.subject_thresholds.items()
                    for c, f in fits.items()
                ],
            ]
        }
        out["analyze/steps"] = [[s.done, s.total, s.label] for s in steps]
        from experiment.cli import main

        report = Path(tmp) / "report"
        printed = io.StringIO()
        try:
            with contextlib.redirect_stdout(printed):
                main(["analyze", str(csv), "--out", str(report), "--seed", "1", "--no-figures"])
        except SystemExit as exc:
            if exc.code not in (0, None):
                raise
        out["confocal_analyze/printed"] = printed.getvalue()
        out["confocal_analyze/results_json"] = json.loads((report / "results.json").read_text())
        out["confocal_analyze/report_md"] = (report / "report.md").read_text()
        # The temporary folder's name is the one thing that differs from run to run.
        out = json.loads(json.dumps(_plain(out)).replace(tmp, "<tmp>"))

    # Population interval and a tiny power simulation (both reuse the model's likelihood).
    pooled = result.thresholds["cluttered"]
    sel = trials[trials["condition"] == "cluttered"]
    out["cluster_threshold_ci"] = cluster_threshold_ci(
        sel["pixels"].to_numpy(),
        sel["recognized"].to_numpy(),
        [sel["subject"].to_numpy(), sel["object"].to_numpy()],
        pooled.mle,
        pc=0.7,
    )
    power = power_analysis("threshold_ratio", 2.5, (1, 2), n_sims=3, rng=seed)
    out["power_analysis"] = [[p.n_subjects, p.power, p.ci95] for p in power.points]
    return _plain(out)


def compare(new: Any, old: Any, path: str = "") -> list[str]:
    """Return the paths at which ``new`` and ``old`` differ (exact comparison)."""
    if isinstance(new, dict) and isinstance(old, dict):
        diffs = [f"{path}/{k}: missing now" for k in old if k not in new]
        diffs += [f"{path}/{k}: new entry" for k in new if k not in old]
        for k in new:
            if k in old:
                diffs += compare(new[k], old[k], f"{path}/{k}")
        return diffs
    if isinstance(new, list) and isinstance(old, list) and len(new) == len(old):
        pairs = enumerate(zip(new, old, strict=True))
        return [d for i, (a, b) in pairs for d in compare(a, b, f"{path}[{i}]")]
    return [] if new == old else [f"{path}: {old!r} -> {new!r}"[:300]]


def main(argv: list[str] | None = None) -> int:
    """Print the numbers as JSON, or compare them with a saved run."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--compare", type=Path, help="JSON of an earlier run to compare with")
    ap.add_argument("--seed", type=int, default=11)
    args = ap.parse_args(argv)
    numbers = collect(args.seed)
    if args.compare is None:
        json.dump(numbers, sys.stdout, indent=1, sort_keys=True)
        sys.stdout.write("\n")
        return 0
    old = json.loads(args.compare.read_text())
    diffs = compare(json.loads(json.dumps(numbers)), old)
    for d in diffs[:50]:
        print(d)
    n_numbers = json.dumps(old).count(",") + 1
    print(
        f"{'MATCH' if not diffs else 'DIFFER'}: {len(diffs)} differing entries "
        f"(about {n_numbers} values compared)"
    )
    return 0 if not diffs else 1


if __name__ == "__main__":
    sys.exit(main())
