"""The general command's table reading and checks, and the batch sampler (house style H11)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.errors import DataError
from analysis.mixed import fit_mixed
from analysis.psychometric import FitSpec, counts_by_group, read_table, resolve_sigmoid
from analysis.weibull import default_prior, fit_mle
from analysis.weibull.batch import FitJob, sample_batch


def test_headerless_table_is_numbered(tmp_path):
    p = tmp_path / "q.csv"
    p.write_text("1.5,1,1,\n0.5,0,1,\n1.5,0,1,\n")
    df = read_table(p)
    assert list(df.columns) == ["1", "2", "3"]  # trailing empty column dropped
    ((g, lv, k, n),) = counts_by_group(df, FitSpec(x="1", k="2", n="3"))
    assert g == {} and list(lv) == [0.5, 1.5] and list(k) == [0, 1] and list(n) == [1, 2]


def test_percent_and_groups(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("Q,p,N,Obs\n10,50,20,a\n20,100,20,a\n10,0.0,10,b\n20,90,10,b\n")
    out = counts_by_group(read_table(p), FitSpec(x="Q", p="p", n="N", group=("Obs",)))
    assert [g for g, *_ in out] == [{"Obs": "a"}, {"Obs": "b"}]
    assert list(out[0][2]) == [10.0, 20.0] and list(out[1][2]) == [0.0, 9.0]


@pytest.mark.parametrize(
    ("text", "spec", "needle"),
    [
        ("x,y\n1,2\n", {"x": "x", "y": "y"}, "`y` column 'y' must be 0 or 1 per trial"),
        ("x,k,n\n1,1,0\n", {"x": "x", "k": "k", "n": "n"}, "`n` column 'n' must be > 0"),
        ("x,k,n\n1,3,2\n", {"x": "x", "k": "k", "n": "n"}, "need 0 <= correct <= trials"),
        ("x,p,n\n1,300,2\n", {"x": "x", "p": "p", "n": "n"}, "must be in 0-1 or 0-100"),
        ("x,y\n1,1\n", {"x": "x", "y": "y", "group": ("g",)}, "`group` column 'g' not found"),
        ("x,y\nabc,1\n", {"x": "x", "y": "y"}, "`x` column 'x' must be numeric, got 'abc'"),
    ],
)
def test_bad_tables(tmp_path, text, spec, needle):
    p = tmp_path / "t.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=needle.replace("(", r"\(").replace(")", r"\)")):
        counts_by_group(read_table(p), FitSpec(**spec), str(p))


def test_unreadable_tables(tmp_path):
    with pytest.raises(DataError, match="file not found"):
        read_table(tmp_path / "none.csv")
    with pytest.raises(DataError, match="is a folder, expected a CSV table"):
        read_table(tmp_path)
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(DataError, match="file is empty"):
        read_table(tmp_path / "e.csv")
    (tmp_path / "h.csv").write_text("x,y\n")
    with pytest.raises(DataError, match="no data rows"):
        read_table(tmp_path / "h.csv")


def test_spec_and_sigmoid_checks():
    assert resolve_sigmoid("auto", "auto", np.array([-1.0, 2.0])) == "logistic"
    assert resolve_sigmoid("weibull", "linear") == "gumbel"
    assert resolve_sigmoid("normal", "log") == "lognormal"
    with pytest.raises(ValueError, match="sigmoid must be auto or one of"):
        resolve_sigmoid("probit", "auto")
    with pytest.raises(ValueError, match="axis must be 'auto', 'log' or 'linear', got 'ln'"):
        resolve_sigmoid("weibull", "ln")
    with pytest.raises(ValueError, match=r"`guess` must be in \[0, 1\), got 1.0"):
        FitSpec(x="x", y="y", guess=1.0)
    assert FitSpec(x="x", y="y").pcs == ()  # no --pc: psignifit's midpoint threshold
    with pytest.raises(ValueError, match="`axis` must be auto, log or linear"):
        FitSpec(x="x", y="y", axis="ln")


def test_batch_sampler_checks():
    lv, k, n = np.array([1.0, 2.0, 4.0]), np.array([1.0, 5.0, 9.0]), np.array([10.0] * 3)
    prior = default_prior(lv)
    job = FitJob("a", lv, k, n, 0.0, prior, fit_mle(lv, k, n, prior=prior))
    with pytest.raises(ValueError, match="jobs must hold at least one FitJob"):
        next(sample_batch([]))
    with pytest.raises(ValueError, match="n_walkers must be even and >= 8, got 7"):
        next(sample_batch([job], n_walkers=7))


def test_mixed_needs_a_random_effect():
    d = pd.DataFrame(
        {
            "subject": "s1",
            "object": "1",
            "condition": ["cluttered", "decluttered"] * 10,
            "pixels": np.repeat([96.0, 960.0], 10),
            "recognized": [0, 1] * 10,
        }
    )
    with pytest.raises(DataError, match="one subject and one object only"):
        fit_mixed(d)


def test_cluster_interval_matches_statsmodels_cluster_robust_logit():
    """Second method: statsmodels Logit with cov_type='cluster' (one-way, by subject) and the
    delta method for the 50 % point -b0/b1. With the lapse held at 0 our model is that logistic
    regression (alpha = -b0/b1, beta = b1). statsmodels scales by G/(G-1) (N-1)/(N-K); ours by
    G/(G-1), so its SE is divided by sqrt((N-1)/(N-K)). Finite differences: rtol 1e-3."""
    import statsmodels.api as sm

    from analysis.cluster import cluster_threshold_ci
    from analysis.weibull import MLEstimate

    rng = np.random.default_rng(8)
    subj = np.repeat(np.arange(8), 60)
    x = np.tile(np.linspace(-2, 2, 12), 40)
    shift = rng.normal(0, 0.5, 8)[subj]
    y = (rng.random(x.size) < 1 / (1 + np.exp(-1.5 * (x - 0.2 - shift)))).astype(float)
    X = sm.add_constant(x)
    res = sm.Logit(y, X).fit(disp=False, cov_type="cluster", cov_kwds={"groups": subj})
    b0, b1 = res.params
    g = np.array([-1 / b1, b0 / b1**2])
    n, k = x.size, 2
    se_sm = float(np.sqrt(g @ res.cov_params() @ g)) / np.sqrt((n - 1) / (n - k))
    mle = MLEstimate(alpha=-b0 / b1, beta=b1, lapse=0.0, log_likelihood=float(res.llf))
    lo, hi, se = cluster_threshold_ci(x, y, [subj], mle, sigmoid="logistic")
    assert se == pytest.approx(se_sm, rel=1e-3)
    assert lo < -b0 / b1 < hi
