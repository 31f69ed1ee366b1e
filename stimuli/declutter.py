"""Confocal de-cluttering: Sobel edge magnitude and a threshold (Jung et al. 2015, Sec. 2.2).

The blurred background of a confocal (narrow depth-of-field or refocused) image has weak
gradients, so thresholding the Sobel magnitude keeps the in-focus object's edges and drops the
background. The paper set the threshold by hand per confocal image and applied the same value to
the paired wide-DOF image.

Automatic threshold (ours, not the paper's)
-------------------------------------------
:func:`auto_threshold` replaces the paper's hand setting. It splits the histogram of the
narrow-DOF image's Sobel magnitude into two classes, "weak gradients" (flat regions and the
defocused background) and "strong gradients" (in-focus edges), with Otsu's (1979) method, which
maximises the between-class variance. We also implemented the triangle method (Zack, Rogers &
Latt 1977), the usual choice for unimodal, long-tailed histograms such as gradient magnitudes.
On the six real depth-of-field pairs in ``dof_pairs/`` (VABD and EBB! training pairs, at the
492x327 working size), Otsu kept the in-focus object's edges and dropped the blurred background
in all six: the share of edge pixels inside the in-focus mask rose from 2-40 % (wide DOF) to
4-66 % (narrow DOF). The triangle method failed on VABD 0001 (a street lamp against a flat sky:
the spike of zero gradients put the threshold at 0.015, keeping 56 % of all pixels, background
included), so Otsu is the default. See ``tests/stimuli/test_real_pairs.py``.

References
----------
Otsu, N. (1979). A threshold selection method from gray-level histograms. IEEE Trans. Syst. Man
Cybern. 9(1), 62-66.
Zack, G. W., Rogers, W. E., & Latt, S. A. (1977). Automatic measurement of sister chromatid
exchange frequency. J. Histochem. Cytochem. 25(7), 741-753.
"""

from __future__ import annotations

import weakref

import numpy as np

from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = [
    "sobel_magnitude",
    "declutter",
    "auto_threshold",
    "AUTO_THRESHOLD_METHODS",
    "DECLUTTER_MODES",
    "FOCUS_AGREEMENT_RATIO",
    "FOCUS_TOLERANCE_PX",
    "FOCUS_NOISE",
    "VOTE_WINDOW_PX",
    "in_focus_mask",
    "in_focus_evidence",
    "FOCUS_OUT",
    "FOCUS_IN",
    "FOCUS_DROP",
    "agreement_mask",
    "declutter_depth",
    "bokeh_guard",
    "BOKEH_GUARD_RADIUS_PX",
    "AGREE_THREAD_MIN_TESTS",
    "OVERLAP_MIN_TESTS",
    "OVERLAP_MIN_FREE_CORES",
    "STRIPS_MIN_FREE_CORES",
]

#: Automatic threshold methods, by name (ours, not the paper's: the paper set it by hand).
AUTO_THRESHOLD_METHODS: tuple[str, ...] = ("otsu", "triangle")

#: Histogram bins for the automatic threshold. 256 bins over the magnitude range resolve
#: thresholds to about 0.003 on the Sobel scale, finer than the 8-bit input quantisation.
_N_BINS = 256


def sobel_magnitude(image: np.ndarray) -> np.ndarray:
    """Return the Sobel gradient magnitude of a grey image (``skimage.filters.sobel``).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float in [0, 1] or bool

    Returns
    -------
    ndarray of shape (rows, cols), float32 >= 0
        ``sqrt((Gx**2 + Gy**2) / 2)`` as scikit-image defines it (so a unit step gives about
        0.7 at the edge), equal to ``skimage.filters.sobel`` of the float32 image to the bit.
        One compiled pass (:func:`stimuli.kernels.sobel_rows`) on strips of rows in threads;
        the same pass checks that every value is in [0, 1].

    Raises
    ------
    InputError
        If the image is not 2-D, not float or bool, or has values outside [0, 1] (or NaN).
    """
    from stimuli import numpykernels
    from stimuli.rowthreads import default_workers, run_on_row_strips

    a = np.asarray(image)
    if a.ndim != 2 or not (a.dtype == bool or np.issubdtype(a.dtype, np.floating)):
        check_gray(a)  # raises, naming what is wrong
    img = np.ascontiguousarray(a, dtype=np.float32)
    out = np.empty(img.shape, dtype=np.float32)
    if numpykernels.active() and img.size:  # a scan's last steps: the numpy twin, to the bit
        if numpykernels.sobel(img, out):
            check_gray(a)
        return out
    from stimuli.kernels import sobel_rows

    rows = img.shape[0]
    n = 1 if img.size < _THREAD_MIN_PIXELS else min(default_workers(), rows // _STRIP_MIN_ROWS)
    if rows and img.shape[1]:
        outside = sum(run_on_row_strips(lambda r0, r1: sobel_rows(img, out, r0, r1), rows, n))
        if outside:
            check_gray(a)  # raises with the range or the NaN
    return out


#: Images of fewer pixels than this take the Sobel filter in one piece (ours: below it the
#: threads cost more than they save; on a shared 2-core machine the hand-off to a second
#: thread cost more than the 0.3-0.5 ms it saves on the 555x620 and 1024x1024 images).
_THREAD_MIN_PIXELS = 1 << 21

#: Sobel strips are at least this many rows high (ours).
_STRIP_MIN_ROWS = 64


def declutter(image: np.ndarray, *, threshold: float) -> np.ndarray:
    """Return the edge image: Sobel magnitude above ``threshold``.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
    threshold : float >= 0
        On the scale of :func:`sobel_magnitude`.

    Returns
    -------
    ndarray of shape (rows, cols), bool

    References
    ----------
    Jung et al. (2015), Sec. 2.2 ("Sobel edge detection ... threshold").
    """
    try:
        t = float(threshold)
    except (TypeError, ValueError):
        raise InputError(f"threshold must be a number, got {threshold!r}") from None
    if not np.isfinite(t) or t < 0:
        raise InputError(f"threshold must be a finite number >= 0, got {threshold!r}")
    return sobel_magnitude(image) > t


def auto_threshold(image: np.ndarray, *, method: str = "otsu") -> float:
    """Choose a Sobel threshold automatically on a narrow-DOF (confocal) image.

    The threshold separates the strong gradients of the in-focus object from the weak gradients
    of flat regions and of the defocused background, so that the background drops out of the
    edge image (the paper's goal when it set the threshold by hand).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
        The narrow-DOF (confocal) image at the working size.
    method : {'otsu', 'triangle'}
        ``'otsu'``: Otsu (1979) on the histogram of the Sobel magnitude. ``'triangle'``: Zack et
        al. (1977), the triangle method for unimodal histograms.

    Returns
    -------
    float >= 0
        Threshold on the scale of :func:`sobel_magnitude`; 0.0 for an image with no gradients.

    Raises
    ------
    InputError
        If ``method`` is not one of :data:`AUTO_THRESHOLD_METHODS` or ``image`` is not a grey
        image in [0, 1].

    References
    ----------
    Otsu (1979); Zack, Rogers & Latt (1977); Jung et al. (2015), Sec. 2.2 (hand-set threshold).

    Examples
    --------
    >>> img = np.zeros((32, 32), np.float32); img[:, 16:] = 1.0
    >>> t = auto_threshold(img)
    >>> bool(declutter(img, threshold=t)[:, 15:17].all())
    True
    """
    if method not in AUTO_THRESHOLD_METHODS:
        raise InputError(f"method must be one of {AUTO_THRESHOLD_METHODS}, got {method!r}")
    mag = sobel_magnitude(image)
    if mag.size == 0 or float(mag.max()) == float(mag.min()):
        return 0.0
    if method == "otsu":
        from stimuli.otsu import otsu_threshold

        t = otsu_threshold(mag)
    else:
        from skimage.filters import threshold_triangle

        t = threshold_triangle(mag, nbins=_N_BINS)
    return max(0.0, float(t))


# --------------------------------------------------------------------------------------------
# Depth de-cluttering from a light field (ours, beyond the paper)
# --------------------------------------------------------------------------------------------

#: De-cluttering modes: ``'sobel'`` (the paper's Sobel + threshold, the default) and ``'depth'``
#: (Sobel edges kept only where the light field's views agree at the plane).
DECLUTTER_MODES: tuple[str, ...] = ("sobel", "depth")

#: A pixel is in focus at a plane when its neighbouring views, aligned at that plane, differ
#: from the centre view by less than this fraction of what a one-pixel misalignment of the
#: centre view gives there (ours: "less than half a pixel out of register").
FOCUS_AGREEMENT_RATIO: float = 0.5

#: Differences below this (grey levels in [0, 1]) are noise (ours: two levels of 8-bit data):
#: where a one-pixel shift changes nothing (an edge along the views' axis, a flat patch) the
#: views carry no depth information and the pixel is not removed.
FOCUS_NOISE: float = 2.0 / 255.0

#: Depth of field of the test, pixels per view step on either side of the plane (ours: one pixel
#: of the neighbouring views; real objects are not flat, Middlebury's doll spans 2.5 px).
FOCUS_TOLERANCE_PX: float = 1.0

#: Planes sampled per pixel per view step inside the tolerance (ours: quarter-pixel steps).
_FOCUS_STEPS_PER_PX = 4

#: Values of :func:`in_focus_evidence`: out of focus, in focus, and dropped whatever the
#: neighbours say (an edge whose depth the views cannot measure, resolved off the plane).
FOCUS_OUT, FOCUS_IN, FOCUS_DROP = 0, 1, 2

#: An edge pixel is kept when at least half of the edge pixels in this box around it are in
#: focus (ours: a local majority, so single noisy pixels neither keep nor drop an edge).
VOTE_WINDOW_PX: int = 9


def _sample(padded: np.ndarray, pad: int, shift_px: float, axis: int, n: int) -> np.ndarray:
    """Return an edge-padded image sampled at ``x - shift_px`` along ``axis`` (linear interp.).

    ``padded`` is the image padded by ``pad`` samples (edge values) along ``axis``; ``n`` is the
    image's length along it.
    """
    k = int(np.floor(shift_px))
    f = np.float32(shift_px - k)
    if abs(k) + 1 > pad:
        raise InputError(f"shift {shift_px:g} px exceeds the padding {pad} px")
    a0 = pad - k
    idx_a = [slice(None)] * padded.ndim
    idx_b = [slice(None)] * padded.ndim
    idx_a[axis] = slice(a0, a0 + n)
    idx_b[axis] = slice(a0 - 1, a0 - 1 + n)
    a = padded[tuple(idx_a)]
    b = padded[tuple(idx_b)]
    return a + f * (b - a)


def in_focus_mask(
    lightfield,
    slope_px_per_view: float,
    *,
    tolerance_px: float = FOCUS_TOLERANCE_PX,
) -> np.ndarray:
    """Return where a light field is in focus at one plane (bool).

    That is where :func:`in_focus_evidence` equals :data:`FOCUS_IN`.
    """
    return in_focus_evidence(lightfield, slope_px_per_view, tolerance_px=tolerance_px)[0] == 1


def in_focus_evidence(
    lightfield,
    slope_px_per_view: float,
    *,
    tolerance_px: float = FOCUS_TOLERANCE_PX,
    confocal: np.ndarray | None = None,
    where: np.ndarray | None = None,
):
    """Return where a light field is in focus at one plane, and what its edges' depth cost.

    The views' agreement (:func:`agreement_mask`); on a 1-D light field the edges the views
    cannot measure (parallel to the baseline) then take the depth of the measured edges they
    end on, and those that resolve off the plane are dropped
    (:func:`stimuli.edgedepth.resolve_edge_depth`).

    ``confocal``: the confocal image at the plane, if the caller has it (refocused otherwise,
    on 1-D light fields).

    ``where``: the pixels the caller will read (bool image; :func:`declutter_depth` reads only
    its edge pixels): the views' agreement is then tested there and at the edge pixels the
    depth of unmeasured edges is taken from (:func:`agreement_mask`'s ``where``), the same
    evidence at those pixels, to the bit, as without it. On a 1-D light field with many edge
    pixels (:data:`OVERLAP_MIN_TESTS`) and a core standing idle
    (:data:`OVERLAP_MIN_FREE_CORES`), the agreement at ``where`` runs on a second
    thread while the edge classes and segments are made, and the few pixels the
    segment vote adds are tested after it; the same evidence, to the bit.

    Returns
    -------
    evidence : ndarray of shape (rows, cols), uint8
        :data:`FOCUS_OUT` (0), :data:`FOCUS_IN` (1) or :data:`FOCUS_DROP` (2: an edge whose
        depth the views cannot measure and that resolved off the plane;
        :func:`declutter_depth` drops it whatever its neighbours say).
    stats : stimuli.edgedepth.EdgeDepthStats
        How many edge pixels the views could not measure, and what became of them.
    """
    from stimuli.edgedepth import EdgeDepthStats, baseline_axes, resolve_edge_depth
    from stimuli.lfload import as_lightfield

    lf = as_lightfield(lightfield).gray()

    def mask(pixels=None):
        w = None if where is None else (where if pixels is None else where | pixels)
        return agreement_mask(lf, slope_px_per_view, tolerance_px=tolerance_px, where=w)

    if len(baseline_axes(lf.grid)) != 1:
        return mask().astype(np.uint8), EdgeDepthStats()
    if confocal is None:
        from stimuli.refocus import refocus

        confocal = np.clip(refocus(lf, float(slope_px_per_view)), 0.0, 1.0).astype(np.float32)
    if where is None:
        return resolve_edge_depth(confocal, mask(), lf.grid)
    started = _start_agreement(lf, slope_px_per_view, tolerance_px, where)
    if started is None:
        return resolve_edge_depth(confocal, mask, lf.grid)

    job, got = started

    def beside(pixels):  # the test at ``where`` made beside the edge classes; the rest here
        job.finish()
        more = pixels & ~where
        if more.any():
            return got | agreement_mask(
                lf, slope_px_per_view, tolerance_px=tolerance_px, where=more, threads=1
            )
        return got

    try:
        return resolve_edge_depth(confocal, beside, lf.grid)
    finally:
        job.finish()  # never left running past the call (it writes the kept thresholds)


#: On a 1-D light field, the views' agreement at the edge pixels runs on a second thread
#: beside the edge classes and segments of :func:`stimuli.edgedepth.resolve_edge_depth` (which
#: do not need it until their last step) from this many edge pixels times neighbours (ours:
#: about 1 ms of work on one thread, where the hand-off, tens of microseconds, is small beside
#: what it hides; on the 1x7 of 555x620 the agreement, 2-4 ms, is hidden behind the edge
#: classes, 8-10 ms).
OVERLAP_MIN_TESTS = 20_000

#: The agreement test runs beside the edge classes only where at least this many cores stand
#: idle beside the caller's (:func:`stimuli.rowthreads.cores_free`: CPUs less the last
#: minute's load average, which counts the caller), and takes a second strip of rows only
#: where :data:`STRIPS_MIN_FREE_CORES` do (ours, on the shared 2-core machine: with two other
#: busy processes (no core free) the overlap cost 1.1-1.6 ms on the 1x7 of 555x620 and on
#: Baby1 and the second strip 0.4-0.5 ms, the second thread waiting for a core; at a load of
#: about 1.6 the overlap still cost 1.2-1.5 ms while the second strip took the 3x3 of
#: 1024x1024 from 37 to 22 ms).
OVERLAP_MIN_FREE_CORES = 0.5
STRIPS_MIN_FREE_CORES = 0.0


def _start_agreement(lf, d, tolerance_px, where):
    """Start :func:`agreement_mask` at ``where`` on a second thread where that pays; else None.

    Returns the mask, filled once the returned job's ``finish`` returns (the caller takes the
    strips left when it is free). The verdict at each pixel does not depend on the others
    tested with it, so the test at ``where`` and then at the pixels the segment vote adds
    gives the verdict of one call at both, to the bit.
    """
    from stimuli.rowthreads import cores_free, default_workers

    w = np.asarray(where)
    if w.dtype != np.bool_ or w.shape != lf.shape_px or default_workers() < 2:
        return None
    if cores_free() < OVERLAP_MIN_FREE_CORES:
        return None
    n_u, n_v = lf.grid
    neighbours = sum(
        1
        for n, c in ((n_u, lf.centre_index[0]), (n_v, lf.centre_index[1]))
        for s in (-1, 1)
        if n > 1 and 0 <= c + s < n
    )
    if int(np.count_nonzero(w)) * neighbours < OVERLAP_MIN_TESTS:
        return None
    jobs = []
    mask = agreement_mask(lf, d, tolerance_px=tolerance_px, where=w, defer=jobs)
    if not jobs:  # nothing to test
        return None
    jobs[0].start()
    return jobs[0], mask


def agreement_mask(
    lightfield,
    slope_px_per_view: float,
    *,
    tolerance_px: float = FOCUS_TOLERANCE_PX,
    compiled: bool = True,
    where: np.ndarray | None = None,
    cache: bool = True,
    threads: int | None = None,
    defer: list | None = None,
) -> np.ndarray:
    """Return where a light field's views agree at one plane.

    For each of the (up to four) neighbours of the centre view on its row and column, the
    neighbour is aligned at disparities within ``tolerance_px`` of the plane and compared with
    the centre view (absolute difference, 3x3 box). A pixel is in focus when, for at least one
    neighbour (so that one side may be occluded) and one of those disparities, the difference is
    below :data:`FOCUS_AGREEMENT_RATIO` times the difference a one-pixel shift of the centre
    view makes there, plus :data:`FOCUS_NOISE`.

    Parameters
    ----------
    lightfield : LightField or ndarray of shape (n_u, n_v, rows, cols[, C]), float32 in [0, 1]
    slope_px_per_view : float
        The plane, pixels per view step (convention of :mod:`stimuli.lightfield`).
    tolerance_px : float >= 0
        Depth of field of the test, pixels per view step either side.
    compiled : bool
        One compiled pass per neighbour (:func:`stimuli.kernels.focus_agreement`, the
        default) or the numpy twin (a chain of full-image temporaries per disparity); the
        same mask to the bit.
    where : ndarray of shape (rows, cols), bool, optional
        Test only these pixels (the rest are False): the same verdict there, to the bit, at a
        cost that grows with their number (each pixel left at the first neighbour that
        agrees; :func:`stimuli.edgefocus.focus_agreement_at`, on two threads for many
        pixels where a core stands idle: :data:`AGREE_THREAD_MIN_TESTS`,
        :data:`STRIPS_MIN_FREE_CORES`). The depth de-clutter reads the test only at
        edge pixels.
    cache : bool
        With ``where``: take the test's threshold image (``ratio`` times the one-pixel-shift
        difference plus noise, per neighbour), which does not depend on the plane, from a cache
        kept per light-field object (made at the pixels first tested, dropped with the object;
        the views are not to be changed in place), the default; or make it again at the tested
        pixels. The same mask to the bit.
    threads : int, optional
        With ``where``: at most this many threads (default: two where the work and an idle
        core allow, as above); the same mask to the bit.
    defer : list, optional
        With ``where``: run nothing yet; append the test, a
        :class:`stimuli.sharedstrips.SharedStrips` that fills the returned mask (False until
        its ``finish`` returns; ``start`` begins it on a second thread), to this list.

    Returns
    -------
    ndarray of shape (rows, cols), bool
    """
    from stimuli.lfload import as_lightfield

    lf = as_lightfield(lightfield).gray()
    try:
        d0 = float(slope_px_per_view)
        tol = float(tolerance_px)
    except (TypeError, ValueError):
        raise InputError(
            f"slope_px_per_view and tolerance_px must be numbers, got {slope_px_per_view!r}, "
            f"{tolerance_px!r}"
        ) from None
    if not (np.isfinite(d0) and np.isfinite(tol) and tol >= 0):
        raise InputError(f"slope_px_per_view must be finite and tolerance_px >= 0, got {d0}, {tol}")
    views = lf.views
    n_u, n_v = lf.grid
    cu, cv = lf.centre_index
    centre = views[cu, cv]
    steps = max(1, int(np.ceil(2 * tol * _FOCUS_STEPS_PER_PX)))
    ds = np.linspace(d0 - tol, d0 + tol, steps + 1) if tol > 0 else np.array([d0])
    out = np.zeros(centre.shape, bool)
    if where is not None:
        w = np.asarray(where)
        if w.dtype != np.bool_ or w.shape != centre.shape:
            raise InputError(
                f"where must be a bool image of shape {centre.shape}, got {w.dtype} {w.shape}"
            )
        w8 = np.ascontiguousarray(w).view(np.uint8)
        ds = ds[np.argsort(np.abs(ds - d0), kind="stable")]  # the plane's own first
    if compiled or where is not None:
        from stimuli.kernels import focus_agreement

        c32 = np.ascontiguousarray(centre, dtype=np.float32)
    tests = []  # with ``where``: the neighbours' tests, run on strips of rows below
    for axis, n, c in ((0, n_u, cu), (1, n_v, cv)):
        if n < 2:
            continue
        for side in (-1, 1):
            if not 0 <= c + side < n:
                continue
            nb = views[cu + side, cv] if axis == 0 else views[cu, cv + side]
            r, noise = FOCUS_AGREEMENT_RATIO, FOCUS_NOISE
            if where is not None:  # the listed pixels only: the same verdict there
                nb32 = np.ascontiguousarray(nb, dtype=np.float32)
                # the threshold image is made at the pixels tested (NaN until then): kept per
                # light field with ``cache``, else made afresh for this call; the same verdict
                if cache:
                    limit = _focus_limit(lf, c32, axis, side)
                else:
                    limit = np.full(c32.shape, np.nan, np.float32)
                tests.append((nb32, axis, side, limit))
            elif compiled:  # one compiled call per neighbour: the same mask to the bit
                nb32 = np.ascontiguousarray(nb, dtype=np.float32)
                focus_agreement(c32, nb32, axis, side, ds.astype(np.float64), r, noise, out)
            else:
                out |= _agreement_numpy(centre, nb, axis, side, ds)
    if tests:
        _agree_at(c32, tests, ds.astype(np.float64), w8, out, threads, defer)
    return out


#: The agreement test at listed pixels runs on two threads (strips of rows with as many listed
#: pixels each) from this many listed pixels times neighbours (ours: about 2-4 ms of work on one
#: thread, where the hand-off, tens of microseconds, is small beside the half it saves).
AGREE_THREAD_MIN_TESTS = 150_000


def _agree_at(c32, tests, ds, w8, out, threads=None, defer=None) -> None:
    """Run each neighbour's test at the pixels of ``w8`` (:func:`agreement_mask`'s ``where``).

    On strips of rows, taken in turn by two threads where the work pays for them
    (:data:`AGREE_THREAD_MIN_TESTS`, :data:`STRIPS_MIN_FREE_CORES`;
    :data:`_SHARED_STRIPS` strips): each pixel's verdict
    reads only its own row of ``out`` and of the threshold images, so the strips give the
    verdict of one pass, to the bit.
    ``defer`` (a list): nothing runs here; a :class:`stimuli.sharedstrips.SharedStrips` of
    :data:`_SHARED_STRIPS` strips is appended to it (to start on a second thread and finish
    later; :func:`_start_agreement`).
    """
    from stimuli.edgefocus import focus_agreement_at
    from stimuli.rowthreads import cores_free, default_workers

    r, noise = FOCUS_AGREEMENT_RATIO, FOCUS_NOISE

    def work(rows):
        for nb32, axis, side, limit in tests:  # in order: a pixel in focus is not tried again
            focus_agreement_at(c32, nb32, axis, side, ds, r, noise, limit, w8, out, *rows)

    n_rows = w8.shape[0]
    per_row = np.count_nonzero(w8, axis=1)
    if defer is not None:
        from stimuli.sharedstrips import SharedStrips

        defer.append(SharedStrips(work, _strips(per_row, min(_SHARED_STRIPS, max(n_rows, 1)))))
        return
    n = (
        min(default_workers(), 2, threads or 2)
        if int(per_row.sum()) * len(tests) >= AGREE_THREAD_MIN_TESTS
        else 1
    )
    if n > 1 and cores_free() < STRIPS_MIN_FREE_CORES:
        n = 1
    if n == 1 or n_rows < 2:
        work((0, n_rows))
        return
    # strips taken in turn by the pool's thread and this one: where one core is slower (a
    # shared machine) the other takes more of them
    from stimuli.sharedstrips import SharedStrips

    job = SharedStrips(work, _strips(per_row, min(_SHARED_STRIPS, n_rows)))
    job.start()
    job.finish()


#: The agreement on two threads is cut into this many strips of rows, taken in turn by the
#: second thread and the caller (beside the edge classes: once the caller is free) (ours:
#: small enough that neither waits long for the other at the end, few enough that each call
#: is well above its set-up cost).
_SHARED_STRIPS = 12


def _strips(per_row: np.ndarray, n: int) -> list[tuple[int, int]]:
    """Cut the rows into ``n`` strips (fewer where rows are few) with as many listed pixels."""
    n_rows = len(per_row)
    cum = np.cumsum(per_row)
    total = cum[-1] if n_rows else 0
    cuts = [0] + [int(np.searchsorted(cum, total * k / n)) + 1 for k in range(1, n)] + [n_rows]
    cuts = sorted(set(min(max(c, 0), n_rows) for c in cuts))
    return list(zip(cuts[:-1], cuts[1:], strict=True))


#: Per light-field object (dropped with it): the agreement test's threshold image per
#: neighbour, ``{(axis, side, ratio, noise): float32 image}`` (:func:`_focus_limit`).
_LIMITS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _focus_limit(lf, c32: np.ndarray, axis: int, side: int) -> np.ndarray:
    """Return the threshold image of neighbour (``axis``, ``side``) of ``lf``, kept with it.

    NaN where not made yet: :func:`stimuli.edgefocus.focus_agreement_at` makes it
    at the pixels it tests and stores it, so each pixel's is made once per light field.
    """
    per = _LIMITS.setdefault(lf, {})
    key = (axis, side, FOCUS_AGREEMENT_RATIO, FOCUS_NOISE)
    limit = per.get(key)
    if limit is None or limit.shape != c32.shape:
        limit = per[key] = np.full(c32.shape, np.nan, np.float32)
    return limit


def _agreement_numpy(centre, nb, axis, side, ds):
    """Compute :func:`stimuli.kernels.focus_agreement` in numpy (a chain of full images)."""
    from scipy.ndimage import uniform_filter

    pad = int(np.ceil(np.abs(ds).max())) + 2
    widths = [(0, 0), (0, 0)]
    widths[axis] = (pad, pad)
    pc = np.pad(centre, widths, mode="edge")
    pn = np.pad(nb, widths, mode="edge")
    one_px = _sample(pc, pad, float(side), axis, centre.shape[axis])
    texture = uniform_filter(np.abs(one_px - centre), 3, mode="nearest")
    limit = np.float32(FOCUS_AGREEMENT_RATIO) * texture + np.float32(FOCUS_NOISE)
    out = np.zeros(centre.shape, bool)
    for d in ds:
        diff = uniform_filter(
            np.abs(_sample(pn, pad, d * side, axis, centre.shape[axis]) - centre), 3
        )
        out |= diff < limit
    return out


def declutter_depth(
    image: np.ndarray,
    focus_mask: np.ndarray,
    *,
    threshold: float,
    compiled: bool = True,
    edges: np.ndarray | None = None,
) -> np.ndarray:
    """Return the depth-mode edge image: Sobel edges that the light field says are in focus.

    An edge pixel of :func:`declutter` is kept when at least half of the edge pixels in the
    :data:`VOTE_WINDOW_PX` box around it are in focus (``focus_mask``, from
    :func:`in_focus_mask`), unless ``focus_mask`` (the uint8 evidence of
    :func:`in_focus_evidence`) marks it :data:`FOCUS_DROP`.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), float32 in [0, 1]
        The confocal image at the plane.
    focus_mask : ndarray of shape (rows, cols), bool or uint8
        In focus (bool), or :data:`FOCUS_OUT` / :data:`FOCUS_IN` / :data:`FOCUS_DROP` (uint8).
    threshold : float >= 0
        Sobel threshold, as :func:`declutter`.
    compiled : bool
        The vote in one compiled call, summed at the edge pixels only
        (:func:`stimuli.edgevote.vote_lean`, the default), or its numpy twin (two box
        filters of full images); the same edges to the bit.
    edges : ndarray of shape (rows, cols), bool, optional
        ``declutter(image, threshold=threshold)`` if the caller has it (not made again).

    Returns
    -------
    ndarray of shape (rows, cols), bool
    """
    if edges is None:
        edges = declutter(image, threshold=threshold)
    elif np.asarray(edges).dtype != np.bool_ or np.shape(edges) != np.shape(image):
        raise InputError(f"edges must be a bool image of shape {np.shape(image)}")
    edges = np.ascontiguousarray(edges)
    m = np.asarray(focus_mask)
    if m.dtype not in (np.bool_, np.uint8) or m.shape != edges.shape:
        raise InputError(
            f"focus_mask must be a bool image (or in_focus_evidence's uint8) of shape "
            f"{edges.shape}, got {m.dtype} {m.shape}"
        )
    if not compiled:
        return _vote_numpy(edges, m)
    from stimuli.edgevote import vote_lean

    out = np.empty(edges.shape, bool)
    if edges.size:
        f8 = np.ascontiguousarray(m).view(np.uint8)
        vote_lean(edges.view(np.uint8), f8, VOTE_WINDOW_PX, out)
    return out


def _vote_numpy(edges: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Compute :func:`stimuli.kernels.focus_vote` in numpy (two box filters of full images)."""
    from scipy.ndimage import uniform_filter

    drop = None
    if m.dtype == np.uint8:
        m, drop = m == FOCUS_IN, m == FOCUS_DROP
    e = edges.astype(np.float32)
    agree = uniform_filter(e * m, VOTE_WINDOW_PX, mode="constant")
    total = uniform_filter(e, VOTE_WINDOW_PX, mode="constant")
    kept = edges & (agree >= 0.5 * total)
    return kept if drop is None else kept & ~drop


#: Bokeh-rim guard: a narrow-DOF edge is kept only with a wide-DOF edge within this many pixels
#: (ours: the two photos of a pair may be misaligned by a pixel or two, EBB! pairs more).
BOKEH_GUARD_RADIUS_PX: int = 3


def bokeh_guard(
    narrow_edges: np.ndarray, wide_edges: np.ndarray, *, radius_px: int = BOKEH_GUARD_RADIUS_PX
) -> np.ndarray:
    """Drop narrow-DOF edges that the wide-DOF photo does not have at the same place.

    A sharp-rimmed bokeh disc (an out-of-focus highlight in the narrow-DOF photo) has strong
    edges where the wide-DOF photo shows a small point or nothing; a real in-focus edge is sharp
    in both photos. Ours, beyond the paper; optional.

    Parameters
    ----------
    narrow_edges, wide_edges : ndarray of shape (rows, cols), bool
        Edge images of the narrow- and wide-DOF photos (same threshold).
    radius_px : int >= 0
        How far a wide-DOF edge may be from the narrow-DOF edge it confirms, pixels.

    Returns
    -------
    ndarray of shape (rows, cols), bool
        ``narrow_edges`` without the unconfirmed edges.
    """
    from scipy.ndimage import maximum_filter

    n, w = np.asarray(narrow_edges), np.asarray(wide_edges)
    if n.dtype != bool or w.dtype != bool or n.shape != w.shape or n.ndim != 2:
        raise InputError(
            f"narrow_edges and wide_edges must be bool images of one shape, got {n.dtype} "
            f"{n.shape} and {w.dtype} {w.shape}"
        )
    if isinstance(radius_px, bool) or not isinstance(radius_px, int) or radius_px < 0:
        raise InputError(f"radius_px must be an integer >= 0, got {radius_px!r}")
    near = maximum_filter(w, size=2 * radius_px + 1, mode="constant") if radius_px else w
    return n & near
