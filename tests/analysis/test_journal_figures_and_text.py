"""Figures and text a journal would take: no clipped labels, honest legends and marks, exact p.

Fig. S3's y-label inside the figure, Fig. 9 with the pooled threshold and its interval and a
legend of only what is drawn, "SIMULATED" on figures from simulated sessions, p-values below
double precision as a bound, deviance only with positive degrees of freedom, every interval
naming its question, profile-likelihood odds-ratio intervals against a brute-force profile, and
citations only to sections the paper has.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import optimize, special

from analysis.report import (
    QUESTION_POPULATION,
    QUESTION_SAMPLE,
    deviance_text,
    p_text,
    render_markdown,
)


def test_p_below_double_precision_is_a_bound():
    assert p_text(0.0) == "p < 1e-300"
    assert p_text(5e-310) == "p < 1e-300"
    assert p_text(0.0123) == "p = 0.012"


def test_report_never_prints_p_equals_zero(small_result):
    r = copy.deepcopy(small_result.results_json())
    r["logistic"]["odds_ratios"]["log10_pixels"]["p"] = 0.0
    text = render_markdown(small_result, figures=False, results=r)
    assert "p < 1e-300" in text
    assert not re.search(r"p = 0(?![.\d])", text)


@pytest.mark.parametrize("df", [-1, 0])
def test_deviance_without_positive_df_is_not_a_test(small_result, df):
    assert f"on {df} df" not in deviance_text({"deviance": 0.0, "deviance_df": df})
    r = copy.deepcopy(small_result.results_json())
    for c in r["thresholds"]:
        r["thresholds"][c]["goodness_of_fit"]["deviance_df"] = df
    text = render_markdown(small_result, figures=False, results=r)
    assert f"on {df} df" not in text
    assert f"no deviance test ({df + 3} levels with data for 3 parameters)" in text
    assert deviance_text({"deviance": 7.31, "deviance_df": 5}) == "deviance 7.3 on 5 df"


def test_every_interval_names_its_question(small_result):
    text = render_markdown(small_result, figures=False)
    assert "95 % CrI" in text and f"for {QUESTION_SAMPLE}" in text
    assert any(small_result.population_ci[c] for c in small_result.population_ci)
    assert "95 % population interval" in text and f"for {QUESTION_POPULATION}" in text
    # the odds ratios: Wald and profile likelihood side by side
    assert "Wald, " in text and "profile likelihood" in text


def test_figure_s3_label_is_inside_the_figure():
    from analysis.figures import plot_object_difficulty
    from analysis.logistic import fit_logistic
    from analysis.simulate import simulate_logistic_trials

    d = simulate_logistic_trials(rng=1)
    # Long object names push the axes up, where a one-line label ran off the top.
    d["object"] = "a long household object name " + d["object"].astype(str)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_logistic(d)
    ax = plot_object_difficulty(fit)
    fig = ax.figure
    fig.draw_without_rendering()
    bb = ax.yaxis.label.get_window_extent()
    assert bb.y0 >= 0 and bb.y1 <= fig.bbox.height and bb.x0 >= 0
    assert "profile-likelihood" in ax.get_title()


def test_figure_9_draws_the_pooled_threshold_with_its_intervals(small_result):
    from analysis.figures import plot_subject_thresholds

    res = small_result
    ax = plot_subject_thresholds(
        res.subject_thresholds, res.thresholds, population_ci=res.population_ci
    )
    assert ax.get_yscale() == "log"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "pooled: median, 95 % CrI" in labels
    assert "pooled: population 95 % interval" in labels
    # nothing in the legend that is not drawn: no censored subject here, so no triangles
    statuses = {
        f.threshold(0.5).status for s in res.subject_thresholds.values() for f in s.values()
    }
    if "censored_above" not in statuses:
        assert "> highest level tested" not in labels
    if "censored_below" not in statuses:
        assert "< lowest level tested" not in labels
    assert not any("bar" in lab or "posterior median)" in lab for lab in labels)
    # the pooled diamond sits at the posterior median, no bar (a bar on a log axis has no base)
    assert not ax.patches
    diamonds = [ln for ln in ax.lines if ln.get_marker() == "D"]
    medians = sorted(f.threshold(0.5).median for f in res.thresholds.values())
    assert sorted(float(ln.get_ydata()[0]) for ln in diamonds) == pytest.approx(medians)


@pytest.mark.parametrize("simulated", [True, False])
def test_simulated_sessions_stamp_every_figure(small_result, simulated):
    from analysis.figures import SIMULATED_MARK, STUDY_FIGURES, _draw

    res = dataclasses.replace(
        small_result, simulated_sessions=("sim.csv session 1",) if simulated else ()
    )
    for name in STUDY_FIGURES:
        fig = _draw(res, name)
        texts = [t.get_text() for t in fig.texts]
        assert (SIMULATED_MARK in texts) is simulated, name


def _brute_profile(y, X, j, crit=3.841458820694124):
    """Profile deviance by brute force: scipy minimises over the other coefficients."""

    def nll(b):
        eta = X @ b
        return -float(np.sum(y * eta - np.logaddexp(0, eta)))

    full = optimize.minimize(nll, np.zeros(X.shape[1]), method="BFGS", options={"gtol": 1e-10})

    def dev(bj):
        others = [i for i in range(X.shape[1]) if i != j]

        def f(bo):
            b = np.empty(X.shape[1])
            b[j], b[others] = bj, bo
            return nll(b)

        r = optimize.minimize(f, full.x[others], method="BFGS", options={"gtol": 1e-10})
        return 2 * (r.fun - full.fun) - crit

    bj = full.x[j]
    return optimize.brentq(dev, bj - 5, bj), optimize.brentq(dev, bj, bj + 5)


def test_profile_interval_matches_a_brute_force_profile():
    from analysis.logistic import profile_interval

    rng = np.random.default_rng(3)
    x = rng.normal(size=200)
    g = rng.integers(0, 2, 200)
    X = np.column_stack([np.ones(200), g, x])
    y = (rng.random(200) < special.expit(-0.3 + 0.8 * g + 1.5 * x)).astype(float)
    for j in (1, 2):
        lo, hi = profile_interval(y, X, j)
        ref = _brute_profile(y, X, j)
        # both solve the same equation to ~1e-6 in the deviance: 1e-4 in the coefficient
        assert (lo, hi) == pytest.approx(ref, abs=1e-4)
    # the profile interval is not the symmetric Wald one
    import statsmodels.api as sm

    res = sm.Logit(y, X).fit(disp=False)
    wald = (res.params[2] - 1.96 * res.bse[2], res.params[2] + 1.96 * res.bse[2])
    assert profile_interval(y, X, 2) != pytest.approx(wald, abs=1e-3)
    with pytest.raises(ValueError, match="j must be a column of X"):
        profile_interval(y, X, 3)


def test_firth_profile_interval_is_finite_below_under_separation():
    from analysis.logistic import profile_interval

    x = np.repeat([0.0, 1.0], 10)
    X = np.column_stack([np.ones(20), x])
    y = x.copy()  # separated: every x = 1 recognised, none at x = 0
    lo, hi = profile_interval(y, X, 1, penalized=True)
    assert 0 < lo < 10 and lo < hi


#: Sections of Jung et al. 2015 (its headings: 1 Introduction ... 5 Discussion).
PAPER_SECTIONS = {"1", "2", "3", "3.1", "3.2", "3.2.1", "3.2.2", "4", "4.1", "4.2", "5"}


def test_analysis_cites_only_sections_the_paper_has():
    root = Path(__file__).resolve().parents[2]
    paper = root.parent / "shared" / "paper-full.txt"
    for cand in (paper, root.parent.parent / "shared" / "paper-full.txt"):
        if cand.exists():
            heads = re.findall(r"^\s*(\d(?:\.\d)*)\.? [A-Z]", cand.read_text("utf-8"), re.M)
            assert PAPER_SECTIONS <= set(heads) | {"1"}
    bad = []
    for folder in ("analysis", "benchmarks", "tests/analysis"):
        for f in sorted((root / folder).rglob("*.py")):
            for m in re.finditer(r"Sec(?:tion|s)?\.? (\d+(?:\.\d+)*)", f.read_text("utf-8")):
                if m.group(1) not in PAPER_SECTIONS:
                    bad.append(f"{f.relative_to(root)}: Sec. {m.group(1)}")
    assert not bad, bad


def test_kappa_is_not_reported_with_a_point_interval_on_two_trials():
    from experiment.session.scoring import kappa_interval_few_trials

    k, se, lo, hi = kappa_interval_few_trials(["a", "b"], ["a", "b"])
    assert k == 1.0 and all(math.isnan(v) for v in (se, lo, hi))
