"""Screen layout of the viewer and its numpy reference drawing (no GL).

The window is four panes in a 2x2 grid above a one-line status bar:

=========================  ====================================================
top left: centre view      the cluttered image; the zoom box outlined in yellow
top right: confocal image  at the current depth (or the obstacle-masked view), zoomed
bottom left: edges         de-cluttered (Sobel above the threshold), zoomed
bottom right: implant      the compressed image drawn as phosphenes at the implant's
                           field of view; a red frame while the obstacle alert is on
=========================  ====================================================

The marked point (confocal extension) is a cyan cross on the centre view; the key help, when
on, is a box of text over the middle of the frame.

Every image is drawn with nearest-neighbour cells chosen in integers (``cell = ((2 p + 1) n) //
(2 extent)``, as :func:`experiment.presentation.presenter.cell_index`), so a GPU screenshot can be
compared with :func:`expected_screen` pixel for pixel. Text (the status line) is drawn by Pillow
into an 8-bit image that both the GPU and this reference use as is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from stimuli.implants import ImplantLayout, render_phosphenes

__all__ = [
    "status_line",
    "STATUS_ROWS_PX",
    "BACKGROUND_RGB",
    "BOX_RGB",
    "ALERT_RGB",
    "ALERT_BORDER_PX",
    "MARKER_RGB",
    "HELP_LINE_PX",
    "ScreenLayout",
    "FramePainter",
    "draw_implant",
    "help_image",
    "help_rect",
    "marker_arm_px",
    "screen_layout",
    "status_image",
    "expected_screen",
    "nearest_cells",
]

#: Height of the status bar, px (ours: one line of Pillow's default font with a margin).
STATUS_ROWS_PX: int = 20
#: Pane background, device RGB (ours: dark grey, so black image areas stay visible).
BACKGROUND_RGB: tuple[int, int, int] = (40, 40, 40)
#: Zoom box outline colour (ours).
BOX_RGB: tuple[int, int, int] = (255, 255, 0)
#: Obstacle alert frame colour (ours).
ALERT_RGB: tuple[int, int, int] = (255, 0, 0)
#: Obstacle alert frame width, px (ours).
ALERT_BORDER_PX: int = 4
#: Marked point's cross colour (confocal extension), device RGB (ours: cyan, unlike the box).
MARKER_RGB: tuple[int, int, int] = (0, 255, 255)
#: Line height of the key help, px (ours: Pillow's default font with a gap).
HELP_LINE_PX: int = 15
_MARGIN_PX = 6


@dataclass(frozen=True)
class ScreenLayout:
    """Where each pane's image is drawn: ``(left, top, cols, rows)`` in screen pixels.

    Attributes
    ----------
    screen_shape_px : (rows, cols)
    panes : tuple of four (left, top, cols, rows)
        The pane areas (centre, confocal, edges, implant).
    images : tuple of four (left, top, cols, rows)
        The image rectangles inside the panes.
    status : (left, top, cols, rows)
    """

    screen_shape_px: tuple[int, int]
    panes: tuple[tuple[int, int, int, int], ...]
    images: tuple[tuple[int, int, int, int], ...]
    status: tuple[int, int, int, int]


def _fit(pane: tuple[int, int, int, int], shape_px: tuple[int, int]) -> tuple[int, int, int, int]:
    left, top, cols, rows = pane
    avail_c, avail_r = cols - 2 * _MARGIN_PX, rows - 2 * _MARGIN_PX
    r, c = shape_px
    s = min(avail_c / c, avail_r / r)
    w, h = max(1, int(c * s)), max(1, int(r * s))
    return (left + (cols - w) // 2, top + (rows - h) // 2, w, h)


def screen_layout(
    screen_shape_px: tuple[int, int],
    view_shape_px: tuple[int, int],
    zoom_shape_px: tuple[int, int],
    layout: ImplantLayout,
    *,
    px_per_deg: float | None = None,
) -> ScreenLayout:
    """Place the panes and the images in them.

    Parameters
    ----------
    screen_shape_px : (rows, cols)
    view_shape_px : (rows, cols)
        Size of the centre view.
    zoom_shape_px : (rows, cols)
        Size of the (zoomed) confocal and edge images.
    layout : ImplantLayout
        Its field of view sets the implant image's aspect ratio (and size, with ``px_per_deg``).
    px_per_deg : float, optional
        Draw the implant's field of view at this scale (the right visual angle on a calibrated
        screen); by default it fills its pane.
    """
    rows, cols = screen_shape_px
    pr, pc = (rows - STATUS_ROWS_PX) // 2, cols // 2
    if pr < 2 * _MARGIN_PX + 4 or pc < 2 * _MARGIN_PX + 4:
        raise ValueError(f"screen {cols}x{rows} px is too small for the viewer")
    panes = tuple((k % 2 * pc, k // 2 * pr, pc, pr) for k in range(4))
    fov = (layout.fov_height_deg, layout.fov_width_deg)
    imp = _fit(panes[3], fov)
    if px_per_deg is not None:
        h, w = int(round(fov[0] * px_per_deg)), int(round(fov[1] * px_per_deg))
        if w > imp[2] or h > imp[3]:
            raise ValueError(
                f"implant field of view {fov[1]:g}x{fov[0]:g} deg at {px_per_deg:g} px/deg "
                f"({w}x{h} px) does not fit its {pc}x{pr} px pane"
            )
        left, top = panes[3][0] + (pc - w) // 2, panes[3][1] + (pr - h) // 2
        imp = (left, top, w, h)
    images = (
        _fit(panes[0], view_shape_px),
        _fit(panes[1], zoom_shape_px),
        _fit(panes[2], zoom_shape_px),
        imp,
    )
    return ScreenLayout(
        screen_shape_px, panes, images, (0, rows - STATUS_ROWS_PX, cols, STATUS_ROWS_PX)
    )


def status_image(text: str, shape_px: tuple[int, int]) -> np.ndarray:
    """Render one line of white text on black with Pillow's default font: uint8 (rows, cols)."""
    from PIL import Image, ImageDraw, ImageFont

    rows, cols = shape_px
    img = Image.new("L", (cols, rows), 0)
    ImageDraw.Draw(img).text((6, 4), text, fill=255, font=ImageFont.load_default())
    return np.asarray(img, dtype=np.uint8)


def nearest_cells(extent_px: int, n_cells: int) -> np.ndarray:
    """Return the source cell under each of ``extent_px`` pixels (integer nearest neighbour)."""
    p = np.arange(extent_px, dtype=np.int64)
    return ((2 * p + 1) * n_cells) // (2 * extent_px)


def help_image(lines: list[str] | tuple[str, ...], shape_px: tuple[int, int]) -> np.ndarray:
    """Render lines of white text on black into a ``shape_px`` uint8 image (the key help)."""
    from PIL import Image, ImageDraw, ImageFont

    rows, cols = shape_px
    img = Image.new("L", (cols, rows), 0)
    draw = ImageDraw.Draw(img)
    font = ImageFont.load_default()
    for k, line in enumerate(lines):
        draw.text((10, 8 + k * HELP_LINE_PX), line, fill=255, font=font)
    return np.asarray(img, dtype=np.uint8)


def help_rect(
    screen_shape_px: tuple[int, int], n_lines: int, cols_px: int = 560
) -> tuple[int, int, int, int]:
    """Where the key help goes: ``(left, top, cols, rows)``, centred above the status line."""
    rows, cols = screen_shape_px
    w = min(cols - 8, cols_px)
    h = min(rows - STATUS_ROWS_PX - 8, 16 + n_lines * HELP_LINE_PX)
    return ((cols - w) // 2, (rows - STATUS_ROWS_PX - h) // 2, max(1, w), max(1, h))


def _u8(img01: np.ndarray) -> np.ndarray:
    a = np.asarray(img01)
    if a.dtype == bool:
        return a.view(np.uint8) * np.uint8(255)
    return np.round(np.clip(a.astype(np.float32, copy=False), 0, 1) * 255).astype(np.uint8)


def _rgba32(rgb: tuple[int, int, int]) -> np.uint32:
    # one opaque pixel of an RGBA uint8 frame, read as a uint32 (in the machine's byte order)
    return np.array([*rgb, 255], np.uint8).view(np.uint32)[0]


#: grey level -> opaque RGBA pixel as uint32
_GREY32 = np.array([[v, v, v, 255] for v in range(256)], np.uint8).view(np.uint32)[:, 0]


def _put(frame32, rect, img01):
    left, top, w, h = rect
    r = nearest_cells(h, img01.shape[0])
    c = nearest_cells(w, img01.shape[1])
    # bytes first on the (smaller) source, then repeat its pixels (the same values as rounding
    # the repeated floats), written as one uint32 per RGBA pixel (a fraction of the work of
    # three strided channels)
    frame32[top : top + h, left : left + w] = _GREY32[_u8(img01)[r][:, c]]
    return r, c


def _cross(r: np.ndarray, c: np.ndarray, marker: tuple[int, int], arm: int) -> np.ndarray:
    mx, my = marker
    on_c, on_r = c == mx, r == my
    near_c, near_r = np.abs(c - mx) <= arm, np.abs(r - my) <= arm
    return (on_c[None, :] & near_r[:, None]) | (on_r[:, None] & near_c[None, :])


def marker_arm_px(view_shape_px: tuple[int, int]) -> int:
    """Half-length of the marker's cross, view pixels (ours: 1/40 of the larger side, >= 3)."""
    return max(3, max(view_shape_px) // 40)


class FramePainter:
    """A persistent frame that redraws only the panes whose content changed (numpy).

    :meth:`paint` draws the same pixels as a fresh :func:`expected_screen` call; given a key
    per pane, a pane whose key equals the previous call's is left as it is. After each call
    :attr:`dirty` lists the rectangles ``(left, top, cols, rows)`` that changed, so a caller
    that copies the frame into a texture uploads only those. The frame is RGBA
    (:attr:`frame`, rows x cols x 4 uint8, alpha 255): GL takes four-byte pixels without a
    conversion.
    """

    def __init__(self) -> None:
        self.frame: np.ndarray | None = None
        self.dirty: list[tuple[int, int, int, int]] = []
        self._keys: tuple | None = None
        self._screen: ScreenLayout | None = None
        self._had_overlay = False
        self._alert = False

    def paint(
        self,
        screen: ScreenLayout,
        centre: np.ndarray,
        source: np.ndarray,
        edges: np.ndarray,
        cells: np.ndarray,
        layout: ImplantLayout,
        *,
        zoom: tuple[int, int, int, int] | None,
        alert: bool,
        status: np.ndarray,
        marker: tuple[int, int] | None = None,
        overlay: np.ndarray | None = None,
        keys: tuple | None = None,
        phosphenes: np.ndarray | None = None,
    ) -> np.ndarray:
        """Draw a state's panes into the frame; return it (RGBA, valid until the next call).

        Parameters
        ----------
        screen : ScreenLayout
        centre : ndarray (rows, cols), float32 in [0, 1]
        source : ndarray (h, w), float32 in [0, 1]
            Confocal (or obstacle-masked) image, zoomed.
        edges : ndarray (h, w), bool
        cells : ndarray (implant rows, cols), float32 in [0, 1]
            Electrode values (dropout, brightness variation and rotation are applied here, from
            ``layout``).
        layout : ImplantLayout
        zoom : (x, y, w, h) or None
            Outlined on the centre view.
        alert : bool
            Draw the red alert frame around the implant image.
        status : ndarray (STATUS_ROWS_PX, cols), uint8
            The status line (:func:`status_image`).
        marker : (x, y) or None
            The marked point (confocal extension), a cross on the centre view in view pixels.
        overlay : ndarray (h, w), uint8, optional
            The key help (:func:`help_image`), drawn over the middle of the frame.
        keys : tuple or None
            One hashable per pane (centre, confocal, edges, implant), or None to redraw all.
        phosphenes : ndarray or None
            The implant image already drawn at its rectangle's size (a cache), else it is
            drawn here.
        """
        rows, cols = screen.screen_shape_px
        full = (
            self.frame is None
            or self._screen != screen
            or keys is None
            or self._keys is None
            or overlay is not None
            or self._had_overlay
        )
        if self.frame is None or self.frame.shape[:2] != (rows, cols):
            self.frame = np.empty((rows, cols, 4), np.uint8)
        f32 = self.frame.view(np.uint32)[..., 0]
        if full:
            f32[:] = _rgba32(BACKGROUND_RGB)
            redraw = [True] * 4
            self.dirty = [(0, 0, cols, rows)]
        else:
            # same screen layout: each image covers the same rectangle as before
            redraw = [a != b for a, b in zip(keys, self._keys, strict=True)]
            if redraw[3] and alert != self._alert:
                left, top, w, h = screen.panes[3]
                f32[top : top + h, left : left + w] = _rgba32(BACKGROUND_RGB)
            self.dirty = [screen.panes[k] for k in range(4) if redraw[k]] + [screen.status]
        if redraw[0]:
            r, c = _put(f32, screen.images[0], centre)
            left, top, iw, ih = screen.images[0]
            sub = f32[top : top + ih, left : left + iw]
            if zoom is not None:
                x, y, w, h = zoom
                on_r = (r == y) | (r == y + h - 1)
                on_c = (c == x) | (c == x + w - 1)
                in_r = (r >= y) & (r <= y + h - 1)
                in_c = (c >= x) & (c <= x + w - 1)
                box = (on_r[:, None] & in_c[None, :]) | (on_c[None, :] & in_r[:, None])
                sub[box] = _rgba32(BOX_RGB)
            if marker is not None:
                sub[_cross(r, c, marker, marker_arm_px(centre.shape))] = _rgba32(MARKER_RGB)
        if redraw[1]:
            _put(f32, screen.images[1], source)
        if redraw[2]:
            _put(f32, screen.images[2], edges)
        if redraw[3]:
            left, top, w, h = screen.images[3]
            if alert:
                b = ALERT_BORDER_PX
                f32[max(0, top - b) : top + h + b, max(0, left - b) : left + w + b] = _rgba32(
                    ALERT_RGB
                )
            ph = phosphenes
            if ph is None:
                ph = draw_implant(cells, (h, w), layout)
            f32[top : top + h, left : left + w] = _GREY32[_u8(ph)]
        sl, st, sc, sr = screen.status
        f32[st : st + sr, sl : sl + sc] = _GREY32[status]
        if overlay is not None:
            oh, ow = overlay.shape
            left, top = (cols - ow) // 2, (rows - STATUS_ROWS_PX - oh) // 2
            f32[top : top + oh, left : left + ow] = _GREY32[overlay]
        self._keys = keys
        self._screen = screen
        self._alert = alert
        self._had_overlay = overlay is not None
        return self.frame


def draw_implant(cells: np.ndarray, shape_px: tuple[int, int], layout: ImplantLayout) -> np.ndarray:
    """Return the implant pane's image: ``cells`` drawn as the layout's phosphenes, float32 [0, 1].

    Dead electrodes, brightness variation and rotation come from the layout
    (:meth:`~stimuli.implants.ImplantLayout.electrode_gain`, ``rotation_deg``).
    """
    return render_phosphenes(
        cells,
        shape_px,
        shape=layout.phosphene_shape,
        size=layout.phosphene_size,
        gain=layout.electrode_gain(),
        rotation_deg=layout.rotation_deg,
    )


def expected_screen(*panes: Any, **options: Any) -> np.ndarray:
    """Return the (rows, cols, 3) uint8 screen the GPU renderer should draw (numpy reference).

    Takes :meth:`FramePainter.paint`'s arguments (``keys`` and ``phosphenes`` make no
    difference to a fresh painter) and returns its frame's RGB.
    """
    return FramePainter().paint(*panes, **options)[..., :3].copy()


def status_line(viewer: Any, averaging_frames: int) -> str:
    """Return the viewer's status line: depth, plane, implant, grey levels, threshold, zoom...

    ``viewer`` is a :class:`~experiment.viewer.app.Viewer`; ``averaging_frames`` the length of
    its temporal average.
    """
    from experiment.viewer.reference import effective_grey_levels

    s, lay = viewer.state, viewer.layout
    z = viewer.lf.depth_m(s.disparity_px)
    depth = f"depth {s.disparity_px:+.3f} px/view" + (
        f" ({z:.2f} m)" if z is not None and np.isfinite(z) and z > 0 else ""
    )
    n = len(viewer.model.planes_px)
    plane = f"plane {s.plane + 1}/{n}" if s.plane is not None else f"plane -/{n}"
    t = "auto" if s.threshold is None else f"{s.threshold:.3g}"
    parts = [
        depth,
        plane,
        f"{lay.label} {lay.cols}x{lay.rows}",
        f"grey levels {effective_grey_levels(s, lay)}",
        f"threshold {t}",
    ]
    parts.append(
        f"zoom {s.zoom[2]}x{s.zoom[3]} at {s.zoom[0]},{s.zoom[1]}"
        if s.zoom is not None
        else "zoom off"
    )
    if s.mode == "obstacle" and s.obstacle_px is not None:
        parts.append(f"OBSTACLE {s.obstacle_px[1]:+.2f}..{s.obstacle_px[0]:+.2f} px/view")
        if viewer.alert:
            parts.append("ALERT")
    if s.mode == "extension" or s.marker is not None or s.extension_px != 0:
        on = "extension ON" if s.mode == "extension" else "extension off"
        mark = f"marker {s.marker[0]},{s.marker[1]}" if s.marker is not None else "no marker"
        parts.append(f"{on} {s.extension_px:+.2f} px/view, {mark}")
    if s.averaging:
        parts.append(f"averaging {viewer.averaged_frames()}/{averaging_frames} frames")
    if s.percept != "phosphenes":
        parts.append(f"percept {s.percept} (pulse2percept)")
    if viewer.source.n_frames > 1:
        parts.append(f"frame {s.frame + 1}/{viewer.source.n_frames}")
    parts.append(f"{viewer.frame_ms:.1f} ms | ? help")
    text = " | ".join(parts)
    return f"{viewer.message}  || {text}" if viewer.message else text
