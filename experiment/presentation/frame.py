"""Where a stimulus lands on the subject's screen, and the frame expected there (numpy, no GL).

- *stimulus*: the stimulus fills a rectangle of the protocol's physical size (cm, converted with the
  monitor's pixels per cm), centred (:func:`stimulus_rect_px`). Each screen pixel takes the value
  of exactly one stimulus cell, chosen with integer arithmetic (:func:`cell_index`:
  ``cell = ((2 x + 1) n) // (2 w)``, nearest neighbour at the pixel centre), so cells are crisp,
  uniform blocks whose sizes differ by at most one pixel (none when the scale is an integer).
- optional *phosphene view* (beyond the paper, :class:`PhospheneSpec`): every cell drawn as a
  Gaussian or disc phosphene at the cell centre, with a set size and a fraction of dropped-out
  (dead) phosphenes.

:func:`expected_frame` is the reference the GL presenter is tested against.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from experiment.presentation.errors import PresenterError
from experiment.presentation.geometry import ScreenGeometry

__all__ = [
    "PhospheneSpec",
    "stimulus_rect_px",
    "cell_index",
    "expected_frame",
    "as_stimulus",
]


@dataclass(frozen=True)
class PhospheneSpec:
    """Phosphene view: each stimulus cell drawn as a phosphene (beyond the paper).

    Parameters
    ----------
    kind : {'gaussian', 'disc'}
    size : float
        Phosphene diameter as a fraction of the spacing (disc: diameter; gaussian: FWHM), > 0.
    dropout : float
        Fraction of phosphenes that never light, in [0, 1).
    spacing_deg : float or None
        Centre-to-centre spacing, degrees; None keeps the protocol's image size
        (spacing = cell pitch).
    seed : int
        Seed of the dropout pattern (fixed per session so the same phosphenes are dead throughout).
    """

    kind: Literal["gaussian", "disc"] = "gaussian"
    size: float = 0.8
    dropout: float = 0.0
    spacing_deg: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in ("gaussian", "disc"):
            raise ValueError(f"kind must be 'gaussian' or 'disc', got {self.kind!r}")
        if not self.size > 0:
            raise ValueError(f"size must be > 0, got {self.size!r}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout!r}")
        if self.spacing_deg is not None and not self.spacing_deg > 0:
            raise ValueError(f"spacing_deg must be > 0 or None, got {self.spacing_deg!r}")

    def alive_mask(self, shape_px: tuple[int, int]) -> np.ndarray:
        """Return the bool (rows, cols) mask of phosphenes that light (dropout from ``seed``)."""
        rng = np.random.default_rng(self.seed)
        return rng.random(shape_px) >= self.dropout


def stimulus_rect_px(
    geometry: ScreenGeometry,
    stimulus_shape_px: tuple[int, int],
    *,
    integer_scale: bool = False,
    phosphenes: PhospheneSpec | None = None,
) -> tuple[int, int, int, int]:
    """Return where a stimulus is drawn: ``(top, left, rows, cols)``, screen px from the top-left.

    Parameters
    ----------
    geometry : ScreenGeometry
    stimulus_shape_px : (rows, cols)
        The stimulus's native resolution (cells).
    integer_scale : bool
        Round the magnification to the nearest integer (>= 1) so that every cell is the same size;
        the physical size then differs from the protocol's by less than half a cell.
    phosphenes : PhospheneSpec or None
        With ``spacing_deg`` set, the size is ``cells x spacing`` instead of the protocol's.

    Returns
    -------
    (top, left, rows, cols) : ints
        The image is centred; ``rows, cols`` are the protocol's size in pixels, rounded.
    """
    n_rows, n_cols = (int(v) for v in stimulus_shape_px)
    if n_rows < 1 or n_cols < 1:
        raise ValueError(f"stimulus_shape_px must be (rows, cols) > 0, got {stimulus_shape_px!r}")
    if phosphenes is not None and phosphenes.spacing_deg is not None:
        pitch = phosphenes.spacing_deg * geometry.px_per_deg
        rows, cols = int(round(n_rows * pitch)), int(round(n_cols * pitch))
    else:
        rows, cols = geometry.image_shape_px
    if integer_scale:
        k = max(1, int(round(cols / n_cols)))
        rows, cols = n_rows * k, n_cols * k
    screen_rows, screen_cols = geometry.screen_shape_px
    if rows > screen_rows or cols > screen_cols:
        raise PresenterError(
            f"image of {cols}x{rows} px does not fit the {screen_cols}x{screen_rows} px screen; "
            "check screen_width_cm and image_size_cm"
        )
    return (screen_rows - rows) // 2, (screen_cols - cols) // 2, rows, cols


def cell_index(pixel: np.ndarray, n_cells: int, extent_px: int) -> np.ndarray:
    """Return the stimulus cell under each screen pixel (nearest neighbour at the pixel centre).

    ``cell = floor((pixel + 0.5) * n_cells / extent_px)``, computed exactly in integers as the
    shader does. ``pixel`` counts from the image's first row or column.
    """
    pixel = np.asarray(pixel, dtype=np.int64)
    return ((2 * pixel + 1) * n_cells) // (2 * extent_px)


def expected_frame(
    geometry: ScreenGeometry, image: np.ndarray, *, integer_scale: bool = False
) -> np.ndarray:
    """Return the (rows, cols, 3) uint8 frame the presenter should draw for a stimulus.

    A reference written with numpy only (no GL), for tests and for ``--screenshot`` checks. Grey
    values are gamma-corrected and rounded like an 8-bit framebuffer (round to nearest); a colour
    photo (rows, cols, 3) is drawn as it is, each channel gamma-corrected.
    """
    img = as_stimulus(image)
    top, left, rows, cols = stimulus_rect_px(geometry, img.shape[:2], integer_scale=integer_scale)
    frame = np.empty((*geometry.screen_shape_px, 3), dtype=np.uint8)
    b = geometry.border_width_px
    if b is None:
        frame[:] = geometry.border_rgb
    else:
        frame[:] = geometry.background_rgb
        frame[max(0, top - b) : top + rows + b, max(0, left - b) : left + cols + b] = (
            geometry.border_rgb
        )
    r = cell_index(np.arange(rows), img.shape[0], rows)
    c = cell_index(np.arange(cols), img.shape[1], cols)
    v = img[np.ix_(r, c)].astype(np.float64) ** (1.0 / geometry.gamma)
    if img.ndim == 3:
        rgb = v
    else:
        fg = np.asarray(geometry.stimulus_on_rgb, np.float64) / 255
        bg = np.asarray(geometry.stimulus_off_rgb, np.float64) / 255
        rgb = bg + (fg - bg) * v[..., None]
    frame[top : top + rows, left : left + cols] = np.round(rgb * 255).astype(np.uint8)
    return frame


def as_stimulus(image: np.ndarray) -> np.ndarray:
    """Check a stimulus (H6) and return it as float32 (rows, cols) or (rows, cols, 3) in [0, 1]."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.float32:
        pass  # a colour training photo
    elif image.ndim != 2:
        raise ValueError(
            f"image must be 2-D (rows, cols) or a float32 colour photo (rows, cols, 3), "
            f"got shape {image.shape}"
        )
    if image.dtype == np.bool_:
        return image.astype(np.float32)
    if image.dtype != np.float32:
        raise TypeError(f"image must be bool or float32, got dtype {image.dtype}")
    if image.size and not (np.isfinite(image).all() and image.min() >= 0 and image.max() <= 1):
        raise ValueError(
            f"image values must be in [0, 1], got [{float(image.min())}, {float(image.max())}]"
        )
    return image
