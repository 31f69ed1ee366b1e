"""Second rater: main trials by default, undo, progress; kappa with a 95 % interval."""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from experiment import cli
from experiment.commands.score import pending_for_rater
from experiment.log import TrialLog
from experiment.session.scoring import (
    KAPPA_MIN_TRIALS,
    cohen_kappa,
    kappa,
    kappa_interval,
    kappa_interval_few_trials,
)
from tests.experiment.conftest import make_answered_log


@pytest.fixture()
def answered(tmp_path):
    """A log with one person's session: 2 training + 8 main trials, all answered 'named'."""
    return make_answered_log(tmp_path)


def test_main_trials_only_unless_asked(answered):
    with TrialLog(answered, readonly=True) as log:
        main = pending_for_rater(log, "B")
        every = pending_for_rater(log, "B", include_training=True)
    assert {p["part"] for p in main} == {"main"} and len(main) == 8
    assert len(every) == 10 and {p["part"] for p in every} == {"main", "training"}


def test_undo_and_progress(answered):
    from experiment.console import ScoringApp

    log = TrialLog(answered)
    pending = pending_for_rater(log, "B")
    app = ScoringApp(log, "B", pending)
    seen = {}

    async def script() -> None:
        async with app.run_test() as pilot:
            seen["start"] = str(app.query_one("#status").render())
            await pilot.press("f1", "f2")
            seen["two"] = str(app.query_one("#status").render())
            await pilot.press("ctrl+z")
            seen["undone"] = str(app.query_one("#item").render())
            seen["back"] = str(app.query_one("#status").render())
            await pilot.press("f4", "f3")
            await pilot.press("ctrl+q")

    asyncio.run(asyncio.wait_for(script(), timeout=60))
    assert app.return_value == 3
    assert "scored 0 of 8, 8 left" in seen["start"] and "0 %" in seen["start"]
    assert "scored 2 of 8, 6 left" in seen["two"] and "25 %" in seen["two"]
    assert "scored 1 of 8, 7 left" in seen["back"]
    assert "undone: you gave use" in seen["undone"] and pending[1]["response"] in seen["undone"]
    rows = log.execute("SELECT trial_index, score, note FROM scores WHERE rater = 'B' "
                       "ORDER BY score_id")  # fmt: skip
    t = [p["trial_index"] for p in pending]
    assert [(r["trial_index"], r["score"]) for r in rows] == [
        (t[0], "named"), (t[1], "use"), (t[1], "wrong"), (t[2], "shape")
    ]  # fmt: skip
    assert "replaces this rater's undone use" in rows[2]["note"]
    latest = log.latest_scores("B")
    assert latest[(1, t[1])] == "wrong", "the re-score after undo is the one that counts"
    log.close()


def test_score_command_says_training_is_left(answered, tmp_path, capsys):
    with TrialLog(answered) as log:
        for p in pending_for_rater(log, "B"):
            log.add_score(p["session_id"], p["trial_index"], "named", True, "B")
    with pytest.raises(SystemExit) as exc:
        cli.main(["score", str(answered), "--rater", "B"])
    assert exc.value.code in (0, None)
    out = capsys.readouterr().out
    assert "every answered main trial has a score by 'B'" in out
    assert "2 training trial(s) left: --include-training" in out


def fleiss_cohen_everitt(table: np.ndarray) -> tuple[float, float]:
    """Cohen's kappa and its large-sample SE by the closed forms of Cohen (1960) and
    Fleiss, Cohen & Everitt (1969), Psychol. Bull. 72, eq. 13, written out independently."""
    n = table.sum()
    p = table / n
    rows, cols = p.sum(axis=1), p.sum(axis=0)
    po, pe = np.trace(p), float(rows @ cols)
    k = (po - pe) / (1 - pe)
    a = sum(p[i, i] * (1 - (rows[i] + cols[i]) * (1 - k)) ** 2 for i in range(len(p)))
    b = (1 - k) ** 2 * sum(
        p[i, j] * (cols[i] + rows[j]) ** 2 for i in range(len(p)) for j in range(len(p)) if i != j
    )
    c = (k - pe * (1 - k)) ** 2
    return float(k), float(math.sqrt((a + b - c) / (n * (1 - pe) ** 2)))


def test_kappa_interval_matches_the_closed_form():
    rng = np.random.default_rng(4)
    labels = ["named", "use", "shape", "wrong", "pass"]
    a = list(rng.choice(labels, 60, p=[0.4, 0.2, 0.1, 0.2, 0.1]))
    b = [x if rng.random() < 0.7 else str(rng.choice(labels)) for x in a]
    k, se, lo, hi = kappa_interval(a, b)
    table = np.zeros((5, 5))
    for x, y in zip(a, b, strict=True):
        table[labels.index(x), labels.index(y)] += 1
    k_ref, se_ref = fleiss_cohen_everitt(table)
    assert k == pytest.approx(k_ref, rel=1e-12) == pytest.approx(kappa(a, b)[0], rel=1e-12)
    assert se == pytest.approx(se_ref, rel=1e-9)
    z = 1.959963984540054  # Phi^-1(0.975)
    assert (lo, hi) == pytest.approx((k - z * se, k + z * se), rel=1e-9)
    # perfect agreement on few trials: the Wald interval would pass 1; it is clipped
    _, _, lo1, hi1 = kappa_interval(["a", "b", "a"], ["a", "b", "a"])
    assert hi1 == 1.0 and -1.0 <= lo1 <= 1.0
    with pytest.raises(ValueError, match="equally long and non-empty"):
        kappa_interval([], [])


def test_status_says_too_few_trials_for_a_kappa_interval(answered, capsys):
    with TrialLog(answered) as log:
        pending = pending_for_rater(log, "B")
        for i, p in enumerate(pending):
            log.add_score(p["session_id"], p["trial_index"], "named" if i % 3 else "wrong",
                          i % 3 != 0, "B")  # fmt: skip
        res = cohen_kappa(log, "B", "operator")
    assert res.n < KAPPA_MIN_TRIALS and math.isnan(res.ci95_low)
    with pytest.raises(SystemExit):
        cli.main(["session", "status", str(answered)])
    out = capsys.readouterr().out
    assert "95% CI -" not in out and "(95% CI 1.000 to 1.000)" not in out
    assert f"(no 95% CI: too few trials, fewer than {KAPPA_MIN_TRIALS})" in out


def test_kappa_interval_on_perfect_agreement_is_not_a_point():
    # 30 of 30 trials agree: the Wald interval is 1.000 to 1.000 (standard error 0). The
    # Clopper-Pearson lower bound of 30/30 is 0.025^(1/30) = 0.8843 in closed form; mapped with
    # chance agreement 0.5 it gives kappa (0.8843 - 0.5) / 0.5.
    a = ["a", "b"] * 15
    k, _, lo, hi = kappa_interval_few_trials(a, a)
    assert k == 1.0 and hi == 1.0
    assert lo == pytest.approx((0.025 ** (1 / 30) - 0.5) / 0.5, rel=1e-9)
    assert kappa_interval(a, a)[2:] == (1.0, 1.0)
    k, se, lo, hi = kappa_interval_few_trials(a[:2], a[:2])
    assert k == 1.0 and math.isnan(se) and math.isnan(lo) and math.isnan(hi)
