"""Censored time to recognition (analysis/survival.py), its figure and active-search power.

Reference values come from hand computation (the product-limit estimate, Wilson's formula) and
from a stratified Cox partial likelihood written out here and maximised with scipy, not from the
statsmodels code the module calls.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from analysis.active import ActiveSearchResult, summarize_active, write_active_report
from analysis.active_power import (
    ActiveDesign,
    ActivePowerPoint,
    active_power_grid,
    simulate_active_study,
)
from analysis.survival import (
    SurvivalAnalysis,
    analyze_survival,
    cox_hazard_ratio,
    kaplan_meier,
    recognition_model,
)

from .conftest import active_session


def _table(rows) -> pd.DataFrame:
    """Trial table from (subject, condition, rt_s, recognized) rows, other columns filled."""
    df = pd.DataFrame(rows, columns=["subject", "condition", "rt_s", "recognized"])
    n = len(df)
    return df.assign(
        session=1,
        trial=range(n),
        attempt=0,
        target="tree",
        scene="synthetic:three_plane",
        searcher="sim:planes",
        score=np.where(df["recognized"], "named", "pass"),
        time_to_recognition_s=np.where(df["recognized"], df["rt_s"], np.nan),
        planes_visited=np.arange(n) % 3 + 1,
        detected_planes_visited=1,
        depth_keys=np.arange(n) % 4,
        zooms=np.arange(n) % 2,
        zoomed=(np.arange(n) % 2).astype(bool),
        zoom_time_s=0.0,
        at_target_plane=None,
    )


# Hand-made table. Condition "decluttered": times 1..5, recognised at 1, 3, 4, censored at 2 and
# 5. Product-limit: S(1) = 4/5 = 0.8, S(3) = 0.8 * 2/3, S(4) = 0.8 * 2/3 * 1/2 = 0.2667: the
# median (first time S < 1/2) is 4 s. Condition "cluttered": recognised at 1.5 only, censored at
# 2.5, 3.5, 4.5, 5.5 (four of five): S stays at 0.8, the median is not reached.
HAND = [
    ("S1", "decluttered", 1.0, True),
    ("S1", "decluttered", 2.0, False),
    ("S2", "decluttered", 3.0, True),
    ("S2", "decluttered", 4.0, True),
    ("S1", "decluttered", 5.0, False),
    ("S1", "cluttered", 1.5, True),
    ("S2", "cluttered", 2.5, False),
    ("S1", "cluttered", 3.5, False),
    ("S2", "cluttered", 4.5, False),
    ("S2", "cluttered", 5.5, False),
]


def test_km_median_and_curve_match_the_product_limit_by_hand() -> None:
    sv = analyze_survival(_table(HAND))
    d = sv.conditions["decluttered"]
    assert d.time_s == (1.0, 3.0, 4.0)
    np.testing.assert_allclose(d.survival, [0.8, 0.8 * 2 / 3, 0.8 * 2 / 3 / 2], rtol=1e-12)
    assert d.median_s == 4.0
    assert d.censored_s == (2.0, 5.0)
    # the pointwise band contains the curve and stays in [0, 1]
    assert all(0 <= lo <= s <= hi <= 1 for lo, s, hi in zip(*_band(d), strict=True))


def _band(km):
    return km.survival_ci95_low, km.survival, km.survival_ci95_high


def test_median_not_reached_when_more_than_half_censored_is_null_in_json() -> None:
    trials = _table(HAND)
    result = summarize_active(trials)
    c = result.survival.conditions["cluttered"]
    assert c.n_recognized == 1 and c.n_censored == 4
    np.testing.assert_allclose(c.survival, [0.8])
    assert c.median_s is None
    assert c.median_ci95_s[1] is None  # upper end not reached either
    text = json.dumps(result.to_dict(), allow_nan=False)
    entry = json.loads(text)["conditions"]["cluttered"]
    assert entry["time_to_recognition_km_median_s"] is None
    assert "null" in text
    assert json.loads(text)["conditions"]["decluttered"]["time_to_recognition_km_median_s"] == 4.0


def test_recognition_rate_interval_is_wilsons() -> None:
    k, n, z = 3, 5, 1.959963984540054
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    km = kaplan_meier([1, 2, 3, 4, 5], [True, False, True, True, False])
    np.testing.assert_allclose(km.recognition_rate_ci95, (centre - half, centre + half), rtol=1e-9)


def _stratified_partial_loglik(beta, t, e, x, strata):
    """Cox partial log-likelihood, summed over strata (no tied times, so Breslow is exact)."""
    ll = 0.0
    for s in np.unique(strata):
        m = strata == s
        ts, es, xs = t[m], e[m], x[m]
        for i in np.flatnonzero(es):
            risk = ts >= ts[i]
            ll += beta * xs[i] - math.log(np.exp(beta * xs[risk]).sum())
    return ll


def test_hazard_ratio_matches_the_partial_likelihood_maximised_by_scipy() -> None:
    from scipy.optimize import minimize_scalar

    rng = np.random.default_rng(7)
    n = 40
    subj = np.repeat(["A", "B", "C", "D"], n // 4)
    x = np.tile([0.0, 1.0], n // 2)
    t = rng.exponential(10.0 / np.where(x == 1, 2.5, 1.0)) + rng.uniform(0, 1e-3, n)
    e = t < 12.0
    t = np.minimum(t, 12.0) + rng.uniform(0, 1e-6, n)  # distinct censoring times: no ties
    cond = np.where(x == 1, "decluttered", "cluttered")
    h = cox_hazard_ratio(t, e, cond, subj, treated="decluttered", reference="cluttered")
    res = minimize_scalar(
        lambda b: -_stratified_partial_loglik(b, t, e, x, subj), bounds=(-5, 5), method="bounded"
    )
    beta = res.x
    eps = 1e-4
    f = [_stratified_partial_loglik(beta + k * eps, t, e, x, subj) for k in (-1, 0, 1)]
    se = 1 / math.sqrt(-(f[0] - 2 * f[1] + f[2]) / eps**2)
    # rtol: the bounded scalar search stops at ~1e-5 in beta; the finite-difference curvature
    # is good to ~1e-4
    assert h.hazard_ratio == pytest.approx(math.exp(beta), rel=1e-4)
    assert h.ci95[0] == pytest.approx(math.exp(beta - 1.959964 * se), rel=1e-3)
    assert h.ci95[1] == pytest.approx(math.exp(beta + 1.959964 * se), rel=1e-3)
    from scipy.stats import norm

    assert h.p == pytest.approx(2 * norm.sf(abs(beta / se)), rel=1e-3)
    assert "stratified by subject" in h.method


def test_censored_analysis_is_right_where_the_recognised_only_median_misleads() -> None:
    """Cluttered: subjects mostly give up early (passes), so the few recognised are fast.

    Recognition hazard 1/20 s (cluttered) vs 1/5 s (de-cluttered): the true hazard ratio is 4.
    Subjects pass at rate 1/4 s in the cluttered condition, independently of recognition, so
    the recognised cluttered trials are those quick enough to beat the pass: their median is
    ~2.3 s, below the de-cluttered ~3.5 s.
    """
    rng = np.random.default_rng(2015)
    rows = []
    for s in range(6):
        for _ in range(20):
            t_rec = rng.exponential(5.0)
            rows.append((f"S{s}", "decluttered", min(t_rec, 60.0), t_rec < 60.0))
            t_rec, t_pass = rng.exponential(20.0), rng.exponential(4.0)
            rows.append((f"S{s}", "cluttered", min(t_rec, t_pass, 60.0), t_rec < min(t_pass, 60)))
    result = summarize_active(_table(rows))
    c, d = result.conditions["cluttered"], result.conditions["decluttered"]
    assert c.median_rt_recognised_only_s < d.median_rt_recognised_only_s  # the naive reading
    h = result.survival.comparison
    assert (h.condition, h.reference) == ("decluttered", "cluttered")
    assert h.ci95[0] > 1.5 and h.p < 1e-6
    assert 2.0 < h.hazard_ratio < 8.0
    km_c = result.survival.conditions["cluttered"].median_s
    assert km_c is None or km_c > result.survival.conditions["decluttered"].median_s


def test_results_round_trip_and_carry_the_published_keys() -> None:
    result = summarize_active(_table(HAND))
    d = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    for key in ("hazard_ratio", "hazard_ratio_ci95", "p"):
        assert key in d["comparison"]
    assert d["conditions"]["decluttered"]["time_to_recognition_km_median_ci95_s"][0] == 1.0
    sub = d["subjects"]["S2"]["cluttered"]
    assert (sub["trials"], sub["recognized"], sub["km_median_s"]) == (3, 0, None)
    assert sub["longest_censored_s"] == 5.5
    assert {"planes_visited_mean", "zoom_use_rate"} <= set(sub)
    assert "planes_visited_mean_ci95" in d["conditions"]["cluttered"]
    assert "right-censored" in d["censoring"]
    back = ActiveSearchResult.from_dict(d)
    assert back == result
    assert SurvivalAnalysis.from_dict(d) == result.survival


def test_recognition_model_says_not_estimable_on_degenerate_data() -> None:
    one = recognition_model(
        [1, 0, 1, 0], ["a", "a", "b", "b"], ["S1"] * 4, treated="b", reference="a"
    )
    assert one.odds_ratio is None and "one subject" in one.note
    allrec = recognition_model(
        [1, 1, 0, 1], ["a", "a", "b", "b"], ["S1", "S2"] * 2, treated="b", reference="a"
    )
    assert allrec.odds_ratio is None and "every trial in condition 'a'" in allrec.note
    rng = np.random.default_rng(3)
    subj = np.repeat([f"S{i}" for i in range(8)], 20)
    cond = np.tile(["a", "b"], 80)
    y = rng.random(160) < np.where(cond == "b", 0.8, 0.3)
    fit = recognition_model(y, cond, subj, treated="b", reference="a")
    assert fit.odds_ratio is not None and fit.ci95[0] > 1.0
    assert "BinomialBayesMixedGLM" in fit.method


def test_hazard_ratio_not_estimable_without_recognitions_in_a_condition() -> None:
    h = cox_hazard_ratio(
        [1, 2, 3, 4],
        [True, True, False, False],
        ["b", "b", "a", "a"],
        ["S1", "S2"] * 2,
        treated="b",
        reference="a",
    )
    assert h.hazard_ratio is None and "no recognitions in condition 'a'" in h.note


@pytest.mark.parametrize(
    ("times", "rec", "match"),
    [
        ([1.0, 2.0], [True], "same length"),
        ([], [], "at least one trial"),
        ([1.0, -2.0], [True, True], "finite and >= 0"),
        ([1.0, float("nan")], [True, True], "finite and >= 0"),
    ],
)
def test_kaplan_meier_refuses_bad_times(times, rec, match) -> None:
    with pytest.raises(ValueError, match=match):
        kaplan_meier(times, rec)


def test_analyze_survival_refuses_a_table_without_the_columns() -> None:
    with pytest.raises(ValueError, match="lacks column"):
        analyze_survival(pd.DataFrame({"rt_s": [1.0]}))
    with pytest.raises(ValueError, match="at least one trial"):
        analyze_survival(_table(HAND).iloc[:0])


@pytest.mark.parametrize("simulated", [True, False])
def test_figure_has_curves_censor_marks_and_the_simulated_mark(simulated) -> None:
    from analysis.figures import plot_time_to_recognition

    fig = plot_time_to_recognition(analyze_survival(_table(HAND)), simulated=simulated)
    texts = [t.get_text() for t in fig.texts] + [fig._suptitle.get_text() if fig._suptitle else ""]
    assert any("SIMULATED" in t for t in texts) == simulated
    km_ax, subj_ax = fig.axes
    assert len(km_ax.get_legend().get_texts()) == 3  # two conditions and the censor mark
    assert [t.get_text() for t in subj_ax.get_yticklabels()] == ["S1", "S2"]


def _active_log(path):
    """A trial log of two simulated trials: one recognised, one passed."""
    from experiment.active.eventlog import ActiveEventLog
    from experiment.log import TrialLog

    log = TrialLog(path)
    ev = ActiveEventLog(log, active_session(log))
    state = {"depth_px": 3.0, "plane": 0, "zoom": None}
    for trial, (cond, rec, t1) in enumerate(
        [("decluttered", True, 4.0), ("cluttered", False, 9.0)]
    ):
        start = {"target": "tree", "condition": cond, "searcher": "sim:planes"}
        ev.append("trial_start", start, 0.0, trial=trial, attempt=0)
        ev.append("state", state, 0.0, trial=trial, attempt=0)
        ev.append("answer", {"response": "tree", "state": state}, t1, trial=trial, attempt=0)
        score = {"score": "named" if rec else "pass", "recognized": rec, "primary": True}
        ev.append("score", score, t1, trial=trial, attempt=0)
    log.close()


def test_report_folder_has_the_figure_scene_column_and_censoring_text(tmp_path) -> None:
    db = tmp_path / "a.sqlite"
    _active_log(db)
    write_active_report([db], tmp_path / "rep")
    rep = tmp_path / "rep"
    for ext in ("png", "pdf"):
        assert (rep / f"active_time_to_recognition.{ext}").stat().st_size > 1000
    from PIL import Image

    with Image.open(rep / "active_time_to_recognition.png") as im:
        assert round(im.info["dpi"][0]) == 300
    csv = pd.read_csv(rep / "active_trials.csv")
    assert list(csv["scene"]) == ["synthetic:three_plane"] * 2
    assert list(csv["rt_s"]) == [4.0, 9.0] and list(csv["recognized"]) == [True, False]
    md = (rep / "report.md").read_text()
    assert "right-censored at the time the trial ended" in md
    assert "not reached" in md  # the cluttered condition: its only trial was a pass
    assert "active_time_to_recognition.png" in md


def test_simulated_study_has_the_design_and_censors_at_the_limit() -> None:
    d = ActiveDesign(3, n_scenes=2, n_targets=3, time_limit_s=10.0, median_time_s=30.0)
    t = simulate_active_study(d, 2.0, rng=1)
    assert len(t) == 3 * 2 * 3 * 2
    assert t.groupby(["subject", "condition"]).size().eq(6).all()
    assert t["rt_s"].max() == 10.0 and not t.loc[t["rt_s"] == 10.0, "recognized"].any()


def test_simulated_times_have_the_stated_median() -> None:
    d = ActiveDesign(
        1,
        n_scenes=2000,
        n_targets=5,
        time_limit_s=1e6,
        median_time_s=12.0,
        weibull_shape=2.0,
        frailty_sd=0.0,
    )
    t = simulate_active_study(d, 3.0, rng=2)
    # Weibull PH: the treated median is the reference median times HR^(-1/shape)
    med = t.groupby("condition")["rt_s"].median()
    assert med["cluttered"] == pytest.approx(12.0, rel=0.03)
    assert med["decluttered"] == pytest.approx(12.0 * 3.0**-0.5, rel=0.03)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_subjects": 0}, "n_subjects must be an integer >= 1"),
        ({"n_subjects": 2, "n_scenes": 1.5}, "n_scenes must be an integer"),
        ({"n_subjects": 2, "time_limit_s": 0.0}, "time_limit_s must be a finite number > 0"),
        ({"n_subjects": 2, "frailty_sd": -0.1}, "frailty_sd must be a finite number >= 0"),
    ],
)
def test_active_design_refuses_bad_values(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        ActiveDesign(**kwargs)


def test_power_is_about_alpha_at_hazard_ratio_one_and_near_one_for_a_big_effect() -> None:
    out = list(active_power_grid([1.0, 5.0], [4], n_sims=150, alpha=0.05, seed=11, processes=1))
    pts = [p for p in out if isinstance(p, ActivePowerPoint)]
    null, big = pts
    # 150 studies: a binomial SD of 0.018 around 0.05; the Wald test is slightly liberal in
    # small samples, so the band is 0.01-0.12
    assert 0.01 <= null.power <= 0.12
    assert big.power >= 0.95
    assert ActivePowerPoint.from_dict(json.loads(json.dumps(big.to_dict()))) == big


@pytest.mark.slow
def test_power_grid_gives_the_same_result_in_worker_processes() -> None:
    def run(processes):
        return [
            p
            for p in active_power_grid([2.0], [2], n_sims=50, seed=5, processes=processes)
            if isinstance(p, ActivePowerPoint)
        ]

    assert run(1) == run(2)


def test_cli_active_power_prints_a_table_and_refuses_bad_options(capsys) -> None:
    from experiment import cli

    with pytest.raises(SystemExit) as exc:
        argv = "analyze power --active --hazard-ratio 4 --subjects 3 --sims 20 --seed 1"
        cli.main([*argv.split(), "--processes", "1"])
    assert exc.value.code in (0, None)
    out = capsys.readouterr().out
    assert "active search, hazard ratio" in out and "SIMULATED" in out
    for argv, match in (
        (["--active"], "--active needs --hazard-ratio"),
        (["--odds-ratio", "2", "--scenes", "2"], "--scenes is for active-search power"),
        (["--hazard-ratio", "0"], "--hazard-ratio must be in"),
        (["--hazard-ratio", "2", "--targets", "0"], "--targets"),
    ):
        with pytest.raises(SystemExit) as exc:
            cli.main(["analyze", "power", *argv])
        assert exc.value.code == 2
        assert match in capsys.readouterr().err
