"""The one CPU renderer: what each pane shows for a state, with numpy and ``stimuli``.

This is the reference the GPU pipeline (:mod:`experiment.viewer.gpu`) is tested against, the
baseline of ``benchmarks/bench_viewer.py``, and the renderer of active search (its sessions,
simulated searchers and demo), which has no GL context. :func:`cpu_panes` draws a
:class:`ViewerState`; :class:`CpuRenderer` adds the cache of confocal images by disparity that
both callers keep. For a state:

1. the *source* image: the confocal image at the state's disparity
   (:func:`stimuli.refocus.refocus`), or in obstacle mode the centre view kept only where the
   per-pixel depth lies in the obstacle range (:func:`obstacle_mask`), or in active search's
   cluttered condition the centre view itself;
2. crop to the zoom box (before de-clutter and compress, Jung et al. 2015, Fig. 14);
3. de-clutter: Sobel magnitude (:func:`stimuli.declutter.sobel_magnitude`) above the threshold
   (the state's, or :func:`stimuli.declutter.auto_threshold`);
4. compress to the implant's electrode grid: with 2 grey levels the binary compression of the
   edges (:func:`stimuli.compress.compress`, edge ratio 1/13), with more the grey compression of
   the source (:func:`stimuli.compress.compress_grey`) at
   ``min(state grey levels, implant grey levels)``. An implant given as a bare grid
   ``(rows, cols)`` (active search's task grid) is on/off.

Per-pixel depth ("agreement across views", for obstacle avoidance and confocal extension) is
the disparity at which the views agree best: the smallest variance across the shifted views,
``E[I^2] - E[I]^2`` over the views, both terms from shift-and-add refocusing of ``I`` and
``I^2``. Pixels whose variance barely changes with disparity (flat, texture-less regions) have
no reliable depth and are left out (:data:`DEPTH_CONFIDENCE_FRACTION`), as are pixels whose best
disparity is the first or last candidate (the true one may lie beyond the range).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from experiment.viewer.state import ViewerState
from stimuli import jung2015
from stimuli.implants import ImplantLayout
from stimuli.lightfield import LightField

__all__ = [
    "EDGE_RATIO",
    "DEPTH_CONFIDENCE_FRACTION",
    "OBSTACLE_ALERT_FRACTION",
    "Panes",
    "CpuRenderer",
    "DepthMap",
    "depth_map",
    "obstacle_mask",
    "cpu_panes",
    "effective_grey_levels",
    "compress_for_implant",
    "implant_cells",
    "track_point",
    "brightest_point",
    "otsu_threshold",
]

#: Compression edge ratio. Source: Jung et al. (2015), Sec. 2.2 (1/13).
EDGE_RATIO: float = jung2015.EDGE_RATIO

#: A pixel has a depth when its variance-versus-disparity curve varies by at least this fraction
#: of the image's median variation (ours: flat regions vary by ~0, textured ones by ~median).
DEPTH_CONFIDENCE_FRACTION: float = 0.5

#: The obstacle alert fires when more than this fraction of the view lies in the obstacle range
#: (ours: 0.5 %, about a 20x20 px object in a 383x552 view).
OBSTACLE_ALERT_FRACTION: float = 0.005


@dataclass(frozen=True)
class Panes:
    """The images of the four panes for one state (CPU reference).

    Attributes
    ----------
    centre : ndarray (rows, cols), float32 in [0, 1]
        Centre view (full, not zoomed).
    source : ndarray (h, w), float32 in [0, 1]
        Confocal image (or obstacle-masked centre view), cropped to the zoom box.
    magnitude : ndarray (h, w), float32
        Sobel magnitude of ``source``.
    threshold : float
    edges : ndarray (h, w), bool
    cells : ndarray (implant rows, cols), float32 in [0, 1]
        Electrode values before dropout.
    grey_levels : int
        Grey levels used for ``cells``.
    alert : bool
        Obstacle alert (obstacle mode only).
    """

    centre: np.ndarray
    source: np.ndarray
    magnitude: np.ndarray
    threshold: float
    edges: np.ndarray
    cells: np.ndarray
    grey_levels: int
    alert: bool = False

    @property
    def grid(self) -> np.ndarray:
        """The lit electrodes, bool (implant rows, cols): ``cells`` above half brightness."""
        return self.cells >= 0.5


@dataclass(frozen=True)
class DepthMap:
    """Per-pixel disparity by agreement across views.

    Attributes
    ----------
    disparity_px : ndarray (rows, cols), float32
        Best-agreeing disparity at full resolution (pixels per view step).
    valid : ndarray (rows, cols), bool
        Pixels with a reliable depth.
    candidates_px : ndarray (n,), float64
        Disparities tried.
    binning : int
        View binning used.
    """

    disparity_px: np.ndarray
    valid: np.ndarray
    candidates_px: np.ndarray
    binning: int

    def at(self, x: int, y: int, *, radius_px: int = 6) -> float:
        """Median valid disparity in a ``(2 r + 1)``-pixel square around ``(x, y)``.

        Falls back to the whole image's median valid disparity when the square has none.
        """
        rows, cols = self.disparity_px.shape
        y0, y1 = max(0, y - radius_px), min(rows, y + radius_px + 1)
        x0, x1 = max(0, x - radius_px), min(cols, x + radius_px + 1)
        d = self.disparity_px[y0:y1, x0:x1][self.valid[y0:y1, x0:x1]]
        if d.size == 0:
            d = self.disparity_px[self.valid]
        return float(np.median(d)) if d.size else 0.0


def depth_map(lightfield: LightField, candidates_px: np.ndarray, *, binning: int = 2) -> DepthMap:
    """Estimate per-pixel disparity as the one where the views agree best (least variance).

    Parameters
    ----------
    lightfield : LightField, grey
    candidates_px : ndarray (n,)
        Disparities to try, full-resolution pixels per view step.
    binning : int >= 1
        Box binning of the views first (speed; disparities divide by it).

    Returns
    -------
    DepthMap
    """
    from stimuli.refocus import refocus

    lf = lightfield.gray().binned(binning) if binning > 1 else lightfield.gray()
    sq = LightField(lf.views * lf.views)
    ds = np.asarray(candidates_px, dtype=np.float64)
    dmax = lf.max_disparity_px()  # binning shrinks the views, and so the usable range
    binned = np.clip(ds / binning, -dmax, dmax)
    var = np.stack([np.maximum(refocus(sq, d) - refocus(lf, d) ** 2, 0.0) for d in binned])
    best = np.argmin(var, axis=0)
    spread = np.median(var, axis=0) - np.min(var, axis=0)
    ref = float(np.median(spread))
    valid = spread > DEPTH_CONFIDENCE_FRACTION * ref if ref > 0 else np.zeros_like(spread, bool)
    # a best match at either end of the candidates is not bracketed: the depth may lie beyond
    valid &= (best > 0) & (best < ds.size - 1)
    rows, cols = lightfield.shape_px
    disp = ds[best].astype(np.float32)
    full = np.repeat(np.repeat(disp, binning, axis=0), binning, axis=1)
    vfull = np.repeat(np.repeat(valid, binning, axis=0), binning, axis=1)
    out_d = np.zeros((rows, cols), np.float32)
    out_v = np.zeros((rows, cols), bool)
    r, c = min(rows, full.shape[0]), min(cols, full.shape[1])
    out_d[:r, :c], out_v[:r, :c] = full[:r, :c], vfull[:r, :c]
    return DepthMap(out_d, out_v, ds, binning)


def obstacle_mask(depth: DepthMap, near_px: float, far_px: float) -> np.ndarray:
    """Return the bool mask of pixels whose depth lies in ``[far_px, near_px]`` (disparities)."""
    lo, hi = min(near_px, far_px), max(near_px, far_px)
    return depth.valid & (depth.disparity_px >= lo) & (depth.disparity_px <= hi)


def _grid(layout: ImplantLayout | tuple[int, int]) -> tuple[tuple[int, int], int]:
    # (electrode grid, grey levels) of a layout, or of a bare grid (on/off)
    if isinstance(layout, ImplantLayout):
        return layout.shape, layout.levels
    rows, cols = (int(v) for v in layout)
    return (rows, cols), 2


def effective_grey_levels(state: ViewerState, layout: ImplantLayout | tuple[int, int]) -> int:
    """Grey levels used for the implant view: 2 stays binary; otherwise at most the implant's."""
    g = state.grey_levels
    return 2 if g <= 2 else max(2, min(g, _grid(layout)[1]))


def compress_for_implant(
    source: np.ndarray,
    edges: np.ndarray,
    layout: ImplantLayout | tuple[int, int],
    grey_levels: int,
    *,
    grey: np.ndarray | None = None,
) -> np.ndarray:
    """Compress to the implant's grid: binary edges (2 grey levels) or the grey source (more).

    ``layout`` is an implant layout or a bare electrode grid ``(rows, cols)``. ``grey``
    replaces ``source`` for the grey compression (obstacle mode: the share of each electrode's
    window that lies in the depth range).
    """
    from stimuli.compress import compress, compress_grey

    shape = _grid(layout)[0]
    if grey_levels <= 2:
        return compress(edges, shape, edge_ratio=EDGE_RATIO).astype(np.float32)
    return compress_grey(source if grey is None else grey, shape, grey_levels=grey_levels)


def cpu_panes(
    lightfield: LightField,
    state: ViewerState,
    layout: ImplantLayout | tuple[int, int],
    *,
    depth: DepthMap | None = None,
    confocal: np.ndarray | None = None,
    cluttered: bool = False,
) -> Panes:
    """Compute the four panes' images for a state with the CPU pipeline (the reference).

    Parameters
    ----------
    lightfield : LightField, grey
    state : ViewerState
    layout : ImplantLayout or (rows, cols)
        The implant, or a bare on/off electrode grid.
    depth : DepthMap, optional
        Needed in obstacle mode.
    confocal : ndarray (rows, cols), float32, optional
        The confocal image at the state's disparity, if already refocused (a cache).
    cluttered : bool
        The implant path starts from the centre view, not the confocal image (active search's
        cluttered condition; ignored in obstacle mode).

    Returns
    -------
    Panes

    Notes
    -----
    In obstacle mode with grey levels an electrode's brightness is the share of its window
    that lies in the obstacle range (its coverage), not the mean luminance of the masked view:
    the masked view is mostly black, so its window means quantise to 0 and the implant pane
    would stay dark however close the obstacle came.
    """
    from stimuli.refocus import refocus

    centre = lightfield.centre_view()
    alert = False
    grey = None
    if state.mode == "obstacle" and state.obstacle_px is not None:
        if depth is None:
            raise ValueError("obstacle mode needs a depth map")
        mask = obstacle_mask(depth, *state.obstacle_px)
        source = np.where(mask, centre, np.float32(0)).astype(np.float32)
        grey = mask.astype(np.float32)
        alert = bool(mask.mean() > OBSTACLE_ALERT_FRACTION)
    elif cluttered:
        source = centre
    elif confocal is not None:
        source = confocal
    else:
        source = refocus(lightfield, state.disparity_px)
    if state.zoom is not None:
        x, y, w, h = state.zoom
        source = np.ascontiguousarray(source[y : y + h, x : x + w])
        if grey is not None:
            grey = np.ascontiguousarray(grey[y : y + h, x : x + w])
    grey_levels = effective_grey_levels(state, layout)
    mag, t, edges, cells = implant_cells(
        source, layout, threshold=state.threshold, grey_levels=grey_levels, grey=grey
    )
    return Panes(centre, source, mag, t, edges, cells, grey_levels, alert)


def implant_cells(
    image: np.ndarray,
    layout: ImplantLayout | tuple[int, int],
    *,
    threshold: float | None = None,
    grey_levels: int = 2,
    grey: np.ndarray | None = None,
    edge_mask: np.ndarray | None = None,
) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """De-clutter an image (already cropped to the zoom box) and compress it to the implant.

    Steps 3 and 4 of the pipeline (module docstring), for :func:`cpu_panes` and for any image
    that is not a light field's (active search's recogniser templates).

    Parameters
    ----------
    image : ndarray (h, w), float32 in [0, 1]
    layout : ImplantLayout or (rows, cols)
    threshold : float, optional
        Sobel threshold (None: Otsu on the magnitude).
    grey_levels : int
        2: binary compression of the edges; more: grey compression of ``image`` (or ``grey``).
    grey : ndarray (h, w), float32, optional
        What the grey compression compresses instead of ``image`` (obstacle mode's coverage).
    edge_mask : ndarray (h, w), bool, optional
        Keep only the edges inside it before compressing.

    Returns
    -------
    magnitude : ndarray (h, w), float32
    threshold : float
    edges : ndarray (h, w), bool
    cells : ndarray (implant rows, cols), float32 in [0, 1]
    """
    from stimuli.declutter import sobel_magnitude

    mag = sobel_magnitude(image)
    t = float(threshold) if threshold is not None else otsu_threshold(mag)
    edges = mag > t
    if edge_mask is not None:
        edges &= np.asarray(edge_mask, dtype=bool)
    return mag, t, edges, compress_for_implant(image, edges, layout, grey_levels, grey=grey)


class CpuRenderer:
    """The panes of a state, with the confocal images kept by disparity (most recent first).

    Parameters
    ----------
    lightfield : LightField, grey
        The views (a video's current frame: replace it with :meth:`set_frame`).
    layout : ImplantLayout or (rows, cols)
        The implant, or a bare on/off electrode grid (active search).
    cluttered : bool
        Draw the implant path from the centre view (active search's cluttered condition).
    cache : int >= 1
        Confocal images kept.
    workers : int, optional
        Threads of each refocus (None: the default; active search: 1).
    """

    def __init__(
        self,
        lightfield: LightField,
        layout: ImplantLayout | tuple[int, int],
        *,
        cluttered: bool = False,
        cache: int = 48,
        workers: int | None = None,
    ) -> None:
        self.lightfield = lightfield
        self.layout = layout
        self.cluttered = bool(cluttered)
        self.cache = int(cache)
        self.workers = workers
        self.frame = 0
        self._confocal: OrderedDict[tuple[int, float], np.ndarray] = OrderedDict()

    def set_frame(self, frame: int, lightfield: LightField) -> None:
        """Show video frame ``frame`` (its confocal images are cached apart from others)."""
        self.frame, self.lightfield = int(frame), lightfield

    def has(self, disparity_px: float) -> bool:
        """Whether the confocal image at a disparity of the current frame is cached."""
        return (self.frame, float(disparity_px)) in self._confocal

    def confocal(self, disparity_px: float) -> np.ndarray:
        """Return the confocal image of the current frame at a disparity (cached)."""
        from stimuli.refocus import refocus

        key = (self.frame, float(disparity_px))
        img = self._confocal.get(key)
        if img is None:
            img = refocus(self.lightfield, key[1], workers=self.workers)
            self._confocal[key] = img
            while len(self._confocal) > self.cache:
                self._confocal.popitem(last=False)
        else:
            self._confocal.move_to_end(key)
        return img

    def render(
        self,
        state: ViewerState,
        *,
        layout: ImplantLayout | None = None,
        depth: DepthMap | None = None,
    ) -> Panes:
        """Return the panes of ``state`` (:func:`cpu_panes`); ``layout`` overrides the own."""
        obstacle = state.mode == "obstacle" and state.obstacle_px is not None
        conf = None if obstacle or self.cluttered else self.confocal(state.disparity_px)
        return cpu_panes(
            self.lightfield,
            state,
            self.layout if layout is None else layout,
            depth=depth,
            confocal=conf,
            cluttered=self.cluttered,
        )


def otsu_threshold(magnitude: np.ndarray) -> float:
    """Return the automatic threshold of a Sobel magnitude image (>= 0).

    The rule of :func:`stimuli.declutter.auto_threshold` (Otsu, 256 bins) applied to a
    magnitude already computed, so the viewer runs the Sobel filter once per image.
    """
    from skimage.filters import threshold_otsu

    if magnitude.size == 0 or float(magnitude.max()) == float(magnitude.min()):
        return 0.0
    return max(0.0, float(threshold_otsu(magnitude, nbins=256)))


def brightest_point(image: np.ndarray, *, sigma_px: float = 2.0) -> tuple[int, int]:
    """Return ``(x, y)`` of the brightest spot of a grey image after Gaussian smoothing."""
    from scipy.ndimage import gaussian_filter

    s = gaussian_filter(np.asarray(image, np.float32), sigma_px)
    y, x = np.unravel_index(int(np.argmax(s)), s.shape)
    return int(x), int(y)


def track_point(
    previous: np.ndarray,
    current: np.ndarray,
    point: tuple[int, int],
    *,
    patch_px: int = 15,
    search_px: int = 24,
) -> tuple[int, int]:
    """Follow a point from one frame to the next by normalised cross-correlation of a patch.

    Parameters
    ----------
    previous, current : ndarray (rows, cols), float32
        Consecutive centre views.
    point : (x, y)
        The point in ``previous``.
    patch_px : int
        Side of the template (odd).
    search_px : int
        How far the point may move between frames, pixels.

    Returns
    -------
    (x, y) in ``current``
    """
    from skimage.feature import match_template

    rows, cols = previous.shape
    x, y = point
    h = patch_px // 2
    y0, y1, x0, x1 = max(0, y - h), min(rows, y + h + 1), max(0, x - h), min(cols, x + h + 1)
    tmpl = previous[y0:y1, x0:x1]
    sy0, sy1 = max(0, y0 - search_px), min(rows, y1 + search_px)
    sx0, sx1 = max(0, x0 - search_px), min(cols, x1 + search_px)
    region = current[sy0:sy1, sx0:sx1]
    if tmpl.size == 0 or region.shape[0] < tmpl.shape[0] or region.shape[1] < tmpl.shape[1]:
        return point
    if float(tmpl.std()) == 0.0:
        return point
    score = match_template(region, tmpl)
    dy, dx = np.unravel_index(int(np.argmax(score)), score.shape)
    return int(sx0 + dx + (x - x0)), int(sy0 + dy + (y - y0))
