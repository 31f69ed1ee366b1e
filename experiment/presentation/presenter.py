"""The subject's screen: the moderngl presenter (window or offscreen), its drawing and flips.

This is the only module that imports :mod:`moderngl` (house style H13); it is imported lazily by
the console and the presenter process, never as a side effect of ``import experiment``. The
presenter's parts live beside it, GL-free:

- :mod:`experiment.presentation.geometry`: the screen's physical geometry and colours;
- :mod:`experiment.presentation.frame`: where a stimulus lands, phosphenes, the expected frame;
- :mod:`experiment.presentation.drawing`: the GLSL program and the text image;
- :mod:`experiment.presentation.timing`: dropped frames and the refresh self-test;
- :mod:`experiment.presentation.window`: the subject's window and input.

Their public names are importable from here too.
"""

from __future__ import annotations

import logging
from collections import deque
from pathlib import Path
from typing import Any

import moderngl
import numpy as np

from experiment.clock import Clock, PerfCounterClock
from experiment.interfaces import ClosesOnExit, FlipRecord
from experiment.presentation.drawing import (
    FIXATION_HALF_DEG,
    FIXATION_THICKNESS_PX,
    FRAGMENT_SHADER,
    MODE_BLANK,
    MODE_STIMULUS,
    MODE_TEXT,
    VERTEX_SHADER,
    text_image,
)
from experiment.presentation.errors import PresenterError
from experiment.presentation.frame import (
    PhospheneSpec,
    as_stimulus,
    cell_index,
    expected_frame,
    stimulus_rect_px,
)
from experiment.presentation.geometry import ScreenGeometry
from experiment.presentation.timing import (
    StimulusTiming,
    TimingCheckFailed,
    check_timing,
    count_dropped,
    refresh_stats,
)
from experiment.presentation.window import INPUT_KEYS, bind_subject_input, open_window

__all__ = [
    "INPUT_KEYS",
    "ScreenGeometry",
    "PhospheneSpec",
    "PresenterError",
    "TimingCheckFailed",
    "Presenter",
    "stimulus_rect_px",
    "cell_index",
    "expected_frame",
    "count_dropped",
]

logger = logging.getLogger(__name__)


class Presenter(ClosesOnExit):
    """The subject's screen drawn with moderngl; implements :class:`experiment.interfaces.Display`.

    Use :meth:`offscreen` (EGL, no window; the test twin and ``--screenshot``) or :meth:`windowed`
    (a moderngl-window/pyglet window on a chosen screen).

    Parameters
    ----------
    ctx : moderngl.Context
    geometry : ScreenGeometry
    clock : Clock
        Time stamps of flips (H17).
    window : moderngl_window BaseWindow or None
        The window whose buffers are swapped; None draws into an offscreen framebuffer.
    integer_scale : bool
        Round the magnification to an integer (equal-size cells); see :func:`stimulus_rect_px`.
    phosphenes : PhospheneSpec or None
        Draw cells as phosphenes.
    """

    def __init__(
        self,
        ctx: moderngl.Context,
        geometry: ScreenGeometry,
        *,
        clock: Clock | None = None,
        window: Any = None,
        integer_scale: bool = False,
        phosphenes: PhospheneSpec | None = None,
    ) -> None:
        self.ctx = ctx
        self.geometry = geometry
        self.clock = clock if clock is not None else PerfCounterClock()
        self.window = window
        self.integer_scale = integer_scale
        self.phosphenes = phosphenes
        self.refresh_hz: float | None = None
        rows, cols = geometry.screen_shape_px
        if window is None or ctx.screen is None:  # offscreen, or a test window without a screen
            max_px = int(ctx.info.get("GL_MAX_RENDERBUFFER_SIZE", 0) or 0)
            if max_px and max(rows, cols) > max_px:
                raise PresenterError(
                    f"screen {cols}x{rows} px is larger than this GL driver's largest framebuffer "
                    f"({max_px}x{max_px} px); use a smaller screen size (display.screen_width_px, "
                    "display.screen_height_px or --screen-px)"
                )
            self._fbo = ctx.framebuffer(color_attachments=[ctx.renderbuffer((cols, rows), 4)])
        else:
            self._fbo = ctx.screen
            fb_cols, fb_rows = window.buffer_size
            if (fb_rows, fb_cols) != (rows, cols):
                raise PresenterError(
                    f"the window's framebuffer is {fb_cols}x{fb_rows} px but the protocol's screen "
                    f"is {cols}x{rows} px; set the screen to the protocol's resolution"
                )
        self._prog = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=FRAGMENT_SHADER)
        self._vao = ctx.vertex_array(self._prog, [])
        self._stim_tex: moderngl.Texture | None = None
        self._text_tex: moderngl.Texture | None = None
        self._mode = MODE_BLANK
        self._text_box = (0, 0, 0, 0)
        self._timing: StimulusTiming | None = None
        self._closed = False
        #: Subject input collected since the last :meth:`poll_inputs` (see :meth:`enable_input`).
        self.inputs: deque[dict[str, Any]] = deque()
        g = geometry
        self._set("u_screen", (cols, rows))
        self._set("u_border", tuple(c / 255 for c in g.border_rgb))
        self._set("u_border_px", -1 if g.border_width_px is None else g.border_width_px)
        self._set("u_background", tuple(c / 255 for c in g.background_rgb))
        self._set("u_fg", tuple(c / 255 for c in g.stimulus_on_rgb))
        self._set("u_bg", tuple(c / 255 for c in g.stimulus_off_rgb))
        self._set("u_inv_gamma", 1.0 / g.gamma)
        fix = int(round(FIXATION_HALF_DEG * g.px_per_deg)) if g.fixation else 0
        self._set("u_fixation", fix)
        self._set("u_fix_thick", FIXATION_THICKNESS_PX)
        self._set("u_fix_rgb", (0.5, 0.5, 0.5))
        self._set("u_stim", 0)
        self._set("u_text", 1)
        self._set("u_phos", 0)
        top, left, r, c = stimulus_rect_px(g, g.image_shape_px)
        self._set("u_rect", (left, top, c, r))
        self._rect = (left, top, c, r)

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def offscreen(cls, geometry: ScreenGeometry, **kwargs: Any) -> Presenter:
        """Open a headless presenter (EGL standalone context, offscreen framebuffer).

        Raises
        ------
        PresenterError
            When no OpenGL 3.3 context can be created.
        """
        try:
            ctx = moderngl.create_standalone_context(require=330, backend="egl")
        except Exception as exc:  # noqa: BLE001 - any back-end failure means "no context"
            try:
                ctx = moderngl.create_standalone_context(require=330)
            except Exception:  # noqa: BLE001
                raise PresenterError(f"no headless OpenGL 3.3 context: {exc}") from exc
        return cls(ctx, geometry, **kwargs)

    @classmethod
    def windowed(
        cls,
        geometry: ScreenGeometry,
        *,
        screen: int | None = None,
        fullscreen: bool = True,
        vsync: bool = True,
        title: str = "confocal: subject screen",
        **kwargs: Any,
    ) -> Presenter:
        """Open a window (moderngl-window, pyglet) at the protocol's resolution on ``screen``.

        ``screen`` is an index into pyglet's screen list (0 = first); full screen uses that screen's
        current mode, which must equal the protocol's resolution.
        """
        window = open_window(
            geometry, screen=screen, fullscreen=fullscreen, vsync=vsync, title=title
        )
        try:
            return cls(window.ctx, geometry, window=window, **kwargs)
        except Exception:
            window.close()
            raise

    # -- subject input ------------------------------------------------------------------------

    def enable_input(self) -> None:
        """Report the subject's keys, wheel and mouse drags in :attr:`inputs` (active search).

        Each input is a dict with ``t_s`` (clock time) and ``key`` (a value of
        :data:`INPUT_KEYS`, ``WheelUp``/``WheelDown``, or ``drag`` with ``box``: ``[x0, y0, x1,
        y1]`` as fractions of the stimulus rectangle, top-left origin, clipped to [0, 1]).
        Escape stops closing the window (moderngl-window's default): it is the un-zoom key.
        Offscreen, input arrives only through :meth:`post_input`.
        """
        if self.window is None:
            return
        bind_subject_input(self.window, self.post_input, self.stimulus_fraction)

    def stimulus_fraction(self, x: float, y: float) -> tuple[float, float]:
        """Map a window point (top-left origin, window units) to fractions of the stimulus."""
        ratio = float(getattr(self.window, "pixel_ratio", 1.0) or 1.0) if self.window else 1.0
        left, top, cols, rows = self._rect
        fx = (x * ratio - left) / max(cols, 1)
        fy = (y * ratio - top) / max(rows, 1)
        return float(min(max(fx, 0.0), 1.0)), float(min(max(fy, 0.0), 1.0))

    def post_input(self, event: dict[str, Any]) -> None:
        """Queue one subject input (stamped with the clock unless it has ``t_s``)."""
        self.inputs.append({"t_s": self.clock.now_s(), **event})

    def poll_inputs(self) -> list[dict[str, Any]]:
        """Return and forget the inputs queued so far, oldest first."""
        out = list(self.inputs)
        self.inputs.clear()
        return out

    def _set(self, name: str, value: Any) -> None:
        if name in self._prog:
            self._prog[name].value = value

    # -- drawing and flipping -----------------------------------------------------------------

    def _gl_box(self, left: int, top: int, cols: int, rows: int) -> tuple[int, int, int, int]:
        """Convert a top-left-origin box to GL's bottom-left (x, y, width, height), clipped."""
        screen_rows, screen_cols = self.geometry.screen_shape_px
        x0, y0 = max(0, left), max(0, top)
        x1, y1 = min(screen_cols, left + cols), min(screen_rows, top + rows)
        return x0, screen_rows - y1, max(0, x1 - x0), max(0, y1 - y0)

    def _draw(self) -> None:
        # Only the image (or text) rectangle runs the fragment shader; the border frame and the
        # background are plain clears. The shader alone decides every image pixel; this just
        # spares a software rasteriser (llvmpipe) shading a million pixels of flat colour.
        fbo, g = self._fbo, self.geometry
        fbo.use()
        if self._mode == MODE_TEXT:
            fbo.clear(0.0, 0.0, 0.0, 1.0)
            box = self._gl_box(*self._text_box)
        else:
            border = tuple(c / 255 for c in g.border_rgb)
            left, top, cols, rows = self._rect
            b = g.border_width_px
            if b is None:
                fbo.clear(*border, 1.0)
            else:
                fbo.clear(*(c / 255 for c in g.background_rgb), 1.0)
                fbo.clear(
                    *border,
                    1.0,
                    viewport=self._gl_box(left - b, top - b, cols + 2 * b, rows + 2 * b),
                )
            box = self._gl_box(left, top, cols, rows)
        self._prog["u_mode"].value = self._mode
        if self._stim_tex is not None:
            self._stim_tex.use(0)
        if self._text_tex is not None:
            self._text_tex.use(1)
        self.ctx.scissor = box
        try:
            self._vao.render(moderngl.TRIANGLES, vertices=3)
        finally:
            self.ctx.scissor = None

    def _flip(self) -> float:
        if self._closed:
            raise PresenterError("the presenter is closed")
        if self.window is not None:
            if self.window.is_closing:
                raise PresenterError("the subject's window was closed")
            self.window.swap_buffers()
        self.ctx.finish()
        return self.clock.now_s()

    def pump(self) -> float:
        """Redraw the current screen and flip once (once per refresh); return the flip time, s."""
        self._draw()
        t = self._flip()
        if self._timing is not None:
            self._timing.intervals_ms.append((t - self._timing.last_flip_s) * 1e3)
            self._timing.last_flip_s = t
        return t

    def _upload_stimulus(self, img: np.ndarray) -> None:
        if self._stim_tex is not None:
            self._stim_tex.release()
        rows, cols = img.shape[:2]
        colour = img.ndim == 3
        # Colour photos are training material shown as photos, never as phosphenes.
        phos = None if colour else self.phosphenes
        if phos is not None:
            img = img * phos.alive_mask(img.shape)
        tex = self.ctx.texture(
            (cols, rows),
            3 if colour else 1,
            np.ascontiguousarray(img, np.float32).tobytes(),
            dtype="f4",
        )
        self._set("u_colour", 1 if colour else 0)
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._stim_tex = tex
        top, left, r, c = stimulus_rect_px(
            self.geometry, (rows, cols), integer_scale=self.integer_scale, phosphenes=phos
        )
        self._set("u_rect", (left, top, c, r))
        self._rect = (left, top, c, r)
        self._set("u_grid", (cols, rows))
        self._set("u_phos", 0 if phos is None else (1 if phos.kind == "gaussian" else 2))
        if phos is not None:
            self._set("u_phos_size", float(phos.size))

    def show_stimulus(self, image: np.ndarray) -> FlipRecord:
        """Draw ``image`` and flip; return the onset flip.

        ``image`` is bool or float32 in [0, 1], (rows, cols), or a float32 colour photo
        (rows, cols, 3).
        """
        img = as_stimulus(image)
        self._upload_stimulus(img)
        self._mode = MODE_STIMULUS
        self._draw()
        t = self._flip()
        self._timing = StimulusTiming(onset_s=t, last_flip_s=t)
        return FlipRecord(onset_s=t, refresh_hz=self.refresh_hz)

    def clear(self) -> FlipRecord:
        """Replace the stimulus by the blank/fixation screen and flip.

        Returns the offset flip: ``onset_s`` is the offset time; ``frame_intervals_ms`` and
        ``dropped_frames`` cover the stimulus from its onset to this flip (empty if none was up).
        """
        self._mode = MODE_BLANK
        self._draw()
        t = self._flip()
        timing, self._timing = self._timing, None
        if timing is None:
            return FlipRecord(onset_s=t, refresh_hz=self.refresh_hz)
        intervals = (*timing.intervals_ms, (t - timing.last_flip_s) * 1e3)
        return FlipRecord(
            onset_s=t,
            frame_intervals_ms=tuple(intervals),
            dropped_frames=count_dropped(intervals, self.refresh_hz),
            refresh_hz=self.refresh_hz,
        )

    def show_blank(self) -> float:
        """Show the blank/fixation screen; return the flip time, s."""
        self._timing = None
        self._mode = MODE_BLANK
        self._draw()
        return self._flip()

    def show_text(self, text: str) -> None:
        """Show an instruction, pause or end screen (white text on black, centred)."""
        rows, cols = self.geometry.screen_shape_px
        size = max(12, int(round(0.6 * self.geometry.px_per_deg)))
        im = text_image(text, (rows, cols), size)
        w, h = im.size
        if self._text_tex is not None:
            self._text_tex.release()
        self._text_tex = self.ctx.texture((w, h), 1, im.tobytes())
        self._text_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._text_box = ((cols - w) // 2, (rows - h) // 2, w, h)
        self._set("u_text_rect", self._text_box)
        self._timing = None
        self._mode = MODE_TEXT
        self._draw()
        self._flip()

    def read_pixels(self) -> np.ndarray:
        """Return the last drawn frame as (rows, cols, 3) uint8, row 0 at the top of the screen."""
        rows, cols = self.geometry.screen_shape_px
        if self.window is not None:
            self._draw()  # the back buffer after a swap is undefined; redraw the current screen
        data = self._fbo.read(components=3, alignment=1)
        return np.frombuffer(data, np.uint8).reshape(rows, cols, 3)[::-1].copy()

    def screenshot(self, path: str | Path) -> Path:
        """Write the current frame to a PNG at the screen's full resolution; return the path."""
        from PIL import Image

        from stimuli.io import atomic_path  # a link at the path is refused; no partial file

        path = Path(path)
        pixels = self.read_pixels()
        with atomic_path(path) as tmp:
            Image.fromarray(pixels, "RGB").save(tmp, format="PNG")
        return path

    def measure_refresh(self, n_frames: int = 60, *, check: bool = True) -> float | None:
        """Flip ``n_frames`` blank frames and return the measured refresh rate, Hz.

        Offscreen there is no refresh and None is returned. With ``check``, raise
        :class:`TimingCheckFailed` when the flips are not vsync-locked (faster than 300 Hz) or
        irregular (more than 10 % of intervals off the median by over 20 %).
        """
        if self.window is None:
            self.refresh_hz = None
            return None
        self._mode = MODE_BLANK
        times = []
        for _ in range(n_frames + 1):
            self._draw()
            times.append(self._flip())
        hz, irregular = refresh_stats(times)
        self.refresh_hz = hz
        logger.info("measured refresh %.2f Hz, %.0f%% irregular intervals", hz, 100 * irregular)
        if check:
            check_timing(hz, irregular)
        return hz

    def close(self) -> None:
        """Release the GL objects and close the window (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for obj in (self._stim_tex, self._text_tex, self._vao, self._prog):
            if obj is not None:
                obj.release()
        if self.window is not None:
            self.window.close()
            self.window.destroy()
        if self._fbo is not self.ctx.screen:
            self._fbo.release()
        if self.window is None or self.ctx.screen is None:
            self.ctx.release()
