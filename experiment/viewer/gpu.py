"""The viewer's pipeline in fragment shaders: refocus, Sobel, threshold, compress, draw.

Same images as the CPU pipeline (:mod:`experiment.viewer.reference`), computed on the GPU
(or llvmpipe, the floor: no GPU is ever required):

* the views live in one ``RGBA32F`` 2-D texture array: a layer per (group of four grid rows
  ``u``, grid column ``v``), the four rows in the four channels (they share their column
  shifts, so one fetch serves four views: 1.7x faster on llvmpipe than a layer per view);
* shift-and-add at a sub-pixel disparity in two passes, as :func:`stimuli.refocus.refocus`:
  first, per grid row ``u``, the views summed over ``v`` with column shifts (linear
  interpolation as two integer-shifted samples, zero outside the view) into a tall
  ``(n_u / 4 rows) x cols`` RGBA texture; then those partial images summed over ``u`` with row
  shifts,
  times the inverse of the separable weight ``W(y, x)`` (computed once per disparity in numpy,
  exactly as the CPU does, and uploaded), clipped to [0, 1]. The integer shifts and weights are
  computed in Python with the CPU's rules (a fraction within 1e-6 of a whole pixel snaps to it);
* Sobel magnitude on the zoom box with reflected borders (``scipy.ndimage`` 'reflect', as
  ``skimage.filters.sobel``);
* compression per electrode window (:func:`stimuli.compress.window_bounds`): the number of edge
  pixels compared with the smallest count whose fraction exceeds the edge ratio (computed in
  numpy with the CPU's float32 rounding, so the comparison is exact), or the window mean
  quantised to grey levels;
* the four panes and the status line drawn with integer nearest-neighbour cells and the same
  phosphene formula as :func:`stimuli.implants.render_phosphenes`.

Floating-point sums run in a different order (and may be fused) on the GPU, so the confocal
image and the Sobel magnitude differ from numpy's by a few float32 ulps; the tests state the
tolerances. Only this module imports :mod:`moderngl` in the viewer (house style H13).
"""

from __future__ import annotations

import math
from collections import OrderedDict

import moderngl
import numpy as np

from experiment.errors import ConfocalError
from experiment.presentation.drawing import VERTEX_SHADER
from experiment.viewer.screen import (
    ALERT_BORDER_PX,
    ALERT_RGB,
    BACKGROUND_RGB,
    BOX_RGB,
    MARKER_RGB,
    STATUS_ROWS_PX,
    ScreenLayout,
    marker_arm_px,
)
from experiment.viewer.shaders import (
    COMPRESS_SHADER,
    DRAW_SHADER,
    PASS1_SHADER,
    PASS2_SHADER,
    SOBEL_SHADER,
)
from stimuli.implants import ImplantLayout

# the CPU refocus's own interpolation rule, so that both add the same shifted views
from stimuli.refocus import overlap_weights, shift_weights

__all__ = [
    "MAX_GRID",
    "CACHE_BYTES",
    "GpuError",
    "GpuPipeline",
    "min_on_counts",
    "create_headless_context",
]

#: Largest number of views along one grid axis (size of the shaders' uniform arrays).
MAX_GRID = 32

#: GPU memory for cached confocal images, bytes (ours: 64 MiB, about 80 Lytro-size images).
CACHE_BYTES = 64 << 20


class GpuError(ConfocalError):
    """No OpenGL context, or the light field does not fit the GPU pipeline."""


def create_headless_context() -> moderngl.Context:
    """Open a standalone OpenGL 3.3 context (EGL first, then the platform default).

    Raises
    ------
    GpuError
        When no context can be created.
    """
    try:
        return moderngl.create_standalone_context(require=330, backend="egl")
    except Exception as exc:  # noqa: BLE001 - any back-end failure means "no context"
        try:
            return moderngl.create_standalone_context(require=330)
        except Exception:  # noqa: BLE001
            raise GpuError(f"no headless OpenGL 3.3 context: {exc}") from exc


def min_on_counts(areas: np.ndarray, edge_ratio: float) -> np.ndarray:
    """Smallest edge count per window whose fraction exceeds ``edge_ratio`` (CPU rounding).

    A window of ``A`` pixels is on when ``float32(n / A) > float32(edge_ratio)``, with ``n / A``
    computed in float64 as :func:`stimuli.compress.block_mean` does; ``A + 1`` means never.
    """
    areas = np.asarray(areas, dtype=np.int64)
    out = np.empty(areas.shape, dtype=np.float32)
    r = np.float32(edge_ratio)
    for a in np.unique(areas):
        n = np.arange(a + 1, dtype=np.float64)
        ok = (n / a).astype(np.float32) > r
        out[areas == a] = float(np.argmax(ok)) if ok.any() else float(a + 1)
    return out


class GpuPipeline:
    """The viewer's images on the GPU: one light field's views in a texture array.

    Parameters
    ----------
    ctx : moderngl.Context
        Any OpenGL 3.3 context (headless EGL, or a window's).
    views : ndarray of shape (n_u, n_v, rows, cols), float32 in [0, 1]
        Grey views.

    Raises
    ------
    GpuError
        A grid larger than :data:`MAX_GRID` per axis, or more views than the GPU's texture
        array holds.
    """

    def __init__(self, ctx: moderngl.Context, views: np.ndarray) -> None:
        self.ctx = ctx
        n_u, n_v, rows, cols = views.shape
        if n_u > MAX_GRID or n_v > MAX_GRID:
            raise GpuError(f"light field grid {n_u}x{n_v} exceeds {MAX_GRID}x{MAX_GRID} views")
        if (n_u + 3) // 4 * n_v > ctx.info["GL_MAX_ARRAY_TEXTURE_LAYERS"]:
            raise GpuError(f"{n_u * n_v} views exceed the GPU's texture-array layers")
        self.grid = (n_u, n_v)
        self.shape_px = (rows, cols)
        self._progs = {
            name: ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=src)
            for name, src in (
                ("pass1", PASS1_SHADER),
                ("pass2", PASS2_SHADER),
                ("sobel", SOBEL_SHADER),
                ("compress", COMPRESS_SHADER),
                ("draw", DRAW_SHADER),
            )
        }
        self._vaos = {k: ctx.vertex_array(p, []) for k, p in self._progs.items()}
        n_g = (n_u + 3) // 4
        self._n_groups = n_g
        self._views = ctx.texture_array((cols, rows, n_g * n_v), 4, dtype="f4")
        self._views.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._partial = ctx.texture((cols, n_g * rows), 4, dtype="f4")
        self._partial_fbo = ctx.framebuffer([self._partial])
        # Confocal images by disparity, least recently used last out: scanning back over
        # depths already seen costs no refocus (ours: up to CACHE_BYTES of images).
        self._cache: OrderedDict[float, tuple[moderngl.Texture, moderngl.Framebuffer]] = (
            OrderedDict()
        )
        self._cache_max = max(2, CACHE_BYTES // (4 * rows * cols))
        self._blank = self._new_confocal()  # the source before any refocus
        self._confocal = self._blank
        self._inv = ctx.texture((cols, rows), 1, dtype="f4")
        self._upload = ctx.texture((cols, rows), 1, dtype="f4")  # obstacle-masked source
        self._centre = ctx.texture((cols, rows), 1, dtype="f4")
        for t in (self._partial, self._inv, self._upload, self._centre):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._mag: moderngl.Texture | None = None
        self._mag_fbo: moderngl.Framebuffer | None = None
        self._cells: moderngl.Texture | None = None
        self._cells_fbo: moderngl.Framebuffer | None = None
        self._grid_key: tuple | None = None
        self._aux: dict[str, moderngl.Texture] = {}
        self._text: moderngl.Texture | None = None
        self._src = self._confocal
        self._grey = False
        self._crop = (0, 0, cols, rows)
        self._disparity: float | None = None
        self.set_views(views)

    # -- data ----------------------------------------------------------------------------------

    def set_views(self, views: np.ndarray) -> None:
        """Upload a new set of views of the same shape (the next video frame)."""
        n_u, n_v, rows, cols = views.shape
        if (n_u, n_v) != self.grid or (rows, cols) != self.shape_px:
            raise GpuError(f"views {views.shape} differ from the pipeline's {self.grid}")
        v = np.asarray(views, dtype=np.float32)
        n_g = self._n_groups
        packed = np.zeros((n_g * 4, n_v, rows, cols), np.float32)
        packed[:n_u] = v
        # layer (group, v) holds grid rows 4 group .. 4 group + 3 as its RGBA channels
        packed = packed.reshape(n_g, 4, n_v, rows, cols).transpose(0, 2, 3, 4, 1)
        self._views.write(np.ascontiguousarray(packed).tobytes())
        self._centre.write(np.ascontiguousarray(v[n_u // 2, n_v // 2]).tobytes())
        self._disparity = None
        while self._cache:
            tex, fbo = self._cache.popitem()[1]
            fbo.release()
            tex.release()
        if self._src is self._confocal:
            self._src = self._blank
        self._confocal = self._blank

    def _new_confocal(self) -> moderngl.Texture:
        rows, cols = self.shape_px
        t = self.ctx.texture((cols, rows), 1, dtype="f4")
        t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        return t

    # -- passes --------------------------------------------------------------------------------

    @staticmethod
    def _pairs_arrays(shifts: list[float]) -> tuple[bytes, bytes]:
        m = np.zeros((MAX_GRID, 2), np.int32)
        w = np.zeros((MAX_GRID, 2), np.float32)
        for k, s in enumerate(shifts):
            pairs = shift_weights(s)
            m[k, 0], w[k, 0] = pairs[0]
            if len(pairs) == 2:
                m[k, 1], w[k, 1] = pairs[1]
        return m.tobytes(), w.tobytes()

    def refocus(self, slope_px_per_view: float) -> None:
        """Shift-and-add the views at one disparity into a confocal texture (cached)."""
        d = float(slope_px_per_view)
        self._grey = False
        hit = self._cache.get(d)
        if hit is not None:
            self._cache.move_to_end(d)
            self._src = self._confocal = hit[0]
            self._disparity = d
            return
        if len(self._cache) >= self._cache_max:
            oldest = next(iter(self._cache))
            if self._cache[oldest][0] is self._confocal:  # never recycle the shown image
                self._cache.move_to_end(oldest)
            tex, fbo = self._cache.popitem(last=False)[1]
        else:
            tex = self._new_confocal()
            fbo = self.ctx.framebuffer([tex])
        self._cache[d] = (tex, fbo)
        self._src = self._confocal = tex
        n_u, n_v = self.grid
        rows, cols = self.shape_px
        row_shifts = [d * (u - n_u // 2) for u in range(n_u)]
        col_shifts = [d * (v - n_v // 2) for v in range(n_v)]
        w = np.outer(overlap_weights(rows, row_shifts), overlap_weights(cols, col_shifts))
        inv = np.zeros_like(w)
        np.divide(1.0, w, out=inv, where=w > 1e-9)
        self._inv.write(inv.astype(np.float32).tobytes())

        p1 = self._progs["pass1"]
        p1["u_rows"].value, p1["u_cols"].value, p1["u_nv"].value = rows, cols, n_v
        m, wt = self._pairs_arrays(col_shifts)
        p1["u_m"].write(m)
        p1["u_w"].write(wt)
        self._views.use(0)
        p1["u_views"].value = 0
        self._partial_fbo.use()
        self._vaos["pass1"].render(moderngl.TRIANGLES, vertices=3)

        p2 = self._progs["pass2"]
        p2["u_rows"].value, p2["u_nu"].value = rows, n_u
        m, wt = self._pairs_arrays(row_shifts)
        p2["u_m"].write(m)
        p2["u_w"].write(wt)
        self._partial.use(0)
        self._inv.use(1)
        p2["u_partial"].value, p2["u_inv"].value = 0, 1
        fbo.use()
        self._vaos["pass2"].render(moderngl.TRIANGLES, vertices=3)
        self._disparity = d

    def prefetch(self, slope_px_per_view: float) -> bool:
        """Refocus into the cache without changing what is shown; False if already cached."""
        d = float(slope_px_per_view)
        if d in self._cache:
            return False
        shown = (self._src, self._confocal, self._disparity)
        self.refocus(d)
        self._src, self._confocal, self._disparity = shown
        for key, (tex, _) in self._cache.items():
            if tex is self._confocal:  # the shown image stays the most recently used
                self._cache.move_to_end(key)
                break
        return True

    def set_source(self, image: np.ndarray, grey: np.ndarray | None = None) -> None:
        """Use an uploaded image (rows, cols, float32) as the source instead of the refocus.

        ``grey`` (same shape), when given, is what the grey-level compression averages instead
        (obstacle mode: the in-range mask).
        """
        self._upload.write(np.ascontiguousarray(image, dtype=np.float32).tobytes())
        self._src = self._upload
        if grey is not None:
            rows, cols = self.shape_px
            g = self._ensure("grey", (cols, rows))
            g.write(np.ascontiguousarray(grey, dtype=np.float32).tobytes())
        self._grey = grey is not None

    def _ensure(self, key: str, size: tuple[int, int], dtype: str = "f4") -> moderngl.Texture:
        t = self._aux.get(key)
        if t is None or t.size != size or t.dtype != dtype:
            if t is not None:
                t.release()
            t = self.ctx.texture(size, 1, dtype=dtype)
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._aux[key] = t
        return t

    def sobel(self, zoom: tuple[int, int, int, int] | None) -> None:
        """Sobel magnitude of the source inside the zoom box (whole image when None)."""
        rows, cols = self.shape_px
        crop = tuple(zoom) if zoom is not None else (0, 0, cols, rows)
        self._crop = crop
        size = (crop[2], crop[3])
        if self._mag is None or self._mag.size != size:
            if self._mag is not None:
                self._mag_fbo.release()
                self._mag.release()
            self._mag = self.ctx.texture(size, 1, dtype="f4")
            self._mag.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._mag_fbo = self.ctx.framebuffer([self._mag])
        p = self._progs["sobel"]
        p["u_crop"].value = crop
        self._src.use(0)
        p["u_src"].value = 0
        self._mag_fbo.use()
        self._vaos["sobel"].render(moderngl.TRIANGLES, vertices=3)

    def magnitude_at(
        self, slope_px_per_view: float, zoom: tuple[int, int, int, int] | None
    ) -> np.ndarray | None:
        """Sobel magnitude of a cached confocal image, without touching what is shown.

        Returns None when that disparity is not cached. Used to find the automatic threshold of
        a prefetched depth while the window is idle.
        """
        hit = self._cache.get(float(slope_px_per_view))
        if hit is None:
            return None
        rows, cols = self.shape_px
        crop = tuple(zoom) if zoom is not None else (0, 0, cols, rows)
        tex = self._ensure("scratch_mag", (crop[2], crop[3]))
        fbo = self.ctx.framebuffer([tex])
        try:
            p = self._progs["sobel"]
            p["u_crop"].value = crop
            hit[0].use(0)
            p["u_src"].value = 0
            fbo.use()
            self._vaos["sobel"].render(moderngl.TRIANGLES, vertices=3)
            raw = tex.read()
        finally:
            fbo.release()
        return np.frombuffer(raw, np.float32).reshape(crop[3], crop[2]).copy()

    def read_magnitude(self) -> np.ndarray:
        """Return the Sobel magnitude, float32 (h, w)."""
        w, h = self._mag.size
        return np.frombuffer(self._mag.read(), np.float32).reshape(h, w).copy()

    def read_source(self) -> np.ndarray:
        """Return the source image inside the zoom box, float32 (h, w)."""
        rows, cols = self.shape_px
        full = np.frombuffer(self._src.read(), np.float32).reshape(rows, cols)
        x, y, w, h = self._crop
        return full[y : y + h, x : x + w].copy()

    def compress(
        self, grid_px: tuple[int, int], threshold: float, grey_levels: int, edge_ratio: float
    ):
        """Compress the zoomed edges (or grey source) to a ``grid_px`` electrode grid."""
        from stimuli.compress import window_bounds

        n_r, n_c = grid_px
        w, h = self._crop[2], self._crop[3]
        key = (n_r, n_c, w, h, float(edge_ratio))
        if key != self._grid_key:
            rb = window_bounds(h, n_r).astype(np.int32)
            cb = window_bounds(w, n_c).astype(np.int32)
            self._ensure("rb", (n_r + 1, 1), "i4").write(rb.tobytes())
            self._ensure("cb", (n_c + 1, 1), "i4").write(cb.tobytes())
            areas = np.outer(np.diff(rb), np.diff(cb))
            self._ensure("kmin", (n_c, n_r)).write(min_on_counts(areas, edge_ratio).tobytes())
            if self._cells is None or self._cells.size != (n_c, n_r):
                if self._cells is not None:
                    self._cells_fbo.release()
                    self._cells.release()
                self._cells = self.ctx.texture((n_c, n_r), 1, dtype="f4")
                self._cells.filter = (moderngl.NEAREST, moderngl.NEAREST)
                self._cells_fbo = self.ctx.framebuffer([self._cells])
            self._grid_key = key
        p = self._progs["compress"]
        self._mag.use(0)
        (self._aux["grey"] if self._grey else self._src).use(1)
        self._aux["rb"].use(2)
        self._aux["cb"].use(3)
        self._aux["kmin"].use(4)
        for name, unit in (("u_mag", 0), ("u_src", 1), ("u_rb", 2), ("u_cb", 3), ("u_kmin", 4)):
            p[name].value = unit
        p["u_crop"].value = self._crop
        p["u_t"].value = float(threshold)
        p["u_levels"].value = int(grey_levels)
        self._cells_fbo.use()
        self._vaos["compress"].render(moderngl.TRIANGLES, vertices=3)

    def read_cells(self) -> np.ndarray:
        """Return the electrode values, float32 (grid rows, cols)."""
        w, h = self._cells.size
        return np.frombuffer(self._cells.read(), np.float32).reshape(h, w).copy()

    def write_cells(self, cells: np.ndarray) -> None:
        """Replace the electrode values (temporal averaging is done by the caller)."""
        self._cells.write(np.ascontiguousarray(cells, dtype=np.float32).tobytes())

    # -- drawing -------------------------------------------------------------------------------

    def draw(
        self,
        fbo: moderngl.Framebuffer,
        screen: ScreenLayout,
        layout: ImplantLayout,
        *,
        threshold: float,
        zoom: tuple[int, int, int, int] | None,
        alert: bool,
        status: np.ndarray,
        panes: tuple[bool, bool, bool, bool] = (True, True, True, True),
        marker: tuple[int, int] | None = None,
        overlay: np.ndarray | None = None,
        implant_image: np.ndarray | None = None,
    ) -> None:
        """Draw the panes and the status line into ``fbo`` (top-left origin).

        ``panes`` says which of the four to redraw; the others keep what ``fbo`` holds (the
        caller's persistent frame). The status line is always redrawn. ``marker``: a cross on
        the centre view (view pixels); ``overlay``: the key help (uint8), drawn over the
        middle; ``implant_image``: a picture (float32 [0, 1], the implant rectangle's size)
        drawn instead of the phosphenes (a pulse2percept percept).
        """
        ctx = self.ctx
        rows, cols = screen.screen_shape_px
        fbo.use()
        ctx.scissor = None
        bg = tuple(c / 255 for c in BACKGROUND_RGB)

        def gl_box(left, top, w, h):
            return (left, rows - (top + h), w, h)

        if all(panes):
            fbo.clear(*bg, 1.0)
        else:
            for k, redraw in enumerate(panes):
                if redraw:
                    fbo.clear(*bg, 1.0, viewport=gl_box(*screen.panes[k]))

        p = self._progs["draw"]
        p["u_screen_rows"].value = rows
        alive = self._ensure("alive", (layout.cols, layout.rows))
        alive_key = (id(alive), layout)
        if getattr(self, "_alive_for", None) != alive_key:
            alive.write(layout.electrode_gain().astype(np.float32).tobytes())
            self._alive_for = alive_key
        r, c = self.shape_px
        x, y, w, h = self._crop
        implant = (2, screen.images[3], self._cells, (0, 0, layout.cols, layout.rows), None)
        if implant_image is not None:
            ih, iw = implant_image.shape
            tex = self._ensure("implant_image", (iw, ih))
            tex.write(np.ascontiguousarray(implant_image, dtype=np.float32).tobytes())
            implant = (0, screen.images[3], tex, (0, 0, iw, ih), None)
        items = [
            (0, screen.images[0], self._centre, (0, 0, c, r), zoom),
            (0, screen.images[1], self._src, (x, y, w, h), None),
            (1, screen.images[2], self._mag, (0, 0, w, h), None),
            implant,
        ]
        items = [it for it, redraw in zip(items, panes, strict=True) if redraw]
        if alert and panes[3]:
            left, top, iw, ih = screen.images[3]
            b = ALERT_BORDER_PX
            ctx.scissor = None
            fbo.clear(
                *(v / 255 for v in ALERT_RGB),
                1.0,
                viewport=gl_box(left - b, top - b, iw + 2 * b, ih + 2 * b),
            )
        p["u_t"].value = float(threshold)
        p["u_box_rgb"].value = tuple(v / 255 for v in BOX_RGB)
        p["u_phos"].value = 1 if layout.phosphene_shape == "gaussian" else 2
        p["u_phos_size"].value = float(layout.phosphene_size)
        th = math.radians(float(layout.rotation_deg))
        p["u_rot"].value = (1.0, 0.0) if th == 0 else (math.cos(th), math.sin(th))
        p["u_marker_rgb"].value = tuple(v / 255 for v in MARKER_RGB)
        for k, (kind, rect, tex, src_rect, box) in enumerate(items):
            mark = (-1, -1, -1)
            if marker is not None and k == 0 and src_rect == (0, 0, c, r):
                mark = (int(marker[0]), int(marker[1]), marker_arm_px((r, c)))
            p["u_marker"].value = mark
            p["u_kind"].value = kind
            p["u_rect"].value = rect
            p["u_src_rect"].value = src_rect
            p["u_box"].value = tuple(box) if box is not None else (0, 0, 0, 0)
            tex.use(0)
            alive.use(1)
            p["u_tex"].value, p["u_alive"].value = 0, 1
            ctx.scissor = gl_box(*rect)
            self._vaos["draw"].render(moderngl.TRIANGLES, vertices=3)
        sl, st, sc, sr = screen.status
        text = self._text
        if text is None or text.size != (sc, sr):
            if text is not None:
                text.release()
            text = self._text = ctx.texture((sc, sr), 1, dtype="u1")
        text.write(np.ascontiguousarray(status, dtype=np.uint8).tobytes())
        p["u_kind"].value = 3
        p["u_rect"].value = screen.status
        text.use(2)
        p["u_text"].value = 2
        ctx.scissor = gl_box(*screen.status)
        self._vaos["draw"].render(moderngl.TRIANGLES, vertices=3)
        if overlay is not None:
            oh, ow = overlay.shape
            tex = self._ensure("overlay", (ow, oh), "u1")
            tex.write(np.ascontiguousarray(overlay, dtype=np.uint8).tobytes())
            rect = ((cols - ow) // 2, (rows - STATUS_ROWS_PX - oh) // 2, ow, oh)
            p["u_rect"].value = rect
            tex.use(2)
            ctx.scissor = gl_box(*rect)
            self._vaos["draw"].render(moderngl.TRIANGLES, vertices=3)
        ctx.scissor = None

    def release(self) -> None:
        """Free the GPU objects."""
        for t in list(self._aux.values()):
            t.release()
        self._aux.clear()
        for tex, fbo in self._cache.values():
            fbo.release()
            tex.release()
        self._cache.clear()
        for obj in (
            self._views,
            self._partial_fbo,
            self._partial,
            self._inv,
            self._upload,
            self._blank,
            self._centre,
            self._mag_fbo,
            self._mag,
            self._cells_fbo,
            self._cells,
            self._text,
        ):
            if obj is not None:
                obj.release()
        for v in self._vaos.values():
            v.release()
        for pr in self._progs.values():
            pr.release()
