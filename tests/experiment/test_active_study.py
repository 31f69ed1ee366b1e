"""Active search as a study: several scenes, layouts drawn per trial and logged, counterbalanced
condition order, and recorded light fields whose targets a scene description names."""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from analysis.active import active_trials, read_active_events
from experiment.active import adapter
from experiment.active.scenefile import read_scene_file
from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher
from experiment.active.session import ActiveSession, auto_scorer
from experiment.active.task import ActiveTrial, balanced_latin_square, condition_order
from experiment.clock import FakeClock
from experiment.log import ResumeMismatch, TrialLog
from experiment.protocol import PROTOCOLS_DIR, ProtocolError, ProtocolSpec, load_protocol
from stimuli.errors import InputError
from stimuli.lfsynth import (
    JUNG2015_LAYOUT,
    RANDOM_LAYOUT_BACKDROP_M,
    RANDOM_LAYOUT_FRONT_M,
    RANDOM_LAYOUT_MIN_SEPARATION,
    RANDOM_LAYOUT_X_FRAC,
    layer_masks,
    random_three_plane_layout,
    three_plane_scene,
)
from tests.conftest import require_data

#: Small scenes keep each session in seconds (the shipped protocol uses the paper's 308x385).
SMALL = {
    "type": "active_search",
    "scene": ["synthetic:random_three_plane"],
    "targets": ["pedestrian", "tree"],
    "conditions": ["decluttered", "cluttered"],
    "scene_shape_px": [96, 120],
    "scene_grid": [3, 3],
    "grid_px": [12, 15],
    "n_planes": 20,
    "time_limit_s": 30.0,
}


def protocol(source_path: str | None = None, **task) -> ProtocolSpec:
    """The shipped protocol with a small task (and any task fields overridden)."""
    data = load_protocol("active_search").to_dict()
    data["task"] = {**SMALL, **task}
    return ProtocolSpec.from_dict(data, source_path=source_path)


def simulate(session: ActiveSession, seed: int = 3) -> list[dict]:
    rec = EdgeRecogniser(session.scene, session.task.grid_px, rng=seed)
    return session.run(SimulatedSearcher(rec, "planes", rng=seed))


# -- randomised layouts -------------------------------------------------------------------------


def test_random_layouts_stay_in_their_ranges_and_depend_only_on_the_seed() -> None:
    layouts = [random_three_plane_layout(k) for k in range(200)]
    assert random_three_plane_layout(7) == random_three_plane_layout(np.random.default_rng(7))
    for lay in layouts:
        p, t, b = lay["pedestrian"], lay["tree"], lay["building"]
        for o in (p, t):
            assert RANDOM_LAYOUT_X_FRAC[0] <= o["x_frac"] <= RANDOM_LAYOUT_X_FRAC[1]
            assert (
                RANDOM_LAYOUT_FRONT_M[0] - 1e-3 <= o["depth_m"] <= RANDOM_LAYOUT_FRONT_M[1] + 1e-3
            )
        assert abs(p["x_frac"] - t["x_frac"]) >= 0.2 - 1e-3
        # rounding to 4 decimals may eat a hair of the separation
        assert abs(1 / p["depth_m"] - 1 / t["depth_m"]) >= RANDOM_LAYOUT_MIN_SEPARATION - 1e-3
        assert RANDOM_LAYOUT_BACKDROP_M[0] - 1e-3 <= b["depth_m"] <= RANDOM_LAYOUT_BACKDROP_M[1]
    # nothing to learn: each object is sometimes nearer, and the columns spread over the range
    assert (
        0.3
        < np.mean([lay["pedestrian"]["depth_m"] < lay["tree"]["depth_m"] for lay in layouts])
        < 0.7
    )
    assert np.ptp([lay["tree"]["x_frac"] for lay in layouts]) > 0.5


@pytest.mark.parametrize("seed", [2, 7, 11, 16, 20, 29])
def test_a_random_layouts_backdrop_is_found_however_far_it_stands(seed) -> None:
    """Layouts whose building stands at 9.6-11 m: with the camera array's far limit fixed at
    12 m, the scan's range stopped just beyond the backdrop, its pixels' spread piled up at the
    range's end (a "widen it" warning) and its plane was missed; the far limit now follows the
    deepest layer (``stimuli.lfsynth.FAR_MARGIN``)."""
    import warnings

    from stimuli.lfsynth import render_camera_array
    from stimuli.planes import find_object_planes

    layout = random_three_plane_layout(seed)
    shape = (120, 180)
    lf = render_camera_array(
        three_plane_scene(shape, layout=layout), grid=(5, 5), shape_px=shape, baseline_m=0.03
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no pile-up at either end of the range
        scan = find_object_planes(lf, n_planes=60, workers=1)
    found = [p.disparity_px for p in scan.peaks]
    for name, obj in layout.items():
        d = lf.disparity_px(obj["depth_m"])
        assert min(abs(f - d) for f in found) < 0.25, (name, d, found)


def test_layout_moves_the_objects_and_the_paper_layout_is_the_paper_scene() -> None:
    shape = (96, 120)
    paper = three_plane_scene(shape, rng=0)
    same = three_plane_scene(shape, rng=0, layout=JUNG2015_LAYOUT)
    for a, b in zip(paper, same, strict=True):
        assert a.depth_m == b.depth_m and np.array_equal(a.texture, b.texture)
    lay = {
        "pedestrian": {"x_frac": 0.75, "depth_m": 5.0},
        "tree": {"x_frac": 0.25, "depth_m": 1.5},
        "building": {"x_frac": 0.56, "depth_m": 10.0},
    }
    moved = {layer.name: layer for layer in three_plane_scene(shape, rng=0, layout=lay)}
    assert moved["tree"].depth_m == 1.5 and moved["pedestrian"].depth_m == 5.0
    masks = layer_masks(list(moved.values()), shape)
    cols = {k: np.nonzero(masks[k])[1].mean() / shape[1] for k in ("pedestrian", "tree")}
    assert abs(cols["pedestrian"] - 0.75) < 0.1 and abs(cols["tree"] - 0.25) < 0.1


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"tree": None}, r"layout must place exactly building, pedestrian, tree"),
        ({"tree": {"x_frac": 0.5}}, r"layout\['tree'\] must be \{'x_frac': float"),
        ({"tree": {"x_frac": 1.5, "depth_m": 2.0}}, r"layout\['tree'\] needs x_frac in \[0, 1\]"),
        ({"building": {"x_frac": 0.5, "depth_m": 3.0}}, r"building is the opaque backdrop"),
    ],
)
def test_bad_layouts_are_refused_naming_the_object(change, match) -> None:
    lay = {**JUNG2015_LAYOUT, **change}
    lay = {k: v for k, v in lay.items() if v is not None}
    with pytest.raises(InputError, match=match):
        three_plane_scene((40, 50), layout=lay)


def test_each_trial_has_its_own_layout_logged_and_rebuilt_exactly(tmp_path) -> None:
    p = protocol(repetitions=2)
    log = TrialLog(tmp_path / "a.sqlite")
    s = ActiveSession.open(log, p, "S01", seed=11, clock=FakeClock())
    events = simulate(s)
    s.close()
    again = ActiveSession.open(TrialLog(":memory:"), p, "S01", seed=11, clock=FakeClock())
    assert again.plan["trials"] == s.plan["trials"]  # the seed fixes every layout
    starts = [e for e in events if e["kind"] == "trial_start"]
    assert len(starts) == 8
    layouts = [json.dumps(e["payload"]["layout"], sort_keys=True) for e in starts]
    assert len(set(layouts)) == 8  # a new layout every trial
    for e in starts[:3]:
        pl = e["payload"]
        assert pl["scene"] == "synthetic:random_three_plane"
        rebuilt = adapter.load_scene(
            pl["scene"], shape_px=(96, 120), grid=(3, 3), seed=pl["scene_seed"], layout=pl["layout"]
        )
        assert rebuilt.sha256 == pl["scene_sha256"]
        assert rebuilt.objects == pytest.approx(pl["objects_px"])
        # the logged true planes are where the layout put the objects (400 px x 3 cm / depth)
        for name in ("pedestrian", "tree"):
            assert pl["objects_px"][name] == pytest.approx(12.0 / pl["layout"][name]["depth_m"])
    rows = active_trials(read_active_events([tmp_path / "a.sqlite"]))
    assert set(rows["scene"]) == {"synthetic:random_three_plane"}
    # the trial's own true plane (trial_start), not a plan-wide one, decides at_target_plane
    named = rows[rows["recognized"]]
    assert len(named) > 0 and named["at_target_plane"].all()
    log.close()


def test_a_resumed_trial_must_rebuild_to_the_logged_scene(tmp_path, monkeypatch) -> None:
    import stimuli.lfsynth

    p = protocol(conditions=["decluttered"], targets=["tree"])
    db = tmp_path / "a.sqlite"
    with TrialLog(db) as log:
        s = ActiveSession.open(log, p, "S01", seed=2, clock=FakeClock())
        s.start_trial("sim:planes")  # cut before its answer
        s.close()
    with TrialLog(db) as log:  # the same generator: the trial resumes
        s = ActiveSession.open(log, p, "S01", clock=FakeClock())
        s.start_trial("sim:planes")
        s.close()
    monkeypatch.setattr(stimuli.lfsynth, "GRAIN", 0.1)  # a changed generator
    with TrialLog(db) as log:
        s = ActiveSession.open(log, p, "S01", clock=FakeClock())
        with pytest.raises(ResumeMismatch, match=r"trial 0: the rebuilt scene synthetic:random"):
            s.start_trial("sim:planes")
        s.close()


# -- several scenes and counterbalanced condition order ----------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_balanced_latin_square_is_balanced(n) -> None:
    rows = balanced_latin_square(n)
    assert len(rows) == (n if n % 2 == 0 else 2 * n)
    for row in rows:
        assert sorted(row) == list(range(n))
    for col in zip(*rows, strict=True):  # every condition equally often at every position
        assert len(set(np.bincount(col, minlength=n))) == 1
    follows = [(a, b) for row in rows for a, b in itertools.pairwise(row)]
    counts = {pair: follows.count(pair) for pair in itertools.permutations(range(n), 2)}
    assert len(set(counts.values())) <= 1  # every condition follows every other equally often


def test_balanced_latin_square_refuses_a_bad_size() -> None:
    with pytest.raises(ValueError, match=r"n must be an integer >= 1, got 0"):
        balanced_latin_square(0)
    with pytest.raises(ValueError, match=r"subject_index must be an integer >= 0, got -1"):
        condition_order(protocol().task, -1)


def test_condition_blocks_alternate_across_subjects_and_are_logged() -> None:
    p = protocol(
        scene=["synthetic:random_three_plane", "synthetic:three_plane"],
        counterbalance="latin_square",
    )
    log = TrialLog(":memory:")
    orders = []
    for subject in ("S01", "S02", "S03"):
        s = ActiveSession.open(log, p, subject, seed=1, clock=FakeClock())
        conds = [t.condition for t in s.trials]
        # one block per condition: 2 scenes x 2 targets each
        assert conds[:4] == [conds[0]] * 4 and conds[4:] == [conds[4]] * 4 != conds[:4]
        assert {t.scene for t in s.trials[:4]} == set(p.task.scenes)
        cb = s.plan["counterbalance"]
        assert cb["scheme"] == "latin_square" and cb["condition_order"] == [conds[0], conds[4]]
        orders.append((cb["subject_index"], conds[0]))
        s.close()
    assert orders == [(0, "decluttered"), (1, "cluttered"), (2, "decluttered")]
    s = ActiveSession.open(TrialLog(":memory:"), p, "S09", seed=1, subject_index=5)
    assert s.plan["counterbalance"]["subject_index"] == 5 and s.trials[0].condition == "cluttered"
    with pytest.raises(ValueError, match=r"subject_index must be an integer >= 0"):
        ActiveSession.open(TrialLog(":memory:"), p, "S09", subject_index=-2)


def test_without_counterbalancing_the_plan_interleaves_conditions() -> None:
    p = protocol(scene="synthetic:three_plane", trial_order="listed")
    s = ActiveSession.open(TrialLog(":memory:"), p, "S01", seed=1, clock=FakeClock())
    assert [(t.target, t.condition) for t in s.trials] == [
        ("pedestrian", "decluttered"),
        ("tree", "decluttered"),
        ("pedestrian", "cluttered"),
        ("tree", "cluttered"),
    ]
    assert "planes_px" in s.plan and s.plan["counterbalance"]["scheme"] == "none"
    assert "counterbalance" not in p.task.to_dict()  # old protocols keep their content hash


def test_targets_and_scenes_must_meet(tmp_path) -> None:
    log = TrialLog(":memory:")
    with pytest.raises(ProtocolError, match=r"task.targets: 'dog' is not an object of"):
        ActiveSession.open(log, protocol(targets=["dog", "tree"]), "S01")
    desc = _described_scene(tmp_path)
    with pytest.raises(ProtocolError, match=r"task.scene: '.*scene.toml' holds none of"):
        ActiveSession.open(
            log, protocol(scene=["synthetic:three_plane", str(desc)], targets=["pedestrian"]), "S01"
        )
    with pytest.raises(ProtocolError, match=r"task.scene lists a scene twice"):
        protocol(scene=["synthetic:three_plane", "synthetic:three_plane"])
    with pytest.raises(ProtocolError, match=r"task.counterbalance must be one of none, latin"):
        protocol(counterbalance="abba")


# -- recorded light fields with a scene description --------------------------------------------


def _described_scene(tmp_path, **fields) -> object:
    """A light field saved as .npy (the synthetic scene, so its planes are known) with a
    description naming two targets by their true plane and a box around their mask."""
    layers = three_plane_scene((96, 120), rng=0)
    from stimuli.lfsynth import render_camera_array

    lf = render_camera_array(layers, grid=(3, 3), shape_px=(96, 120), baseline_m=0.03)
    np.save(tmp_path / "views.npy", lf.views)
    masks = layer_masks(layers, (96, 120))

    def box(name):
        ys, xs = np.nonzero(masks[name])
        return [
            int(xs.min()),
            int(ys.min()),
            int(xs.max() - xs.min() + 1),
            int(ys.max() - ys.min() + 1),
        ]

    entry = {
        "lightfield": '"views.npy"',
        "targets": [
            ("figure", 12.0, box("pedestrian"), '["person", "man"]'),
            ("tree", 3.0, box("tree"), "[]"),
        ],
    }
    entry.update(fields)
    # the .npy has no geometry: the description gives the scan's range (12 and 3 px inside)
    text = f"[scene]\nlightfield = {entry['lightfield']}\nscan_px = [14.0, 0.5]\n"
    for name, d, b, syn in entry["targets"]:
        text += f'\n[[targets]]\nname = "{name}"\ndisparity_px = {d}\nbox_xywh = {b}\n'
        text += f"synonyms = {syn}\n"
    (tmp_path / "scene.toml").write_text(text)
    return tmp_path / "scene.toml"


def test_simulated_searcher_searches_a_described_light_field(tmp_path) -> None:
    _described_scene(tmp_path)
    (tmp_path / "p.toml").write_text("")  # the protocol's folder resolves relative scene paths
    p = protocol(
        source_path=str(tmp_path / "p.toml"),
        scene=["scene.toml", "synthetic:random_three_plane"],
        targets=["figure", "tree"],
        conditions=["decluttered"],
        grid_px=[28, 35],
    )
    log = TrialLog(tmp_path / "a.sqlite")
    s = ActiveSession.open(log, p, "S01", seed=4, clock=FakeClock())
    assert [t.scene for t in s.trials].count("scene.toml") == 2  # both of its targets
    assert [t.scene for t in s.trials].count("synthetic:random_three_plane") == 1  # tree only
    events = simulate(s)
    s.close()
    answers = {e["trial"]: e["payload"]["response"] for e in events if e["kind"] == "answer"}
    by_target = {t.target: answers[t.index] for t in s.trials if t.scene == "scene.toml"}
    assert by_target["figure"] == "figure" and "tree" in by_target
    # its templates come from the description: at the tree's plane the tree is what it sees
    from experiment.active.adapter import search_renderer
    from experiment.viewer.state import ViewerState

    scene = next(st.scene for k, st in s._states.items() if k[0] == "scene.toml")
    view = search_renderer(scene, (28, 35), "decluttered").render(ViewerState(3.0))
    assert EdgeRecogniser(scene, (28, 35), rng=0).judge(view.grid, None)[0] == "tree"
    starts = [e["payload"] for e in events if e["kind"] == "trial_start"]
    assert {st["scene"] for st in starts} == {"scene.toml", "synthetic:random_three_plane"}
    fig = next(st for st in starts if st["target"] == "figure")
    assert fig["objects_px"] == {"figure": 12.0, "tree": 3.0} and "layout" not in fig
    # the description's synonyms score "person" as naming the figure
    trial = next(t for t in s.trials if t.target == "figure")
    assert auto_scorer(trial, "a person", ("figure", "tree"), s.object_infos)[0] == "named"
    assert auto_scorer(trial, "a person", ("figure", "tree"))[0] != "named"
    rows = active_trials(read_active_events([tmp_path / "a.sqlite"]))
    assert set(rows["scene"]) == {"scene.toml", "synthetic:random_three_plane"}


def _write(tmp_path, text: str):
    (tmp_path / "views.npy").touch()
    p = tmp_path / "bad.toml"
    p.write_text(textwrap.dedent(text))
    return p


_OK_TARGET = '[[targets]]\nname = "a"\ndisparity_px = 1.0\nbox_xywh = [0, 0, 8, 8]\n'


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[scene]\n", r"bad.toml: scene.lightfield must be the light field's path"),
        (
            '[scene]\nlightfield = "nope.npy"\n' + _OK_TARGET,
            r"scene.lightfield .*nope.npy: light field not found$",
        ),
        (
            '[scene]\nlightfield = "${CONFOCAL_DATA}/x/none"\n' + _OK_TARGET,
            r"light field not found \(set CONFOCAL_DATA",
        ),
        ('lightfield = "views.npy"\n', r"unknown key 'lightfield' in the file"),
        ("[targets]\n", r"missing table \[scene\]"),
        ('[scene]\nlightfield = "views.npy"\n', r"needs at least one \[\[targets\]\] entry"),
        ('[scene]\nlightfield = "views.npy"\ncolour = 1\n', r"unknown key 'colour' in \[scene\]"),
        (
            '[scene]\nlightfield = "views.npy"\n[[targets]]\nname = "a"\nbox_xywh = [0, 0, 8, 8]\n',
            r"targets\[0\] is missing field disparity_px",
        ),
        (
            '[scene]\nlightfield = "views.npy"\n' + _OK_TARGET.replace("[0, 0, 8, 8]", "[0, 0, 8]"),
            r"targets\[0\].box_xywh must be \[x, y, w, h\]",
        ),
        (
            '[scene]\nlightfield = "views.npy"\n' + _OK_TARGET.replace("1.0", '"near"'),
            r"targets\[0\].disparity_px must be a finite number",
        ),
        (
            '[scene]\nlightfield = "views.npy"\n' + _OK_TARGET + _OK_TARGET,
            r"targets lists 'a' twice",
        ),
        (
            '[scene]\nlightfield = "views.npy"\n' + _OK_TARGET + "synonyms = [1]\n",
            r"targets\[0\].synonyms must be a list of non-empty strings",
        ),
        (
            '[scene]\nlightfield = "views.npy"\nscan_px = [-1.0, 2.0]\n' + _OK_TARGET,
            r"scene.scan_px must be \[nearest, farthest\] with nearest > farthest",
        ),
        (
            '[scene]\nlightfield = "views.npy"\ncrop_xywh = [4, 4, 20, 20]\n' + _OK_TARGET,
            r"targets\[0\].box_xywh must be inside scene.crop_xywh \[4, 4, 20, 20\]",
        ),
        ('[scene]\nlightfield = "views.npy"\n[[targets]\n', r"not a readable TOML scene"),
    ],
)
def test_bad_scene_descriptions_are_one_line_naming_the_field(tmp_path, monkeypatch, text, match):
    monkeypatch.delenv("CONFOCAL_DATA", raising=False)
    path = _write(tmp_path, text)
    with pytest.raises(ProtocolError, match=match) as err:
        read_scene_file(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_boxes_and_crops_outside_the_views_are_refused(tmp_path) -> None:
    np.save(tmp_path / "views.npy", np.zeros((3, 3, 20, 24), np.float32))
    p = _write(
        tmp_path, '[scene]\nlightfield = "views.npy"\n' + _OK_TARGET.replace("8, 8]", "8, 30]")
    )
    np.save(tmp_path / "views.npy", np.zeros((3, 3, 20, 24), np.float32))
    with pytest.raises(InputError, match=r"targets\[0\].box_xywh \[0, 0, 8, 30\] must lie inside"):
        adapter.load_scene(str(p))
    p.write_text('[scene]\nlightfield = "views.npy"\ncrop_xywh = [0, 0, 30, 20]\n' + _OK_TARGET)
    with pytest.raises(InputError, match=r"scene.crop_xywh \[0, 0, 30, 20\] must lie inside"):
        adapter.load_scene(str(p))
    with pytest.raises(ProtocolError, match=r"scene description not found"):
        read_scene_file(tmp_path / "none.toml")


def test_cli_refuses_a_bad_scene_description_in_one_line(tmp_path) -> None:
    exe = os.path.join(os.path.dirname(sys.executable), "confocal")
    (tmp_path / "scene.toml").write_text('[scene]\nlightfield = "missing.npy"\n' + _OK_TARGET)
    text = open(load_protocol("active_search").source_path, encoding="utf-8").read()
    line = next(x for x in text.splitlines() if x.startswith("scene = "))
    (tmp_path / "p.toml").write_text(text.replace(line, 'scene = ["scene.toml"]'))
    r = subprocess.run(
        [
            exe,
            "active",
            "run",
            str(tmp_path / "p.toml"),
            "--data",
            str(tmp_path / "x.sqlite"),
            "--subject",
            "S",
            "--subject-index",
            "1",
        ],
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
    )
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().count("\n") == 0 and "missing.npy: light field not found" in r.stderr
    assert not (tmp_path / "x.sqlite").exists()


def test_shipped_scene_descriptions_match_their_sha256sums() -> None:
    folder = PROTOCOLS_DIR / "scenes"
    sums = dict(
        reversed(line.split(maxsplit=1))
        for line in (folder / "SHA256SUMS").read_text().splitlines()
    )
    assert sorted(sums) == sorted(p.name for p in folder.glob("*.toml"))
    for name, digest in sums.items():
        assert hashlib.sha256((folder / name).read_bytes()).hexdigest() == digest, name
    for name in ("active_search", "active_search_recorded"):
        assert len(load_protocol(name).task.scenes) >= 2


@pytest.mark.data
def test_simulated_searcher_finds_the_stegosaurus_in_the_lytro_capture(data_dir, monkeypatch):
    """The shipped description of the Lytro capture 2067: its planes come from EPINET's
    estimate, so the depth scan (run here) must find the stegosaurus's plane near 0.79 px,
    and the simulated searcher, whose templates come from the description, must name it."""
    require_data(data_dir, "lightfield", "lytro_illum_2067_epinet", "2067_05_05.png")
    monkeypatch.setenv("CONFOCAL_DATA", str(data_dir))
    spec = load_protocol("active_search_recorded")
    data = spec.to_dict()
    data["task"].update(
        scene=["scenes/lytro_2067.toml"],
        targets=["stegosaurus"],
        conditions=["decluttered"],
        n_planes=40,
        counterbalance="none",
    )
    p = ProtocolSpec.from_dict(data, source_path=spec.source_path)
    log = TrialLog(":memory:")
    s = ActiveSession.open(log, p, "S01", seed=1, clock=FakeClock())
    # measured: one plane at 0.77 px; EPINET's estimate on the object 0.79 (quartiles 0.70-0.89)
    assert min(abs(d - 0.79) for d in s.planes_px) < 0.25
    events = simulate(s, seed=1)
    s.close()
    ans = next(e for e in events if e["kind"] == "answer")
    assert ans["payload"]["response"] == "stegosaurus"
    start = next(e for e in events if e["kind"] == "trial_start")
    assert start["payload"]["scene"] == "scenes/lytro_2067.toml"


def test_trial_round_trips_with_and_without_a_layout() -> None:
    t = ActiveTrial(
        3, "tree", "cluttered", 1, "synthetic:random_three_plane", random_three_plane_layout(0), 42
    )
    assert ActiveTrial.from_dict(json.loads(json.dumps(t.to_dict()))) == t
    old = {"index": 0, "target": "tree", "condition": "cluttered", "repetition": 0}
    assert ActiveTrial.from_dict(old).scene == ""  # a plan written before scenes per trial
