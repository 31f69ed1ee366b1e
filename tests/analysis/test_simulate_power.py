"""Simulated designs and simulation-based power."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analysis.power import PowerResult, iter_power, power_analysis
from analysis.simulate import (
    LogisticObserver,
    WeibullObserver,
    design,
    simulate_logistic_trials,
    simulate_weibull_trials,
)


def test_design_is_the_papers():
    d = design()
    assert len(d) == 1920
    assert d.groupby(["subject", "object", "condition"]).size().eq(8).all()
    assert sorted(d["pixels"].unique()) == [96, 486, 950, 3290, 6370, 17876, 40344, 160884]


def test_simulations_are_seeded():
    a = simulate_logistic_trials(rng=4)
    b = simulate_logistic_trials(rng=4)
    assert a.equals(b)
    c = simulate_weibull_trials({"cluttered": WeibullObserver(5000, 1, 0.05)}, rng=1)
    assert set(c["condition"]) == {"cluttered"} and len(c) == 960


def test_weibull_simulation_matches_model():
    obs = WeibullObserver(5000.0, 1.5, 0.1)
    d = simulate_weibull_trials({"cluttered": obs}, n_subjects=50, rng=0)
    top = d[d["pixels"] == 160884]["recognized"].mean()
    # 1000 trials at P = 0.9: SD 0.0095, so +-0.04 is > 4 SD.
    assert top == pytest.approx(0.9, abs=0.04)


def test_observer_checks():
    with pytest.raises(ValueError, match="alpha_px must be > 0, got 0"):
        WeibullObserver(0, 1)
    with pytest.raises(ValueError, match="need 0 <= guess < 1 and 0 <= lapse < 1 - guess"):
        WeibullObserver(1, 1, lapse=0.6, guess=0.5)


def test_power_large_effect_is_detected():
    r = power_analysis("odds_ratio", 30.0, [2], n_sims=6, rng=1)
    assert r.points[0].power == 1.0 and r.n_required == 2


def test_power_null_effect_is_rarely_detected():
    # OR = 1: detections are false positives at level alpha = 0.05; with 20 simulations,
    # P(>= 6 of 20 | p = 0.05) < 0.001.
    r = power_analysis("odds_ratio", 1.0, [2], n_sims=20, rng=2)
    assert r.points[0].power < 0.3 and r.n_required is None


def test_threshold_ratio_power():
    r = power_analysis("threshold_ratio", 3.0, [1], n_sims=5, rng=3)
    assert r.points[0].power >= 0.8
    back = PowerResult.from_dict(json.loads(json.dumps(r.to_dict())))
    assert back == r


def test_iter_power_yields_progress():
    items = list(iter_power("odds_ratio", 10.0, [1], n_sims=3, rng=0))
    assert items[:3] == [None, None, None] and items[3].n_sims == 3


def test_power_bad_arguments():
    with pytest.raises(ValueError, match="effect must be 'odds_ratio' or 'threshold_ratio'"):
        next(iter_power("slope", 2.0, [1]))
    with pytest.raises(ValueError, match="size must be > 0, got 0"):
        next(iter_power("odds_ratio", 0, [1]))
    with pytest.raises(ValueError, match=r"target_power must be in \(0, 1\), got 1"):
        power_analysis("odds_ratio", 2.0, [1], target_power=1)
    with pytest.raises(ValueError, match="n_subjects must be a non-empty list"):
        next(iter_power("odds_ratio", 2.0, []))


def test_logistic_observer_defaults_put_cluttered_50pct_at_paper_threshold():
    o = LogisticObserver()
    eta = o.intercept + np.log(o.log10_pixels_or) * np.log10(8695.0)
    assert eta == pytest.approx(0.0, abs=1e-12)


def _grid(**kw):
    from analysis.power import GridPoint, power_grid

    return [
        p
        for p in power_grid(
            "odds_ratio", [1.0, 30.0], [1], n_objects=[4], n_levels=[3, 8], n_sims=10, seed=42, **kw
        )
        if isinstance(p, GridPoint)
    ]


@pytest.mark.slow
def test_power_grid_same_seed_same_result_in_processes(monkeypatch):
    monkeypatch.setattr("analysis.power.MIN_POOL_STUDIES", 0)  # a pool even for 40 studies
    here = _grid(processes=1)
    assert len(here) == 4 and [p.n_levels for p in here[:2]] == [3, 8]
    assert _grid(processes=2) == here  # studies seeded by grid position, not by worker
    # OR 30 is detected far more often than no effect (OR 1: false positives at alpha).
    assert sum(p.power for p in here if p.size == 30.0) > sum(p.power for p in here if p.size == 1)


@pytest.mark.slow
def test_power_grid_on_a_local_dask_cluster():
    distributed = pytest.importorskip(
        "dask.distributed", reason="dask not installed (pip install .[dask])"
    )
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        on_dask = _grid(cluster=cluster.scheduler_address)
    assert on_dask == _grid(processes=1)


def test_power_grid_bad_arguments():
    from analysis.power import level_pixels, power_grid

    with pytest.raises(ValueError, match=r"effect sizes must be finite and > 0, got \[inf\]"):
        next(power_grid("odds_ratio", [float("inf")], [1]))
    with pytest.raises(ValueError, match=r"numbers of levels must be integers >= 2, got \[1\]"):
        next(power_grid("odds_ratio", [2.0], [1], n_levels=[1]))
    with pytest.raises(ValueError, match="n_levels must be >= 2, got 1"):
        level_pixels(1)
    assert level_pixels(3) == (96.0, 3930.0, 160884.0)


def test_power_cli_one_line_errors(capsys):
    from experiment.cli import main

    for args, needle in (
        (["--odds-ratio", "inf"], "--odds-ratio must be in (0, inf), a finite number"),
        (["--odds-ratio", "2", "--subjects", "1000000000"], "GiB of memory"),
        (["--odds-ratio", "2", "--power", "2"], "--power must be in (0, 1), got 2.0"),
        (["--odds-ratio", "2", "--levels", "1"], "--levels must be integers >= 2"),
    ):
        with pytest.raises(SystemExit) as exc:
            main(["analyze", "power", *args])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip()
        assert needle in err and "\n" not in err, err
