"""The mixed logistic model of k conditions (``confocal analyze --mixed`` on a comparison)."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from analysis.conditions_mixed import fit_condition_mixed
from analysis.conditions_sim import simulate_condition_trials
from analysis.errors import DataError
from tests.conftest import run_cli

TRUE_OR = {"cluttered": 1.0, "segment": 2.0, "decluttered": 5.6, "mask": 11.0}


@pytest.fixture(scope="module")
def study():
    """A simulated study (ours): 4 conditions, random subject (SD 0.8) and object intercepts."""
    return simulate_condition_trials(
        TRUE_OR, n_subjects=8, n_objects=10, object_sd=0.5, subject_sd=0.8, rng=7
    )


def test_recovers_generating_odds_ratios_and_agrees_with_statsmodels(study):
    """Each true log OR lies within 3 SE of its estimate; the estimates agree with statsmodels'
    variational-Bayes GLMM (flat priors on the fixed effects) to a fraction of an SE."""
    from statsmodels.genmod.bayes_mixed_glm import BinomialBayesMixedGLM

    fit = fit_condition_mixed(study, list(TRUE_OR), "cluttered")
    assert sorted(fit.odds_ratios) == ["decluttered", "mask", "segment"]
    d = study.assign(lp=np.log10(study["pixels"]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        vb = BinomialBayesMixedGLM.from_formula(
            "recognized ~ C(condition, Treatment('cluttered')) + lp",
            {"s": "0 + C(subject)", "o": "0 + C(object)"},
            d,
            fe_p=100,
            vcp_p=2,
        ).fit_vb()
    names = vb.model.exog_names
    for c, o in fit.odds_ratios.items():
        b = math.log(o["or"])
        se = (math.log(o["ci95"][1]) - math.log(o["ci95"][0])) / (2 * 1.959963984540054)
        assert abs(b - math.log(TRUE_OR[c])) < 3 * se, (c, o)
        vb_b = vb.fe_mean[names.index(f"C(condition, Treatment('cluttered'))[T.{c}]")]
        assert abs(b - vb_b) < 0.4 * se, (c, b, vb_b, se)
    assert math.isclose(fit.subject_sd, math.exp(vb.vcp_mean[0]), rel_tol=0.15)
    assert 0.4 < fit.subject_sd < 1.3
    slope = math.log(fit.per_log10_pixels["or"])
    assert math.isclose(slope, vb.fe_mean[names.index("lp")], rel_tol=0.05)


def test_contrasts_match_a_refit_with_another_reference(study):
    """A pairwise contrast from the fixed effects' covariance equals the odds ratio and Wald
    p-value of a refit with one of the pair as the reference; Holm adjusts every pair."""
    fit = fit_condition_mixed(study, list(TRUE_OR), "cluttered")
    ref = fit_condition_mixed(study, list(TRUE_OR), "decluttered")
    (c,) = [c for c in fit.contrasts if c["pair"] == ["decluttered", "mask"]]
    assert math.isclose(c["or"], ref.odds_ratios["mask"]["or"], rel_tol=1e-3)
    assert math.isclose(c["p"], ref.odds_ratios["mask"]["p"], rel_tol=0.05)
    assert len(fit.contrasts) == 6
    assert all(c["p_adjusted"] >= c["p"] for c in fit.contrasts)


def test_separated_or_degenerate_data_are_refused(study):
    allyes = study.assign(recognized=1)
    with pytest.raises(DataError, match="all .* trials are recognised"):
        fit_condition_mixed(allyes, list(TRUE_OR), "cluttered")
    sep = study.copy()
    sep.loc[sep["condition"] == "mask", "recognized"] = 1
    with pytest.raises(DataError, match="condition 'mask'.* separated .* not estimable"):
        fit_condition_mixed(sep, list(TRUE_OR), "cluttered")


def test_cli_mixed_writes_the_k_condition_model(tmp_path):
    df = simulate_condition_trials(
        {"cluttered": 1.0, "sobel": 5.6, "mask": 11.0}, n_subjects=3, n_objects=6, rng=4
    )
    csv = tmp_path / "trials.csv"
    df.to_csv(csv, index=False)
    out = tmp_path / "report"
    argv = ["analyze", "run", csv, "--out", out, "--seed", "1", "--by", "none", "--mixed"]
    assert run_cli([*argv, "--include-simulated", "--no-figures", "--reference", "sobel"]) == 0
    r = json.loads((out / "results.json").read_text())
    m = r["logistic_mixed"]
    assert m["reference"] == "sobel"
    assert sorted(m["odds_ratios"]) == ["cluttered", "mask"]
    assert all(len(o["ci95"]) == 2 and o["p"] is not None for o in m["odds_ratios"].values())
    assert len(m["contrasts"]) == 3 and all("p_adjusted" in c for c in m["contrasts"])
    assert {"subject_sd", "object_sd", "per_log10_pixels"} <= set(m)
    assert "random subject and object intercepts" in (out / "report.md").read_text()
