"""Depth for the edges a light field's views cannot measure (ours, beyond the paper).

With the views along one line (a 1-D light field: one row or one column of views), an edge
parallel to that baseline looks the same in every view whatever its depth: shifting it along
itself changes nothing, so the views "agree" on it at every plane and the view-agreement test
of :func:`stimuli.declutter.in_focus_mask` keeps it wherever it lies. Such edges carry their
depth only through what they connect to.

:func:`resolve_edge_depth` therefore

1. gives every edge pixel of the confocal image a *depth confidence* from its orientation
   relative to the baseline: the share of the Sobel gradient around it (a
   :data:`CONFIDENCE_WINDOW_PX` box, the scale of the views' agreement test) that lies along
   the baseline (about 1 for an edge across the baseline, 0 for one along it, 0.7 for a
   texture or a corner). A pixel is *measured* when it reaches :data:`MIN_CONFIDENCE`; on a 2-D
   grid every direction is measured along one axis or the other, so nothing changes there;
2. splits the unmeasured edge pixels into segments (8-connected; cut where a measured edge
   passes within :data:`CONTACT_RADIUS_PX`, so that a box's top edge and a background line
   continuing it past the corner are two segments) and lets each segment take the depth of the
   measured structure at its two *end points* (its first and last pixel along the baseline):
   a measured edge that ends where the segment ends (a corner: the box's side ending at its
   top edge) votes with the views' verdict where the two touch; a measured edge that runs on
   past the contact on both sides (a T-junction: a background stripe disappearing behind the
   box's side) is the occluder's, not the segment's, and gives no vote; contacts along the
   middle of a segment (crossings) give none either;
3. a segment with an end on a corner in focus and none on a corner off the plane is kept as
   the views say; a segment with an end on a corner off the plane, or that runs off the image
   along the baseline (a line continuing past the frame, like the wall's stripes, is
   background: a foreground outline closes inside the picture), is *resolved off the plane*
   and dropped (:data:`stimuli.declutter.FOCUS_DROP`, whatever its neighbours say); a segment
   with no vote stays *unresolved* and keeps the views' verdict. Both are counted
   (:class:`EdgeDepthStats`).

Unresolved segments are kept, not dropped: on the shared Middlebury captures (ground-truth
disparity; ``tests/stimuli/test_lf_stimuli.py``), dropping them took the L8 share of white
pixels on the plane from 0.67 to 0.49 (Baby1) and from 0.93 to 0.77 (Aloe): most of them are
the object's own edges (the pedestal's rim, the leaves) whose ends are not in the picture's
corners. Dropping only what resolves off the plane gives 0.74 and 0.95 (measured with
``stimuli.retention`` thresholds at full resolution).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = [
    "CONFIDENCE_WINDOW_PX",
    "CONTACT_RADIUS_PX",
    "EdgeDepthStats",
    "MIN_CONFIDENCE",
    "PASS_THROUGH_PX",
    "baseline_axes",
    "edge_confidence",
    "resolve_edge_depth",
]

#: An edge pixel's depth is measured by the views when at least this share of its gradient lies
#: along the baseline (ours: sin 24 degrees; a one-pixel shift along the baseline then moves
#: the edge by 0.4 px, which the agreement test's 1 px tolerance still tells from no shift).
MIN_CONFIDENCE: float = 0.4

#: The neighbourhood whose gradients give a pixel's confidence, px (ours: a little more than the
#: 3x3 box the views' agreement test compares, so a corner's both edges are seen).
CONFIDENCE_WINDOW_PX: int = 5


#: Unmeasured edge pixels within this many pixels of a measured edge are junction pixels: they
#: cut the unmeasured edges into segments there and go with the segment they complete; a
#: measured edge within one more pixel of a segment touches it (ours: Sobel's edges are 2-3 px
#: wide, so the two meet within 2 px at a corner).
CONTACT_RADIUS_PX: int = 2

#: A measured edge that extends this many pixels beyond the contact on both sides, across the
#: baseline, runs past the segment's end (a T-junction, where the segment is occluded) rather
#: than turning there (a corner) (ours: more than an edge's width and the contact radius).
PASS_THROUGH_PX: int = 5


@dataclass(frozen=True)
class EdgeDepthStats:
    """How much of a confocal image's edges the views could not measure, and what became of it.

    Parameters
    ----------
    edge_pixels : int
        Edge pixels of the confocal image (Sobel magnitude above half Otsu's threshold).
    unmeasured : int
        Of those, the pixels below :data:`MIN_CONFIDENCE`.
    resolved_in_focus, resolved_off_plane, unresolved : int
        Unmeasured pixels whose segment ends on a corner in focus (kept as the views say),
        that resolved off the plane (dropped), and that had no corner to take a depth from
        (kept as the views say).
    """

    edge_pixels: int = 0
    unmeasured: int = 0
    resolved_in_focus: int = 0
    resolved_off_plane: int = 0
    unresolved: int = 0

    def to_dict(self) -> dict:
        """Return the counts with the shares of the edge pixels dropped and left unresolved.

        ``dropped_share`` is the share resolved off the plane, ``unresolved_share`` the share
        left unresolved.
        """
        d = asdict(self)
        n = self.edge_pixels
        d["dropped_share"] = self.resolved_off_plane / n if n else 0.0
        d["unresolved_share"] = self.unresolved / n if n else 0.0
        return d


def baseline_axes(grid: tuple[int, int]) -> tuple[int, ...]:
    """Image axes along which a grid of views is spread: 0 (rows of views), 1 (columns).

    Examples
    --------
    >>> baseline_axes((1, 7)), baseline_axes((7, 1)), baseline_axes((3, 3))
    ((1,), (0,), (0, 1))
    """
    n_u, n_v = (int(n) for n in grid)
    return tuple(a for a, n in ((0, n_u), (1, n_v)) if n > 1)


def edge_confidence(image: np.ndarray, axes: tuple[int, ...]) -> np.ndarray:
    """Return each pixel's depth confidence.

    The confidence is the share of its neighbourhood's gradient along the baseline.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    axes : tuple of int
        Image axes the views are spread along (:func:`baseline_axes`).

    Returns
    -------
    ndarray of shape (rows, cols), float32 in [0, 1]
        ``sqrt(max over axes of E_axis / (E_0 + E_1))``, ``E_a`` the Sobel gradient energy
        along image axis ``a`` summed over a :data:`CONFIDENCE_WINDOW_PX` box (1 where there is
        no gradient: nothing to doubt). A long edge along the baseline scores about 0, a
        texture or a corner about 0.7 or more.

    Examples
    --------
    >>> img = np.zeros((9, 9), np.float32); img[5:] = 1.0  # a horizontal edge
    >>> float(edge_confidence(img, (1,))[5, 4]), float(edge_confidence(img, (0,))[5, 4])
    (0.0, 1.0)
    """
    img = np.asarray(image, dtype=np.float32)
    from scipy import ndimage  # here: scipy.ndimage costs the scan's exit 0.1-0.5 s

    return _confidence([ndimage.sobel(img, axis=a) for a in (0, 1)], axes)


def _confidence(grads, axes):
    """:func:`edge_confidence` from the image's Sobel gradients along axes 0 and 1."""
    w = CONFIDENCE_WINDOW_PX
    energy = [_box_mean(g**2, w) for g in grads]
    total = energy[0] + energy[1]
    along = np.max([energy[a] for a in axes], axis=0) if axes else np.zeros_like(total)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.where(total > 0, np.sqrt(along / total), 1.0)
    return c.astype(np.float32)


def resolve_edge_depth(
    confocal: np.ndarray, focus, grid: tuple[int, int]
) -> tuple[np.ndarray, EdgeDepthStats]:
    """Give the edges the views cannot measure the depth of what they end on (module notes).

    Parameters
    ----------
    confocal : ndarray of shape (rows, cols), float32 in [0, 1]
        The confocal image at the plane.
    focus : ndarray of shape (rows, cols), bool, or callable
        The views' agreement at the plane (:func:`stimuli.declutter.in_focus_mask`'s raw test),
        or a function that takes the edge pixels this function reads it at (bool image) and
        returns it, right at least there (:func:`stimuli.declutter.agreement_mask`'s
        ``where``).
    grid : (n_u, n_v)
        The light field's views.

    Returns
    -------
    evidence : ndarray of shape (rows, cols), uint8
        ``focus`` as 0 / 1, with the unmeasured edge pixels resolved off the plane set to 2
        (dropped: :data:`stimuli.declutter.FOCUS_DROP`).
    stats : EdgeDepthStats
    """
    img = np.asarray(confocal, dtype=np.float32)
    if callable(focus):
        at = focus
    else:
        mask = np.asarray(focus, dtype=bool)

        def at(_pixels):
            return mask

    axes = baseline_axes(grid)
    if len(axes) != 1:  # a 2-D grid measures every direction
        return at(np.zeros(img.shape, bool)).astype(np.uint8), EdgeDepthStats()
    classes = _edge_classes(img, axes[0])
    if classes is None:  # no gradient anywhere
        return at(np.zeros(img.shape, bool)).astype(np.uint8), EdgeDepthStats()
    low, measured, n_edges = classes

    def at_t(pixels):  # the views' verdict, read where the vote reads it
        return np.asarray(at(pixels), dtype=bool)

    if axes[0] == 0:  # work with the baseline along the columns
        low, measured = low.T, measured.T

        def at_t(pixels):
            return np.asarray(at(np.ascontiguousarray(pixels.T)), dtype=bool).T

    seg_in, seg_off, focus = _vote(low, measured, at_t)
    if axes[0] == 0:
        seg_in, seg_off, low, focus = seg_in.T, seg_off.T, low.T, focus.T
    out = focus.astype(np.uint8)
    out[seg_off] = 2  # resolved off the plane: dropped; the rest keeps the views' verdict
    n_low = int(np.count_nonzero(low))
    n_in = int(np.count_nonzero(seg_in & low))
    n_off = int(np.count_nonzero(seg_off & low))
    stats = EdgeDepthStats(
        edge_pixels=n_edges,
        unmeasured=n_low,
        resolved_in_focus=n_in,
        resolved_off_plane=n_off,
        unresolved=n_low - n_in - n_off,
    )
    return out, stats


def _vote(low: np.ndarray, measured: np.ndarray, at, *, compiled: bool = True):
    """Segments of ``low`` voted in focus by the measured edges they end on (baseline = x).

    ``at(pixels)`` returns the views' verdict (bool image), right at least at ``pixels``: it
    is asked only where the measured edges touch a segment. ``compiled``: the masks and labels
    in the lean passes of :mod:`stimuli.edgevote` (the default), or in the chain of
    ``scipy.ndimage``-equivalent filters and numpy temporaries; the same masks to the bit.

    Returns the masks of the segments resolved in focus and off the plane, and the verdict.
    """
    if compiled:
        return _vote_compiled(low, measured, at)
    r = CONTACT_RADIUS_PX
    # cut the unmeasured edges where measured ones pass (corners, junctions): a box's top edge
    # and a background line continuing it past the corner become two segments
    junction = low & _grow(measured, 2 * r + 1)
    seg, n_seg = _label8(low & ~junction)
    comp, n_comp = _label8(measured)
    if n_seg == 0 or n_comp == 0:
        return np.zeros_like(low), np.zeros_like(low), at(np.zeros_like(low))
    top, bottom, _, _ = _extents(comp, n_comp)  # bounding boxes: extents in one pass each
    _, _, left, right = _extents(seg, n_seg)
    # each measured pixel near a segment: which segment (the largest label nearby)
    near = _box_max(seg, 2 * (r + 1) + 1)
    touch = measured & (near > 0)
    focus = at(touch)
    if not touch.any():
        return np.zeros_like(low), np.zeros_like(low), focus
    y, x = np.nonzero(touch)  # the order of a boolean mask's selection, found once
    keep, off = _decide(y, x, near, comp, focus, (top, bottom, left, right), low.shape[1])
    kept, dropped = keep[seg], off[seg]
    # a junction pixel goes with a segment it touches (the corner of the box's outline), kept
    # first
    kept |= junction & _grow(kept, 2 * r + 3)
    dropped |= junction & ~kept & _grow(dropped, 2 * r + 3)
    return kept, dropped, focus


def _vote_compiled(low: np.ndarray, measured: np.ndarray, at):
    """:func:`_vote` in the compiled passes of :mod:`stimuli.edgevote`, the same masks."""
    from stimuli import edgevote

    r = CONTACT_RADIUS_PX
    low8 = np.ascontiguousarray(low).view(np.uint8)
    meas8 = np.ascontiguousarray(measured).view(np.uint8)
    junction, rest = np.empty_like(low8), np.empty_like(low8)
    edgevote.split_junctions(low8, meas8, 2 * r + 1, junction, rest)
    seg, comp = np.empty(low8.shape, np.int32), np.empty(low8.shape, np.int32)
    n_seg, _, _, left, right = edgevote.label8_extents(rest, seg)
    n_comp, top, bottom, _, _ = edgevote.label8_extents(meas8, comp)
    if n_seg == 0 or n_comp == 0:
        return np.zeros_like(low), np.zeros_like(low), at(np.zeros_like(low))
    near = _box_max(seg, 2 * (r + 1) + 1)
    touch, y, x = edgevote.touch_pairs(meas8, near)
    focus = at(touch.view(bool))
    if not y.size:
        return np.zeros_like(low), np.zeros_like(low), focus
    keep, off = _decide(y, x, near, comp, focus, (top, bottom, left, right), low.shape[1])
    kept, dropped = np.empty_like(low8), np.empty_like(low8)
    edgevote.settle(
        seg, keep.view(np.uint8), off.view(np.uint8), junction, 2 * r + 3, kept, dropped
    )
    return kept.view(bool), dropped.view(bool), focus


def _decide(y, x, near, comp, focus, extents, cols):
    """Return which segments are kept and which dropped (bool per label, 0 the background).

    From the measured pixels ``(y, x)`` that touch a segment (``near``: the segment, ``comp``:
    the measured component, ``focus``: the views' verdict there), the components' top and
    bottom rows and the segments' left and right columns (``extents``), and the image's width.
    """
    top, bottom, left, right = extents
    r = CONTACT_RADIUS_PX
    n_comp, n_seg = len(top), len(left)
    s, c = near[y, x], comp[y, x]
    key = s.astype(np.int64) * (n_comp + 1) + c
    uniq, inv = np.unique(key, return_inverse=True)
    n = np.bincount(inv)
    y_mean, x_mean = np.bincount(inv, weights=y) / n, np.bincount(inv, weights=x) / n
    at_contact = np.bincount(inv, weights=focus[y, x]) / n >= 0.5  # the depth at the corner
    seg_of, comp_of = uniq // (n_comp + 1), uniq % (n_comp + 1)
    t, b = top[comp_of - 1], bottom[comp_of - 1]
    through = (t < y_mean - PASS_THROUGH_PX) & (b > y_mean + PASS_THROUGH_PX)
    # a corner votes with the views' verdict where it touches; a T-junction says nothing
    vote = np.where(through, 0, np.where(at_contact, 1, -1))
    reach = r + 3
    at_left = x_mean - left[seg_of - 1] <= reach
    at_right = right[seg_of - 1] - x_mean <= reach
    ends = []
    for at in (at_left, at_right):  # each end's verdict: the sum of its corners' votes
        score = np.zeros(n_seg + 1, np.int64)
        np.add.at(score, seg_of[at], vote[at])
        ends.append(score)
    # kept: an end on a corner in focus, no end on a corner off the plane, and no end running
    # off the image along the baseline (a line continuing past the frame, such as a wall's
    # stripe continuing the box's edge past its corner, is not the box's)
    off_frame = np.zeros(n_seg + 1, bool)
    off_frame[1:] = (left <= r) | (right >= cols - 1 - r)
    keep = ((ends[0] > 0) | (ends[1] > 0)) & (ends[0] >= 0) & (ends[1] >= 0) & ~off_frame
    off = ~keep & ((ends[0] < 0) | (ends[1] < 0) | off_frame)
    keep[0] = off[0] = False
    return keep, off


def _edge_classes(img: np.ndarray, axis: int):
    """Return the unmeasured and the measured edge pixels and the number of edge pixels.

    Edge pixels: the magnitude of :func:`_edge_field` above half its Otsu threshold; unmeasured:
    those whose confidence is below :data:`MIN_CONFIDENCE` (and magnitude above 0). ``None``
    where the magnitude is 0 everywhere. Two compiled passes where every side is longer than
    :data:`CONFIDENCE_WINDOW_PX` (:func:`stimuli.edgefield.edge_energy` and
    :func:`stimuli.edgefield.edge_classes`; neither keeps the confidence image), else
    the numpy chain; the same pixels.
    """
    from stimuli.otsu import otsu_threshold

    if min(img.shape) <= CONFIDENCE_WINDOW_PX:
        mag, conf = _edge_field(img, (axis,))
        if float(mag.max()) <= 0.0:
            return None
        edges = mag > 0.5 * otsu_threshold(mag)
        low_all = (conf < MIN_CONFIDENCE) & (mag > 0)
        return edges & low_all, edges & ~low_all, int(edges.sum())
    from stimuli.edgefield import edge_classes, edge_energy

    img = np.ascontiguousarray(img, dtype=np.float32)
    mag, e0, e1 = np.empty_like(img), np.empty_like(img), np.empty_like(img)
    lo, hi = edge_energy(img, mag, e0, e1)
    if float(hi) <= 0.0:
        return None
    threshold = np.float32(0.5 * otsu_threshold(mag, extrema=(lo, hi)))  # compared in float32
    low, measured = np.empty(img.shape, np.uint8), np.empty(img.shape, np.uint8)
    n_edges, _ = edge_classes(
        e0,
        e1,
        mag,
        axis,
        CONFIDENCE_WINDOW_PX,
        threshold,
        np.float32(MIN_CONFIDENCE),
        low,
        measured,
    )
    return low.view(bool), measured.view(bool), int(n_edges)


def _edge_field(img: np.ndarray, axes: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Return the Sobel magnitude ``np.hypot`` of :func:`_sobel_pair` and :func:`_confidence`.

    One compiled call where every side is longer than :data:`CONFIDENCE_WINDOW_PX`
    (:func:`stimuli.edgekernels.edge_field`, the same values to the bit), else the numpy twin.
    """
    if len(axes) != 1 or min(img.shape) <= CONFIDENCE_WINDOW_PX:
        grads = _sobel_pair(img)
        return np.hypot(*grads), _confidence(grads, axes)
    from stimuli.edgekernels import edge_field

    img = np.ascontiguousarray(img, dtype=np.float32)
    mag, conf = np.empty_like(img), np.empty_like(img)
    edge_field(img, axes[0], CONFIDENCE_WINDOW_PX, mag, conf)
    return mag, conf


def _sobel_pair(img: np.ndarray) -> list[np.ndarray]:
    """Compute ``[ndimage.sobel(img, axis=a) for a in (0, 1)]`` in one compiled call.

    The result is the same to the bit (:func:`stimuli.kernels.sobel_pair`).
    """
    from stimuli.kernels import sobel_pair

    img = np.ascontiguousarray(img, dtype=np.float32)
    gy, gx = np.empty_like(img), np.empty_like(img)
    sobel_pair(img, gy, gx)
    return [gy, gx]


def _box_mean(a: np.ndarray, size: int) -> np.ndarray:
    """Compute ``ndimage.uniform_filter(a, size)`` of a float32 image.

    It is compiled where every side is longer than ``size``
    (:func:`stimuli.kernels.box_mean_reflect`, to the bit).
    """
    if min(a.shape) <= size:
        from scipy import ndimage

        return ndimage.uniform_filter(a, size)
    from stimuli.kernels import box_mean_reflect

    out = np.empty_like(a)
    box_mean_reflect(np.ascontiguousarray(a), size, out)
    return out


def _label8(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """``scipy.ndimage.label(mask, np.ones((3, 3)))`` in one compiled call, to the bit.

    :func:`stimuli.edgekernels.label8`: the same numbering (first pixels in raster order).
    """
    from stimuli.edgekernels import label8

    m = np.ascontiguousarray(mask, dtype=bool)
    out = np.empty(m.shape, np.int32)
    n = label8(m.view(np.uint8), out) if m.size else 0
    return out, int(n)


def _extents(labels: np.ndarray, n: int):
    """Return top, bottom, left and right (last row and column included) of labels ``1..n``.

    They are as ``scipy.ndimage.find_objects`` gives them
    (:func:`stimuli.kernels.label_extents`).
    """
    from stimuli.kernels import label_extents

    big = np.iinfo(np.int64).max
    top, left = np.full(n, big, np.int64), np.full(n, big, np.int64)
    bottom, right = np.full(n, -1, np.int64), np.full(n, -1, np.int64)
    label_extents(np.ascontiguousarray(labels), n, top, bottom, left, right)
    return top, bottom, left, right


def _grow(mask: np.ndarray, size: int) -> np.ndarray:
    """``mask`` dilated by a ``size`` x ``size`` square (two separable running maxima)."""
    return _box_max(mask.view(np.uint8), size) > 0


def _box_max(a: np.ndarray, size: int) -> np.ndarray:
    """Return the largest value in the ``size`` x ``size`` box around each pixel (values >= 0).

    It is ``scipy.ndimage.maximum_filter`` / ``grey_dilation`` in one compiled call
    (:func:`stimuli.kernels.box_max`).
    """
    from stimuli.kernels import box_max

    a = np.ascontiguousarray(a)
    out = np.empty_like(a)
    box_max(a, size, out)
    return out
