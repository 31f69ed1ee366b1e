"""Screen layout of the viewer and its numpy reference drawing (no GL).

The window is four panes in a 2x2 grid above a one-line status bar:

=========================  ====================================================
top left: centre view      the cluttered image; the zoom box outlined in yellow
top right: confocal image  at the current depth (or the obstacle-masked view), zoomed
bottom left: edges         de-cluttered (Sobel above the threshold), zoomed
bottom right: implant      the compressed image drawn as phosphenes at the implant's
                           field of view; a red frame while the obstacle alert is on
=========================  ====================================================

Every image is drawn with nearest-neighbour cells chosen in integers (``cell = ((2 p + 1) n) //
(2 extent)``, as :func:`experiment.presentation.presenter.cell_index`), so a GPU screenshot can be
compared with :func:`expected_screen` pixel for pixel. Text (the status line) is drawn by Pillow
into an 8-bit image that both the GPU and this reference use as is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stimuli.implants import ImplantLayout, render_phosphenes

__all__ = [
    "STATUS_ROWS_PX",
    "BACKGROUND_RGB",
    "BOX_RGB",
    "ALERT_RGB",
    "ALERT_BORDER_PX",
    "ScreenLayout",
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


def _put(frame, rect, img01):
    left, top, w, h = rect
    r = nearest_cells(h, img01.shape[0])
    c = nearest_cells(w, img01.shape[1])
    v = np.asarray(img01, np.float32)[np.ix_(r, c)]
    frame[top : top + h, left : left + w] = np.round(np.clip(v, 0, 1) * 255).astype(np.uint8)[
        ..., None
    ]
    return r, c


def expected_screen(
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
) -> np.ndarray:
    """Return the (rows, cols, 3) uint8 screen the GPU renderer should draw (numpy reference).

    Parameters
    ----------
    screen : ScreenLayout
    centre : ndarray (rows, cols), float32 in [0, 1]
    source : ndarray (h, w), float32 in [0, 1]
        Confocal (or obstacle-masked) image, zoomed.
    edges : ndarray (h, w), bool
    cells : ndarray (implant rows, cols), float32 in [0, 1]
        Electrode values (dropout is applied here, from ``layout``).
    layout : ImplantLayout
    zoom : (x, y, w, h) or None
        Outlined on the centre view.
    alert : bool
        Draw the red alert frame around the implant image.
    status : ndarray (STATUS_ROWS_PX, cols), uint8
        The status line (:func:`status_image`).
    """
    rows, cols = screen.screen_shape_px
    frame = np.empty((rows, cols, 3), np.uint8)
    frame[:] = BACKGROUND_RGB
    r, c = _put(frame, screen.images[0], centre)
    if zoom is not None:
        x, y, w, h = zoom
        on_r = (r == y) | (r == y + h - 1)
        on_c = (c == x) | (c == x + w - 1)
        in_r = (r >= y) & (r <= y + h - 1)
        in_c = (c >= x) & (c <= x + w - 1)
        box = (on_r[:, None] & in_c[None, :]) | (on_c[None, :] & in_r[:, None])
        left, top, iw, ih = screen.images[0]
        sub = frame[top : top + ih, left : left + iw]
        sub[box] = BOX_RGB
    _put(frame, screen.images[1], source)
    _put(frame, screen.images[2], edges.astype(np.float32))
    left, top, w, h = screen.images[3]
    if alert:
        b = ALERT_BORDER_PX
        frame[max(0, top - b) : top + h + b, max(0, left - b) : left + w + b] = ALERT_RGB
    ph = render_phosphenes(
        cells,
        (h, w),
        shape=layout.phosphene_shape,
        size=layout.phosphene_size,
        alive=layout.alive_mask(),
    )
    frame[top : top + h, left : left + w] = np.round(ph * 255).astype(np.uint8)[..., None]
    sl, st, sc, sr = screen.status
    frame[st : st + sr, sl : sl + sc] = status[..., None]
    return frame
