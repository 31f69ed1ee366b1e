"""Simulated observers: the logistic model's parameters, and an image-based model observer."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest

from experiment.observers import (
    OBSERVERS,
    LogisticObserver,
    LogisticParams,
    TemplateObserver,
    TemplateParams,
    make_observer,
    to_retina,
)
from experiment.protocol import load_protocol
from experiment.schedule import Trial, build_schedule
from experiment.stimset import StimulusSet
from experiment.testing import make_stimulus_set


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    return StimulusSet.load(
        make_stimulus_set(tmp_path_factory.mktemp("s"), n_main=5, n_training=1, levels=(1, 8))
    )


def trial(obj="obj01", condition="cluttered", pixels=8695, level=5):
    return Trial(0, "main", 1, obj, "mug", condition, level, 7, pixels, "p", "x", 60.0)


def test_registry_has_both_observers(small_set):
    assert set(OBSERVERS) >= {"logistic", "model"}
    assert isinstance(make_observer("logistic", small_set, "S1", rng=0), LogisticObserver)
    assert isinstance(make_observer("model", small_set, "S1", rng=0), TemplateObserver)
    with pytest.raises(ValueError, match="observer must be one of logistic, model"):
        make_observer("oracle", small_set, "S1")
    with pytest.raises(ValueError, match="unknown parameter 'slope' for observer 'logistic'"):
        make_observer("logistic", small_set, "S1", slope=3)


def test_logistic_defaults_are_the_papers_numbers():
    p = LogisticParams()
    assert (p.or_background, p.or_per_log10_px, p.x50_cluttered_px) == (5.6, 74.5, 8695.0)
    # de-cluttered 50 % point implied by OR 5.6 and OR 74.5 / log10 px: 10^(log10 8695 -
    # ln 5.6 / ln 74.5) = 3,470 px; the paper's Weibull fit gave 3,532 px
    assert p.x50_decluttered_px == pytest.approx(3470, rel=0.01)
    assert p.intercept == pytest.approx(-math.log(74.5) * math.log10(8695))


def test_logistic_probability_at_the_thresholds(small_set):
    obs = make_observer("logistic", small_set, "S1", subject_sd=0.0, object_sd=0.0, lapse=0.1)
    p = obs.params
    assert obs.p_recognized(trial(pixels=8695)) == pytest.approx(0.45)
    assert obs.p_recognized(trial(condition="decluttered", pixels=p.x50_decluttered_px)) == (
        pytest.approx(0.45)
    )
    # Eq. 1 of the paper: with OR 5.6, 50 % cluttered -> 84.9 % de-cluttered (no lapse here)
    nolapse = make_observer("logistic", small_set, "S1", subject_sd=0.0, object_sd=0.0, lapse=0)
    assert nolapse.p_recognized(trial(condition="decluttered")) == pytest.approx(0.849, abs=1e-3)
    assert obs.p_recognized(trial(condition="photo")) == pytest.approx(0.9)


def test_logistic_effects_are_shared_across_subjects_and_differ_between_them(small_set):
    a = make_observer("logistic", small_set, "S1", rng=0)
    a2 = make_observer("logistic", small_set, "S1", rng=1)
    b = make_observer("logistic", small_set, "S2", rng=0)
    assert a.object_effects == b.object_effects, "object difficulty is a property of the object"
    assert a.subject_effect == a2.subject_effect != b.subject_effect
    assert len(set(a.object_effects.values())) == len(small_set.objects)
    other = make_observer("logistic", small_set, "S1", population_seed=5)
    assert other.object_effects != a.object_effects


def test_logistic_answers_are_consistent_with_the_draw(small_set):
    obs = make_observer("logistic", small_set, "S1", rng=3)
    seen = defaultdict(int)
    for px in (96, 950, 8695, 160884):
        for _ in range(200):
            a = obs.respond(trial(pixels=px), np.zeros((2, 2), bool))
            seen[a.score] += 1
            assert a.rater == "sim:logistic"
            if a.score == "named":
                assert a.response == "mug"
            if a.score == "pass":
                assert a.response == "" and a.rt_s >= 60.0
    assert set(seen) == {"named", "use", "shape", "wrong", "pass"}


def test_logistic_recognition_rate_follows_the_model(small_set):
    obs = make_observer("logistic", small_set, "S1", rng=4)
    t = trial(pixels=8695)
    p = obs.p_recognized(t)
    n = 4000
    k = sum(obs.respond(t, np.zeros((1, 1))).score in ("named", "use") for _ in range(n))
    # binomial SE at n = 4000 is <= 0.008; 4 SE
    assert abs(k / n - p) < 0.032


def test_logistic_params_are_checked():
    with pytest.raises(ValueError, match="or_background must be > 0"):
        LogisticParams(or_background=0)
    with pytest.raises(ValueError, match="or_per_log10_px must be > 1"):
        LogisticParams(or_per_log10_px=1)
    with pytest.raises(ValueError, match="x50_cluttered_px must be > 0"):
        LogisticParams(x50_cluttered_px=-1)
    with pytest.raises(ValueError, match=r"lapse must be in \[0, 0.5\)"):
        LogisticParams(lapse=0.5)


def test_template_params_are_checked():
    with pytest.raises(ValueError, match="retina_shape_px must be"):
        TemplateParams(retina_shape_px=(1, 5))
    with pytest.raises(ValueError, match="blur_sd_px must be >= 0"):
        TemplateParams(blur_sd_px=-1)
    with pytest.raises(ValueError, match="pixel_noise_sd must be >= 0"):
        TemplateParams(pixel_noise_sd=-1)
    with pytest.raises(ValueError, match=r"lapse must be in \[0, 0.5\)"):
        TemplateParams(lapse=0.7)


def test_to_retina_standardises_and_keeps_the_input():
    img = np.zeros((8, 12), bool)
    img[2:5, 3:9] = True
    copy = img.copy()
    r = to_retina(img, (16, 24), 0.0)
    assert r.shape == (16, 24)
    assert r.mean() == pytest.approx(0.0, abs=1e-12) and r.std() == pytest.approx(1.0)
    # pixel replication: each input pixel becomes a 2x2 patch
    assert np.array_equal(r > 0, np.kron(img, np.ones((2, 2), bool)))
    assert np.array_equal(img, copy)
    assert np.all(to_retina(np.zeros((4, 4)), (8, 8), 1.0) == 0)


def test_model_observer_without_noise_recognises_its_own_templates(small_set):
    obs = make_observer("model", small_set, "S1", rng=0, pixel_noise_sd=0.0, lapse=0.0)
    for oid in small_set.object_ids("main"):
        rec = small_set.get(oid, "decluttered", 8)
        t = trial(obj=oid, condition="decluttered", level=8, pixels=rec.pixels)
        ids, r = obs.correlations(t, small_set.load_image(rec))
        assert ids[int(np.argmax(r))] == oid
        assert r.max() == pytest.approx(1.0)
        assert obs.respond(t, small_set.load_image(rec)).score in ("named", "use")


def test_model_observer_answers_from_the_image_not_the_label(small_set):
    """Shown object B's image under object A's label, it names B (a 'wrong' answer for A)."""
    obs = make_observer("model", small_set, "S1", rng=0, pixel_noise_sd=0.0, lapse=0.0)
    rec_b = small_set.get("obj02", "decluttered", 8)
    a = obs.respond(
        trial(obj="obj01", condition="decluttered", level=8), small_set.load_image(rec_b)
    )
    assert a.score == "wrong" and a.response == small_set.objects["obj02"].name


@pytest.fixture(scope="module")
def medium_set(tmp_path_factory):
    """20 objects at a quarter of the paper's working size, all 8 levels."""
    return StimulusSet.load(
        make_stimulus_set(
            tmp_path_factory.mktemp("m"), n_main=20, n_training=3, working_shape_px=(82, 123), rng=1
        )
    )


def test_model_observer_is_hurt_by_clutter_and_low_resolution(medium_set):
    spec = load_protocol("jung2015")
    obs = make_observer("model", medium_set, "S1", rng=11)
    rate = defaultdict(list)
    for rep in range(3):
        for t in build_schedule(spec, medium_set, rng=rep).part("main"):
            a = obs.respond(
                t, medium_set.load_image(medium_set.get(t.object, t.condition, t.level))
            )
            rate[(t.condition, t.level)].append(a.score in ("named", "use"))
    clut = np.mean([np.mean(rate[("cluttered", lv)]) for lv in range(1, 9)])
    decl = np.mean([np.mean(rate[("decluttered", lv)]) for lv in range(1, 9)])
    low = np.mean(rate[("cluttered", 1)] + rate[("decluttered", 1)])
    high = np.mean(rate[("cluttered", 8)] + rate[("decluttered", 8)])
    print(
        f"model observer: cluttered {clut:.2f}, de-cluttered {decl:.2f}, level 1 {low:.2f}, "
        f"level 8 {high:.2f}"
    )
    # 480 trials per condition: SE of a difference of rates <= 0.033; margins are > 3 SE
    assert decl - clut > 0.1
    assert high - low > 0.15


def test_model_observer_template_level_is_checked():
    with pytest.raises(ValueError, match="template_level must be a level >= 1 or None"):
        TemplateParams(template_level=0)


def test_model_observer_full_resolution_memory_makes_coarse_stimuli_harder(medium_set):
    """With same-level templates a coarse de-cluttered stimulus matches its own template exactly;
    remembering the objects at full resolution (the default) must make a coarse level harder.
    Level 4 of this quarter-size set is 18x12 cells (levels 1-3 are too coarse for either)."""
    rates = {}
    for tl in (None, 8):
        obs = make_observer("model", medium_set, "S1", rng=5, template_level=tl)
        hits = []
        for _ in range(10):
            for oid in medium_set.object_ids("main"):
                rec = medium_set.get(oid, "decluttered", 4)
                t = trial(obj=oid, condition="decluttered", level=4, pixels=rec.pixels)
                hits.append(obs.respond(t, medium_set.load_image(rec)).score in ("named", "use"))
        rates[tl] = float(np.mean(hits))
    print(f"de-cluttered 18x12: same-level templates {rates[None]:.2f}, full-res {rates[8]:.2f}")
    # 200 trials each: SE of the difference <= 0.05; require a 0.15 drop (3 SE)
    assert rates[None] - rates[8] > 0.15
