"""Simulated observers: the logistic model's parameters, the template observer, and the
``exemplar`` observer that recognises objects from other renderings."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest

from experiment.observers import (
    OBSERVERS,
    LogisticParams,
    LogisticResponder,
    TemplateObserver,
    TemplateParams,
    make_observer,
    to_retina,
)
from experiment.protocol import load_protocol
from experiment.session.schedule import Trial, build_schedule
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set


@pytest.fixture(scope="module")
def small_set(tmp_path_factory):
    return StimulusSet.load(
        make_stimulus_set(tmp_path_factory.mktemp("s"), n_main=5, n_training=1, levels=(1, 8))
    )


def trial(obj="obj01", condition="cluttered", pixels=8695, level=5):
    return Trial(0, "main", 1, obj, "mug", condition, level, 7, pixels, "p", "x", 60.0)


def test_registry_has_both_observers(small_set):
    assert set(OBSERVERS) >= {"calibrated", "exemplar", "logistic", "model"}
    assert isinstance(make_observer("logistic", small_set, "S1", rng=0), LogisticResponder)
    assert isinstance(make_observer("model", small_set, "S1", rng=0), TemplateObserver)
    with pytest.raises(
        ValueError, match="observer must be one of calibrated, exemplar, logistic, model"
    ):
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


# -- the exemplar observer ------------------------------------------------------------------------

from experiment.observers.exemplar import (  # noqa: E402
    ExemplarParams,
    best_criterion,
    hog_features,
    image_sha256,
    retinal_image,
)


def test_retinal_image_is_the_area_average_of_the_shown_image():
    """Independent method: replicate every pixel (the presenter's NEAREST enlargement) to a
    common multiple of both sizes, then average blocks; exact to rounding."""
    rng = np.random.default_rng(0)
    for shape, grid in (((8, 12), (6, 9)), ((6, 9), (8, 12)), ((5, 7), (5, 7))):
        img = rng.random(shape) < 0.3
        copy = img.copy()
        r = retinal_image(img, (grid[0] / 4, grid[1] / 4), samples_per_deg=4, blur_deg=0)
        fr, fc = math.lcm(shape[0], grid[0]), math.lcm(shape[1], grid[1])
        big = np.kron(img.astype(float), np.ones((fr // shape[0], fc // shape[1])))
        ref = big.reshape(grid[0], fr // grid[0], grid[1], fc // grid[1]).mean(axis=(1, 3))
        np.testing.assert_allclose(r, ref, atol=1e-12)
        assert np.array_equal(img, copy)
    # blur spreads a point but keeps its mass (up to the border)
    pt = np.zeros((21, 21))
    pt[10, 10] = 1
    b = retinal_image(pt, (21 / 10, 21 / 10), samples_per_deg=10, blur_deg=0.1)
    assert b.sum() == pytest.approx(1.0) and b.max() < 0.2


def test_retinal_image_errors():
    with pytest.raises(ValueError, match=r"image must be 2-D \(rows, cols\)"):
        retinal_image(np.zeros(5), (1, 1), samples_per_deg=4, blur_deg=0)
    with pytest.raises(ValueError, match="samples_per_deg must be > 0"):
        retinal_image(np.zeros((4, 4)), (1, 1), samples_per_deg=0, blur_deg=0)
    with pytest.raises(ValueError, match="blur_deg must be >= 0"):
        retinal_image(np.zeros((4, 4)), (1, 1), samples_per_deg=4, blur_deg=-1)


def test_hog_features_are_unit_length_and_orientation_selective():
    bars_v = np.zeros((48, 48))
    bars_v[:, ::8] = 1
    f_v = hog_features(bars_v, cell_px=6, orientations=9)
    f_h = hog_features(bars_v.T.copy(), cell_px=6, orientations=9)
    assert np.sum(f_v * f_v) == pytest.approx(1.0) and abs(f_v.mean()) < 1e-12
    assert float(f_v @ f_v) > float(f_v @ f_h) + 0.5  # a vertical grating is not a horizontal one
    assert not np.any(hog_features(np.zeros((48, 48)), cell_px=6, orientations=9))


def test_best_criterion_matches_brute_force():
    """Independent method: try every criterion between sorted margins, keep the best score."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        m = rng.normal(0.05, 0.05, 40)
        g = np.where(rng.random(40) < 0.3 + 5 * np.clip(m, 0, None), 1.0, -1.5)
        c = best_criterion(m, g)
        cand = np.concatenate([[m.max() + 1], np.sort(m) - 1e-12])
        scores = [g[m > x].sum() for x in cand]
        assert g[m > c].sum() == pytest.approx(max(scores))
    with pytest.raises(ValueError, match="margins and gains must be 1-D arrays"):
        best_criterion(np.zeros(3), np.zeros(2))


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("image_width_cm", 0, "image_width_cm must be > 0"),
        ("samples_per_deg", 0, "samples_per_deg must be > 0"),
        ("blur_deg", -0.1, "blur_deg must be >= 0"),
        ("cell_deg", 0.1, "cell_deg must span >= 2 retinal samples"),
        ("exemplar_level", 0, "exemplar_level must be a level >= 1 or None"),
        ("exemplar_condition", "photo", "exemplar_condition must be 'decluttered' or"),
        ("noise_sd", -1, "noise_sd must be >= 0"),
        ("wrong_cost", 0, "wrong_cost must be > 0"),
        ("calibration_repeats", 0, "calibration_repeats must be >= 1"),
        ("lapse", 0.5, r"lapse must be in \[0, 0.5\)"),
    ],
)
def test_exemplar_params_refuse_a_bad_value(tmp_path, field, value, match):
    with pytest.raises(ValueError, match=match):
        ExemplarParams(knowledge=str(tmp_path), **{field: value})


def test_exemplar_params_are_checked(tmp_path):
    k = str(tmp_path)
    with pytest.raises(ValueError, match="knowledge must be the folder of a stimulus set"):
        ExemplarParams()
    # the paper's display: 14.6 x 9.7 cm at 80 cm is 10.4 x 6.9 deg (Jung et al. 2015, Sec. 3.1)
    h, w = ExemplarParams(knowledge=k).image_size_deg
    assert (round(w, 1), round(h, 1)) == (10.4, 6.9)


@pytest.fixture(scope="module")
def tiny_knowledge(tmp_path_factory):
    """Another draw of the small set's objects (same names, other random outlines)."""
    return make_stimulus_set(
        tmp_path_factory.mktemp("k"), n_main=5, n_training=1, levels=(1, 8), rng=7
    )


def test_exemplar_observer_needs_knowledge_and_training_objects(
    small_set, tiny_knowledge, tmp_path
):
    with pytest.raises(ValueError, match="knowledge must be the folder"):
        make_observer("exemplar", small_set, "S1")
    no_training = StimulusSet.load(make_stimulus_set(tmp_path, n_main=2, n_training=0))
    with pytest.raises(ValueError, match="criterion must be given: stimulus set .* no training"):
        make_observer("exemplar", no_training, "S1", knowledge=str(tiny_knowledge))
    obs = make_observer("exemplar", no_training, "S1", knowledge=str(tiny_knowledge), criterion=0)
    assert obs.criterion == 0 and obs.calibration == {"method": "given"}


def test_exemplar_observer_answers_from_the_image(small_set, tiny_knowledge):
    """Shown a knowledge exemplar of B under object A's label, it names B (wrong for A); shown
    B's exemplar under B's label, it is right. No noise, criterion 0."""
    ks = StimulusSet.load(tiny_knowledge)
    obs = make_observer(
        "exemplar", small_set, "S1", rng=0, knowledge=str(tiny_knowledge), noise_sd=0, criterion=0
    )
    assert obs.name == "exemplar" and obs.rater == "sim:exemplar"
    img_b = ks.load_image(ks.get("obj02", "decluttered", 8))
    a = obs.respond(trial(obj="obj01", condition="decluttered", level=8), img_b)
    assert a.score == "wrong" and a.response == ks.objects["obj02"].name
    a = obs.respond(trial(obj="obj02", condition="decluttered", level=8), img_b)
    assert a.score in ("named", "use")
    # a blank screen matches nothing better than anything else: the observer passes
    blank = np.zeros_like(img_b)
    assert obs.respond(trial(obj="obj02"), blank).score in ("pass", "shape")


def test_exemplar_observer_describes_itself_for_the_log(small_set, tiny_knowledge):
    import json

    obs = make_observer("exemplar", small_set, "S1", rng=1, knowledge=str(tiny_knowledge))
    d = json.loads(json.dumps(obs.describe()))
    assert d["observer"] == "exemplar" and d["simulated"] is True
    assert d["params"]["knowledge"] == str(tiny_knowledge) and d["criterion"] == obs.criterion
    ks = StimulusSet.load(tiny_knowledge)
    assert d["knowledge"]["manifest_sha256"] == ks.manifest_sha256
    assert {e["file_sha256"] for e in d["knowledge"]["exemplars"]} == {
        ks.get(o, "decluttered", 8).sha256 for o in ks.objects
    }
    assert d["calibration"]["n_training_stimuli"] == 4  # 1 training object x 2 levels x 2 cond.


def _x50_px(px: list[float], rate: list[float]) -> float:
    """First crossing of 50 % by linear interpolation on log10 pixels (inf if never reached):
    a threshold computed here, from the observer's answers alone, not by the analysis code."""
    lx = np.log10(px)
    if rate[0] >= 0.5:
        return float(px[0])
    for i in range(len(px) - 1):
        if rate[i] < 0.5 <= rate[i + 1]:
            return float(
                10 ** (lx[i] + (0.5 - rate[i]) / (rate[i + 1] - rate[i]) * (lx[i + 1] - lx[i]))
            )
    return math.inf


@pytest.fixture(scope="module")
def synth_sets(tmp_path_factory):
    """A synthetic test set (seed 10) and the observer's knowledge: the same kinds rendered
    with another seed (11), built at full resolution only. 10 main + 3 training objects."""
    from stimuli.stimset import BuildParams, build_stimulus_set
    from stimuli.synth import write_pairs

    root = tmp_path_factory.mktemp("synth")
    write_pairs(root / "pairs", n_objects=10, n_training=3, seed=10)
    build_stimulus_set(root / "pairs", root / "test")
    write_pairs(root / "kpairs", n_objects=10, n_training=3, seed=11)
    build_stimulus_set(root / "kpairs", root / "knowledge", params=BuildParams(windows_px=(1,)))
    return StimulusSet.load(root / "test"), root / "knowledge"


def test_exemplar_observer_generalises_to_unseen_renderings(synth_sets):
    """Exemplars from another seed; (a) recognition rises with resolution in both conditions,
    (b) the de-cluttered 50 % threshold is below the cluttered one, (c) no test stimulus's
    pixels were part of what the observer knows or was calibrated on."""
    test, knowledge = synth_sets
    hits = defaultdict(list)
    observers = [
        make_observer("exemplar", test, f"S{i}", rng=i, knowledge=str(knowledge)) for i in range(4)
    ]
    test_pixel_sha, test_file_sha = set(), set()
    for oid in test.object_ids("main"):
        for cond in ("cluttered", "decluttered"):
            for lv in test.levels():
                rec = test.get(oid, cond, lv)
                img = test.load_image(rec)
                test_pixel_sha.add(image_sha256(img))
                test_file_sha.add(rec.sha256)
                t = trial(obj=oid, condition=cond, level=lv, pixels=rec.pixels)
                for obs in observers:
                    hits[(cond, lv)].append(obs.respond(t, img).score in ("named", "use"))
    levels = test.levels()
    px = [test.get(test.object_ids("main")[0], "cluttered", lv).pixels for lv in levels]
    rate = {
        c: [float(np.mean(hits[(c, lv)])) for lv in levels] for c in ("cluttered", "decluttered")
    }
    x50 = {c: _x50_px(px, r) for c, r in rate.items()}
    print(f"criteria {[round(o.criterion, 4) for o in observers]}")
    for c in rate:
        print(f"{c:<12} " + " ".join(f"{v:.2f}" for v in rate[c]) + f"  x50 {x50[c]:,.0f} px")
    # (a) 10 objects x 4 observers = 40 trials per level: SE <= 0.08; top two levels above the
    # bottom two by > 0.3 is > 3 SE of the difference of two 80-trial means
    for c, r in rate.items():
        assert np.mean(r[-2:]) - np.mean(r[:2]) > 0.3, c
    # (b) from the pixels alone
    assert math.isfinite(x50["decluttered"]) and x50["decluttered"] < x50["cluttered"]
    # (c) nothing of the test stimuli was known or used for calibration
    for obs in observers:
        known = obs.knowledge.sources
        assert not {e["pixel_sha256"] for e in known} & test_pixel_sha
        assert not {e["file_sha256"] for e in known} & test_file_sha
        calib = obs.calibration["stimuli"]
        assert not {e["pixel_sha256"] for e in calib} & test_pixel_sha
        assert {test.objects[e["object"]].role for e in calib} == {"training"}
    # and no image of the test set at all (training objects included) is an exemplar
    all_test = {r.sha256 for r in test.records}
    assert not {e["file_sha256"] for e in observers[0].knowledge.sources} & all_test


def test_headless_session_logs_its_observer(tmp_path, tiny_knowledge, capsys):
    """``session run --headless --observer exemplar`` logs who answered, and from what."""
    import json
    import sqlite3

    from experiment import cli

    stim = make_stimulus_set(tmp_path / "stim", n_main=5, n_training=1, levels=(1, 8))
    proto = tmp_path / "p.toml"
    proto.write_text(
        '[protocol]\nname = "p"\n[[blocks]]\npart = "main"\nobjects = "main"\n'
        'levels = [1, 8]\nconditions = ["cluttered", "decluttered"]\n'
    )
    db = tmp_path / "s.sqlite"
    args = ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S09"]
    args += ["--data", db, "--headless", "--observer", "exemplar"]
    with pytest.raises(SystemExit) as exc:
        cli.main([str(a) for a in args])
    assert exc.value.code == 2
    assert "--observer-param: knowledge must be the folder" in capsys.readouterr().err
    assert not db.exists()
    with pytest.raises(SystemExit) as exc:
        cli.main([str(a) for a in [*args, "--observer-param", f"knowledge={tiny_knowledge}"]])
    assert exc.value.code == 0, capsys.readouterr().err
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        (note,) = con.execute("SELECT note FROM events WHERE kind = 'observer'").fetchone()
        n = con.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
    finally:
        con.close()
    d = json.loads(note)
    assert n == 5 * 2 * 2
    assert d["observer"] == "exemplar" and d["params"]["knowledge"] == str(tiny_knowledge)
    assert d["knowledge"]["manifest_sha256"] == StimulusSet.load(tiny_knowledge).manifest_sha256


def test_declutter_advantage_is_not_built_into_the_exemplars(synth_sets):
    """Remembering the exemplars *with* their own cluttered backgrounds, the observer still
    recognises de-cluttered stimuli better: the advantage comes from the test pixels, not from
    giving it de-cluttered knowledge."""
    test, knowledge = synth_sets
    obs = make_observer(
        "exemplar", test, "S1", rng=5, knowledge=str(knowledge), exemplar_condition="cluttered"
    )
    hits = defaultdict(list)
    for _ in range(3):
        for oid in test.object_ids("main"):
            for cond in ("cluttered", "decluttered"):
                for lv in test.levels():
                    rec = test.get(oid, cond, lv)
                    t = trial(obj=oid, condition=cond, level=lv, pixels=rec.pixels)
                    a = obs.respond(t, test.load_image(rec))
                    hits[cond].append(a.score in ("named", "use"))
    clut, decl = float(np.mean(hits["cluttered"])), float(np.mean(hits["decluttered"]))
    print(f"cluttered exemplars: cluttered {clut:.2f}, de-cluttered {decl:.2f}")
    # 240 trials per condition: SE of the difference <= 0.046; require 0.15 (> 3 SE)
    assert decl - clut > 0.15


@pytest.mark.parametrize(
    ("value", "rule", "ok"),
    [
        (0.0, "> 0", False),
        (1e-9, "> 0", True),
        (0.0, ">= 0", True),
        (-1e-9, ">= 0", False),
        (0.0, "in [0, 0.5)", True),
        (0.5, "in [0, 0.5)", False),
        (0.5, "in [0, 0.5]", True),
        (0.0, "in (0, 1]", False),
        (float("nan"), ">= 0", False),
        ("1", "> 0", False),
    ],
)
def test_check_limits_reads_each_rule(value, rule, ok):
    from types import SimpleNamespace

    from experiment.observers.base import check_limits

    params = SimpleNamespace(x=value)
    if ok:
        check_limits(params, {"x": rule})
    else:
        with pytest.raises(ValueError, match=r"^x must be "):
            check_limits(params, {"x": rule})
