"""Offscreen (EGL) presenter tests: geometry, exact nearest-neighbour blocks, border, gamma, timing.

Every test reads the framebuffer back and compares pixels (H23); none only checks that nothing
crashed. They skip with a reason when no headless OpenGL context can be created.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.gl

presenter = pytest.importorskip(
    "experiment.presentation.presenter", reason="moderngl not importable"
)

from experiment.clock import FakeClock  # noqa: E402
from experiment.presentation.geometry import PAPER_BORDER_RGB  # noqa: E402
from experiment.presentation.presenter import (  # noqa: E402
    PhospheneSpec,
    Presenter,
    PresenterError,
    ScreenGeometry,
    count_dropped,
    expected_frame,
    stimulus_rect_px,
)


@pytest.fixture(scope="module")
def gl_ok() -> None:
    try:
        p = Presenter.offscreen(
            ScreenGeometry.jung2015(screen_shape_px=(8, 8), image_size_cm=(0.1, 0.1))
        )
    except PresenterError as exc:
        pytest.skip(f"no headless OpenGL context: {exc}")
    p.close()


@pytest.fixture
def open_presenter(gl_ok):
    opened = []

    def make(geometry: ScreenGeometry, **kw) -> Presenter:
        p = Presenter.offscreen(geometry, **kw)
        opened.append(p)
        return p

    yield make
    for p in opened:
        p.close()


def checkerboard(shape_px: tuple[int, int]) -> np.ndarray:
    """A bool checkerboard: every cell differs from its four neighbours."""
    r, c = np.indices(shape_px)
    return (r + c) % 2 == 0


def run_lengths(line: np.ndarray) -> list[int]:
    """Lengths of runs of equal values along a 1-D array."""
    change = np.flatnonzero(np.diff(line) != 0)
    edges = np.concatenate(([0], change + 1, [line.size]))
    return np.diff(edges).tolist()


@pytest.mark.parametrize("shape_px", [(8, 12), (25, 38), (65, 98)])
def test_paper_geometry_blocks_and_border(open_presenter, shape_px) -> None:
    """The image covers 14.6 x 9.7 cm of pixels (+-1), each cell a uniform block, blue around."""
    g = ScreenGeometry.jung2015()
    # Independent expectation from the paper's numbers: px = cm * (1280 px / screen width cm).
    want_cols = 14.6 * 1280 / g.screen_width_cm
    want_rows = 9.7 * 1280 / g.screen_width_cm
    assert math.isclose(g.image_size_deg[1], 10.4, abs_tol=0.05)
    assert math.isclose(g.image_size_deg[0], 6.9, abs_tol=0.05)

    p = open_presenter(g)
    img = checkerboard(shape_px)
    p.show_stimulus(img)
    frame = p.read_pixels()
    assert frame.shape == (1024, 1280, 3)

    border = np.all(frame == PAPER_BORDER_RGB, axis=-1)
    inside = np.argwhere(~border)
    (top, left), (bottom, right) = inside.min(0), inside.max(0) + 1
    assert abs((right - left) - want_cols) <= 1
    assert abs((bottom - top) - want_rows) <= 1
    assert ~border[top:bottom, left:right].any() == True  # noqa: E712 - nothing blue inside
    # Centred (to the pixel): equal margins, +-1.
    assert abs(left - (1280 - right)) <= 1 and abs(top - (1024 - bottom)) <= 1

    image = frame[top:bottom, left:right]
    assert set(np.unique(image)) <= {0, 255}
    assert (image == image[..., :1]).all()  # grey: r == g == b
    lum = image[..., 0]
    # Every row of the image crosses shape_px[1] uniform runs, every column shape_px[0].
    for axis, n_cells, extent in ((1, shape_px[1], right - left), (0, shape_px[0], bottom - top)):
        lines = lum if axis == 1 else lum.T
        lo, hi = math.floor(extent / n_cells), math.ceil(extent / n_cells)
        for line in lines:
            runs = run_lengths(line)
            assert len(runs) == n_cells
            assert set(runs) <= {lo, hi}, (runs, lo, hi)
    # Each block carries its cell's value (top-left cell is white in this checkerboard).
    assert lum[0, 0] == 255 and lum[-1, -1] == (255 if (sum(shape_px) - 2) % 2 == 0 else 0)


def test_integer_scale_is_exact_kron(open_presenter) -> None:
    """At an integer scale the image is exactly np.kron(image, ones(k, k)), the rest border."""
    g = ScreenGeometry.jung2015()
    rng = np.random.default_rng(6)
    img = rng.random((8, 12)) < 0.5
    p = open_presenter(g, integer_scale=True)
    p.show_stimulus(img)
    frame = p.read_pixels()
    k = round(g.image_shape_px[1] / 12)  # 41 px per cell at 33.7 px/cm
    top, left, rows, cols = stimulus_rect_px(g, img.shape, integer_scale=True)
    assert (rows, cols) == (8 * k, 12 * k)
    want = np.kron(img.astype(np.uint8) * 255, np.ones((k, k), np.uint8))
    np.testing.assert_array_equal(frame[top : top + rows, left : left + cols, 0], want)
    np.testing.assert_array_equal(frame[top : top + rows, left : left + cols, 2], want)
    surround = np.ones(frame.shape[:2], bool)
    surround[top : top + rows, left : left + cols] = False
    assert (frame[surround] == PAPER_BORDER_RGB).all()


def test_full_resolution_is_one_to_one(open_presenter) -> None:
    """With the paper's 33.7 px/cm the 492 x 327 working image is drawn pixel for pixel."""
    g = ScreenGeometry.jung2015()
    img = np.random.default_rng(1).random((327, 492)) < 0.3
    p = open_presenter(g)
    p.show_stimulus(img)
    top, left, rows, cols = stimulus_rect_px(g, img.shape)
    assert (rows, cols) == (327, 492)
    got = p.read_pixels()[top : top + rows, left : left + cols, 0]
    np.testing.assert_array_equal(got, img.astype(np.uint8) * 255)


def test_protocol_frame_and_background_match_reference(open_presenter) -> None:
    """A 6 px border frame on black (the shipped protocol's display) equals the numpy reference."""
    g = ScreenGeometry.jung2015(screen_width_cm=40.0, border_width_px=6, background_rgb=(0, 0, 0))
    img = checkerboard((18, 27))
    p = open_presenter(g)
    p.show_stimulus(img)
    frame = p.read_pixels()
    np.testing.assert_array_equal(frame, expected_frame(g, img))
    top, left, rows, cols = stimulus_rect_px(g, img.shape)
    assert (frame[top - 6, left - 6] == (0, 0, 255)).all()
    assert (frame[top - 7, left] == (0, 0, 0)).all() and (frame[0, 0] == (0, 0, 0)).all()
    assert (frame[top + rows + 5, left + cols + 5] == (0, 0, 255)).all()


def test_gamma_correction_in_shader(open_presenter) -> None:
    """A 0.5 luminance stimulus is sent as 0.5 ** (1/2.2) (186 of 255); 0 and 1 are unchanged."""
    g = ScreenGeometry.jung2015(gamma=2.2)
    img = np.array([[0.0, 0.5, 1.0]], np.float32)
    p = open_presenter(g, integer_scale=True)
    p.show_stimulus(img)
    top, left, rows, cols = stimulus_rect_px(g, img.shape, integer_scale=True)
    row = p.read_pixels()[top + rows // 2, left : left + cols, 1]
    k = cols // 3
    assert row[k // 2] == 0 and row[-k // 2] == 255
    assert abs(int(row[k + k // 2]) - 255 * 0.5 ** (1 / 2.2)) <= 1


def test_grey_stimulus_within_one_level_of_reference(open_presenter) -> None:
    """Grey stimuli match the numpy reference to 1 of 255 (8-bit rounding of the GPU)."""
    g = ScreenGeometry.jung2015(gamma=1.8)
    img = np.random.default_rng(2).random((25, 38)).astype(np.float32)
    p = open_presenter(g)
    p.show_stimulus(img)
    diff = np.abs(p.read_pixels().astype(int) - expected_frame(g, img).astype(int))
    assert diff.max() <= 1


def test_blank_text_screens(open_presenter) -> None:
    """Blank keeps the frame with a black image area and a fixation cross; text is drawn centred."""
    g = ScreenGeometry.jung2015()
    p = open_presenter(g)
    p.show_stimulus(np.ones((8, 12), bool))
    p.clear()
    frame = p.read_pixels()
    top, left, rows, cols = stimulus_rect_px(g, (8, 12))
    assert (frame[512, 640] == 128).all()  # fixation cross (grey) at the centre
    assert (frame[top + 2, left + 2] == 0).all()  # image area black
    assert (frame[top - 1, left] == PAPER_BORDER_RGB).all()
    p.show_text("Pause")
    frame = p.read_pixels()
    lit = np.argwhere(frame[..., 0] > 128)
    assert len(lit) > 50
    centre = lit.mean(0)
    assert abs(centre[0] - 512) < 40 and abs(centre[1] - 640) < 100
    assert (frame[0, 0] == 0).all()


def test_flip_timestamps_from_injected_clock(open_presenter) -> None:
    """Onset/offset and frame intervals come from the injected clock; dropped frames over 1.5 T."""
    clock = FakeClock(100.0)
    p = open_presenter(ScreenGeometry.jung2015(), clock=clock)
    on = p.show_stimulus(np.ones((8, 12), bool))
    assert on.onset_s == 100.0
    for dt in (0.010, 0.010, 0.030):
        clock.advance(dt)
        p.pump()
    clock.advance(0.010)
    off = p.clear()
    assert off.onset_s == pytest.approx(100.06)
    assert off.frame_intervals_ms == pytest.approx((10.0, 10.0, 30.0, 10.0))
    assert off.dropped_frames == 0 and off.refresh_hz is None  # offscreen: no refresh
    assert count_dropped(off.frame_intervals_ms, 100.0) == 1  # 30 ms > 1.5 x 10 ms
    assert p.clear().frame_intervals_ms == ()  # nothing was up


def test_phosphene_view_discs_and_dropout(open_presenter) -> None:
    """Disc phosphenes: each live cell lit at its centre, dark at its corners; dead cells dark."""
    g = ScreenGeometry.jung2015()
    spec = PhospheneSpec(kind="disc", size=0.8, dropout=0.3, seed=4)
    p = open_presenter(g, integer_scale=True, phosphenes=spec)
    img = np.ones((8, 12), bool)
    p.show_stimulus(img)
    frame = p.read_pixels()[..., 0]
    top, left, rows, cols = stimulus_rect_px(g, img.shape, integer_scale=True)
    k = cols // 12
    centres = frame[top + k // 2 : top + rows : k, left + k // 2 : left + cols : k]
    corners = frame[top : top + rows : k, left : left + cols : k]
    alive = spec.alive_mask(img.shape)
    assert 0 < alive.sum() < alive.size
    np.testing.assert_array_equal(centres == 255, alive)
    assert (corners == 0).all()


def test_gaussian_phosphene_profile_peaks_at_centre(open_presenter) -> None:
    """A single Gaussian phosphene is brightest at its cell centre and falls off with distance."""
    g = ScreenGeometry.jung2015()
    p = open_presenter(g, integer_scale=True, phosphenes=PhospheneSpec(kind="gaussian", size=0.5))
    img = np.zeros((5, 5), bool)
    img[2, 2] = True
    p.show_stimulus(img)
    top, left, rows, cols = stimulus_rect_px(g, img.shape, integer_scale=True)
    k = cols // 5
    row = p.read_pixels()[top + 2 * k + k // 2, left : left + cols, 0].astype(int)
    peak = int(np.argmax(row))
    assert abs(peak - (2 * k + k // 2)) <= 1
    assert row[peak] >= 250 and row[peak] > row[peak + k // 4] > row[peak + k // 2] and row[0] == 0


def test_bad_stimulus_raises(open_presenter) -> None:
    p = open_presenter(ScreenGeometry.jung2015())
    with pytest.raises(TypeError, match="bool or float32, got dtype uint8"):
        p.show_stimulus(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match=r"must be in \[0, 1\]"):
        p.show_stimulus(np.full((4, 4), 2.0, np.float32))
    with pytest.raises(ValueError, match="must be 2-D"):
        p.show_stimulus(np.zeros((4, 4, 2), np.float32))
    with pytest.raises(ValueError, match="must be 2-D"):  # colour photos are float32 only
        p.show_stimulus(np.zeros((4, 4, 3), bool))


def test_geometry_checks() -> None:
    with pytest.raises(ValueError, match="viewing_distance_cm must be a positive number"):
        ScreenGeometry.jung2015(viewing_distance_cm=0)
    with pytest.raises(ValueError, match="border_rgb must be three integers 0-255"):
        ScreenGeometry.jung2015(border_rgb=(0, 0, 300))
    with pytest.raises(PresenterError, match="does not fit"):
        stimulus_rect_px(ScreenGeometry.jung2015(image_size_cm=(40, 60)), (8, 12))
    with pytest.raises(ValueError, match="dropout must be in"):
        PhospheneSpec(dropout=1.0)
    g = ScreenGeometry.jung2015(gamma=2.0)
    assert ScreenGeometry.from_dict(g.to_dict()) == g


def test_from_protocol_display_spec() -> None:
    """The geometry follows the engine's DisplaySpec field names (resolution in cols x rows)."""
    protocol = pytest.importorskip("experiment.protocol")
    spec = protocol.DisplaySpec()
    g = ScreenGeometry.from_display_spec(spec)
    assert g.screen_shape_px == (spec.screen_height_px, spec.screen_width_px)
    assert g.image_size_cm == (spec.image_height_cm, spec.image_width_cm)
    assert g.px_per_cm == pytest.approx(spec.px_per_cm)
    assert g.border_width_px == spec.border_width_px


def _run_cli(*args: str) -> subprocess.CompletedProcess:
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    return subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=120
    )


def test_present_screenshot_cli(gl_ok, tmp_path) -> None:
    """``confocal present --screenshot`` writes the full-resolution frame the subject would see."""
    from PIL import Image

    stim = tmp_path / "stim.png"
    img = checkerboard((8, 12))
    Image.fromarray(img.astype(np.uint8) * 255).save(stim)
    out = tmp_path / "shot.png"
    r = _run_cli(
        "present", "--screen-width-cm", "37.98", "--stimulus", str(stim), "--screenshot", str(out)
    )
    assert r.returncode == 0, r.stderr
    shot = np.asarray(Image.open(out).convert("RGB"))
    assert shot.shape == (1024, 1280, 3)
    g = ScreenGeometry.jung2015(screen_width_cm=37.98)
    np.testing.assert_array_equal(shot, expected_frame(g, img))


def test_present_invalid_protocol_one_line_exit_2(tmp_path) -> None:
    """A broken protocol opens nothing and prints one clear line with exit status 2."""
    bad = tmp_path / "bad.toml"
    bad.write_text('[protocol]\nname = "x"\n[display]\nscreen_width_px = -5\n')
    out = tmp_path / "shot.png"
    r = _run_cli("present", "--protocol", str(bad), "--stimulus", "x.png", "--screenshot", str(out))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("confocal: error:") and "bad.toml" in lines[0]
    assert not out.exists()


class FakeVsyncWindow:
    """A window twin whose buffer swap advances a FakeClock by the next refresh interval."""

    def __init__(self, clock: FakeClock, shape_px: tuple[int, int], intervals_s) -> None:
        self.clock = clock
        self.buffer_size = (shape_px[1], shape_px[0])
        self.is_closing = False
        self._intervals = iter(intervals_s)

    def swap_buffers(self) -> None:
        self.clock.advance(next(self._intervals))

    def close(self) -> None:
        self.is_closing = True

    def destroy(self) -> None:
        pass


def _windowed_twin(gl_ok, intervals_s):
    import moderngl

    g = ScreenGeometry.jung2015(
        screen_shape_px=(64, 80), screen_width_cm=4.0, image_size_cm=(1.0, 1.5)
    )
    clock = FakeClock()
    ctx = moderngl.create_standalone_context(require=330, backend="egl")
    window = FakeVsyncWindow(clock, g.screen_shape_px, intervals_s)
    return Presenter(ctx, g, clock=clock, window=window), clock


def test_refresh_measured_and_dropped_frames_counted(gl_ok) -> None:
    """At 60 Hz the self-test passes; a stimulus with one doubled interval has 1 dropped frame."""
    period = 1 / 60
    intervals = [period] * 31 + [period, period, 2 * period, period, period]
    p, clock = _windowed_twin(gl_ok, intervals)
    try:
        assert p.measure_refresh(30) == pytest.approx(60.0)
        on = p.show_stimulus(np.ones((4, 6), bool))
        for _ in range(3):
            p.pump()
        off = p.clear()
        assert off.frame_intervals_ms == pytest.approx((16.667, 33.333, 16.667, 16.667), abs=1e-3)
        assert off.dropped_frames == 1 and off.refresh_hz == pytest.approx(60.0)
        assert off.onset_s - on.onset_s == pytest.approx(5 * period)
    finally:
        p.close()


def test_timing_self_test_refuses_without_vsync(gl_ok) -> None:
    """Flips that do not wait for a refresh (2 ms apart) fail the self-test (H12)."""
    p, _ = _windowed_twin(gl_ok, [0.002] * 31)
    try:
        with pytest.raises(presenter.TimingCheckFailed, match="frame-timing self-test failed"):
            p.measure_refresh(30)
    finally:
        p.close()


def test_present_missing_stimulus_one_line_exit_2(tmp_path) -> None:
    """A missing stimulus file is one line, exit status 2, and no screenshot."""
    out = tmp_path / "shot.png"
    r = _run_cli("present", "--stimulus", str(tmp_path / "nope.png"), "--screenshot", str(out))
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "nope.png" in lines[0] and not out.exists()


@pytest.mark.parametrize("gamma", [1.0, 2.2])
def test_colour_photo_within_one_level_of_reference(open_presenter, gamma) -> None:
    """Training's colour photos: each channel as given (gamma-corrected), to 1 of 255."""
    g = ScreenGeometry.jung2015(gamma=gamma)
    img = np.random.default_rng(3).random((25, 38, 3)).astype(np.float32)
    p = open_presenter(g)
    p.show_stimulus(img)
    frame = p.read_pixels()
    ref = expected_frame(g, img)
    assert np.abs(frame.astype(int) - ref.astype(int)).max() <= 1
    top, left, rows, cols = stimulus_rect_px(g, img.shape[:2])
    # not a grey rendering: the channels differ inside the image
    assert (frame[top : top + rows, left : left + cols].std(axis=2) > 10).mean() > 0.5
    # and a binary stimulus afterwards is drawn in the stimulus colours again
    p.show_stimulus(checkerboard((8, 12)))
    np.testing.assert_array_equal(p.read_pixels(), expected_frame(g, checkerboard((8, 12))))
