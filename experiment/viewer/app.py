"""The viewer application: a state, a renderer (GPU or CPU), an event log, a window or none.

:class:`Viewer` owns the light field (or video), the :class:`~experiment.viewer.state.ViewerState`
and the event log. :meth:`Viewer.handle` takes one input event, logs it, applies it with the pure
:func:`~experiment.viewer.state.apply_event`, updates what depends on the data (video frame,
tracked marker, focus in confocal-extension mode) and logs the resulting state.
:meth:`Viewer.render` draws the current state into a frame: on the GPU
(:class:`~experiment.viewer.gpu.GpuPipeline`) or, without GL, with the CPU reference
(:func:`~experiment.viewer.screen.expected_screen`). The window
(:func:`~experiment.viewer.window.run_window`) only turns moderngl-window callbacks into
:meth:`Viewer.handle` calls.
"""

from __future__ import annotations

import logging
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from experiment.errors import ConfocalError
from experiment.viewer.events import ViewerEventLog
from experiment.viewer.glview import GlFrames
from experiment.viewer.memo import FrameAverage, LruCache
from experiment.viewer.options import COMPUTE_CHOICES, check_options, start_state
from experiment.viewer.reference import (
    OBSTACLE_ALERT_FRACTION,
    CpuRenderer,
    DepthMap,
    Panes,
    brightest_point,
    depth_map,
    effective_grey_levels,
    obstacle_mask,
    track_point,
)
from experiment.viewer.screen import (
    STATUS_ROWS_PX,
    FramePainter,
    ScreenLayout,
    draw_implant,
    help_image,
    help_rect,
    screen_layout,
    status_image,
    status_line,
)
from experiment.viewer.source import LightFieldSource
from experiment.viewer.state import KEY_HELP, ViewerModel, ViewerState, apply_event
from stimuli.implants import ImplantLayout, load_implant

__all__ = [
    "AVERAGING_FRAMES",
    "COMPUTE_CHOICES",
    "STEPS_PER_RANGE",
    "PREFETCH_STEPS",
    "REFOCUS_CACHE",
    "PERCEPTS",
    "Viewer",
    "is_software_renderer",
]

log = logging.getLogger(__name__)

#: Frames averaged by the implant view's temporal averaging (ours; the paper names the idea,
#: Sec. 5, without a number).
AVERAGING_FRAMES: int = 4

#: One arrow/wheel step is this fraction of the scanned disparity range (ours: 100 steps).
STEPS_PER_RANGE: int = 100

#: Arrow steps either side of the current depth refocused ahead while the window is idle (ours).
PREFETCH_STEPS: int = 8

#: Confocal images the numpy pipeline keeps, by (frame, disparity) (ours: 48 Lytro-size images,
#: 40 MB; scanning back over depths already seen, or to a prefetched one, costs no refocus).
REFOCUS_CACHE: int = 48

#: What the implant pane can show (the ``m`` key cycles): the layout's own phosphenes, or
#: pulse2percept's scoreboard or axon-map percept of the same electrodes (the ``p2p`` extra,
#: retinal layouts only).
PERCEPTS: tuple[str, ...] = ("phosphenes", "scoreboard", "axonmap")

#: Candidate disparities of the per-pixel depth map, spread over the viewer's depth range
#: (ours: about two per detected-plane width on the shipped light fields).
DEPTH_CANDIDATES: int = 48


_SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software rasterizer")


def is_software_renderer(ctx: Any) -> bool:
    """Return whether ``ctx`` renders on the CPU (Mesa llvmpipe, softpipe or swrast)."""
    name = str(ctx.info.get("GL_RENDERER", "")).lower()
    return any(k in name for k in _SOFTWARE_RENDERERS)


class Viewer:
    """The live viewer: data, state, event log and renderer.

    Parameters
    ----------
    source : LightFieldSource
    implants : sequence of str
        Implant names or ``.toml`` paths the ``i`` key cycles through (first = initial).
    screen_shape_px : (rows, cols)
        Frame size.
    ctx : moderngl.Context or None
        Render on the GPU with this context; None renders with the CPU reference.
    event_log : ViewerEventLog, optional
        Where every input event and displayed state goes (default: in memory).
    px_per_deg : float, optional
        Draw the implant's field of view at this scale (see :func:`screen_layout`).
    n_planes : int
        Planes of the startup depth scan. At the default the scan is
        :func:`stimuli.planechoice.detect_planes`, the detector ``confocal stimuli build`` and
        ``confocal lightfield scan`` use, so the viewer lists the same planes.
    track_bright : bool
        Follow the brightest spot of the centre view as the marker (confocal extension).
    clock : callable, optional
        Monotonic time in seconds (default ``time.perf_counter``).
    compute : {'auto', 'gpu', 'cpu'}
        Where refocus, Sobel, threshold and compression run when ``ctx`` is given. ``gpu``: the
        shaders; ``cpu``: the numpy pipeline, its frame drawn into ``ctx``'s framebuffer;
        ``auto``: ``cpu`` on a software rasteriser (llvmpipe, softpipe, swrast), where the numpy
        pipeline is the faster (``benchmarks/bench_viewer.py``), else ``gpu``. Both give the
        same images (``tests/experiment/test_viewer_gpu.py``).
    """

    def __init__(
        self,
        source: LightFieldSource,
        implants: list[str],
        *,
        screen_shape_px: tuple[int, int] = (720, 1080),
        ctx: Any = None,
        event_log: ViewerEventLog | None = None,
        px_per_deg: float | None = None,
        n_planes: int = 200,
        track_bright: bool = False,
        clock: Any = None,
        compute: str = "auto",
    ) -> None:
        from stimuli.declutter import auto_threshold
        from stimuli.planechoice import detect_planes
        from stimuli.planes import DEFAULT_N_PLANES, find_object_planes
        from stimuli.refocus import refocus

        self.source = source
        self.clock = clock or time.perf_counter
        self.log = event_log if event_log is not None else ViewerEventLog(":memory:")
        self.layouts: dict[str, ImplantLayout] = {}
        names = []
        for spec in implants:
            lay = load_implant(spec)
            self.layouts[lay.name] = lay
            names.append(lay.name)
        self.screen_shape_px = screen_shape_px
        self.px_per_deg = px_per_deg
        self.track_bright = track_bright
        lf = source.frame(0)
        self.lf = lf
        dmax = lf.max_disparity_px()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            if n_planes == DEFAULT_N_PLANES:
                scan = detect_planes(lf)
            else:
                scan = find_object_planes(lf, n_planes=n_planes)
        ds = np.clip(scan.disparities_px, -dmax, dmax)
        self.scan = scan
        lo, hi = max(float(ds.min()), -dmax), min(float(ds.max()), dmax)
        self.model = ViewerModel(
            shape_px=lf.shape_px,
            disparity_range_px=(lo, hi),
            step_px=(hi - lo) / STEPS_PER_RANGE,
            planes_px=tuple(p.disparity_px for p in scan.peaks if lo <= p.disparity_px <= hi),
            implants=tuple(names),
            implant_grey_levels=tuple(self.layouts[n].levels for n in names),
            auto_threshold=0.0,
            n_frames=source.n_frames,
            depth_at=self._depth_at,
        )
        first = self.model.initial_state(names[0])
        t0 = auto_threshold(refocus(lf, first.disparity_px))
        self.model = replace(self.model, auto_threshold=t0)
        self.state = first
        #: the one CPU renderer (numpy pipeline), its confocal images cached by depth
        self.renderer = CpuRenderer(lf, self.layouts[names[0]], cache=REFOCUS_CACHE)
        self._depth: dict[int, DepthMap] = {}
        self._average = FrameAverage(AVERAGING_FRAMES)
        #: the obstacle alert is on (more than OBSTACLE_ALERT_FRACTION of the view in range)
        self.alert = False
        self.frame_ms = 0.0
        #: one line shown before the status (why a key did nothing, a question); cleared by
        #: the next input event
        self.message = ""
        self._painter = FramePainter()
        self._panes: tuple[tuple, Panes] | None = None  # (state key, CPU panes)
        self._implant_img = LruCache(64)
        self._help_img: np.ndarray | None = None
        self.gpu = None
        if compute not in COMPUTE_CHOICES:
            raise ConfocalError(f"compute must be one of {COMPUTE_CHOICES}, got {compute!r}")
        self.ctx = ctx
        if ctx is not None:
            if compute == "auto":
                compute = "cpu" if is_software_renderer(ctx) else "gpu"
            if compute == "gpu":
                from experiment.viewer.gpu import GpuPipeline

                self.gpu = GpuPipeline(ctx, lf.views)
        self.compute = "cpu" if self.gpu is None else "gpu"
        self._gl = None if ctx is None else GlFrames(ctx, self.gpu)
        if track_bright:
            self.state = replace(self.state, marker=brightest_point(lf.centre_view()))
        self.log.append(
            self.clock(),
            "open",
            {
                "source": lf.source,
                "shape": list(lf.views.shape),
                "view_crop": list(source.view_crop) if source.view_crop is not None else None,
                "planes_px": list(self.model.planes_px),
            },
        )
        self.log.append(self.clock(), "state", self.state.to_dict())

    @classmethod
    def from_options(
        cls,
        source: LightFieldSource,
        implants: list[str] | None = None,
        *,
        grey_levels: int = 2,
        threshold: float | None = None,
        disparity_px: float | None = None,
        plane: int | None = None,
        zoom: tuple[int, int, int, int] | None = None,
        obstacle_px: tuple[float, float] | None = None,
        marker: tuple[int, int] | None = None,
        extension_px: float = 0.0,
        averaging: bool = False,
        compute: str = "auto",
        **kwargs: Any,
    ) -> Viewer:
        """Check the options, build the viewer and set (and log) its first state.

        The checks of ``confocal view``, for Python callers: a refusal is an
        :class:`~experiment.viewer.options.ViewerOptionError` naming the parameter.

        Parameters
        ----------
        source : LightFieldSource
        implants : list of str, optional
            Implant names or ``.toml`` paths (default: every shipped implant, argus2 first).
        grey_levels : {2, 4, 8}
            2: binary edges; more: the grey compression (as many as the implant shows).
        threshold : float >= 0, optional
            Sobel threshold (None: automatic).
        disparity_px, plane, zoom, obstacle_px, marker, extension_px, averaging
            The first state, as :func:`~experiment.viewer.options.start_state` takes them.
        compute : {'auto', 'gpu', 'cpu'}
        **kwargs
            The other parameters of :class:`Viewer` (``ctx``, ``event_log``, ...).

        Returns
        -------
        Viewer

        Raises
        ------
        experiment.viewer.options.ViewerOptionError
        """
        names = check_options(
            implants,
            grey_levels=grey_levels,
            threshold=threshold,
            compute=compute,
            extension_px=extension_px,
        )
        v = cls(source, names, compute=compute, **kwargs)
        try:
            v.state = start_state(
                v,
                disparity_px=disparity_px,
                plane=plane,
                zoom=zoom,
                grey_levels=grey_levels,
                threshold=threshold,
                obstacle_px=obstacle_px,
                marker=marker,
                extension_px=extension_px,
                averaging=averaging,
            )
        except BaseException:
            v.close()
            raise
        v.log.append(v.clock(), "state", v.state.to_dict())
        return v

    # -- data-dependent helpers ----------------------------------------------------------------

    def depth(self) -> DepthMap:
        """Per-pixel depth of the current frame (computed once per frame, on the CPU)."""
        k = self.state.frame
        if k not in self._depth:
            lf = self.source.frame(k)
            lo, hi = self.model.disparity_range_px
            cands = np.linspace(lo, hi, DEPTH_CANDIDATES)
            # binning 2 (a quarter of the work) unless the views are small (ours)
            self._depth = {k: depth_map(lf, cands, binning=2 if min(lf.shape_px) >= 64 else 1)}
        return self._depth[k]

    def _depth_at(self, x: int, y: int) -> float:
        return self.depth().at(x, y)

    @property
    def layout(self) -> ImplantLayout:
        """The current implant layout."""
        return self.layouts[self.state.implant]

    # -- events --------------------------------------------------------------------------------

    def handle(self, kind: str, payload: dict[str, Any], t: float | None = None) -> ViewerState:
        """Log one input event, apply it, and log the state shown next; return that state."""
        t = self.clock() if t is None else t
        self.log.append(t, kind, payload)
        before = self.state
        s = apply_event(self.model, before, kind, payload)
        if s.frame != before.frame:
            s = self._follow(before, s)
        self.state = s
        if kind in ("key", "wheel", "drag", "click"):
            self.message = ""
        if kind == "key" and payload.get("key") == "g" and self.model.is_binary(s.implant):
            self.say(
                f"g: {self.layout.label} has on/off phosphenes only (levels = 2 in its layout); "
                "i switches to an implant with grey levels"
            )
        if kind == "key" and payload.get("key") == "m":
            s = self.state = self._next_percept(s)
        self.log.append(t, "state", s.to_dict())
        return s

    def say(self, text: str) -> None:
        """Show one line before the status until the next input event (and log it)."""
        self.message = text
        self.log.append(self.clock(), "message", {"text": text})

    def _next_percept(self, s: ViewerState) -> ViewerState:
        from experiment.viewer.p2p import p2p_unavailable

        k = (PERCEPTS.index(s.percept) + 1) % len(PERCEPTS) if s.percept in PERCEPTS else 0
        want = PERCEPTS[k]
        if want != "phosphenes":
            why = p2p_unavailable(self.layout)
            if why:
                self.say(f"m: no {want} percept: {why}")
                return replace(s, percept="phosphenes")
        return replace(s, percept=want)

    def _follow(self, before: ViewerState, s: ViewerState) -> ViewerState:
        prev = self.source.frame(before.frame).centre_view()
        lf = self.source.frame(s.frame)
        cur = lf.centre_view()
        if self.track_bright:
            s = replace(s, marker=brightest_point(cur))
        elif s.marker is not None:
            s = replace(s, marker=track_point(prev, cur, s.marker))
        self.lf = lf
        self.renderer.set_frame(s.frame, lf)
        if s.mode == "extension" and s.marker is not None:
            d = self.model.clamp(self.depth().at(*s.marker) + s.extension_px)
            s = replace(s, disparity_px=d, plane=self.model.plane_of(d))
        return s

    # -- rendering -----------------------------------------------------------------------------

    def _source_image(self) -> tuple[np.ndarray, np.ndarray] | None:
        # obstacle mode: (the masked centre view, the mask as float32); else None
        s = self.state
        if s.mode == "obstacle" and s.obstacle_px is not None:
            mask = obstacle_mask(self.depth(), *s.obstacle_px)
            alert = bool(mask.mean() > OBSTACLE_ALERT_FRACTION)
            if alert and not self.alert:
                sys.stderr.write("\a")  # audible alert: the terminal bell (no sound library)
                sys.stderr.flush()
                self.log.append(self.clock(), "alert", {"fraction": float(mask.mean())})
            self.alert = alert
            masked = np.where(mask, self.lf.centre_view(), np.float32(0)).astype(np.float32)
            return masked, mask.astype(np.float32)
        self.alert = False
        return None

    def status_text(self) -> str:
        """Return the status line for the current state (:func:`~.screen.status_line`)."""
        return status_line(self, AVERAGING_FRAMES)

    def screen(self, zoom_shape: tuple[int, int]) -> ScreenLayout:
        """Return the screen layout for the current implant and zoom."""
        return screen_layout(
            self.screen_shape_px,
            self.lf.shape_px,
            zoom_shape,
            self.layout,
            px_per_deg=self.px_per_deg,
        )

    def averaged_frames(self) -> int:
        """Return how many video frames the implant view's average holds now."""
        return len(self._average)

    def average_cells(self, cells: np.ndarray) -> np.ndarray:
        """Add electrode values to the average over the last :data:`AVERAGING_FRAMES` frames.

        Redrawing the same video frame (a depth step, a key) replaces its entry instead of
        adding one; with averaging off the average is the values themselves.
        """
        s = self.state
        key = (s.implant, s.grey_levels, s.zoom)
        return self._average.add(key, s.frame, cells, on=s.averaging)

    def confocal(self, disparity_px: float) -> np.ndarray:
        """Return the confocal image of the current frame at a disparity (numpy; cached)."""
        return self.renderer.confocal(disparity_px)

    def implant_image(self, cells: np.ndarray, shape_px: tuple[int, int]) -> np.ndarray:
        """Return the implant pane's picture of electrode values (uint8), remembered by value.

        A depth scan on a 60-electrode implant keeps meeting the same few patterns.
        """
        s, lay = self.state, self.layout
        key = (cells.tobytes(), cells.shape, shape_px, lay, s.percept)
        img = self._implant_img.get(key)
        if img is not None:
            return img
        if s.percept == "phosphenes":
            img = draw_implant(cells, shape_px, lay)
        else:
            from experiment.viewer.p2p import p2p_percept
            from experiment.viewer.screen import nearest_cells

            p = p2p_percept(cells * lay.electrode_gain(), lay, model=s.percept)
            rows = nearest_cells(shape_px[0], p.shape[0])
            img = p[np.ix_(rows, nearest_cells(shape_px[1], p.shape[1]))]
        self._implant_img.put(key, img)
        return img

    def help_overlay(self) -> np.ndarray | None:
        """Return the key help image (uint8) when the state asks for it, else None."""
        if not self.state.help:
            return None
        lines = [f"{k:<18s}{v}" for k, v in KEY_HELP] + ["", "? or h: close this help"]
        _, _, w, h = help_rect(self.screen_shape_px, len(lines))
        if self._help_img is None or self._help_img.shape != (h, w):
            self._help_img = help_image(lines, (h, w))
        return self._help_img

    def render(self, fbo: Any = None) -> np.ndarray | None:
        """Draw the current state: into ``fbo`` on the GPU, or return the CPU frame (uint8)."""
        t0 = time.perf_counter()
        s, lay = self.state, self.layout
        src = self._source_image()
        status = status_image(self.status_text(), (STATUS_ROWS_PX, self.screen_shape_px[1]))
        overlay = self.help_overlay()
        if self.gpu is None:
            depth_key = s.disparity_px if src is None else ("obstacle", s.obstacle_px)
            levels = effective_grey_levels(s, lay)
            key = (s.frame, depth_key, s.zoom, s.threshold, lay.name, levels)
            if self._panes is None or key != self._panes[0]:
                depth = self.depth() if s.mode == "obstacle" else None
                self._panes = (key, self.renderer.render(s, layout=lay, depth=depth))
            p = self._panes[1]
            cells = self.average_cells(p.cells)
            screen = self.screen(p.source.shape)
            rect = screen.images[3]
            keys = (
                (s.frame, s.zoom, s.marker),
                (s.frame, depth_key, s.zoom),
                (s.frame, depth_key, s.zoom, p.threshold),
                (cells.tobytes(), lay.name, s.percept, p.alert),
            )
            frame = self._painter.paint(
                screen,
                p.centre,
                p.source,
                p.edges,
                cells,
                lay,
                zoom=s.zoom,
                alert=p.alert,
                status=status,
                marker=s.marker,
                overlay=overlay,
                keys=keys,
                phosphenes=self.implant_image(cells, (rect[3], rect[2])),
            )
            if fbo is not None and self.ctx is not None:
                self._gl.upload(frame, fbo, self._painter.dirty)
                self.frame_ms = (time.perf_counter() - t0) * 1e3
                return frame[..., :3]  # the painter's own frame: valid until the next render
            self.frame_ms = (time.perf_counter() - t0) * 1e3
            return frame[..., :3].copy()
        self._gl.draw(self, fbo, src, status, overlay)
        self.frame_ms = (time.perf_counter() - t0) * 1e3
        return None

    def prefetch(self) -> bool:
        """Refocus one depth the user may go to next into the GPU cache; False if none left.

        Candidates, in order: the detected planes, then up to :data:`PREFETCH_STEPS` arrow
        steps nearer and farther (computed exactly as the state machine steps, so they hit).
        Each call does one piece of work: a refocus, or the automatic threshold of a cached
        image. Without the shaders (the numpy pipeline) the nearest steps come first and go
        into :meth:`confocal`'s cache.
        """
        if self.state.mode == "obstacle":
            return False
        if self.gpu is None:
            m, d = self.model, self.state.disparity_px
            up = down = d
            near: list[float] = []
            for _ in range(PREFETCH_STEPS):
                up, down = m.clamp(up + m.step_px), m.clamp(down - m.step_px)
                near += [up, down]
            for x in [*near, *m.planes_px]:
                if not self.renderer.has(x):
                    self.confocal(x)
                    return True
            return False
        m, d = self.model, self.state.disparity_px
        up = down = d
        ahead: list[float] = list(m.planes_px)
        for _ in range(PREFETCH_STEPS):
            up, down = m.clamp(up + m.step_px), m.clamp(down - m.step_px)
            ahead += [up, down]
        return self._gl.prefetch(self, ahead)

    def screenshot(self, path: Path | None = None) -> np.ndarray:
        """Render the current state offscreen and return (and optionally save) the RGB frame."""
        rows, cols = self.screen_shape_px
        if self.gpu is None:
            frame = self.render()
        else:
            fbo = self.ctx.simple_framebuffer((cols, rows))
            try:
                self.render(fbo)
                self.ctx.finish()
                raw = fbo.read(components=3)
            finally:
                fbo.release()
            frame = np.frombuffer(raw, np.uint8).reshape(rows, cols, 3)[::-1].copy()
        if path is not None:
            from PIL import Image

            from stimuli.io import atomic_path

            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(path) as tmp:
                Image.fromarray(frame).save(tmp, format="PNG")
        return frame

    def view_pixel(self, x_px: float, y_px: float) -> tuple[int, int] | None:
        """Map a screen pixel to a centre-view pixel, or None outside the centre-view image."""
        left, top, w, h = self.screen(self.lf.shape_px).images[0]
        rows, cols = self.lf.shape_px
        px, py = int(x_px) - left, int(y_px) - top
        if not (0 <= px < w and 0 <= py < h):
            return None
        return int(((2 * px + 1) * cols) // (2 * w)), int(((2 * py + 1) * rows) // (2 * h))

    def close(self) -> None:
        """Release the GPU objects and close the event log."""
        if self._gl is not None:
            self._gl.release()
        self.log.append(self.clock(), "close", {})
        self.log.close()
