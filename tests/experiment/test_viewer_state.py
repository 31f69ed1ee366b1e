"""Viewer state machine, implant layouts, CPU modes and the ``confocal view`` command.

All GL-free except the CLI screenshot test, which uses ``--cpu``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from experiment.viewer.reference import DepthMap, depth_map, obstacle_mask, track_point
from experiment.viewer.state import GREY_LEVELS, ViewerModel, ViewerState, apply_event
from stimuli.implants import (
    RETINA_UM_PER_DEG,
    ImplantError,
    ImplantLayout,
    implant_names,
    load_implant,
    render_phosphenes,
)
from tests.experiment.conftest import confocal_process, viewer_model

MODEL = viewer_model(
    planes_px=(12.0, 3.0, 1.0), implants=("argus2", "alpha_ims", "brainport"), auto_threshold=0.08
)


def run(state, *events):
    for kind, payload in events:
        state = apply_event(MODEL, state, kind, payload)
    return state


def test_initial_state_is_nearest_plane() -> None:
    s = MODEL.initial_state()
    assert (s.disparity_px, s.plane, s.implant) == (12.0, 0, "argus2")


def test_plane_keys_walk_the_detected_planes_and_clamp() -> None:
    s = MODEL.initial_state()
    s = run(s, ("key", {"key": "page_down"}))
    assert (s.disparity_px, s.plane) == (3.0, 1)
    s = run(s, ("key", {"key": "page_down"}), ("key", {"key": "page_down"}))
    assert (s.disparity_px, s.plane) == (1.0, 2)
    s = run(s, ("key", {"key": "2"}))
    assert s.plane == 1
    assert run(s, ("key", {"key": "9"})) == s  # no ninth plane: unchanged
    s = run(s, ("key", {"key": "page_up"}), ("key", {"key": "page_up"}))
    assert s.plane == 0


def test_depth_steps_leave_the_plane_and_clamp_to_range() -> None:
    s = MODEL.initial_state()
    s = run(s, ("key", {"key": "up"}))
    assert s.disparity_px == pytest.approx(12.2) and s.plane is None
    s = run(s, *[("wheel", {"dy": 1})] * 50)
    assert s.disparity_px == 15.0
    # off-plane page_down goes to the first plane farther than here
    s = run(s, ("wheel", {"dy": -40}), ("key", {"key": "page_down"}))
    assert s.disparity_px == pytest.approx(3.0) and s.plane == 1


def test_zoom_box_is_normalised_clipped_and_escape_unzooms() -> None:
    s = MODEL.initial_state()
    s = run(s, ("drag", {"box": [140, 90, -40, -30]}))
    assert s.zoom == (100, 60, 40, 30)
    s = run(s, ("drag", {"box": [140, 90, 40, 30]}))
    assert s.zoom == (140, 90, 10, 10)  # clipped to the view
    assert run(s, ("drag", {"box": [0, 0, 3, 3]})).zoom == s.zoom  # too small: ignored
    assert run(s, ("key", {"key": "escape"})).zoom is None


def test_implant_levels_threshold_keys_cycle() -> None:
    s = MODEL.initial_state()
    names = [run(s, *[("key", {"key": "i"})] * k).implant for k in range(4)]
    assert names == ["argus2", "alpha_ims", "brainport", "argus2"]
    grey = [run(s, *[("key", {"key": "g"})] * k).grey_levels for k in range(len(GREY_LEVELS) + 1)]
    assert grey == [*GREY_LEVELS, GREY_LEVELS[0]]
    t = run(s, ("key", {"key": "]"})).threshold
    assert t == pytest.approx(0.08 * 1.25)
    assert run(s, ("key", {"key": "]"}), ("key", {"key": "a"})).threshold is None


def test_obstacle_mode_wheel_moves_the_far_edge() -> None:
    s = MODEL.initial_state()
    s = run(s, ("key", {"key": "page_down"}), ("key", {"key": "o"}))
    assert s.mode == "obstacle" and s.obstacle_px == (15.0, 3.0)
    s = run(s, ("wheel", {"dy": -5}))
    assert s.obstacle_px == pytest.approx((15.0, 2.0)) and s.disparity_px == 3.0
    assert run(s, ("key", {"key": "o"})).mode == "free"


def test_extension_click_focuses_in_front_of_the_marked_depth() -> None:
    model = ViewerModel(**{**MODEL.__dict__, "depth_at": lambda x, y: 2.0 + x / 100})
    s = apply_event(model, model.initial_state(), "key", {"key": "e"})
    s = apply_event(model, s, "key", {"key": "="})
    s = apply_event(model, s, "click", {"x": 50, "y": 10})
    assert s.marker == (50, 10) and s.disparity_px == pytest.approx(2.5 + 0.2)
    assert apply_event(model, s, "click", {"x": 500, "y": 10}) == s  # outside the view


def test_state_round_trips_through_json() -> None:
    import json

    s = ViewerState(3.0, "argus2", 1, (1, 2, 30, 40), 4, 0.1, "obstacle", (5.0, 2.0), (3, 4))
    assert ViewerState.from_dict(json.loads(json.dumps(s.to_dict()))) == s


# -- implants --------------------------------------------------------------------------------


def test_shipped_layouts_follow_their_sources() -> None:
    assert implant_names() == ["alpha_ims", "argus2", "brainport"]
    a = load_implant("argus2")
    assert (a.rows, a.cols, a.pitch_um) == (6, 10, 575.0)  # Humayun et al. 2012
    assert load_implant("brainport").shape == (20, 20)  # Nau et al. 2013
    ims = load_implant("alpha_ims")
    assert ims.n_electrodes == pytest.approx(1500, rel=0.02)  # Stingl et al. 2013 (39x39 grid)
    for lay in (a, ims):  # field of view = n * pitch at 288 um/deg (closed form)
        assert lay.fov_width_deg == pytest.approx(lay.cols * lay.pitch_um / RETINA_UM_PER_DEG, 1e-3)
        assert lay.fov_height_deg == pytest.approx(
            lay.rows * lay.pitch_um / RETINA_UM_PER_DEG, 1e-3
        )


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (
            'label = "x"\nkind = "epiretinal"\nrows = 0\ncols = 3\nfov_width_deg = 5\n'
            "fov_height_deg = 5\n",
            "field 'rows' must be an integer >= 1",
        ),
        (
            'label = "x"\nkind = "ear"\nrows = 2\ncols = 3\nfov_width_deg = 5\n'
            "fov_height_deg = 5\n",
            "field 'kind' must be one of",
        ),
        (
            'label = "x"\nkind = "other"\nrows = 2\ncols = 3\nfov_width_deg = 5\n',
            "'fov_height_deg' is missing",
        ),
        (
            'label = "x"\nkind = "other"\nrows = 2\ncols = 3\nfov_width_deg = 5\n'
            "fov_height_deg = 5\ndropout = 1.0\n",
            "field 'dropout' must be a number in",
        ),
        (
            'label = "x"\nkind = "other"\nrows = 2\ncols = 3\nfov_width_deg = 5\n'
            "fov_height_deg = 5\ncolour = 1\n",
            "unknown field 'colour'",
        ),
        ("rows = [", "not valid TOML"),
    ],
)
def test_bad_layout_files_give_one_line_errors(tmp_path, text, match) -> None:
    f = tmp_path / "mine.toml"
    f.write_text(text)
    with pytest.raises(ImplantError, match=match) as exc:
        load_implant(f)
    assert str(f) in str(exc.value) and "\n" not in str(exc.value)


def test_user_grid_and_unknown_name(tmp_path) -> None:
    f = tmp_path / "mine.toml"
    f.write_text(
        'label = "Mine"\nkind = "cortical"\nrows = 4\ncols = 5\nfov_width_deg = 10\n'
        "fov_height_deg = 8\ndropout = 0.5\nseed = 3\n"
    )
    lay = load_implant(f)
    assert lay.name == "mine" and lay.shape == (4, 5)
    assert ImplantLayout.from_dict(lay.to_dict()) == lay
    assert 0 < lay.alive_mask().sum() < 20
    with pytest.raises(ImplantError, match="unknown implant 'argus9'"):
        load_implant("argus9")


def test_phosphenes_disc_covers_expected_area_and_zero_in_zero_out() -> None:
    cells = np.zeros((3, 4), bool)
    assert not render_phosphenes(cells, (60, 80), shape="disc").any()
    cells[1, 2] = True
    img = render_phosphenes(cells, (60, 80), shape="disc", size=0.8)
    # a disc of diameter 0.8 * 20 px: area pi * 8^2 ~ 201 px (pixel-centre sampling, +-10 %)
    assert img.sum() == pytest.approx(math.pi * 8**2, rel=0.1)
    ys, xs = np.nonzero(img)
    assert (ys.mean(), xs.mean()) == pytest.approx((29.5, 49.5), abs=0.01)
    g = render_phosphenes(cells, (60, 80), shape="gaussian", size=0.5)
    assert g.max() == pytest.approx(np.exp(-(0.5**2) / 2 / (10 / 2.3548) ** 2 * 2), abs=0.02)
    dead = render_phosphenes(cells, (60, 80), alive=~cells)
    assert not dead.any()


# -- depth by agreement, obstacle, tracking --------------------------------------------------


def test_depth_map_recovers_the_planes_of_a_layered_scene() -> None:
    from stimuli.lfsynth import layer_masks, render_camera_array, three_plane_scene

    shape = (96, 128)
    layers = three_plane_scene(shape, rng=0)
    lf = render_camera_array(layers, shape_px=shape, baseline_m=0.03)
    g = lf.geometry
    cands = np.linspace(0.5, 14.0, 28)
    dm = depth_map(lf, cands, binning=1)
    masks = layer_masks(layers, shape)
    hits = 0
    for layer in layers:
        true_d = g.disparity_px(layer.depth_m)
        m = masks[layer.name] & dm.valid
        err = np.abs(dm.disparity_px[m] - true_d)
        hits += np.median(err) < 1.0
    assert hits == len(layers)
    near = obstacle_mask(dm, 14.0, g.disparity_px(2.0))
    ped = masks[layers[0].name] if layers[0].depth_m < 2 else None
    if ped is not None:
        assert (near & ped).sum() > 0.5 * (near.sum())


def test_track_point_follows_a_shifted_pattern() -> None:
    rng = np.random.default_rng(1)
    a = rng.random((80, 100)).astype(np.float32)
    b = np.roll(a, (3, -5), (0, 1))
    assert track_point(a, b, (50, 40)) == (45, 43)


def test_depth_at_falls_back_to_the_image_median() -> None:
    d = np.full((10, 10), 2.0, np.float32)
    v = np.zeros((10, 10), bool)
    v[0, 0] = True
    assert DepthMap(d, v, np.array([2.0]), 1).at(9, 9, radius_px=1) == 2.0


# -- command line ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_lf(tmp_path_factory):
    out = tmp_path_factory.mktemp("lf") / "scene.npz"
    r = confocal_process(
        "lightfield", "synth", "--kind", "camera", "--size", "128x96", "--out", out
    )
    assert r.returncode == 0, r.stderr
    return out


def _confocal_in_process(capsys, *args) -> tuple[int, str]:
    """Run the command line in this process (no interpreter start-up); return (status, stderr)."""
    from experiment.cli import main

    try:
        main(list(args))
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    return code, capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--implant", "argus9"], "unknown implant 'argus9'"),
        (["--size", "10x10"], "--size must be at least"),
        (["--grey-levels", "3"], "--grey-levels must be one of (2, 4, 8), got 3"),
        (["--levels", "3"], "--grey-levels must be one of"),  # the old spelling, still read
        (["--zoom", "1,2,3"], "--zoom must be 4 comma-separated integers"),
        (["--plane", "99"], "--plane must be in 1.."),
        (["--obstacle", "near"], "--obstacle must be FAR:NEAR"),
    ],
)
def test_view_bad_options_one_line_exit_2(small_lf, tmp_path, capsys, args, match) -> None:
    shot = tmp_path / "s.png"
    code, err = _confocal_in_process(
        capsys, "view", str(small_lf), "--cpu", "--screenshot", str(shot), *args
    )
    assert code == 2, err
    assert match in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not shot.exists()


def test_view_levels_is_a_hidden_alias_of_grey_levels(small_lf, tmp_path, capsys) -> None:
    shot = tmp_path / "s.png"
    args = ("view", str(small_lf), "--cpu", "--implant", "brainport", "--screenshot", str(shot))
    from tests.conftest import run_cli

    assert run_cli([*args, "--levels", "4"]) == 0
    assert shot.exists()
    assert "grey levels 4" in capsys.readouterr().out  # the status line of the screenshot
    assert run_cli(["view", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--grey-levels" in out and "--levels" not in out


def test_viewer_from_options_names_parameters_not_flags(small_lf) -> None:
    """A Python caller gets the viewer's checks, in its own words."""
    from experiment.viewer.app import Viewer
    from experiment.viewer.options import ViewerOptionError
    from experiment.viewer.source import open_source

    src = open_source(small_lf)
    bad = [
        ({"grey_levels": 3}, "grey_levels", "grey_levels must be one of (2, 4, 8), got 3"),
        ({"threshold": -1.0}, "threshold", "threshold must be None (automatic) or >= 0"),
        ({"compute": "tpu"}, "compute", "compute must be one of auto, gpu, cpu"),
        ({"plane": 99}, "plane", "plane must be in 1.."),
        ({"zoom": (0, 0, 4, 4)}, "zoom", "must be at least 8x8 inside "),
        ({"marker": (500, 1)}, "marker", "marker (500, 1) must lie inside the "),
    ]
    for kwargs, parameter, match in bad:
        with pytest.raises(ViewerOptionError, match=re.escape(match)) as exc:
            Viewer.from_options(src, ["argus2"], n_planes=24, **kwargs)
        assert exc.value.parameter == parameter and "--" not in str(exc.value)
    v = Viewer.from_options(src, ["brainport"], grey_levels=4, plane=1, n_planes=24)
    try:
        assert v.state.grey_levels == 4 and v.state.plane == 0
        assert [e.kind for e in v.log.events()][-1] == "state"
    finally:
        v.close()


def test_view_missing_lightfield_and_bad_script(small_lf, tmp_path, capsys) -> None:
    code, err = _confocal_in_process(
        capsys, "view", str(tmp_path / "none.npz"), "--cpu", "--screenshot", "x.png"
    )
    assert code == 2 and "light field not found" in err
    script = tmp_path / "s.jsonl"
    script.write_text('{"kind": "key", "payload": {"key": "i"}}\nnot json\n')
    code, err = _confocal_in_process(
        capsys,
        "view",
        str(small_lf),
        "--cpu",
        "--script",
        str(script),
        "--screenshot",
        str(tmp_path / "s.png"),
    )
    assert code == 2 and "s.jsonl:2: not JSON" in err


@pytest.mark.gl
def test_present_implant_draws_one_phosphene_per_lit_electrode(tmp_path) -> None:
    """``confocal present --implant argus2``: the edge stimulus compressed to 6x10 (paper's rule)
    and drawn as separate phosphenes, one blob per lit electrode."""
    from PIL import Image
    from scipy.ndimage import label

    from stimuli.compress import compress

    edges = np.zeros((60, 100), bool)
    edges[10:50:3, 20:70] = True  # a block of dense lines
    stim = tmp_path / "edges.png"
    Image.fromarray(edges.astype(np.uint8) * 255).save(stim)
    shot = tmp_path / "shot.png"
    r = confocal_process(
        "present", "--stimulus", str(stim), "--implant", "argus2", "--screenshot", str(shot)
    )
    if r.returncode != 0 and "OpenGL" in r.stderr:
        pytest.skip(f"no headless OpenGL context: {r.stderr.strip()}")
    assert r.returncode == 0, r.stderr
    assert "stimulus 10x6" in r.stdout
    lit = int(compress(edges, (6, 10), edge_ratio=1 / 13).sum())
    frame = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    white = (frame[..., 0] > 128) & (frame[..., 2] > 128) & (frame[..., 1] > 128)
    assert 0 < lit == label(white)[1]
    r = confocal_process(
        "present",
        "--stimulus",
        str(stim),
        "--implant",
        "argus9",
        "--screenshot",
        str(tmp_path / "x.png"),
    )
    assert r.returncode == 2 and "unknown implant 'argus9'" in r.stderr


# -- the Viewer with the CPU renderer: video, temporal averaging, extension, event log ---------


@pytest.fixture(scope="module")
def video_dir(tmp_path_factory):
    """Three frames of the simulated camera-array scene, the scene moving 4 px right per frame."""
    from stimuli.lfsynth import render_camera_array, three_plane_scene
    from stimuli.lightfield import LightField

    out = tmp_path_factory.mktemp("video")
    shape = (72, 96)
    lf = render_camera_array(three_plane_scene(shape, rng=2), shape_px=shape, baseline_m=0.03)
    v = lf.gray().views
    import json

    geometry = json.dumps(lf.geometry.to_dict())
    for k in range(3):
        np.savez(out / f"frame_{k:02d}.npz", views=np.roll(v, 4 * k, axis=3), geometry=geometry)
    del LightField
    return out


def test_video_folder_plays_frames_tracks_marker_and_averages(video_dir) -> None:
    from experiment.viewer.app import Viewer
    from experiment.viewer.reference import cpu_panes
    from experiment.viewer.source import open_source

    src = open_source(video_dir)
    assert src.n_frames == 3
    v = Viewer(src, ["brainport"], screen_shape_px=(240, 320), n_planes=30)
    try:
        v.handle("click", {"x": 40, "y": 30})
        v.handle("key", {"key": "v"})
        singles = [cpu_panes(v.lf, v.state, v.layout).cells]
        v.render()
        for k in (1, 2):
            s = v.handle("key", {"key": "n"})
            assert s.frame == k and s.marker == (40 + 4 * k, 30)  # followed frame to frame
            singles.append(cpu_panes(src.frame(k), s, v.layout).cells)
            v.render()
        np.testing.assert_allclose(v._average.frames[-1], singles[-1])
        averaged = np.mean(np.stack(singles), axis=0)
        np.testing.assert_allclose(
            np.mean(np.stack(v._average.frames), axis=0), averaged, atol=1e-7
        )
        kinds = [e.kind for e in v.log.events()]
        assert kinds.count("key") == 3 and kinds.count("click") == 1
    finally:
        v.close()


def test_extension_mode_focuses_in_front_of_the_clicked_object(video_dir) -> None:
    from experiment.viewer.app import Viewer
    from experiment.viewer.source import open_source

    v = Viewer(
        open_source(video_dir / "frame_00.npz"), ["argus2"], screen_shape_px=(240, 320), n_planes=30
    )
    try:
        v.handle("key", {"key": "e"})
        for _ in range(3):
            v.handle("key", {"key": "="})
        s = v.handle("click", {"x": 40, "y": 30})
        want = v.model.clamp(v.depth().at(40, 30) + 3 * v.model.step_px)
        assert s.mode == "extension" and s.disparity_px == pytest.approx(want)
        assert "extension" in v.status_text()
    finally:
        v.close()


def test_obstacle_alert_is_visible_audible_and_logged(video_dir, capfd) -> None:
    from dataclasses import replace

    from experiment.viewer.app import Viewer
    from experiment.viewer.screen import ALERT_RGB
    from experiment.viewer.source import open_source

    v = Viewer(
        open_source(video_dir / "frame_00.npz"), ["argus2"], screen_shape_px=(240, 320), n_planes=30
    )
    try:
        hi = v.model.disparity_range_px[1]
        v.state = replace(v.state, mode="obstacle", obstacle_px=(hi, hi - 0.01))  # nothing there
        frame = v.render()
        assert "ALERT" not in v.status_text()
        assert not (frame == ALERT_RGB).all(axis=2).any()
        nearest = v.model.planes_px[0] - 2 * v.model.step_px  # the nearest detected object
        v.state = replace(v.state, obstacle_px=(hi, nearest))
        frame = v.render()
        assert "ALERT" in v.status_text()
        assert (frame == ALERT_RGB).all(axis=2).sum() > 100  # the red frame
        assert "\a" in capfd.readouterr().err  # the terminal bell
        assert [e.kind for e in v.log.events()].count("alert") == 1
        v.render()
        assert [e.kind for e in v.log.events()].count("alert") == 1  # once per onset
    finally:
        v.close()


def test_brightest_point_and_screen_to_view_mapping(video_dir) -> None:
    from experiment.viewer.app import Viewer
    from experiment.viewer.reference import brightest_point
    from experiment.viewer.source import open_source

    img = np.zeros((50, 80), np.float32)
    img[30:33, 60:63] = 1.0
    img[5, 5] = 1.0  # a single hot pixel is weaker after smoothing than the 3x3 spot
    assert brightest_point(img) == (61, 31)
    v = Viewer(
        open_source(video_dir / "frame_00.npz"), ["argus2"], screen_shape_px=(240, 320), n_planes=30
    )
    try:
        left, top, w, h = v.screen(v.lf.shape_px).images[0]
        rows, cols = v.lf.shape_px
        assert v.view_pixel(left, top) == (0, 0)
        assert v.view_pixel(left + w - 1, top + h - 1) == (cols - 1, rows - 1)
        assert v.view_pixel(left - 1, top) is None
    finally:
        v.close()


def test_view_falls_back_to_cpu_without_gl(small_lf, tmp_path, capsys, monkeypatch) -> None:
    """No OpenGL at all: the screenshot is still drawn (CPU pipeline), with one warning line."""
    gpu = pytest.importorskip("experiment.viewer.gpu", reason="moderngl not importable")

    def no_gl():
        raise gpu.GpuError("no headless OpenGL 3.3 context: test")

    monkeypatch.setattr(gpu, "create_headless_context", no_gl)
    shot = tmp_path / "s.png"
    code, err = _confocal_in_process(capsys, "view", str(small_lf), "--screenshot", str(shot))
    assert code == 0 and "drawing with the CPU pipeline" in err
    from PIL import Image

    assert Image.open(shot).size == (1080, 720)
