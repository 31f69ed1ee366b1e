"""The viewer's frames in a GL context: the shaders' path, and a CPU frame's upload.

:class:`GlFrames` holds what :class:`~experiment.viewer.app.Viewer` keeps on the GPU between
frames: the views' video frame, the key of the edges and electrodes computed last, the automatic
thresholds already found, the persistent composite frame and the texture a CPU frame is
uploaded through. Only the viewer imports it, and only with a GL context.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from experiment.viewer.memo import LruCache
from experiment.viewer.reference import EDGE_RATIO, effective_grey_levels, otsu_threshold

__all__ = ["GlFrames"]


class GlFrames:
    """The GL side of one viewer.

    Parameters
    ----------
    ctx : moderngl.Context
    gpu : experiment.viewer.gpu.GpuPipeline or None
        The shaders (None: the numpy pipeline's frames are only uploaded).
    """

    def __init__(self, ctx: Any, gpu: Any = None) -> None:
        self.ctx = ctx
        self.gpu = gpu
        #: automatic thresholds by (frame, depth, zoom), found without a readback when seen
        self.auto_t = LruCache(4096)
        self.last_threshold = 0.0
        self._frame = 0  # the video frame whose views are on the GPU
        self._memo: tuple[tuple, float] | None = None  # (what the GPU holds, its threshold)
        self._composite: Any = None
        self._pane0_key: tuple | None = None
        self._blit: tuple[Any, Any] | None = None

    def draw(self, viewer: Any, fbo: Any, source: Any, status: Any, overlay: Any) -> None:
        """Draw the viewer's state with the shaders into ``fbo``.

        ``source``: the obstacle mode's (masked view, mask), or None for the confocal image.
        """
        g, s, lay = self.gpu, viewer.state, viewer.layout
        if self._frame != s.frame:
            g.set_views(viewer.lf.views)
            self._frame = s.frame
        if source is None:
            g.refocus(s.disparity_px)
        else:
            g.set_source(*source)
        grey_levels = effective_grey_levels(s, lay)
        depth_key = s.disparity_px if source is None else ("obstacle", s.obstacle_px)
        key = (s.frame, depth_key, s.zoom, s.threshold, lay.name, grey_levels, s.averaging)
        if self._memo is None or key != self._memo[0]:  # else the GPU's are current
            g.sobel(s.zoom)
            if s.threshold is None:
                tkey = (s.frame, depth_key, s.zoom)
                if tkey not in self.auto_t:
                    self.auto_t.put(tkey, otsu_threshold(g.read_magnitude()))
                t = self.auto_t.get(tkey)
            else:
                t = float(s.threshold)
            g.compress(lay.shape, t, grey_levels, EDGE_RATIO)
            if s.averaging or viewer.averaged_frames():
                g.write_cells(viewer.average_cells(g.read_cells()))
            self._memo = (key, t)
        t = self._memo[1]
        zoom_shape = (s.zoom[3], s.zoom[2]) if s.zoom is not None else viewer.lf.shape_px
        # Draw into a persistent frame and copy it out: the centre-view pane, which only
        # changes with the zoom box or the video frame, is not redrawn on a depth step.
        rows, cols = viewer.screen_shape_px
        if self._composite is None or self._composite.size != (cols, rows):
            if self._composite is not None:
                self._composite.release()
            self._composite = self.ctx.simple_framebuffer((cols, rows))
            self._pane0_key = None
        pane0_key = (s.zoom, s.frame, s.marker, viewer.screen_shape_px, overlay is None)
        full = pane0_key != self._pane0_key or overlay is not None
        screen = viewer.screen(zoom_shape)
        implant_image = None
        if s.percept != "phosphenes":
            rect = screen.images[3]
            implant_image = viewer.implant_image(g.read_cells(), (rect[3], rect[2]))
        g.draw(
            self._composite,
            screen,
            lay,
            threshold=t,
            zoom=s.zoom,
            alert=viewer.alert,
            status=status,
            panes=(True, True, True, True) if full else (False, True, True, True),
            marker=s.marker,
            overlay=overlay,
            implant_image=implant_image,
        )
        self._pane0_key = pane0_key
        self.ctx.copy_framebuffer(fbo, self._composite)
        self.last_threshold = t

    def prefetch(self, viewer: Any, ahead: list[float]) -> bool:
        """Refocus (or threshold) one of the depths ``ahead``; False when all are ready."""
        s = viewer.state
        if self._frame != s.frame:
            return False
        for x in ahead:
            if self.gpu.prefetch(x):
                return True
            tkey = (s.frame, x, s.zoom)
            if s.threshold is None and tkey not in self.auto_t:
                mag = self.gpu.magnitude_at(x, s.zoom)
                if mag is not None:
                    self.auto_t.put(tkey, otsu_threshold(mag))
                    return True
        return False

    def upload(
        self, frame: np.ndarray, fbo: Any, dirty: list[tuple[int, int, int, int]] | None = None
    ) -> None:
        """Copy a CPU frame (rows, cols, 3 or 4 uint8, top row first) into ``fbo``.

        ``dirty``: the rectangles ``(left, top, cols, rows)`` that changed since the last call
        (only those are uploaded); None uploads the whole frame.
        """
        rows, cols, n = frame.shape
        old = self._blit[0] if self._blit is not None else None
        if old is None or old.size != (cols, rows) or old.components != n:
            if self._blit is not None:
                for obj in self._blit[::-1]:
                    obj.release()
            tex = self.ctx.texture((cols, rows), n)
            self._blit = (tex, self.ctx.framebuffer(color_attachments=[tex]))
            dirty = None
        tex, src = self._blit
        for left, top, w, h in dirty if dirty is not None else [(0, 0, cols, rows)]:
            part = np.ascontiguousarray(frame[top : top + h, left : left + w][::-1])
            tex.write(part, viewport=(left, rows - (top + h), w, h))  # GL rows run bottom-up
        self.ctx.copy_framebuffer(fbo, src)

    def release(self) -> None:
        """Release the GL objects (the shaders too)."""
        if self._blit is not None:
            for obj in self._blit[::-1]:
                obj.release()
        if self.gpu is not None:
            self.gpu.release()
        if self._composite is not None:
            self._composite.release()
