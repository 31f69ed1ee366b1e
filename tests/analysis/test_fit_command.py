"""``confocal analyze fit`` on every shared psychophysics data set, checked by independent fits.

Second method (written here, not imported): the binomial log-likelihood of
``P = g + (1 - g - l) F(exp(b) (s(x) - m))`` in (m, b = log beta, l), with ``s`` = ln x or x and
``m`` the axis position of alpha, maximised by scipy's bounded Powell from a grid of starts and
polished by L-BFGS-B, within the same parameter box as ours (the box is part of the model:
without it the staircase's ML slope is a step function). The threshold is inverted here too.
ML thresholds must agree to 1e-4 relative (rtol of the issue; both maximise the same smooth
function to ~1e-8 in the parameters, so 1e-4 in the threshold is loose enough for flat ridges and
tight enough to catch a wrong likelihood or inversion). For thresholds near 0 on a linear axis
relative error means nothing, so the tolerance there is 1e-4 of the tested span.

The posterior median of every measured threshold must lie inside the second method's 95 %
profile-likelihood interval (likelihood ratio, chi-square 1 df).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import optimize, special, stats

from experiment.cli import main

from ..conftest import require_data

pytestmark = pytest.mark.data

CDF = {
    "gumbel": lambda z: -np.expm1(-np.exp(z)),
    "logistic": special.expit,
    "normal": special.ndtr,
}
PPF = {
    "gumbel": lambda f: math.log(-math.log1p(-f)),
    "logistic": lambda f: math.log(f / (1 - f)),
    "normal": special.ndtri,
}
# Sigmoid -> (shape, axis): a linear sigmoid is its own shape; these are the shapes on log x.
LOG_AXIS_SHAPE = {"weibull": "gumbel", "loglogistic": "logistic", "lognormal": "normal"}
SHAPE = {s: (s, "linear") for s in CDF} | {n: (s, "log") for n, s in LOG_AXIS_SHAPE.items()}

# (file, arguments): one command per shared data set, as a user would type it.
CASES = [
    ("MPDiR_HSP.csv", ["--x", "Q", "--p", "p", "--n", "N", "--group", "Obs,Run"]),
    (
        "MPDiR_StairCase.csv",
        ["--x", "Contrast", "--y", "Response", "--guess", "0.5", "--pc", "0.75"],
    ),
    (
        "MPDiR_Vernier.csv",
        [
            "--x",
            "Phaseshift",
            "--k",
            "NumUpward",
            "--n",
            "N",
            "--group",
            "WaveForm,TempFreq,Direction",
            "--sigmoid",
            "logistic",
        ],
    ),
    (
        "qpdat.csv",
        ["--x", "phase", "--y", "resp", "--group", "participant,cond", "--sigmoid", "normal"],
    ),
    ("modelfree_Baker_etal.csv", ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "logistic"]),
    ("modelfree_Carcagno.csv", ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "weibull"]),
    ("modelfree_Levi_Tripathy.csv", ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "gumbel"]),
    (
        "modelfree_Miranda_Henson.csv",
        ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "loglogistic"],
    ),
    ("modelfree_Nascimento_etal.csv", ["--x", "x", "--k", "r", "--n", "m"]),
    ("modelfree_Schofield_etal.csv", ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "normal"]),
    ("modelfree_Xie_Griffin.csv", ["--x", "x", "--k", "r", "--n", "m", "--sigmoid", "logistic"]),
    (
        "psignifit_pooling_example_data.csv",
        ["--x", "1", "--k", "2", "--n", "3", "--guess", "0.5", "--pc", "0.6,0.75,0.9"],
    ),
]


def _p(theta, u, g, shape):
    m, b, lapse = theta
    return np.clip(g + (1 - g - lapse) * CDF[shape](math.exp(b) * (u - m)), 1e-12, 1 - 1e-12)


def _nll(theta, u, k, n, g, shape):
    p = _p(theta, u, g, shape)
    return -float(np.sum(k * np.log(p) + (n - k) * np.log1p(-p)))


def independent_ml(levels, k, n, guess, sigmoid, prior):
    shape, axis = SHAPE[sigmoid]
    u = np.log(levels) if axis == "log" else np.asarray(levels, float)
    scale = math.log(10) if axis == "log" else 1.0
    box = [
        (prior["loc_range"][0] * scale, prior["loc_range"][1] * scale),
        tuple(prior["log_beta_range"]),
        (0.0, prior["lapse_max"]),
    ]
    best = None
    for m0 in np.linspace(*box[0], 9)[1:-1]:
        for b0 in np.linspace(*box[1], 5)[1:-1]:
            for l0 in (0.0, 0.05):
                r = optimize.minimize(
                    _nll,
                    [m0, b0, l0],
                    args=(u, k, n, guess, shape),
                    method="Powell",
                    bounds=box,
                    options={"xtol": 1e-10, "ftol": 1e-12, "maxfev": 20000},
                )
                if best is None or r.fun < best.fun:
                    best = r
    r = optimize.minimize(
        _nll,
        best.x,
        args=(u, k, n, guess, shape),
        method="L-BFGS-B",
        bounds=box,
        options={"ftol": 1e-15, "gtol": 1e-10},
    )
    if r.fun < best.fun:
        best = r
    return best.x, best.fun, box, u, shape, axis


def threshold_of(theta, pc, guess, shape, axis):
    m, b, lapse = theta
    f = (pc - guess) / (1 - guess - lapse)
    if f >= 1:
        return math.inf
    s = m + PPF[shape](f) / math.exp(b)
    return math.exp(s) if axis == "log" else s


def profile_interval(theta, fun, box, u, k, n, guess, shape, axis, pc):
    """95 % likelihood-ratio interval of the threshold: profile over (log beta, lapse)."""

    def prof(t_axis):
        def nll2(v):
            b, lapse = v
            f = (pc - guess) / (1 - guess - lapse)
            if f >= 1:
                return 1e12
            m = t_axis - PPF[shape](f) / math.exp(b)
            return _nll([m, b, lapse], u, k, n, guess, shape)

        starts = [(theta[1], theta[2]), (theta[1], 0.0), (theta[1] - 1, 0.02)]
        vals = []
        for s0 in starts:
            r = optimize.minimize(
                nll2,
                [min(max(s0[0], box[1][0]), box[1][1]), s0[1]],
                method="Powell",
                bounds=[box[1], (0.0, min(box[2][1], (1 - guess) - (pc - guess) - 1e-9))],
                options={"xtol": 1e-8, "ftol": 1e-10},
            )
            vals.append(r.fun)
        return 2 * (min(vals) - fun) - stats.chi2.ppf(0.95, 1)

    t_ml = threshold_of(theta, pc, guess, shape, axis)
    t0 = math.log(t_ml) if axis == "log" else t_ml
    span = u.max() - u.min()
    ends = []
    for direction in (-1, 1):
        edge = t0 + direction * 3 * span
        if prof(edge) < 0:
            ends.append(-math.inf if direction < 0 else math.inf)
        else:
            ends.append(optimize.brentq(prof, t0, edge, xtol=1e-6 * span))
    lo, hi = sorted(ends)
    return (math.exp(lo), math.exp(hi)) if axis == "log" else (lo, hi)


@pytest.fixture(scope="module")
def fitted(data_dir, tmp_path_factory):
    out = {}
    for name, args in CASES:
        path = require_data(data_dir, "psychophysics", name)
        rep = tmp_path_factory.mktemp("fit") / "rep"
        with pytest.raises(SystemExit) as exc:
            main(
                ["analyze", "fit", str(path), *args, "--out", str(rep), "--seed", "3", "--no-plots"]
            )
        assert exc.value.code in (0, None), name
        out[name] = json.loads((rep / "results.json").read_text())
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", [c[0] for c in CASES])
def test_ml_thresholds_match_independent_fit_and_posterior_is_inside(fitted, name):
    r = fitted[name]
    for g in r["groups"]:
        k, n, lv = (np.asarray(g[c], float) for c in ("k", "n", "levels"))
        theta, fun, box, u, shape, axis = independent_ml(
            lv, k, n, r["guess"], r["sigmoid"], g["prior"]
        )
        assert -fun == pytest.approx(g["mle_log_likelihood"], abs=1e-6), g["label"]
        span = lv.max() - lv.min()
        for t in g["thresholds"]:
            if t["status"] == "unidentified":
                # No unique ML threshold (e.g. decreasing data: a flat curve at every location
                # fits equally); the equal maximum likelihood above is the check.
                continue
            second = threshold_of(theta, t["pc"], r["guess"], shape, axis)
            if t["mle"] is None:
                assert not math.isfinite(second)
                continue
            atol = 1e-4 * span if axis == "linear" else 0.0
            assert t["mle"] == pytest.approx(second, rel=1e-4, abs=atol), (name, g["label"], t)
            if t["status"] == "measured":
                lo, hi = profile_interval(
                    theta, fun, box, u, k, n, r["guess"], shape, axis, t["pc"]
                )
                assert lo <= t["median"] <= hi, (name, g["label"], t, (lo, hi))


def test_every_data_set_reports_statuses_not_bare_numbers(fitted):
    statuses = {t["status"] for r in fitted.values() for g in r["groups"] for t in g["thresholds"]}
    assert statuses <= {"measured", "censored_below", "censored_above", "unidentified"}
    # The decreasing data sets are recognised as such, not given a threshold.
    for name in ("modelfree_Nascimento_etal.csv", "modelfree_Xie_Griffin.csv"):
        g = fitted[name]["groups"][0]
        assert g["thresholds"][0]["status"] == "unidentified"
        assert any("decreases with level" in w for w in g["warnings"])
    # The staircase's slope sits on its prior bound, and the report says so.
    sc = fitted["MPDiR_StairCase.csv"]["groups"][0]
    assert any("slope presses on its prior upper bound" in w for w in sc["warnings"])


def test_fit_command_bad_input_is_one_line(tmp_path, capsys):
    p = tmp_path / "t.csv"
    p.write_text("level,c\n1,1\n2,0\n")
    q = tmp_path / "z.csv"  # a level 0, which a log-axis sigmoid cannot take
    q.write_text("x,y\n0,0\n1,1\n2,1\n")
    cases = [
        (p, ["--x", "lvl", "--y", "c"], "--x column 'lvl' not found (columns: level, c)"),
        (p, ["--x", "level", "--y", "c", "--k", "c"], "give either --y, or --k with --n"),
        (p, ["--x", "level", "--k", "c"], "give either --y, or --k with --n"),
        (p, ["--x", "level", "--y", "c", "--pc", "1.5"], "--pc values must be in"),
        (p, ["--x", "level", "--y", "c", "--sigmoid", "probit"], "--sigmoid must be auto or"),
        (q, ["--x", "x", "--y", "y", "--sigmoid", "weibull"], "values <= 0"),
    ]
    for table, args, needle in cases:
        with pytest.raises(SystemExit) as exc:
            main(["analyze", "fit", str(table), *args, "--out", str(tmp_path / "r")])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip()
        assert needle in err and "\n" not in err, err
    assert not (tmp_path / "r").exists()


def test_fit_command_writes_a_plot_per_group(tmp_path):
    p = tmp_path / "agg.csv"
    p.write_text(
        "obs,level,k,n\n"
        + "".join(
            f"{o},{lv},{k},20\n"
            for o, ks in (("a", (1, 6, 14, 19)), ("b", (0, 3, 9, 17)))
            for lv, k in zip((1, 2, 4, 8), ks, strict=True)
        )
    )
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "analyze",
                "fit",
                str(p),
                "--x",
                "level",
                "--k",
                "k",
                "--n",
                "n",
                "--group",
                "obs",
                "--pc",
                "0.5,0.8",
                "--out",
                str(tmp_path / "r"),
                "--seed",
                "1",
            ]
        )
    assert exc.value.code in (0, None)
    pngs = sorted(x.name for x in (tmp_path / "r").glob("*.png"))
    assert pngs == ["fit_01_obs_a.png", "fit_02_obs_b.png", "fit_all_groups.png"]
    r = json.loads((tmp_path / "r" / "results.json").read_text())
    assert [len(g["thresholds"]) for g in r["groups"]] == [2, 2]
    assert "| obs=a |" in (tmp_path / "r" / "report.md").read_text()
