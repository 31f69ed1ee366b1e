"""The viewer for daily use: key help, g on on/off implants, modes in the status line, marker,
obstacle grey levels, the vignette crop, and the truer percept (rotation, dropout, brightness).

GL-free except the one GPU comparison, which skips without a headless context.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from experiment.viewer.screen import (
    BACKGROUND_RGB,
    MARKER_RGB,
    STATUS_ROWS_PX,
    FramePainter,
    expected_screen,
    screen_layout,
    status_image,
)
from experiment.viewer.state import KEY_HELP, apply_event
from stimuli.implants import ImplantError, ImplantLayout, load_implant, render_phosphenes
from stimuli.vignette import vignette_crop
from tests.experiment.conftest import viewer_model

MODEL = viewer_model(
    planes_px=(12.0, 3.0), implants=("argus2", "brainport"), implant_grey_levels=(2, 4)
)


@pytest.fixture(scope="module")
def scene():
    """The simulated three-plane scene as a small grey camera array (and its source)."""
    from experiment.viewer.source import LightFieldSource
    from stimuli.lfsynth import render_camera_array, three_plane_scene

    shape = (72, 96)
    lf = render_camera_array(three_plane_scene(shape, rng=2), shape_px=shape, baseline_m=0.03)
    return LightFieldSource(lf.gray())


def _viewer(scene, implants=("argus2", "brainport"), **kw):
    from experiment.viewer.app import Viewer

    return Viewer(scene, list(implants), screen_shape_px=(240, 320), n_planes=30, **kw)


# -- keys --------------------------------------------------------------------------------------


def test_help_key_toggles_the_help_and_every_key_is_listed() -> None:
    s = MODEL.initial_state()
    assert apply_event(MODEL, s, "key", {"key": "?"}).help
    assert apply_event(MODEL, s, "key", {"key": "h"}).help
    assert not apply_event(
        MODEL, apply_event(MODEL, s, "key", {"key": "h"}), "key", {"key": "?"}
    ).help
    listed = " ".join(k for k, _ in KEY_HELP)
    for key in ("Esc", "g", "o", "e", "v", "m", "q", "?"):
        assert key in listed


def test_g_on_an_on_off_implant_keeps_the_state_and_says_why(scene) -> None:
    s = MODEL.initial_state("argus2")
    assert apply_event(MODEL, s, "key", {"key": "g"}) == s
    s4 = apply_event(MODEL, replace(s, implant="brainport"), "key", {"key": "g"})
    assert s4.grey_levels == 4
    v = _viewer(scene)
    try:
        before = v.state
        after = v.handle("key", {"key": "g"})
        assert after == before
        assert "on/off" in v.message and "Argus II" in v.message
        assert v.message in v.status_text()
        assert any(e.kind == "message" for e in v.log.events())
        v.handle("key", {"key": "up"})
        assert v.message == ""  # the next input clears it
    finally:
        v.close()


def test_status_line_shows_every_mode(scene) -> None:
    v = _viewer(scene)
    try:
        v.handle("drag", {"box": [10, 8, 40, 30]})
        v.handle("key", {"key": "v"})
        v.handle("key", {"key": "e"})
        v.handle("key", {"key": "="})
        v.handle("click", {"x": 20, "y": 15})
        v.render()
        text = v.status_text()
        for want in ("Argus II", "zoom 40x30 at 10,8", "averaging 1/4 frames", "extension ON"):
            assert want in text, text
        assert "marker 20,15" in text
        v.handle("key", {"key": "o"})
        assert "OBSTACLE" in v.status_text() and "px/view" in v.status_text()
    finally:
        v.close()


# -- drawing -----------------------------------------------------------------------------------


def _panes(seed: int = 0):
    rng = np.random.default_rng(seed)
    lay = load_implant("argus2")
    centre = rng.random((60, 80)).astype(np.float32)
    src = rng.random((30, 40)).astype(np.float32)
    return lay, centre, src, src > 0.5, (rng.random(lay.shape) > 0.5).astype(np.float32)


def test_marker_is_drawn_on_the_centre_view_only_when_set() -> None:
    lay, centre, src, edges, cells = _panes()
    screen = screen_layout((240, 320), centre.shape, src.shape, lay)
    status = status_image("x", (STATUS_ROWS_PX, 320))
    kw = dict(zoom=None, alert=False, status=status)
    plain = expected_screen(screen, centre, src, edges, cells, lay, **kw)
    marked = expected_screen(screen, centre, src, edges, cells, lay, marker=(40, 30), **kw)
    is_marker = (marked == MARKER_RGB).all(axis=2)
    left, top, w, h = screen.images[0]
    assert is_marker[top : top + h, left : left + w].sum() > 10
    assert is_marker.sum() == is_marker[top : top + h, left : left + w].sum()
    assert not (plain == MARKER_RGB).all(axis=2).any()


def test_painter_redrawing_only_changed_panes_equals_a_fresh_frame() -> None:
    lay, centre, src, edges, cells = _panes(1)
    _, _, src2, edges2, cells2 = _panes(2)
    screen = screen_layout((240, 320), centre.shape, src.shape, lay)
    status = status_image("a", (STATUS_ROWS_PX, 320))
    p = FramePainter()
    steps = [
        (src, edges, cells, (0, 1, 1, 1), None, False),
        (src2, edges2, cells, (0, 2, 2, 1), None, False),
        (src2, edges2, cells2, (0, 2, 2, 2), (5, 5), True),  # marker key is pane 0's
        (src2, edges2, cells2, (0, 2, 2, 3), (5, 5), False),  # alert off: its frame cleared
    ]
    for s, e, c, keys, marker, alert in steps:
        keys = (marker, *keys[1:3], (keys[3], alert))
        got = p.paint(
            screen,
            centre,
            s,
            e,
            c,
            lay,
            zoom=None,
            alert=alert,
            status=status,
            marker=marker,
            keys=keys,
        )[..., :3]
        want = expected_screen(
            screen, centre, s, e, c, lay, zoom=None, alert=alert, status=status, marker=marker
        )
        np.testing.assert_array_equal(got, want)


def test_help_overlay_is_drawn_over_the_view_and_goes_away(scene) -> None:
    v = _viewer(scene)
    try:
        plain = v.render()
        v.handle("key", {"key": "?"})
        shown = v.render()
        rows, cols = v.screen_shape_px
        mid = shown[rows // 2 - 20 : rows // 2 + 20, cols // 2 - 100 : cols // 2 + 100]
        assert (mid == 0).all(axis=2).mean() > 0.5  # the help's black box with text
        assert (mid > 200).all(axis=2).any()  # its text
        v.handle("key", {"key": "h"})
        np.testing.assert_array_equal(v.render()[:-STATUS_ROWS_PX], plain[:-STATUS_ROWS_PX])
    finally:
        v.close()


def test_obstacle_mode_with_grey_levels_lights_the_implant(scene) -> None:
    v = _viewer(scene, implants=("brainport",))
    try:
        lo, hi = v.model.disparity_range_px
        v.state = replace(v.state, mode="obstacle", obstacle_px=(hi, lo), grey_levels=4)
        frame = v.render()
        left, top, w, h = v.screen(v.lf.shape_px).images[3]
        pane = frame[top : top + h, left : left + w]
        assert (pane > BACKGROUND_RGB[0]).any(axis=2).mean() > 0.05, "implant pane is dark"
        assert v._panes[1].cells.max() > 0
    finally:
        v.close()


# -- vignette ----------------------------------------------------------------------------------


def _vignetted(shape=(120, 160), rim_px=10):
    rng = np.random.default_rng(3)
    img = (0.2 + 0.6 * rng.random(shape)).astype(np.float32)
    rows, cols = shape
    y, x = np.mgrid[:rows, :cols]
    # an octagon, as a main lens cuts the micro-images: corners cut at 45 degrees
    d = np.minimum.reduce([x + y, (cols - 1 - x) + y, x + (rows - 1 - y), (cols - x) + (rows - y)])
    img[d < 2 * rim_px] = 0.0
    views = np.stack([np.stack([img, np.roll(img, k, axis=1)]) for k in (0, 1)])
    return img, views


def test_vignette_crop_leaves_out_the_dark_rim_of_a_synthetic_capture() -> None:
    img, views = _vignetted()
    x, y, w, h = vignette_crop(views)
    inside = views.min(axis=(0, 1))[y : y + h, x : x + w]
    assert (inside <= 0.0).mean() <= 0.02
    assert w * h >= 0.6 * img.size
    assert vignette_crop(np.full((50, 60), 0.5, np.float32)) is None  # nothing to leave out


def test_vignette_crop_refuses_a_bad_shape() -> None:
    with pytest.raises(ValueError, match="views must be"):
        vignette_crop(np.zeros((3, 4, 5)))


LYTRO = (
    Path(os.environ.get("CONFOCAL_DATA", "../shared/data")) / "lightfield/lytro_illum_2067_epinet"
)


@pytest.mark.data
@pytest.mark.skipif(not LYTRO.is_dir(), reason=f"no {LYTRO}")
def test_default_view_of_the_lytro_capture_leaves_out_its_rim_and_sky() -> None:
    from experiment.viewer.source import open_source

    src = open_source(LYTRO, view_crop="auto")
    x, y, w, h = src.view_crop
    views = src.frame(0).views
    assert views.shape[2:] == (h, w)
    assert (views.min(axis=(0, 1)) <= 0.01).mean() < 0.01  # the rim was 2.6 % of the view
    assert y >= 8  # the clipped sky strip along the top is left out
    assert w * h >= 0.7 * 383 * 552
    assert open_source(LYTRO, view_crop=None).view_crop is None


# -- percept -----------------------------------------------------------------------------------


def _one_on(lay: ImplantLayout, rc=(0, 0)) -> np.ndarray:
    cells = np.zeros(lay.shape, np.float32)
    cells[rc] = 1.0
    return cells


def test_defaults_keep_the_phosphenes_as_they_were() -> None:
    lay = load_implant("argus2")
    assert (lay.rotation_deg, lay.brightness_sd, lay.dead_electrodes) == (0.0, 0.0, ())
    np.testing.assert_array_equal(lay.electrode_gain(), lay.alive_mask().astype(np.float32))


def test_rotation_turns_the_array_about_the_centre() -> None:
    lay = load_implant("brainport").with_(rotation_deg=90.0)
    shape = (200, 200)
    cells = _one_on(lay, (10, 19))  # right edge, middle row
    up = render_phosphenes(cells, shape, shape=lay.phosphene_shape, size=lay.phosphene_size)
    turned = render_phosphenes(
        cells, shape, shape=lay.phosphene_shape, size=lay.phosphene_size, rotation_deg=90.0
    )
    cy, cx = (np.argwhere(up > 0.5).mean(axis=0) - 100).round()
    ty, tx = (np.argwhere(turned > 0.5).mean(axis=0) - 100).round()
    assert cx > 80 and abs(cy) < 10  # upright: right of centre
    assert ty < -80 and abs(tx) < 10  # turned 90 deg counter-clockwise: above the centre


def test_dead_electrodes_and_dropout_stay_dark_and_brightness_varies() -> None:
    lay = load_implant("argus2").with_(dead_electrodes=[[2, 3]], brightness_sd=0.3, seed=4)
    gain = lay.electrode_gain()
    assert gain[2, 3] == 0.0
    alive = gain > 0
    assert gain[alive].std() > 0.1 and gain.min() >= 0 and gain.max() <= 2
    assert (lay.alive_mask() == alive).all()
    ones = np.ones(lay.shape, np.float32)
    img = render_phosphenes(ones, (120, 200), gain=gain, shape="disc", size=0.5)
    assert img[40:60, 60:80].max() == 0.0  # the cell of electrode (2, 3)
    flat = render_phosphenes(ones, (120, 200), shape="disc", size=0.5)
    assert not np.array_equal(img, flat)
    # the dropout pattern does not depend on the brightness variation
    a = load_implant("argus2").with_(dropout=0.3, seed=7)
    np.testing.assert_array_equal(a.alive_mask(), a.with_(brightness_sd=0.5).alive_mask())


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("rotation_deg", 200, "rotation_deg.*\\[-180, 180\\]"),
        ("rotation_deg", "up", "rotation_deg"),
        ("brightness_sd", -0.1, "brightness_sd.*\\[0, 1\\]"),
        ("dead_electrodes", [[6, 0]], "dead_electrodes.*inside the 6x10 grid"),
        ("dead_electrodes", [[1]], "dead_electrodes"),
        ("dead_electrodes", 3, "dead_electrodes"),
    ],
)
def test_bad_percept_fields_are_one_line_errors(field, value, match) -> None:
    with pytest.raises(ImplantError, match=match):
        load_implant("argus2").with_(**{field: value})


def test_bad_percept_field_in_a_toml_file_names_the_file(tmp_path) -> None:
    text = (Path(__file__).parents[2] / "protocols/implants/argus2.toml").read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text + "rotation_deg = 400\n")
    with pytest.raises(ImplantError, match=r"mine\.toml.*rotation_deg"):
        load_implant(path)


def test_percept_key_explains_when_pulse2percept_cannot_draw(scene) -> None:
    v = _viewer(scene, implants=("brainport",))  # a tongue display: no retina to model
    try:
        s = v.handle("key", {"key": "m"})
        assert s.percept == "phosphenes" and "no scoreboard percept" in v.message
    finally:
        v.close()


def test_gpu_draws_rotation_gain_marker_and_help_as_the_cpu(scene, tmp_path) -> None:
    from experiment.viewer.app import Viewer
    from experiment.viewer.gpu import GpuError, create_headless_context

    try:
        ctx = create_headless_context()
    except GpuError as exc:
        pytest.skip(str(exc))
    path = tmp_path / "turned.toml"
    text = (Path(__file__).parents[2] / "protocols/implants/brainport.toml").read_text()
    path.write_text(text + "rotation_deg = 30.0\nbrightness_sd = 0.4\ndead_electrodes = [[3, 4]]\n")
    try:
        views = []
        for c, compute in ((ctx, "gpu"), (None, "cpu")):
            v = Viewer(
                scene, [str(path)], screen_shape_px=(240, 320), ctx=c, n_planes=30, compute=compute
            )
            v.state = replace(v.state, marker=(30, 20), grey_levels=4, help=True)
            views.append(v)
        gpu, cpu = views[0].screenshot(), views[1].render()
        diff = np.abs(gpu.astype(int) - cpu.astype(int))[:-STATUS_ROWS_PX]
        assert diff.max() <= 1, f"{int((diff > 1).sum())} pixels differ by > 1"
    finally:
        for v in views:
            v.close()
        ctx.release()
