"""Which plane a light-field stimulus is built at, from the evidence, and why (ours).

One detector answers for every command: :func:`detect_planes` is the default agreement scan
(:func:`stimuli.planes.find_object_planes` with its defaults: range from the data, 200 planes,
binning from the views). ``confocal stimuli build``, ``confocal lightfield scan`` and
``confocal view`` all call it, so they report the same planes for the same capture.

Where a plane's content lies
----------------------------
The same sweep, per pixel (:func:`stimuli.agreementscan.best_plane_map`), gives each pixel's
best plane and whether its views agree there. A detected plane *holds* the agreeing pixels
whose best plane lies on its hill of the support curve (between the curve's minima towards
the neighbouring detected planes). That pixel set is the plane's in-focus content: the crop
keeps it, and a plane whose content lies mostly in a thin frame along the image border is
not an object.

The default rule (``plane='auto'``)
-----------------------------------
The nearest detected plane that

* holds at least :data:`SUPPORT_SHARE` of the support, and has at least that share of the
  evidence, of the strongest detected plane (cuts relative to the scan itself, not absolute
  shares of pixels: they follow the capture's own texture and size), and
* has at most :data:`BORDER_SHARE` of its content within the border frame
  (:data:`BORDER_MARGIN` of each side).

The object stands in front of the clutter (Jung et al. 2015, Sec. 4), hence the *nearest*
passing plane. When no plane passes, the strongest is taken and the choice is marked
*marginal*. Other rules: ``'strongest'`` (most support), ``'nearest'`` (the nearest detected
plane, whatever its support), a disparity, a depth, or a region of interest (a box or a
mask): the detected plane holding most of the region's pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from stimuli.errors import InputError
from stimuli.lfload import as_lightfield
from stimuli.lfviews import LightField
from stimuli.planescan import PlaneScan, median_spacing

__all__ = [
    "SUPPORT_BLUR_PX",
    "PLANE_RULES",
    "SUPPORT_SHARE",
    "BORDER_MARGIN",
    "BORDER_SHARE",
    "NEAR_PEAK_SHARE",
    "PlaneCandidate",
    "PlaneChoice",
    "detect_planes",
    "plane_contents",
    "plane_extent",
    "support_reach_px",
    "choose_plane",
    "parse_plane_option",
]

#: A pixel is on a plane when refocusing at the plane blurs it by at most this much between
#: the centre view and the outermost view, px (ours: Sobel's 3x3 kernel still finds its edge).
SUPPORT_BLUR_PX: float = 1.5

#: Named plane rules of ``--plane`` (a number is a disparity, px per view step).
PLANE_RULES: tuple[str, ...] = ("auto", "strongest", "nearest")

#: A plane is an object plane for the default rule when its support and its evidence are at
#: least this fraction of the strongest detected plane's (ours: a twentieth; a small object
#: in front of a wall that fills the view holds about a tenth of the wall's support, a sliver
#: of a table edge far less).
SUPPORT_SHARE: float = 0.05

#: A given plane lies on a detected plane when it is within this share of the scanned range of
#: that plane's peak (ours: 10 of the 200 default planes); else the choice is marginal.
NEAR_PEAK_SHARE: float = 0.05

#: Width of the border frame, as a fraction of each side (ours: a sixteenth, about 6 %).
BORDER_MARGIN: float = 1.0 / 16.0

#: A plane whose content lies more than this fraction within the border frame is a border
#: band, not an object (ours: "mostly"; the frame covers 23 % of the image, so evenly spread
#: content puts about a quarter of its pixels there).
BORDER_SHARE: float = 0.5


@dataclass(frozen=True)
class PlaneCandidate:
    """One detected plane, as the rule saw it.

    Parameters
    ----------
    disparity_px, depth_m, support, evidence
        Those of the detected :class:`~stimuli.planescan.Plane`: pixels per view step, metres
        (with a geometry), the fraction of the scan's pixels agreeing on the plane's hill, the
        peak's prominence over the null's largest.
    border_share : float in [0, 1]
        Fraction of the plane's content within the border frame.
    roi_share : float in [0, 1] or None
        Fraction of the region of interest the plane holds (with a region).
    rejected : str
        Why the default rule passed over it (``""`` when it passed).
    """

    disparity_px: float
    depth_m: float | None
    support: float
    evidence: float
    border_share: float
    roi_share: float | None = None
    rejected: str = ""

    def to_dict(self) -> dict:
        """Return a JSON-ready dict (NaN as ``None``)."""
        return {k: _json_number(v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class PlaneChoice:
    """The plane a stimulus is built at, with its evidence and the rule that chose it.

    Parameters
    ----------
    disparity_px : float
        Pixels per view step.
    depth_m : float or None
    support, evidence : float
        Of the detected plane the choice sits on (NaN when none).
    rule : str
        ``'auto'``, ``'strongest'``, ``'nearest'``, ``'disparity_px'``, ``'depth_m'`` or
        ``'roi'``.
    candidates : tuple of PlaneCandidate
        Every detected plane, nearest first (the alternatives).
    marginal : str
        Why the plane is doubtful (``""`` when it is not): no plane passed the default rule,
        or a given plane lies on no detected plane.
    content : ndarray of shape (rows, cols), bool
        The plane's in-focus content (or the region of interest), full resolution.
    on_plane : ndarray of shape (rows, cols), bool, or None
        The plane's support: the pixels the depth scan puts on the plane itself, whose views
        agree best within :data:`SUPPORT_BLUR_PX` of blur of it or, for a detected plane,
        within its band of disparities (:func:`plane_extent`, widened by the same tolerance;
        the plane's hill may hold the whole scene when the scan finds one plane). What a
        stimulus shows is judged against it.
    edge_depth : dict or None
        On a 1-D light field de-cluttered by depth: the edge pixels whose depth the views
        could not measure and what became of them
        (:meth:`stimuli.edgedepth.EdgeDepthStats.to_dict`); set by the build.
    view_crop : list of int (x, y, w, h) or None
        The crop the views were read with (:func:`stimuli.vignette.apply_view_crop`), in the
        capture's pixels; recorded so that every command can be checked to use the same one.
    baseline_axes : tuple of int
        The image axes the views are spread along (:func:`stimuli.edgedepth.baseline_axes`).
    reach_px : int
        The scan's resolution around ``on_plane``, full-resolution px (:func:`support_reach_px`):
        a pixel's best plane is decided from a box this far around it, so an edge this close
        to the support is within what the scan can resolve of it (0 without a support).
    """

    disparity_px: float
    depth_m: float | None
    support: float
    evidence: float
    rule: str
    candidates: tuple[PlaneCandidate, ...]
    marginal: str = ""
    content: np.ndarray = field(default=None, repr=False, compare=False)  # type: ignore[assignment]
    view_crop: list | None = None
    on_plane: np.ndarray | None = field(default=None, repr=False, compare=False)
    edge_depth: dict | None = None
    reach_px: int = 0
    baseline_axes: tuple[int, ...] = ()

    def describe(self) -> str:
        """One-line provenance: ``disparity=...px,depth=...m,<rule>``."""
        depth = "" if self.depth_m is None else f",depth={self.depth_m:.4g}m"
        return f"disparity={self.disparity_px:.4g}px{depth},{self.rule}"

    def to_dict(self) -> dict:
        """Return the record written to ``stimulus_set.json`` (without the content mask)."""
        return {
            "disparity_px": _json_number(self.disparity_px),
            "depth_m": _json_number(self.depth_m),
            "support": _json_number(self.support),
            "evidence": _json_number(self.evidence),
            "rule": self.rule,
            "marginal": self.marginal,
            "alternatives": [c.to_dict() for c in self.candidates],
            "view_crop": None if self.view_crop is None else list(self.view_crop),
        } | ({} if self.edge_depth is None else {"edge_depth": dict(self.edge_depth)})


def _json_number(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def detect_planes(lightfield: LightField | np.ndarray, *, workers: int | None = None) -> PlaneScan:
    """Return the object planes of a light field: the one detector every command uses.

    :func:`stimuli.planes.find_object_planes` with its defaults (agreement scan with a null,
    range from the data, :data:`stimuli.planes.DEFAULT_N_PLANES` planes, binning from the
    views).
    """
    from stimuli.planes import find_object_planes

    return find_object_planes(as_lightfield(lightfield).gray(), workers=workers)


def _hill_bounds(scan: PlaneScan) -> list[tuple[int, int]]:
    """Index ranges ``[lo, hi)`` of each peak's hill, in the order of ``scan.peaks``."""
    s = np.asarray(scan.scores)
    order = sorted(range(len(scan.peaks)), key=lambda k: scan.peaks[k].index)
    idx = [scan.peaks[k].index for k in order]
    cuts = [0]
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        cuts.append(a + int(np.argmin(s[a : b + 1])))
    cuts.append(len(s))
    out: list[tuple[int, int]] = [(0, 0)] * len(scan.peaks)
    for j, k in enumerate(order):
        out[k] = (cuts[j], cuts[j + 1])
    return out


def _upsample(mask: np.ndarray, b: int, shape_px: tuple[int, int]) -> np.ndarray:
    m = np.repeat(np.repeat(mask, b, axis=0), b, axis=1)
    out = np.zeros(shape_px, bool)
    r, c = min(m.shape[0], shape_px[0]), min(m.shape[1], shape_px[1])
    out[:r, :c] = m[:r, :c]
    return out


def plane_contents(
    lightfield: LightField | np.ndarray, scan: PlaneScan, *, workers: int | None = None
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Return each detected plane's in-focus content, full resolution, in ``scan.peaks`` order.

    Also returns the per-pixel best disparity (px per view step, NaN where the views agree at
    no plane) and the hill bounds as disparities, for planes given by the user.

    Returns
    -------
    contents : list of ndarray of shape (rows, cols), bool
    best_disparity_px : ndarray of shape (rows, cols), float64
    bounds_px : ndarray of shape (n_peaks, 2)
        Each hill's disparity span ``[low, high)``.
    """
    from stimuli.agreementscan import best_plane_map

    lf = as_lightfield(lightfield).gray()
    ds = np.asarray(scan.disparities_px, dtype=np.float64)
    b = int(scan.binning)
    best_i, agrees = best_plane_map(lf, ds, binning=b, workers=workers)
    contents = []
    bounds = []
    for lo, hi in _hill_bounds(scan):
        contents.append(_upsample(agrees & (best_i >= lo) & (best_i < hi), b, lf.shape_px))
        bounds.append((ds[lo] if lo < len(ds) else ds[-1], ds[hi] if hi < len(ds) else np.inf))
    best = np.where(agrees, ds[best_i], np.nan)
    best = np.repeat(np.repeat(best, b, axis=0), b, axis=1)
    full = np.full(lf.shape_px, np.nan)
    r, c = min(best.shape[0], full.shape[0]), min(best.shape[1], full.shape[1])
    full[:r, :c] = best[:r, :c]
    return contents, full, np.asarray(bounds, dtype=np.float64).reshape(-1, 2)


def _border_share(mask: np.ndarray) -> float:
    n = int(mask.sum())
    if n == 0:
        return 1.0
    rows, cols = mask.shape
    mr, mc = max(1, math.ceil(BORDER_MARGIN * rows)), max(1, math.ceil(BORDER_MARGIN * cols))
    inner = int(mask[mr : rows - mr, mc : cols - mc].sum())
    return (n - inner) / n


def parse_plane_option(text: str | float | None) -> str:
    """Check ``--plane``: ``auto``, ``strongest``, ``nearest`` or a disparity (px per view step).

    Returns the rule name, or the disparity as its text (``repr`` of the float).

    Raises
    ------
    InputError
        Anything else, or a disparity that is not finite.
    """
    if text is None:
        return "auto"
    t = str(text).strip().lower()
    if t in PLANE_RULES:
        return t
    try:
        v = float(t)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise InputError(
            f"--plane must be one of {', '.join(PLANE_RULES)} or a disparity in px per view "
            f"step (a finite number), got {text!r}"
        )
    return repr(v)


def _roi_mask(roi, shape_px: tuple[int, int], where: str) -> np.ndarray:
    if isinstance(roi, np.ndarray):
        m = np.asarray(roi)
        if m.shape != tuple(shape_px):
            raise InputError(
                f"{where}: roi mask is {m.shape[1]}x{m.shape[0]} px; expected the centre view's "
                f"{shape_px[1]}x{shape_px[0]}"
            )
        m = m.astype(bool)
    else:
        x, y, w, h = (int(v) for v in roi)
        rows, cols = shape_px
        if x < 0 or y < 0 or w <= 0 or h <= 0 or x + w > cols or y + h > rows:
            raise InputError(
                f"{where}: roi box x,y,w,h = {x},{y},{w},{h} lies outside the {cols}x{rows} "
                f"centre view (expected x + w <= {cols} and y + h <= {rows})"
            )
        m = np.zeros(shape_px, bool)
        m[y : y + h, x : x + w] = True
    if not m.any():
        raise InputError(f"{where}: roi mask selects no pixel")
    return m


def choose_plane(
    lightfield: LightField | np.ndarray,
    *,
    rule: str = "auto",
    disparity_px: float | None = None,
    depth_m: float | None = None,
    roi: tuple[int, int, int, int] | np.ndarray | None = None,
    scan: PlaneScan | None = None,
    where: str = "light field",
    workers: int | None = None,
) -> PlaneChoice:
    """Choose the plane a stimulus is built at and say why (module docstring).

    Precedence: ``depth_m`` or ``disparity_px`` (the object's own plane), then ``roi``, then
    ``rule``.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    rule : {'auto', 'strongest', 'nearest'} or str of a float
        The rule when no plane or region is given; a number is a disparity, px per view step.
    disparity_px : float, optional
        The plane, pixels per view step.
    depth_m : float, optional
        The plane's depth, metres (needs a geometry).
    roi : (x, y, w, h) or ndarray of shape (rows, cols), optional
        Region of interest in the centre view, full-resolution pixels (box or mask).
    scan : PlaneScan, optional
        The scan of :func:`detect_planes`, if already run.
    where : str
        Names the object in error messages.
    workers : int, optional

    Returns
    -------
    PlaneChoice

    Raises
    ------
    InputError
        Both a depth and a disparity, an unknown rule, a region outside the view, or no
        detected plane when the rule needs one.
    """
    if depth_m is not None and disparity_px is not None:
        raise InputError(f"{where}: give plane_depth_m or plane_disparity_px, not both")
    lf = as_lightfield(lightfield).gray()
    if rule not in PLANE_RULES:
        disparity_px = float(parse_plane_option(rule)) if disparity_px is None else disparity_px
        rule = "disparity_px"
    scan = detect_planes(lf, workers=workers) if scan is None else scan
    contents, best_px, bounds = (
        plane_contents(lf, scan, workers=workers) if scan.peaks else ([], None, None)
    )
    roi_m = None if roi is None else _roi_mask(roi, lf.shape_px, where)
    sup = [p.support if math.isfinite(p.support) else p.score for p in scan.peaks]
    top = max(sup, default=0.0)
    top_ev = max((p.evidence for p in scan.peaks if math.isfinite(p.evidence)), default=0.0)
    cands = []
    for p, s, c in zip(scan.peaks, sup, contents, strict=True):
        border = _border_share(c)
        why = []
        if s < SUPPORT_SHARE * top:
            why.append(f"support {s:.3g} < {SUPPORT_SHARE:g} x strongest {top:.3g}")
        if math.isfinite(p.evidence) and p.evidence < SUPPORT_SHARE * top_ev:
            why.append(f"evidence {p.evidence:.3g} < {SUPPORT_SHARE:g} x strongest {top_ev:.3g}")
        if border > BORDER_SHARE:
            why.append(f"{100 * border:.0f} % of its content in the border frame")
        cands.append(
            PlaneCandidate(
                disparity_px=p.disparity_px,
                depth_m=p.depth_m,
                support=s,
                evidence=p.evidence,
                border_share=border,
                roi_share=None if roi_m is None else float((c & roi_m).sum() / roi_m.sum()),
                rejected="; ".join(why),
            )
        )
    marginal = ""
    if depth_m is not None or disparity_px is not None:
        if depth_m is not None:
            d, how = float(lf.disparity_px(depth_m)), "depth_m"
        else:
            d, how = float(disparity_px), rule if rule == "disparity_px" else "disparity_px"
            if not math.isfinite(d):
                raise InputError(f"{where}: plane disparity must be finite, got {disparity_px!r}")
        k = _hill_of(d, bounds)
        span = float(np.ptp(scan.disparities_px))
        if k is not None and abs(scan.peaks[k].disparity_px - d) > NEAR_PEAK_SHARE * span:
            k = None
        if k is None:
            marginal = f"the given plane {d:.4g} px/view lies on no detected plane"
            content = np.zeros(lf.shape_px, bool) if best_px is None else _near(best_px, d, scan)
        else:
            content = contents[k]
    else:
        if not scan.peaks:
            raise InputError(f"{where}: no object plane found in the depth scan")
        if roi_m is not None:
            k, how = int(np.argmax([c.roi_share for c in cands])), "roi"
        elif rule == "strongest":
            k, how = int(np.argmax(sup)), "strongest"
        elif rule == "nearest":
            k, how = 0, "nearest"
        else:
            passing = [i for i, c in enumerate(cands) if not c.rejected]
            how = "auto"
            if passing:
                k = passing[0]  # peaks are nearest first
            else:
                k = int(np.argmax(sup))
                marginal = "no detected plane passed the default rule; took the strongest"
        d = scan.peaks[k].disparity_px
        content = contents[k]
    if roi_m is not None:
        content = roi_m
    on = None if k is None else scan.peaks[k]
    on_plane = None
    if best_px is not None:
        span = None if k is None else plane_extent(scan, k)
        on_plane = _on_plane(best_px, float(d), lf, span)
    return PlaneChoice(
        disparity_px=float(d),
        depth_m=lf.depth_m(d),
        support=math.nan if on is None else float(sup[k]),
        evidence=math.nan if on is None else float(on.evidence),
        rule=how,
        candidates=tuple(cands),
        marginal=marginal,
        content=content,
        view_crop=lf.meta.get("view_crop") if isinstance(lightfield, LightField) else None,
        on_plane=on_plane,
        reach_px=0 if on_plane is None else support_reach_px(scan),
        baseline_axes=_baseline_axes(lf.grid),
    )


def _baseline_axes(grid) -> tuple[int, ...]:
    from stimuli.edgedepth import baseline_axes

    return baseline_axes(grid)


def support_reach_px(scan: PlaneScan) -> int:
    """Return how far around a pixel the scan looks to give it a best plane, full-res px.

    The sweep sums the views' differences over a :data:`stimuli.agreementscan.COST_WINDOW_PX`
    box of the views binned by ``scan.binning``: half that box's side, in full-resolution
    pixels, rounded up. Near an occluding outline the box straddles object and background, so
    the outline itself lies up to this far outside the plane's support (Middlebury Baby1: the
    drum's top edge, 5-10 working px above its support at binning 3).

    Examples
    --------
    >>> from stimuli.planescan import PlaneScan
    >>> support_reach_px(PlaneScan(np.zeros(3), None, np.zeros(3), (), binning=3))
    8
    """
    from stimuli.agreementscan import COST_WINDOW_PX

    return int(math.ceil(int(scan.binning) * COST_WINDOW_PX / 2))


def plane_extent(scan: PlaneScan, k: int) -> tuple[float, float]:
    """Return the disparities a detected plane's object spans, from the support curve.

    The span of the peak's hill (between the curve's minima towards the neighbouring detected
    planes) where the smoothed support stands above half the peak's prominence over its base:
    the width at half prominence. An object that is not flat (a curved pedestal, a plant's
    leaves) spreads its pixels over a band of disparities around its peak; the band is the
    data's, so a thin object gives a narrow band and a deep one a wide band.

    Parameters
    ----------
    scan : PlaneScan
    k : int
        Index into ``scan.peaks``.

    Returns
    -------
    (low, high) : tuple of float
        Pixels per view step, ``low <= peak <= high``.
    """
    s = np.asarray(scan.scores, dtype=np.float64)
    ds = np.asarray(scan.disparities_px, dtype=np.float64)
    p = scan.peaks[k]
    lo, hi = _hill_bounds(scan)[k]
    i = int(p.index)
    level = s[i] - 0.5 * p.prominence
    a = i
    while a > lo and s[a - 1] >= level:
        a -= 1
    b = i
    while b < hi - 1 and s[b + 1] >= level:
        b += 1
    lo_d, hi_d = sorted((float(ds[a]), float(ds[b])))
    return min(lo_d, p.disparity_px), max(hi_d, p.disparity_px)


def _on_plane(
    best_px: np.ndarray, d: float, lf: LightField, span: tuple[float, float] | None = None
) -> np.ndarray:
    """Pixels on the plane ``d``: best plane within :data:`SUPPORT_BLUR_PX` of blur of it.

    With ``span`` (the detected plane's :func:`plane_extent`), also every pixel whose best plane
    lies within that band, widened by the same tolerance.
    """
    n_u, n_v = lf.grid
    reach = max(n_u // 2, n_u - 1 - n_u // 2, n_v // 2, n_v - 1 - n_v // 2, 1)
    tol = SUPPORT_BLUR_PX / reach
    with np.errstate(invalid="ignore"):
        out = np.abs(best_px - d) <= tol
        if span is not None:
            out |= (best_px >= span[0] - tol) & (best_px <= span[1] + tol)
    return out


def _hill_of(d: float, bounds: np.ndarray | None) -> int | None:
    if bounds is None:
        return None
    for k, (lo, hi) in enumerate(bounds):
        if lo <= d < hi:
            return k
    return None


def _near(best_px: np.ndarray, d: float, scan: PlaneScan) -> np.ndarray:
    """Pixels agreeing within one smoothing step of ``d`` (a plane on no detected hill)."""
    step = median_spacing(scan.disparities_px) * 2
    with np.errstate(invalid="ignore"):
        return np.abs(best_px - d) <= step
