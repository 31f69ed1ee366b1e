"""The ``calibrated`` observer: fitted to the cluttered condition only, with an open-set
criterion, and its defaults taken from the committed calibration file."""

from __future__ import annotations

import hashlib
import math
import shutil

import numpy as np
import pytest
from PIL import Image

from experiment.observers import CalibratedObserver, CalibratedParams, make_observer
from experiment.observers.calibration import (
    CALIBRATION_FILE,
    PAPER_CLUTTERED_BETA,
    calibrate,
    crossing_px,
    decision_variable,
    normalized_responses,
    read_calibration,
)
from experiment.observers.exemplar import ExemplarParams, load_knowledge
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set

GRIDS = {"blur_grid_deg": (0.1,), "noise_grid": (0.25, 0.5), "repeats": 5}


@pytest.fixture(scope="module")
def small_pair(tmp_path_factory):
    """A small test set and its knowledge (the same kinds drawn with another seed)."""
    root = tmp_path_factory.mktemp("cal")
    test = make_stimulus_set(root / "test", n_main=4, n_training=1, levels=(1, 5, 8), rng=3)
    knowledge = make_stimulus_set(root / "k", n_main=4, n_training=1, levels=(8,), rng=4)
    return test, knowledge


def test_calibration_never_reads_decluttered_stimuli(small_pair, tmp_path):
    """Fitted on a copy with every de-cluttered image deleted, the values are identical: a
    read of any de-cluttered stimulus would raise (missing file) or change them."""
    test, knowledge = small_pair
    full = calibrate([(test, knowledge)], **GRIDS, rng=1)
    stripped = tmp_path / "test"
    shutil.copytree(test, stripped)
    ts = StimulusSet.load(stripped)
    removed = [r for r in ts.records if r.condition == "decluttered"]
    assert removed
    for r in removed:
        (stripped / r.path).unlink()
    again = calibrate([(stripped, knowledge)], **GRIDS, rng=1)
    for key in ("fitted", "cluttered_rate", "open_set", "predicted_cluttered", "loss"):
        assert again[key] == full[key], key


def test_poisoned_decluttered_stimuli_leave_the_fit_unchanged(small_pair, tmp_path):
    """De-cluttered images swapped for blank ones (manifest hashes updated, so a read would
    succeed and see them): the fitted values are still identical."""
    test, knowledge = small_pair
    full = calibrate([(test, knowledge)], **GRIDS, rng=1)
    poisoned = tmp_path / "test"
    shutil.copytree(test, poisoned)
    manifest = (poisoned / "manifest.csv").read_text(encoding="utf-8").splitlines()
    out = [manifest[0]]
    for line in manifest[1:]:
        cols = line.split(",")
        if cols[2] == "decluttered":
            path = poisoned / cols[8]
            with Image.open(path) as im:
                size = im.size
            Image.new("1", size, 1).save(path)
            cols[9] = hashlib.sha256(path.read_bytes()).hexdigest()
        out.append(",".join(cols))
    (poisoned / "manifest.csv").write_text("\n".join(out) + "\n", encoding="utf-8")
    again = calibrate([(poisoned, knowledge)], **GRIDS, rng=1)
    assert again["fitted"] == full["fitted"] and again["loss"] == full["loss"]


def test_paper_cluttered_slope_is_the_weibull_through_both_paper_numbers():
    # 1 - exp(-ln2 (x / 8695) ** beta) is 0.5 at 8,695 px and 0.10 at 3,100 px (Sec. 3.2.2)
    p = 1 - math.exp(-math.log(2) * (3100 / 8695) ** PAPER_CLUTTERED_BETA)
    assert p == pytest.approx(0.10, abs=1e-12)


def test_calibration_file_is_the_default_and_says_how_it_was_obtained():
    d = read_calibration()
    p = CalibratedParams(knowledge="k")
    for key in ("samples_per_deg", "decision", "blur_deg", "cell_deg", "noise_sd", "criterion"):
        assert getattr(p, key) == d["fitted"][key], key
    assert "cluttered condition only" in d["how"] and "No de-cluttered stimulus" in d["how"]
    assert d["open_set"]["floor"] <= d["fitted"]["criterion"]
    assert CALIBRATION_FILE.name == "jung2015_calibration.json"


def test_calibration_refuses_bad_arguments(small_pair, tmp_path):
    with pytest.raises(ValueError, match="sets must name at least one"):
        calibrate([])
    with pytest.raises(ValueError, match=r"open_set_quantile must be in \(0, 1\), got 1.0"):
        calibrate([small_pair], open_set_quantile=1.0)
    with pytest.raises(ValueError, match=r"lapse must be in \[0, 0.5\), got 0.5"):
        calibrate([small_pair], lapse=0.5)
    with pytest.raises(ValueError, match="repeats must be >= 1, got 0"):
        calibrate([small_pair], repeats=0)
    bad = tmp_path / "bad.json"
    bad.write_text('{"fitted": {"blur_deg": 0.1}}')
    with pytest.raises(ValueError, match="expected a 'fitted' table"):
        read_calibration(bad)


def test_normalized_responses_are_scale_free():
    s = np.array([0.1, 0.3, 0.2, 0.25])
    assert np.allclose(normalized_responses(s), normalized_responses(3 * s + 0.4))
    assert normalized_responses(np.full(3, 0.2)).tolist() == [0.0, 0.0, 0.0]


@pytest.mark.parametrize("decision", ["margin", "standout"])
def test_calibrated_observer_passes_when_no_kind_stands_out(small_pair, decision):
    """Two kinds tied for best above three alike: passed under either decision variable (the
    margin is 0; the best stands only 1.2 SD above the mean match); one kind far above the
    rest: named."""
    test, knowledge = small_pair
    ts = StimulusSet.load(test)
    obs = make_observer("calibrated", ts, "S1", rng=0, knowledge=str(knowledge), noise_sd=0.0,
                        lapse=0.0, criterion=1.5, decision=decision)  # fmt: skip
    assert isinstance(obs, CalibratedObserver) and obs.name == "calibrated"
    assert len(obs.knowledge.categories) == 5
    tied = np.array([0.5, 0.5, 0.1, 0.1, 0.1])
    best, v = obs._decide(tied)
    assert v <= obs.criterion
    alone = np.array([0.9, 0.1, 0.1, 0.1, 0.1])
    best, v = obs._decide(alone)
    assert best == 0 and v > obs.criterion
    d = obs.describe()
    assert d["observer"] == "calibrated" and d["params"]["decision"] == decision
    assert d["calibration"]["method"] == "given (differs from the calibration file)"


def test_standout_names_a_clear_match_that_a_near_kind_would_veto():
    """A mug and a cup both far above 21 other kinds: the margin (best minus second) is tiny,
    so the margin rule passes on a clear match; the standout (best above the spread of all
    matches) names it, as for a lone match."""
    near = normalized_responses(np.array([0.9, 0.85] + [0.1] * 21))
    best, margin = decision_variable(near[None], "margin")
    _, standout = decision_variable(near[None], "standout")
    assert best[0] == 0 and margin[0] < 0.3 and standout[0] > 3.0
    lone = normalized_responses(np.array([0.9] + [0.1] * 22))
    assert decision_variable(lone[None], "standout")[1][0] > 3.0
    # no kind stands out: every match alike but one a little higher
    flat = normalized_responses(np.linspace(0.1, 0.2, 23))
    assert decision_variable(flat[None], "standout")[1][0] < 2.0
    with pytest.raises(ValueError, match="decision must be one of margin, standout, got 'x'"):
        decision_variable(near[None], "x")
    with pytest.raises(ValueError, match="decision must be one of margin, standout, got 'x'"):
        CalibratedParams(knowledge="k", decision="x")


def test_calibration_records_its_decision_variable_and_front_end(small_pair):
    """The fit is made with the decision variable and retinal sampling asked for, and the
    result says which; the open-set floor is that variable's quantile on unknown kinds."""
    grids = {**GRIDS, "noise_grid": (0.25,)}
    m = calibrate([small_pair], **grids, decision="margin", samples_per_deg=8.0, rng=1)
    s = calibrate([small_pair], **grids, decision="standout", samples_per_deg=8.0, rng=1)
    assert m["fitted"]["decision"] == "margin" and s["fitted"]["decision"] == "standout"
    assert m["fitted"]["samples_per_deg"] == s["fitted"]["samples_per_deg"] == 8.0
    assert s["open_set"]["floor"] != m["open_set"]["floor"]
    assert s["open_set"]["floor"] <= s["fitted"]["criterion"]
    with pytest.raises(ValueError, match="decision must be one of margin, standout, got 'x'"):
        calibrate([small_pair], decision="x")
    with pytest.raises(ValueError, match="samples_per_deg must be > 0, got 0"):
        calibrate([small_pair], samples_per_deg=0)


@pytest.fixture(scope="module")
def second_knowledge(tmp_path_factory):
    """A second rendering of the small set's kinds (another draw), for pooled knowledge."""
    root = tmp_path_factory.mktemp("k2")
    return make_stimulus_set(root / "k2", n_main=4, n_training=1, levels=(8,), rng=5)


def test_pooled_knowledge_remembers_every_rendering_of_a_kind_once(small_pair, second_knowledge):
    """Two renderings pooled: the kinds are merged by name, the exemplar rows are stacked, so a
    kind's similarity is its best exemplar over both renderings."""
    _, k1 = small_pair
    one = load_knowledge(ExemplarParams(knowledge=str(k1)))
    other = load_knowledge(ExemplarParams(knowledge=str(second_knowledge)))
    pooled = load_knowledge(ExemplarParams(knowledge=[str(k1), str(second_knowledge)]))
    assert pooled.categories == one.categories and len(set(pooled.categories)) == 5
    assert pooled.features.shape[0] == one.features.shape[0] + other.features.shape[0]
    f = other.features[0]
    assert np.allclose(
        pooled.similarities(f), np.maximum(one.similarities(f), other.similarities(f))
    )
    # a list of one folder is that folder
    assert ExemplarParams(knowledge=[str(k1)]).knowledge == str(k1)
    with pytest.raises(ValueError, match="knowledge must be the folder .* or a list"):
        ExemplarParams(knowledge=[])


def test_pooled_knowledge_calibration_never_reads_decluttered_stimuli(
    small_pair, second_knowledge, tmp_path
):
    """With pooled knowledge (the demo's), deleting every de-cluttered test image still leaves
    the fit identical."""
    test, k1 = small_pair
    sets = [(test, [k1, second_knowledge])]
    full = calibrate(sets, **GRIDS, rng=1)
    stripped = tmp_path / "test"
    shutil.copytree(test, stripped)
    for r in StimulusSet.load(stripped).records:
        if r.condition == "decluttered":
            (stripped / r.path).unlink()
    again = calibrate([(stripped, [k1, second_knowledge])], **GRIDS, rng=1)
    for key in ("fitted", "cluttered_rate", "cluttered_rate_per_set", "open_set", "loss"):
        assert again[key] == full[key], key


@pytest.mark.parametrize("objective", ["curve", "points"])
def test_calibration_loss_is_the_mean_of_each_sets_misfit(small_pair, second_knowledge, objective):
    """Two sets: the loss is the mean over sets of each one's misfit (to the paper's curve level
    by level, or in its 50 % and 10 % points), not the misfit of their pooled rate (which would
    let one set's excess hide another's shortfall)."""
    test, k1 = small_pair
    # a low criterion, so that the sets' rates differ from 0 and from each other
    grids = {**GRIDS, "criterion_grid": (0.0,), "open_set_quantile": 0.01}
    r = calibrate([(test, k1), (test, second_knowledge)], **grids, objective=objective, rng=1)
    assert r["cluttered_rate_per_set"][0] != r["cluttered_rate_per_set"][1]
    levels = np.array([float(x) for x in r["cluttered_rate"]])
    x10 = 8695.0 * (math.log(1 / 0.9) / math.log(2)) ** (1 / PAPER_CLUTTERED_BETA)
    assert x10 == pytest.approx(3100.0, rel=1e-9)  # the paper's "rises from ~3,100 px"
    target = 1 - np.exp(-math.log(2) * (levels / 8695.0) ** PAPER_CLUTTERED_BETA)

    def misfit(rate):
        if objective == "curve":
            return np.mean((rate - target) ** 2)
        return (
            math.log(crossing_px(levels, rate, 0.5) / 8695.0) ** 2
            + math.log(crossing_px(levels, rate, 0.1) / x10) ** 2
        )

    per_set = [misfit(np.array(row)) for row in r["cluttered_rate_per_set"]]
    assert len(per_set) == 2 and len(r["sets"]) == 2 and r["objective"] == objective
    assert r["loss"] == pytest.approx(np.mean(per_set), rel=1e-3)
    pooled = np.array(list(r["cluttered_rate"].values()))
    assert abs(r["loss"] - misfit(pooled)) > 1e-3 * r["loss"]
    assert all("cluttered_x50_px" in s for s in r["sets"])
    with pytest.raises(ValueError, match="objective must be 'curve' or 'points', got 'x'"):
        calibrate([(test, k1)], objective="x")


def test_crossing_px_reads_a_curve_in_log_pixels():
    lv = np.array([100.0, 1000.0, 10000.0])
    assert crossing_px(lv, np.array([0.0, 0.4, 0.8]), 0.6) == pytest.approx(10**3.5)
    assert crossing_px(lv, np.array([0.6, 0.7, 0.8]), 0.5) == pytest.approx(50.0)  # starts above
    assert crossing_px(lv, np.array([0.0, 0.2, 0.45]), 0.5) == pytest.approx(2e4)  # never
    # the first crossing counts, also when the curve falls back below
    assert crossing_px(lv, np.array([0.0, 0.5, 0.4]), 0.5) == pytest.approx(1000.0)


def test_calibrated_observer_logs_its_open_set_rate_from_the_calibration(small_pair):
    """With the fitted values, the observer logs the share of unknown-kind images it passed in
    calibration; with other values it claims none."""
    test, knowledge = small_pair
    ts = StimulusSet.load(test)
    named = read_calibration()["open_set"]["unknown_kinds_named"]
    obs = make_observer("calibrated", ts, "S1", rng=0, knowledge=str(knowledge))
    assert obs.describe()["calibration"]["unknown_kinds_passed"] == round(1 - named, 4)
    other = make_observer("calibrated", ts, "S1", rng=0, knowledge=str(knowledge), noise_sd=0.0)
    assert "unknown_kinds_passed" not in other.describe()["calibration"]


def test_a_kind_named_once_needs_less_evidence_for_the_rest_of_the_session(small_pair):
    """Priming: a match that stands out 2.0 SD is passed under a criterion of 2.2 until the
    observer has named that kind (rightly or not), then named (2.0 > 2.2 - 0.6); another kind
    is not primed, a new session (a new observer) starts unprimed, and with ``priming=0`` the
    match is always passed."""
    from types import SimpleNamespace

    test, knowledge = small_pair
    ts = StimulusSet.load(test)
    kind0 = np.array([0.7, 0.1, 0.1, 0.1, 0.1])  # kind 0 stands out by 2.0 SD
    kind1 = np.array([0.1, 0.7, 0.1, 0.1, 0.1])

    def observer(priming: float) -> CalibratedObserver:
        return make_observer("calibrated", ts, "S1", rng=0, knowledge=str(knowledge),
                             noise_sd=0.0, lapse=0.0, criterion=2.2, priming=priming)  # fmt: skip

    def score(obs: CalibratedObserver, matches: np.ndarray, criterion: float = 2.2) -> str:
        obs.similarities = lambda image: matches  # the image's noise-free matches
        best = int(np.argmax(matches))
        obj = next(o for o in ts.objects if obs._is_correct(best, o))
        obs.criterion = criterion
        trial = SimpleNamespace(object=obj, pass_allowed_after_s=60.0)
        return obs.respond(trial, np.zeros((4, 4))).score

    named = ("named", "use")  # else passed (or a shape described)
    obs = observer(0.6)
    assert score(obs, kind0) not in named
    assert score(obs, kind0, criterion=1.9) in named  # a clearer view: kind 0 named
    assert score(obs, kind0) in named  # primed now
    assert score(obs, kind1) not in named  # kind 1 never named
    assert score(observer(0.6), kind0) not in named  # a new session starts unprimed
    unprimed = observer(0.0)
    assert score(unprimed, kind0, criterion=1.9) in named
    assert score(unprimed, kind0) not in named
