"""One answer per question: the console, results.json and the report print the same odds ratio
(one estimator, named beside it); ``analyze run`` and ``analyze fit`` fit the same default model
and agree on the same trials; a profile interval that cannot be computed is said so, never
replaced by a narrower Wald interval; a censored threshold sits on the side the data put it."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import optimize, special, stats

from analysis.logistic import design_frame, fit_logistic
from tests.conftest import run_cli


def _cli(argv, capsys):
    rc = run_cli(argv)
    return rc, capsys.readouterr()


@pytest.fixture(scope="module")
def run_and_fit(tmp_path_factory, small_csv):
    """``analyze run`` and ``analyze fit --pc 0.5`` on the same 640 trials (seeded)."""
    import contextlib
    import io

    root = tmp_path_factory.mktemp("one_answer")
    outs = {}
    for name, argv in (
        ("run", ["analyze", "run", small_csv, "--by", "none", "--no-figures", "--seed", "2"]),
        (
            "fit",
            ["analyze", "fit", small_csv, "--x", "pixels", "--y", "recognized"]
            + ["--group", "condition", "--pc", "0.5", "--no-plots", "--seed", "2"],
        ),
    ):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rc = run_cli([*argv, "--out", root / name])
        assert rc == 0, buf.getvalue()
        r = json.loads((root / name / "results.json").read_text())
        outs[name] = (buf.getvalue(), r, (root / name / "report.md").read_text())
    return outs


def test_console_odds_ratio_is_results_json_s_and_the_report_s(run_and_fit):
    console, r, report = run_and_fit["run"]
    for term in ("background", "log10_pixels"):
        iv = r["logistic"]["intervals"][term]
        line = next(ln for ln in console.splitlines() if ln.startswith(f"odds ratio {term:>12}"))
        shown = f"{iv['or']:.3g} (95% CI {iv['ci95'][0]:.3g}-{iv['ci95'][1]:.3g}"
        assert shown in line and iv["estimator"] in line
        # the one estimate is Firth's, not the ML one the console printed before
        assert iv["or"] == pytest.approx(iv["firth_or"]) and f"{iv['ml_or']:.3g}" not in line
        ends = f"{iv['ci95'][0]:.3g}-{iv['ci95'][1]:.3g}"
        assert f"{iv['or']:.3g} (Firth's estimate; 95 % CI {ends} Firth profile" in report
    bg = r["logistic"]["intervals"]["background"]["or"]
    pr = r["predictions"]["decluttered_if_cluttered_50pct"]
    assert pr == pytest.approx(bg / (1 + bg))  # Eq. 1 uses the same odds ratio


def test_run_and_fit_state_the_same_default_model_and_agree(run_and_fit):
    c_run, r_run, _ = run_and_fit["run"]
    c_fit, r_fit, _ = run_and_fit["fit"]
    line = "model: binomial (the default; --overdispersion for beta-binomial)"
    assert line in c_run and line in c_fit
    assert r_run["overdispersion"] is False and r_fit["overdispersion"] is False
    for g in r_fit["groups"]:
        cond = g["group"]["condition"]
        t_fit = g["thresholds"][0]
        t_run = r_run["thresholds"][cond]["threshold_50"]
        assert t_fit["status"] == t_run["status"]
        assert t_fit["median"] == pytest.approx(t_run["median"], rel=0.05)
        assert t_fit["mle"] == pytest.approx(t_run["mle"], rel=0.01)


def _brute_profile(y, X, j, bj):
    """Max over the other coefficients of Firth's penalised log-likelihood, b_j fixed (scipy)."""
    free = [i for i in range(X.shape[1]) if i != j]

    def nll(c):
        b = np.empty(X.shape[1])
        b[j], b[free] = bj, c
        eta = X @ b
        w = special.expit(eta) * special.expit(-eta)
        info = X.T @ (w[:, None] * X)
        return -(np.sum(y * eta - np.logaddexp(0, eta)) + 0.5 * np.linalg.slogdet(info)[1])

    start = np.zeros(len(free))
    start[0] = -bj * X[:, j].mean()  # the intercept that keeps the mean linear predictor
    r = optimize.minimize(
        nll, start, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12, "maxiter": 20000}
    )
    r = optimize.minimize(nll, r.x, method="BFGS", options={"gtol": 1e-9})
    return -r.fun


def _sixteen_trials():
    """16 trials at two adjacent levels, the slope separated (none at the low level but one)."""
    rows = []
    for cond in ("cluttered", "decluttered"):
        for px, rec in ((3290, 0), (17876, 1)):
            for r in range(4):
                hit = rec or (cond == "decluttered" and r == 0)
                rows.append(("s1", str(r % 2 + 1), cond, px, int(hit)))
    return pd.DataFrame(rows, columns=["subject", "object", "condition", "pixels", "recognized"])


def test_separated_slope_gets_its_profile_not_a_silent_wald_interval():
    """The profile used to fail (singular start far out) and the report fell back to Wald
    [2.66, 51,905] without a word; the profile runs to 706,714, checked by brute force."""
    t = _sixteen_trials()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = fit_logistic(t)
    iv = f.intervals("log10_pixels")
    assert f.method == "firth" and iv["interval"] == "firth_profile"
    d = design_frame(t)
    X = np.column_stack([np.ones(len(d)), d["background"], d["log10_pixels"]])
    y = d["recognized"].to_numpy(float)
    j = 2
    bhat = math.log(iv["or"])
    l_max = _brute_profile(y, X, j, bhat)
    cut = stats.chi2.ppf(0.95, 1)
    for end in iv["ci95"]:
        dev = 2 * (l_max - _brute_profile(y, X, j, math.log(end)))
        assert dev == pytest.approx(cut, abs=0.02)
    wald = f.odds_ratios["log10_pixels"]["ci95"]
    assert iv["ci95"][1] > 10 * wald[1]  # the Wald end is far too low


def test_a_failed_profile_is_said_and_no_interval_is_given(monkeypatch, tmp_path, capsys):
    import analysis.logistic as lg

    real = lg.profile_interval

    def failing(y, X, j, **kw):
        if kw.get("penalized") and j == X.shape[1] - 1:  # log10 pixels, the last column
            raise np.linalg.LinAlgError("singular information matrix")
        return real(y, X, j, **kw)

    monkeypatch.setattr(lg, "profile_interval", failing)
    t = _sixteen_trials()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = lg.fit_logistic(t)
    iv = f.intervals("log10_pixels")
    assert iv["interval"] == "none" and iv["ci95"] == [None, None]
    assert "could not be computed" in iv["note"]
    assert any("log10_pixels odds ratio could not be computed" in w for w in f.warnings)
    from analysis.cli import _ci_text
    from analysis.report import _or_text

    assert _ci_text(iv["ci95"]) == "no interval: its profile could not be computed"
    text = _or_text(f.odds_ratios["log10_pixels"], "log10_pixels", f.separated, None, iv)
    assert "no 95 % CI" in text and "Wald" not in text.split("no 95 % CI")[1].split(";")[0]


def test_censored_below_only_when_no_tested_level_is_below_pc():
    """Two levels, 47 % correct at the lower: the 50 % threshold is above 3,290, whatever the
    posterior median says; it used to be printed "< 3,290 px"."""
    from analysis.weibull import default_prior, fit_mle
    from analysis.weibull.batch import FitJob, sample_batch

    levels = np.array([3290.0, 17876.0])
    k, n = np.array([9.0, 17.0]), np.array([19.0, 20.0])  # 47 % at 3,290
    prior = default_prior(levels)
    mle = fit_mle(levels, k, n, prior=prior)
    job = FitJob("two levels", levels, k, n, 0.0, prior, mle, False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = [p for p in sample_batch([job], sigmoid="weibull", rng=1) if p.fits][0].fits[0]
    t = fit.threshold(0.5)
    assert t.status != "censored_below"
    assert t.bracket[0] == 3290.0  # "above 3,290": the side the data put it
    assert t.bracket[0] <= t.mle and (math.isnan(t.bracket[1]) or t.mle <= t.bracket[1])
    text = t.text("{:,.0f}", "px")
    assert not text.startswith("<")


def test_fig_s3_marks_separated_objects(small_trials):
    """An object recognised on every trial has no finite ML odds ratio: Fig. S3 circles it."""
    from analysis.figures import plot_object_difficulty

    keep = sorted(set(small_trials["object"]), key=lambda o: int(o))[:4]
    t = small_trials[small_trials["object"].isin(keep)].copy()
    t.loc[t["object"] == keep[-1], "recognized"] = 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f = fit_logistic(t)
    assert any(s.startswith("object:") for s in f.separated)
    ax = plot_object_difficulty(f)
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert any(lb.startswith("separated in these data") for lb in labels)
