"""The depth scan as a figure: score versus depth or disparity, planes marked (Fig. 15).

Drawn with Pillow (axes, ticks, grid, the score curve, its null, the detected planes and their
labels, a legend) rather than matplotlib, whose import alone costs about half a second of the
``lightfield scan`` command (ours).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["nice_ticks", "plot_scores"]

_BLUE, _GREY, _RED, _GRID, _INK = (0, 70, 140), (128, 128, 128), (200, 0, 0), (230, 230, 230), 0


def nice_ticks(lo: float, hi: float, nbins: int) -> np.ndarray:
    """Return round tick values (steps of 1, 2, 2.5 or 5 x 10^k) covering ``[lo, hi]``.

    Parameters
    ----------
    lo, hi : float
        The axis range (``lo < hi``; an empty range is widened by one).
    nbins : int
        The most intervals between ticks.

    Returns
    -------
    numpy.ndarray
        The ticks inside ``[lo, hi]``, ascending.
    """
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    raw = (hi - lo) / max(nbins, 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * mag >= raw * (1 - 1e-9))
    first = math.ceil(lo / step - 1e-9) * step
    ticks = np.arange(first, hi + step * 1e-6, step)
    return np.round(ticks / step) * step


def _fmt(v: float) -> str:
    return f"{v:.4g}" if abs(v) > 1e-12 else "0"


def _dashed(draw, pts: list[tuple[float, float]], fill, dash: float = 6.0) -> None:
    """Draw a polyline dashed (``dash`` px on, ``dash`` px off), the phase kept across points."""
    on, left = True, dash
    for (x0, y0), (x1, y1) in zip(pts, pts[1:], strict=False):
        seg = math.hypot(x1 - x0, y1 - y0)
        t = 0.0
        while t < seg:
            step = min(left, seg - t)
            if on:
                a, b = t / seg, (t + step) / seg
                dx, dy = x1 - x0, y1 - y0
                ends = [(x0 + a * dx, y0 + a * dy), (x0 + b * dx, y0 + b * dy)]
                draw.line(ends, fill=fill, width=1)
            t += step
            left -= step
            if left <= 0:
                on, left = not on, dash


def plot_scores(scan, path: Path, *, size_in: tuple[float, float] = (7.0, 3.6)) -> Path:
    """Draw the score versus depth (or disparity) as a PNG (Fig. 15), 100 pixels per inch.

    Detected planes are marked and labelled with their depth or disparity; the agreement scan's
    null is drawn dashed; both curves are named in a legend. Written whole or not at all.

    Parameters
    ----------
    scan : stimuli.planescan.PlaneScan
        The scan: its scores, planes (disparities, depths where known), null and peaks.
    path : pathlib.Path
        The PNG to write.
    size_in : tuple of float
        Width and height in inches (at 100 dpi).

    Returns
    -------
    pathlib.Path
        The written path.
    """
    from PIL import Image, ImageDraw, ImageFont

    from stimuli.io import atomic_path

    use_depth = scan.depths_m is not None and bool(np.all(np.isfinite(scan.depths_m)))
    xs = np.asarray(scan.depths_m if use_depth else scan.disparities_px, dtype=float)
    order = np.argsort(xs)
    xs = xs[order]
    ys = np.asarray(scan.scores, dtype=float)[order]
    null = None if scan.null_scores is None else np.asarray(scan.null_scores, dtype=float)[order]
    w, h = round(size_in[0] * 100), round(size_in[1] * 100)
    im = Image.new("RGB", (w, h), "white")
    draw = ImageDraw.Draw(im)
    font = ImageFont.load_default(size=12)
    small = ImageFont.load_default(size=11)

    x_lo, x_hi = float(xs[0]), float(xs[-1])
    if not x_hi > x_lo:
        x_lo, x_hi = x_lo - 0.5, x_hi + 0.5
    pad = 0.02 * (x_hi - x_lo)
    x_lo, x_hi = x_lo - pad, x_hi + pad
    top = max(float(np.nanmax(ys)) if ys.size else 0.0, 1e-9)
    y_lo, y_hi = 0.0, 1.3 * top  # room for the legend above the peaks
    yt = nice_ticks(y_lo, y_hi, 5)
    ylabels = [_fmt(v) for v in yt]
    tick_w = max(draw.textlength(s, font=font) for s in ylabels)
    left, right, upper, lower = int(tick_w) + 34, w - 12, 10, h - 44
    pw, ph = right - left, lower - upper

    def px(x: float) -> float:
        return left + (x - x_lo) / (x_hi - x_lo) * pw

    def py(y: float) -> float:
        return lower - (y - y_lo) / (y_hi - y_lo) * ph

    xt = nice_ticks(x_lo, x_hi, 8)
    for v in xt:  # grid, ticks and tick labels
        X = px(v)
        draw.line([(X, upper), (X, lower)], fill=_GRID)
        draw.line([(X, lower), (X, lower + 4)], fill=_INK)
        draw.text((X, lower + 6), _fmt(v), fill=_INK, font=font, anchor="mt")
    for v, s in zip(yt, ylabels, strict=True):
        Y = py(v)
        draw.line([(left, Y), (right, Y)], fill=_GRID)
        draw.line([(left - 4, Y), (left, Y)], fill=_INK)
        draw.text((left - 6, Y), s, fill=_INK, font=font, anchor="rm")
    draw.rectangle([left, upper, right, lower], outline=_INK)
    xlabel = "depth (m)" if use_depth else "disparity (px per view step)"
    draw.text(((left + right) / 2, h - 4), xlabel, fill=_INK, font=font, anchor="md")
    ylab = Image.new("L", (int(draw.textlength("score", font=font)) + 4, 16), 255)
    ImageDraw.Draw(ylab).text((2, 1), "score", fill=0, font=font)
    ylab = ylab.rotate(90, expand=True)
    im.paste((0, 0, 0), (4, int((upper + lower - ylab.height) / 2)), ylab.point(lambda v: 255 - v))

    plot = Image.new("RGB", (w, h), "white")  # the curves, clipped to the axes box
    pdraw = ImageDraw.Draw(plot)
    if null is not None:
        _dashed(pdraw, [(px(x), py(y)) for x, y in zip(xs, null, strict=True)], _GREY)
    pdraw.line([(px(x), py(y)) for x, y in zip(xs, ys, strict=True)], fill=_BLUE, width=2)
    box = (left + 1, upper + 1, right, lower)
    im.paste(plot.crop(box), box[:2])
    for p in scan.peaks:
        xv = p.depth_m if use_depth else p.disparity_px
        X, Y = px(xv), py(p.score)
        draw.ellipse([X - 3, Y - 3, X + 3, Y + 3], fill=_RED)
        draw.text((X + 5, Y - 5), f"{xv:.3g}", fill=_RED, font=font, anchor="ld")

    label = (
        "fraction of pixels whose views agree best here"
        if scan.method == "agreement"
        else "fraction of edge pixels coinciding with the centre view"
    )
    entries = [(label, _BLUE, False)]
    if null is not None:
        entries.append(("null (non-coincident reference)", _GREY, True))
    text_w = max(draw.textlength(s, font=small) for s, _, _ in entries)
    lx = right - 10 - text_w - 34
    for i, (s, colour, dashed) in enumerate(entries):
        ly = upper + 10 + 16 * i
        if dashed:
            _dashed(draw, [(lx, ly), (lx + 26, ly)], colour, dash=4.0)
        else:
            draw.line([(lx, ly), (lx + 26, ly)], fill=colour, width=2)
        draw.text((lx + 32, ly), s, fill=_INK, font=small, anchor="lm")

    path = Path(path)
    with atomic_path(path) as tmp:
        im.save(tmp, format="png")
    return path
