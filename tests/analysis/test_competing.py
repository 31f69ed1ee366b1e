"""Giving up as a competing outcome: the Aalen-Johansen cumulative incidence against a hand
computation, its place in the active-search report, and how each trial ended, read from a log."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.competing import ENDING_CODES, competing_by_condition, cumulative_incidence


def _hand_aalen_johansen(t, codes):
    """F_k(t_max) = sum S(t_j-) d_kj / n_j over distinct event times (written out here)."""
    s, f = 1.0, {1: 0.0, 2: 0.0}
    for tj in np.unique(t):
        n = np.sum(t >= tj)
        d = {k: np.sum((t == tj) & (codes == k)) for k in (1, 2)}
        for k in (1, 2):
            f[k] += s * d[k] / n
        s *= 1 - (d[1] + d[2]) / n
    return f


def test_cumulative_incidence_equals_the_hand_computation_and_stays_in_unit_interval():
    rng = np.random.default_rng(3)
    n = 60
    t = np.round(rng.exponential(10, n), 1) + 0.1
    ended = rng.choice(["recognised", "pass", "wrong", "timeout"], n, p=[0.5, 0.2, 0.1, 0.2])
    r = cumulative_incidence(t, ended)
    codes = np.array([ENDING_CODES[e] for e in ended])
    hand = _hand_aalen_johansen(t, codes)
    assert r["recognised"]["cif"] == pytest.approx(hand[1], abs=1e-12)
    assert r["gave_up"]["cif"] == pytest.approx(hand[2], abs=1e-12)
    for k in ("recognised", "gave_up"):
        lo, hi = r[k]["ci95"]
        assert 0.0 <= lo < r[k]["cif"] < hi <= 1.0
    # a pass cannot later be a recognition: the competing estimate is below 1 - KM's
    from analysis.survival import kaplan_meier

    km = kaplan_meier(t, ended == "recognised")
    assert r["recognised"]["cif"] < 1 - km.survival[-1]


def test_report_and_table_say_how_trials_ended(tmp_path):
    from analysis.active import write_active_report
    from tests.analysis.test_active_survival import _active_log

    db = tmp_path / "a.sqlite"
    _active_log(db)
    write_active_report([db], tmp_path / "rep")
    csv = pd.read_csv(tmp_path / "rep" / "active_trials.csv")
    assert list(csv["ended"]) == ["recognised", "wrong"]  # 'tree' answered, scored 'pass'
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "**Giving up as a competing outcome** (Aalen-Johansen" in md


def test_by_condition_needs_the_ended_column():
    t = pd.DataFrame({"condition": ["a", "a"], "rt_s": [1.0, 2.0]})
    assert competing_by_condition(t) == {}
