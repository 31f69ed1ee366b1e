"""Schedules: the jung2015 ordering rules, other designs, and refusal of missing stimuli (H5)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from experiment.protocol import ProtocolError, load_protocol
from experiment.session.schedule import Schedule, Trial, build_schedule
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set


@pytest.fixture(scope="module")
def paper_set(tmp_path_factory) -> StimulusSet:
    """20 main + 3 training objects, all 8 levels, photos (tiny images; pixels are not used)."""
    return StimulusSet.load(
        make_stimulus_set(tmp_path_factory.mktemp("set"), n_main=20, n_training=3)
    )


@pytest.fixture(scope="module")
def jung(paper_set):
    return load_protocol("jung2015")


def main_trials(schedule: Schedule) -> list[Trial]:
    return list(schedule.part("main"))


def blocks_of(trials):
    out: dict[int, list[Trial]] = {}
    for t in trials:
        out.setdefault(t.block, []).append(t)
    return list(out.values())


def test_jung2015_has_320_main_trials_per_subject(jung, paper_set):
    s = build_schedule(jung, paper_set, rng=1)
    main = main_trials(s)
    assert len(main) == 320
    assert Counter((t.object, t.condition, t.level) for t in main) == Counter(
        {
            (o, c, lv): 1
            for o in paper_set.object_ids("main")
            for c in ("cluttered", "decluttered")
            for lv in range(1, 9)
        }
    )
    assert [t.index for t in s.trials] == list(range(len(s)))


def test_jung2015_levels_ascending(jung, paper_set):
    levels = [t.level for t in main_trials(build_schedule(jung, paper_set, rng=2))]
    assert levels == sorted(levels)


def test_jung2015_cluttered_block_before_decluttered_at_each_level(jung, paper_set):
    blocks = blocks_of(main_trials(build_schedule(jung, paper_set, rng=3)))
    assert len(blocks) == 16
    seq = [(b[0].level, b[0].condition) for b in blocks]
    assert seq == [(lv, c) for lv in range(1, 9) for c in ("cluttered", "decluttered")]
    for b in blocks:
        assert len({(t.level, t.condition) for t in b}) == 1, "a block has one level and condition"


def test_jung2015_every_object_once_per_block(jung, paper_set):
    main_ids = sorted(paper_set.object_ids("main"))
    for b in blocks_of(main_trials(build_schedule(jung, paper_set, rng=4))):
        assert sorted(t.object for t in b) == main_ids


def test_jung2015_orders_differ_between_subjects_and_repeat_for_a_seed(jung, paper_set):
    a = build_schedule(jung, paper_set, rng=np.random.default_rng(10))
    b = build_schedule(jung, paper_set, rng=np.random.default_rng(11))
    a2 = build_schedule(jung, paper_set, rng=np.random.default_rng(10))
    assert a == a2
    assert [t.object for t in main_trials(a)] != [t.object for t in main_trials(b)]
    # inside blocks too: most of the 16 blocks have a different object order
    differ = sum(
        [t.object for t in x] != [t.object for t in y]
        for x, y in zip(blocks_of(main_trials(a)), blocks_of(main_trials(b)), strict=True)
    )
    assert differ >= 14


def test_jung2015_training_part(jung, paper_set):
    s = build_schedule(jung, paper_set, rng=5)
    training = list(s.part("training"))
    train_ids = set(paper_set.object_ids("training"))
    assert len(train_ids) == 3
    assert {t.object for t in training} == train_ids
    # training comes first, the full-resolution colour photos first: wide, then confocal
    # (Sec. 3.1)
    assert [t.part for t in s.trials[: len(training)]] == ["training"] * len(training)
    assert [t.condition for t in training[:6]] == ["colour_wide"] * 3 + ["colour_confocal"] * 3
    assert {t.level for t in training[:6]} == {8}
    rest = training[6:]
    assert len(rest) == 3 * 8 * 2
    assert Counter((t.condition, t.level) for t in rest) == Counter(
        {(c, lv): 3 for c in ("cluttered", "decluttered") for lv in range(1, 9)}
    )
    assert [t.level for t in rest] == sorted(t.level for t in rest)


def test_schedule_is_a_permutation_for_many_seeds(jung, paper_set):
    ref = sorted(
        (t.object, t.condition, t.level, t.part) for t in build_schedule(jung, paper_set, 0)
    )
    for seed in range(1, 8):
        s = build_schedule(jung, paper_set, rng=seed)
        assert sorted((t.object, t.condition, t.level, t.part) for t in s) == ref


def test_iter_trials_resumes_after_an_index(jung, paper_set):
    s = build_schedule(jung, paper_set, rng=6)
    assert [t.index for t in s.iter_trials()] == list(range(len(s)))
    assert [t.index for t in s.iter_trials(start_after=9)][:2] == [10, 11]
    assert list(s.iter_trials(start_after=len(s) - 1)) == []


def test_trial_round_trips_and_pass_time(jung, paper_set):
    t = build_schedule(jung, paper_set, rng=7)[100]
    assert Trial.from_dict(t.to_dict()) == t
    assert t.pass_allowed_after_s == 60.0
    rec = paper_set.get(t.object, t.condition, t.level)
    assert (t.path, t.sha256, t.pixels, t.window) == (rec.path, rec.sha256, rec.pixels, rec.window)


def test_schedule_rejects_bad_indices():
    t = Trial(1, "main", 1, "o", "n", "cluttered", 1, 40, 96, "p", "x", 60.0)
    with pytest.raises(ValueError, match="trial indices must be 0..n-1"):
        Schedule([t])


def write(tmp_path, body, name="p.toml"):
    p = tmp_path / name
    p.write_text('[protocol]\nname = "t"\n' + body)
    return load_protocol(p)


def test_interleaved_shipped_design(paper_set):
    spec = load_protocol("interleaved")
    s = build_schedule(spec, paper_set, rng=1)
    blocks = blocks_of(main_trials(s))
    assert len(blocks) == 8
    for lv, b in enumerate(blocks, start=1):
        assert {t.level for t in b} == {lv}
        assert Counter(t.condition for t in b) == {"cluttered": 20, "decluttered": 20}
        conds = [t.condition for t in b]
        assert conds != sorted(conds), "conditions are mixed inside a block"
    brk = [b[0].break_before for b in blocks]
    assert brk == [False, False, True, False, True, False, True, False]


def test_randomised_blocks_shipped_design(paper_set):
    spec = load_protocol("randomised_blocks")
    a = blocks_of(main_trials(build_schedule(spec, paper_set, rng=1)))
    b = blocks_of(main_trials(build_schedule(spec, paper_set, rng=2)))
    assert len(a) == 16  # 4 levels x 2 conditions x 2 repetitions
    seq_a = [(x[0].level, x[0].condition) for x in a]
    seq_b = [(x[0].level, x[0].condition) for x in b]
    assert Counter(seq_a) == Counter(
        {(lv, c): 2 for lv in (2, 4, 6, 8) for c in ("cluttered", "decluttered")}
    )
    assert seq_a[:8] != sorted(seq_a[:8]) or seq_a != seq_b, "block order is randomised"
    assert seq_a != seq_b
    assert sorted(set(seq_a[:8])) == sorted(set(seq_a[8:])), "each repetition has every block"
    assert [x[0].break_before for x in a] == [i > 0 and i % 4 == 0 for i in range(16)]
    assert {t.repetition for x in a for t in x} == {0, 1}


def test_descending_listed_and_group_by_condition(tmp_path, paper_set):
    spec = write(
        tmp_path,
        """
[[blocks]]
part = "main"
objects = ["obj01", "obj02"]
levels = [3, 1, 2]
conditions = ["decluttered", "cluttered"]
group_by = "condition"
level_order = "descending"
trial_order = "listed"
""",
    )
    s = build_schedule(spec, paper_set, rng=0)
    assert [(t.condition, t.level, t.object) for t in s] == [
        (c, lv, o)
        for c in ("decluttered", "cluttered")
        for lv in (3, 2, 1)
        for o in ("obj01", "obj02")
    ]
    assert len({t.block for t in s}) == 2


def test_listed_level_order_and_single_block(tmp_path, paper_set):
    spec = write(
        tmp_path,
        """
[[blocks]]
part = "main"
objects = ["obj03"]
levels = [5, 2, 7]
conditions = ["cluttered"]
group_by = "none"
level_order = "listed"
trial_order = "listed"
""",
    )
    s = build_schedule(spec, paper_set, rng=0)
    assert [t.level for t in s] == [5, 2, 7] and {t.block for t in s} == {1}


def test_random_level_order_differs_by_seed(tmp_path, paper_set):
    spec = write(
        tmp_path,
        """
[[blocks]]
part = "main"
objects = "main"
levels = [1, 2, 3, 4, 5, 6, 7, 8]
conditions = ["cluttered"]
level_order = "random"
""",
    )
    orders = {
        tuple(b[0].level for b in blocks_of(build_schedule(spec, paper_set, seed)))
        for seed in range(5)
    }
    assert len(orders) > 1


@pytest.mark.parametrize(
    ("objects", "levels", "conditions", "match"),
    [
        ('"main"', "[1, 9]", '["cluttered"]', r"blocks\[0\]\.levels: level 9 is not in stimulus"),
        ('["obj01", "teacup"]', "[1]", '["cluttered"]', r"object 'teacup' is not in stimulus set"),
        ('"practice"', "[1]", '["cluttered"]', r"no objects with role 'practice'"),
        ('"main"', "[1]", '["photo"]', r"no image for object 'obj01', condition 'photo', level 1"),
    ],
    ids=[
        "level_missing",
        "object_missing",
        "role_without_objects",
        "image_missing_for_a_combination",
    ],
)
def test_stimuli_the_protocol_needs_are_missing(
    tmp_path, paper_set, objects, levels, conditions, match
):
    spec = write(
        tmp_path,
        f"""
[[blocks]]
part = "main"
objects = {objects}
levels = {levels}
conditions = {conditions}
""",
    )
    with pytest.raises(ProtocolError, match=match):
        build_schedule(spec, paper_set, rng=0)
