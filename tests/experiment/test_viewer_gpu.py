"""GPU viewer pipeline against the CPU (numpy / ``stimuli``) pipeline, pixel by pixel.

Headless EGL (llvmpipe is enough); skips with a reason when no OpenGL context can be made.

Tolerances (stated, not tuned):

* confocal image: ``atol = 1e-6``. Both sum the same float32 terms in the same order; a GPU
  may fuse multiply-adds, which changes each sum by at most a few ulps of 1.0 (1.2e-7 each).
* Sobel magnitude: ``atol = 1e-6`` (scipy sums in float64 then rounds; the shader sums
  9 float32 terms: a few ulps).
* edges: identical except at pixels whose CPU magnitude lies within 1e-6 of the threshold.
* electrode grid: identical for binary edges (integer counts against exactly computed
  minimum counts); for grey levels, identical except cells whose CPU mean lies within 1e-5 of a
  level boundary (a float32 sum of up to ~4,000 pixels).
* screen: identical (uint8), with the grey panes allowed +-1 for the float-to-8-bit rounding.
"""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.gl

gpu_mod = pytest.importorskip("experiment.viewer.gpu", reason="moderngl not importable")

from experiment.viewer.gpu import GpuError, GpuPipeline, create_headless_context  # noqa: E402
from experiment.viewer.reference import EDGE_RATIO, cpu_panes  # noqa: E402
from experiment.viewer.screen import (  # noqa: E402
    STATUS_ROWS_PX,
    expected_screen,
    screen_layout,
    status_image,
)
from experiment.viewer.state import ViewerState  # noqa: E402
from stimuli.declutter import sobel_magnitude  # noqa: E402
from stimuli.implants import load_implant  # noqa: E402
from stimuli.lfsynth import render_camera_array, three_plane_scene  # noqa: E402
from stimuli.refocus import refocus  # noqa: E402


@pytest.fixture(scope="module")
def ctx():
    try:
        c = create_headless_context()
    except GpuError as exc:
        pytest.skip(f"no headless OpenGL context: {exc}")
    yield c
    c.release()


@pytest.fixture(scope="module")
def scene():
    """The synthetic three-plane scene as a 9x9 camera array of 96x128 views (simulated)."""
    shape = (96, 128)
    return render_camera_array(three_plane_scene(shape, rng=0), shape_px=shape, baseline_m=0.03)


@pytest.fixture(scope="module")
def pipeline(ctx, scene):
    g = GpuPipeline(ctx, scene.gray().views)
    yield g
    g.release()


@pytest.mark.parametrize("d", [0.0, 1.0, 2.5, -1.3, 3.7, 12.44, 0.3333333])
def test_refocus_matches_cpu(pipeline, scene, d) -> None:
    lf = scene.gray()
    pipeline.refocus(d)
    pipeline.sobel(None)
    np.testing.assert_allclose(pipeline.read_source(), refocus(lf, d), rtol=0, atol=1e-6)


def test_refocus_of_shifted_texture_is_exact_at_integer_disparity(ctx) -> None:
    """Analytic case (H21): a texture shifted by d (u, v) refocuses to itself inside (up to the
    rounding of an average of 25 equal float32 values, 1 ulp), and is blurred at d + 0.5."""
    rng = np.random.default_rng(5)
    tex = rng.random((40, 50)).astype(np.float32)
    views = np.stack(
        [
            np.stack([np.roll(tex, (-2 * (u - 2), -2 * (v - 2)), (0, 1)) for v in range(5)])
            for u in range(5)
        ]
    )
    g = GpuPipeline(ctx, views)
    try:
        g.refocus(2.0)
        g.sobel(None)
        out = g.read_source()
        g.refocus(2.5)
        g.sobel(None)
        blurred = g.read_source()
    finally:
        g.release()
    np.testing.assert_allclose(out[4:-4, 4:-4], tex[4:-4, 4:-4], rtol=0, atol=1.2e-7)
    assert np.abs(blurred[6:-6, 6:-6] - tex[6:-6, 6:-6]).mean() > 0.05


@pytest.mark.parametrize("zoom", [None, (10, 5, 60, 50), (0, 0, 9, 8)])
def test_sobel_and_edges_match_cpu(pipeline, scene, zoom) -> None:
    lf = scene.gray()
    pipeline.refocus(3.7)
    pipeline.sobel(zoom)
    src = refocus(lf, 3.7)
    if zoom is not None:
        x, y, w, h = zoom
        src = src[y : y + h, x : x + w]
    mag_cpu = sobel_magnitude(src)
    mag_gpu = pipeline.read_magnitude()
    np.testing.assert_allclose(mag_gpu, mag_cpu, rtol=0, atol=1e-6)
    t = float(np.median(mag_cpu))
    differ = (mag_gpu > t) != (mag_cpu > t)
    assert not (differ & (np.abs(mag_cpu - t) > 1e-6)).any()


@pytest.mark.parametrize("implant", ["argus2", "alpha_ims", "brainport"])
@pytest.mark.parametrize("levels", [2, 4, 8])
def test_panes_and_screen_match_cpu(ctx, pipeline, scene, implant, levels) -> None:
    lf = scene.gray()
    layout = load_implant(implant)
    state = ViewerState(
        disparity_px=3.7, implant=implant, zoom=(8, 6, 100, 80), grey_levels=levels, threshold=None
    )
    p = cpu_panes(lf, state, layout)
    pipeline.refocus(state.disparity_px)
    pipeline.sobel(state.zoom)
    pipeline.compress(layout.shape, p.threshold, p.grey_levels, EDGE_RATIO)
    cells = pipeline.read_cells()
    if p.grey_levels == 2:
        np.testing.assert_array_equal(cells, p.cells)
    else:
        from stimuli.compress import block_mean

        mean = block_mean(p.source, layout.shape)
        g = p.grey_levels
        near = np.abs(mean * g - np.round(mean * g)) < 1e-5 * g
        assert not ((cells != p.cells) & ~near).any()
    screen = screen_layout((360, 480), lf.shape_px, p.source.shape, layout)
    status = status_image(f"test {implant} {levels}", (STATUS_ROWS_PX, 480))
    fbo = ctx.simple_framebuffer((480, 360))
    try:
        pipeline.draw(
            fbo,
            screen,
            layout,
            threshold=p.threshold,
            zoom=state.zoom,
            alert=levels == 4,
            status=status,
        )
        got = np.frombuffer(fbo.read(components=3), np.uint8).reshape(360, 480, 3)[::-1]
    finally:
        fbo.release()
    want = expected_screen(
        screen,
        p.centre,
        p.source,
        p.edges,
        cells,
        layout,
        zoom=state.zoom,
        alert=levels == 4,
        status=status,
    )
    diff = np.abs(got.astype(int) - want.astype(int))
    assert diff.max() <= 1, f"{int((diff > 1).sum())} pixels differ by more than 1"


def test_grid_too_large_is_refused(ctx) -> None:
    with pytest.raises(GpuError, match="exceeds 32x32"):
        GpuPipeline(ctx, np.zeros((33, 1, 4, 4), np.float32))


def test_refocus_cache_serves_revisits_and_is_dropped_with_new_views(ctx, scene) -> None:
    lf = scene.gray()
    g = GpuPipeline(ctx, lf.views)
    try:
        for d in (1.0, 2.0, 1.0):
            g.refocus(d)
            g.sobel(None)
            np.testing.assert_allclose(g.read_source(), refocus(lf, d), rtol=0, atol=1e-6)
        assert len(g._cache) == 2
        other = np.ascontiguousarray(lf.views[:, :, ::-1, :])  # the next "video frame"
        g.set_views(other)
        assert not g._cache
        g.refocus(1.0)
        g.sobel(None)
        np.testing.assert_allclose(g.read_source(), refocus(other, 1.0), rtol=0, atol=1e-6)
    finally:
        g.release()


@pytest.mark.parametrize("grid", [(1, 5), (4, 3), (5, 1), (6, 2)])
def test_refocus_matches_cpu_for_any_grid_shape(ctx, grid) -> None:
    """One row of views (Middlebury), a grid row count not a multiple of four, one column."""
    rng = np.random.default_rng(grid[0] * 10 + grid[1])
    views = rng.random((*grid, 30, 40)).astype(np.float32)
    g = GpuPipeline(ctx, views)
    try:
        for d in (0.0, 1.5, -2.25):
            g.refocus(d)
            g.sobel(None)
            np.testing.assert_allclose(g.read_source(), refocus(views, d), rtol=0, atol=1e-6)
    finally:
        g.release()


@pytest.mark.data
def test_lytro_light_field_gpu_equals_cpu(ctx, data_dir) -> None:
    """The real Lytro Illum 7x7 light field: the GPU confocal image, edges and Argus II grid equal
    the CPU pipeline's (tolerances as above), zoomed on the stegosaurus' head."""
    from stimuli.lightfield import load_lightfield
    from tests.conftest import require_data

    lf = load_lightfield(require_data(data_dir, "lightfield", "lytro_illum_2067_epinet")).gray()
    layout = load_implant("argus2")
    g = GpuPipeline(ctx, lf.views)
    try:
        for d, zoom in ((0.43, None), (-0.8, (20, 20, 200, 150))):
            state = ViewerState(disparity_px=d, implant="argus2", zoom=zoom)
            p = cpu_panes(lf, state, layout)
            g.refocus(d)
            g.sobel(zoom)
            np.testing.assert_allclose(g.read_source(), p.source, rtol=0, atol=1e-6)
            mag = g.read_magnitude()
            np.testing.assert_allclose(mag, p.magnitude, rtol=0, atol=1e-6)
            differ = (mag > p.threshold) != p.edges
            assert not (differ & (np.abs(p.magnitude - p.threshold) > 1e-6)).any()
            g.compress(layout.shape, p.threshold, 2, EDGE_RATIO)
            if not differ.any():
                np.testing.assert_array_equal(g.read_cells(), p.cells)
    finally:
        g.release()


def test_prefetch_fills_the_cache_without_changing_the_shown_image(ctx, scene) -> None:
    from experiment.viewer.app import Viewer
    from experiment.viewer.source import LightFieldSource

    v = Viewer(
        LightFieldSource(scene),
        ["argus2"],
        screen_shape_px=(240, 320),
        ctx=ctx,
        n_planes=30,
        compute="gpu",
    )
    try:
        fbo = ctx.simple_framebuffer((320, 240))
        v.render(fbo)
        before = v.gpu.read_source()
        n = 0
        while v.prefetch():
            n += 1
        assert n >= 8 and not v.prefetch()
        np.testing.assert_array_equal(v.gpu.read_source(), before)
        d_next = v.handle("key", {"key": "up"}).disparity_px
        assert d_next in v.gpu._cache  # the state machine's next step was prefetched
        from stimuli.declutter import auto_threshold

        t_cpu = auto_threshold(refocus(scene.gray(), d_next))
        # Otsu on a 256-bin histogram: the GPU magnitude (a few ulps off) may move it one bin
        mag = sobel_magnitude(refocus(scene.gray(), d_next))
        bin_w = float(mag.max() - mag.min()) / 256
        assert v._gl.auto_t.get((0, d_next, None)) == pytest.approx(t_cpu, abs=bin_w)
        v.render(fbo)
        np.testing.assert_allclose(v.gpu.read_source(), refocus(scene.gray(), d_next), atol=1e-6)
        fbo.release()
    finally:
        v.close()


def test_numpy_pipeline_drawn_into_the_gl_framebuffer(ctx, scene) -> None:
    """``compute='cpu'`` with a context (the default on llvmpipe): the numpy frame is copied into
    the framebuffer unchanged, and ``auto`` picks it exactly on a software rasteriser."""
    from experiment.viewer.app import Viewer, is_software_renderer
    from experiment.viewer.source import LightFieldSource

    src = LightFieldSource(scene)
    v = Viewer(src, ["argus2"], screen_shape_px=(240, 320), ctx=ctx, n_planes=30, compute="cpu")
    auto = Viewer(src, ["argus2"], screen_shape_px=(240, 320), ctx=ctx, n_planes=30)
    try:
        assert v.gpu is None and v.compute == "cpu"
        assert auto.compute == ("cpu" if is_software_renderer(ctx) else "gpu")
        fbo = ctx.simple_framebuffer((320, 240))
        v.handle("key", {"key": "page_down"})
        frame = v.render(fbo)
        ctx.finish()
        shown = np.frombuffer(fbo.read(components=3), np.uint8).reshape(240, 320, 3)[::-1]
        np.testing.assert_array_equal(shown, frame)
        assert frame.std() > 0  # a real picture, not a blank frame
        fbo.release()
    finally:
        v.close()
        auto.close()
