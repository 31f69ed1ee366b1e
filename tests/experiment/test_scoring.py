"""Scoring: suggested scores from typed text, normalisation, Cohen's kappa (H21)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from experiment.clock import FakeClock
from experiment.interfaces import Answer, FlipRecord
from experiment.log import TrialLog
from experiment.protocol import load_protocol
from experiment.session.engine import Session
from experiment.session.scoring import cohen_kappa, kappa, normalize, suggest_score
from experiment.session.stimset import ObjectInfo, StimulusSet
from experiment.testing import make_stimulus_set

MUG = ObjectInfo("o1", "mug", ("coffee cup",), ("drinking coffee", "holding pens"), "main")
SCISSORS = ObjectInfo("o2", "scissors", ("shears",), ("cutting paper",), "main")
TOOTHBRUSH = ObjectInfo("o3", "toothbrush", (), ("brushing teeth",), "main")
ALL = (MUG, SCISSORS, TOOTHBRUSH)


@pytest.mark.parametrize(
    ("obj", "text", "expected"),
    [
        (MUG, "mug", "named"),
        (MUG, "MUG", "named"),
        (MUG, "  a Mug! ", "named"),
        (MUG, "mugs", "named"),
        (MUG, "mugg", "named"),  # typo
        (MUG, "a coffee cup", "named"),  # synonym (two words)
        (MUG, "coffee cups", "named"),
        (MUG, "you use it for drinking coffee", "use"),
        (MUG, "for drinkng coffee", "use"),  # typo in a use
        (MUG, "something round", "shape"),
        (MUG, "a long thin rectangle", "shape"),
        (MUG, "scissors", "wrong"),  # another object
        (MUG, "a shoe", "wrong"),
        (MUG, "", "pass"),
        (MUG, "pass", "pass"),
        (MUG, "don't know", "pass"),
        (SCISSORS, "scisors", "named"),
        (SCISSORS, "Shears", "named"),
        (SCISSORS, "cutting papers", "use"),
        (TOOTHBRUSH, "tooth brush", "named"),  # compound typed as two words
        (TOOTHBRUSH, "toothbrushes", "named"),
        (TOOTHBRUSH, "brushing teeth", "use"),
    ],
)
def test_suggest_score(obj, text, expected):
    assert suggest_score(text, obj, ALL) == expected


def test_short_words_need_an_exact_match():
    cap = ObjectInfo("o9", "cap", (), (), "main")
    assert suggest_score("cup", cap) == "wrong"
    assert suggest_score("caps", cap) == "named"


@given(st.text(max_size=40))
def test_normalize_is_idempotent(text):
    once = normalize(text)
    assert normalize(once) == once
    assert once == once.strip() and "  " not in once


def test_normalize_examples():
    assert normalize("Glasses, BOXES and Batteries") == "glass box and battery"


def test_kappa_matches_a_hand_computation():
    # Cohen 1960 on a 2x2 table [[20, 5], [10, 15]]: po = 35/50 = 0.7;
    # pe = (25/50)(30/50) + (25/50)(20/50) = 0.3 + 0.2 = 0.5; kappa = 0.2 / 0.5 = 0.4
    a = ["y"] * 25 + ["n"] * 25
    b = ["y"] * 20 + ["n"] * 5 + ["y"] * 10 + ["n"] * 15
    k, po, pe = kappa(a, b)
    assert (po, pe) == pytest.approx((0.7, 0.5))
    assert k == pytest.approx(0.4)
    assert kappa(a, a)[0] == pytest.approx(1.0)
    assert math.isnan(kappa([], [])[0])
    assert math.isnan(kappa(["x", "x"], ["x", "x"])[0]), "no variation: kappa undefined"
    with pytest.raises(ValueError, match="must have the same length"):
        kappa(["a"], [])


def test_cohen_kappa_from_a_trial_log_with_a_second_rater(tmp_path):
    stim = StimulusSet.load(
        make_stimulus_set(tmp_path / "s", n_main=4, n_training=1, levels=(1, 2))
    )
    proto = tmp_path / "p.toml"
    proto.write_text(
        '[protocol]\nname = "k"\n[[blocks]]\npart = "main"\nobjects = "main"\n'
        'levels = [1, 2]\nconditions = ["cluttered", "decluttered"]\n'
    )
    scores = ["named", "use", "shape", "wrong", "pass", "named", "wrong", "pass"] * 2
    second = ["named", "named", "shape", "wrong", "pass", "use", "shape", "pass"] * 2
    with TrialLog(tmp_path / "k.sqlite") as log:
        s = Session.open(log, load_protocol(proto), stim, "S01", clock=FakeClock())
        for sc in scores:
            t = s.next_trial()
            s.record(t, Answer("x", sc, "operator"), FlipRecord(0.0))
        for i, sc in enumerate(second):
            s.rescore(i, sc, "B")
        res = cohen_kappa(log, "operator", "B")
        k, po, pe = kappa(scores, second)
        assert (res.n, res.kappa, res.observed, res.expected) == (16, k, po, pe)
        assert 0 < res.kappa < 1
        # only recognised vs not: named/use agree everywhere, shape vs wrong do not matter
        rec = cohen_kappa(log, "operator", "B", labels="recognized")
        assert rec.kappa == pytest.approx(1.0)
        # the operator's own scores are unchanged by the second rater
        assert [r["score"] for r in log.tidy_trials()] == scores
        with pytest.raises(ValueError, match="labels must be 'score' or 'recognized'"):
            cohen_kappa(log, "operator", "B", labels="x")
        assert cohen_kappa(log, "operator", "nobody").n == 0
