"""Analysis of k conditions: thresholds, pairwise ratios, the condition-factor logistic model."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from analysis.conditions import fit_condition_logistic, holm
from analysis.conditions_sim import simulate_condition_trials
from tests.conftest import run_cli

TRUE_OR = {"cluttered": 1.0, "decluttered": 5.6, "mask": 11.0, "segment": 2.0}


def test_holm_matches_statsmodels():
    from statsmodels.stats.multitest import multipletests

    rng = np.random.default_rng(3)
    for m in (1, 3, 6, 10):
        p = rng.random(m) ** 3
        assert np.allclose(holm(p), multipletests(p, method="holm")[1])


def test_logistic_recovers_generating_odds_ratios():
    """A large simulated study: every OR inside its 95 % interval and near the truth; the
    contrasts agree with a formula-API fit of the same model with another reference."""
    import statsmodels.formula.api as smf

    df = simulate_condition_trials(TRUE_OR, n_subjects=8, rng=5)
    fit = fit_condition_logistic(df, list(TRUE_OR), "cluttered")
    assert fit.method == "ml" and fit.object_dummies
    for c, o in fit.odds_ratios.items():
        lo, hi = o["ci95"]
        assert lo < TRUE_OR[c] < hi, (c, o)
    ref = smf.logit(
        "recognized ~ C(condition, Treatment('decluttered')) + np.log10(pixels) + C(object)", df
    ).fit(disp=0)
    name = "C(condition, Treatment('decluttered'))[T.mask]"
    mask_vs_decl = next(c for c in fit.contrasts if c["pair"] == ["decluttered", "mask"])
    assert math.isclose(mask_vs_decl["or"], math.exp(ref.params[name]), rel_tol=1e-5)
    assert math.isclose(mask_vs_decl["p"], ref.pvalues[name], rel_tol=1e-3)
    assert all(c["p_adjusted"] >= c["p"] for c in fit.contrasts)


def test_cli_writes_the_comparison(tmp_path, capsys):
    df = simulate_condition_trials(
        {"cluttered": 1.0, "sobel": 5.6, "mask": 11.0}, n_subjects=3, rng=4
    )
    csv = tmp_path / "trials.csv"
    df.to_csv(csv, index=False)
    out = tmp_path / "report"
    argv = ["analyze", "run", csv, "--out", out, "--seed", "1", "--by", "none"]
    assert run_cli([*argv, "--include-simulated", "--no-figures", "--reference", "sobel"]) == 0
    r = json.loads((out / "results.json").read_text())
    assert set(r["thresholds"]) == {"cluttered", "sobel", "mask"}
    assert all(r["thresholds"][c]["p50_pixels"] > 0 for c in r["thresholds"])
    assert sorted(r["logistic"]["odds_ratios"]) == ["cluttered", "mask"]
    assert len(r["comparisons"]) == 3
    for c in r["comparisons"]:
        assert {"pair", "ratio", "ratio_ci95", "p_adjusted"} <= set(c)
    th = {c: r["thresholds"][c]["p50_pixels"] for c in r["thresholds"]}
    assert th["mask"] < th["cluttered"]
    # the ratio of posterior draws is centred on the ratio of the posterior medians, and near
    # the generating model's: 10 ** (log(OR) / log(74.5)) = 2.6 for the mask
    (cm,) = [c for c in r["comparisons"] if c["pair"] == ["cluttered", "mask"]]
    assert cm["ratio_ci95"][0] < th["cluttered"] / th["mask"] < cm["ratio_ci95"][1]
    assert 0.85 < cm["ratio"] / (th["cluttered"] / th["mask"]) < 1.15
    assert cm["ratio_ci95"][0] < 10 ** (math.log(11.0) / math.log(74.5)) < cm["ratio_ci95"][1]
    assert "Which methods differ" in (out / "report.md").read_text()
    capsys.readouterr()
    bad = tmp_path / "bad"
    assert run_cli([*argv[:3], "--out", bad, "--include-simulated", "--reference", "depth"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--reference 'depth'" in err[0]
    assert not bad.exists()


def test_threshold_ratio_converts_by_the_papers_slope():
    """A threshold ratio r shifts log10 threshold by log10(r); the logistic model's 50 % point
    moves by log(OR) / log(74.5) decades, so OR = 74.5 ** log10(r)."""
    from analysis.conditions_power import ratio_to_odds_ratio

    for r in (1.0, 2.46, 10.0):
        o = ratio_to_odds_ratio(r)
        assert math.isclose(10 ** (math.log(o) / math.log(74.5)), r, rel_tol=1e-12)
    assert math.isclose(ratio_to_odds_ratio(10.0), 74.5)


def test_power_of_a_method_comparison(capsys):
    argv = ["analyze", "power", "--conditions", "3", "--threshold-ratio", "2.46"]
    assert run_cli([*argv, "--subjects", "1", "--sims", "2", "--seed", "1"]) == 0
    out = capsys.readouterr().out
    assert "method comparison of 3 conditions" in out and "Holm over 3 pairs" in out
    assert "2.46   5.39        1" in out
    assert run_cli(["analyze", "power", "--conditions", "1", "--odds-ratio", "2"]) == 2


def test_a_plugin_method_is_a_condition(tmp_path, monkeypatch):
    """Trials of a plug-in method's condition are read (its entry point names it); an unknown
    condition is still refused."""
    from analysis.data import read_trials
    from analysis.errors import DataError

    site = tmp_path / "site"
    info = site / "toy-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[confocal.declutter]\ndeepseg = toy:f\n")
    csv = tmp_path / "t.csv"
    csv.write_text("subject,object,condition,pixels,recognized\ns1,1,deepseg,96,0\n")
    with pytest.raises(DataError, match="'deepseg'"):
        read_trials([csv])
    monkeypatch.syspath_prepend(str(site))
    assert read_trials([csv]).trials["condition"].tolist() == ["deepseg"]
