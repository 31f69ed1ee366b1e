"""Cluttered backgrounds: a patterned wall, a bookshelf, clothes on a rail, a pin board, cables.

Each ``draw_<background>(canvas, rng)`` paints one layer of the clutter behind an object, in
metres on the layer's plane (origin on the optical axis, y up), over the whole canvas.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from stimuli.objects import drawing as dr

__all__ = ["BACKGROUNDS", "draw_wall", "draw_shelf", "draw_clothes", "draw_pinboard", "draw_cables"]


def draw_wall(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a patterned wall (bricks, stripes, tiles, diamonds or dots) with pictures hung on it."""
    x0, y0, x1, y1 = cv.extent
    kind = rng.choice(["bricks", "stripes", "tiles", "diamonds", "dots"])
    v0, v1 = rng.uniform(0.25, 0.45), rng.uniform(0.7, 0.9)
    if kind == "bricks":
        h, w = 0.075, 0.2

        def f(x, y):
            row = np.floor(y / h)
            xs = x + (row % 2) * w / 2
            mortar = (np.mod(y, h) < 0.012) | (np.mod(xs, w) < 0.012)
            tone = 0.08 * np.sin(row * 12.9898 + np.floor(xs / w) * 78.233)
            return np.where(mortar, v1, v0 + tone)

    elif kind == "stripes":
        f = dr.stripes(rng.uniform(0.06, 0.12), v0, v1, 0.0, duty=rng.uniform(0.3, 0.6))
    elif kind == "tiles":
        s = rng.uniform(0.1, 0.16)

        def f(x, y):
            grout = (np.mod(x, s) < 0.01) | (np.mod(y, s) < 0.01)
            checker = (np.floor(x / s) + np.floor(y / s)) % 2
            return np.where(grout, 0.15, v0 + (v1 - v0) * checker)

    elif kind == "diamonds":
        s = rng.uniform(0.08, 0.14)

        def f(x, y):
            u = np.abs(np.mod(x / s, 1.0) - 0.5) + np.abs(np.mod(y / s, 1.0) - 0.5)
            return np.where(u < 0.3, v0, v1)

    else:
        s = rng.uniform(0.06, 0.1)

        def f(x, y):
            u, v = np.mod(x / s, 1.0) - 0.5, np.mod(y / s + 0.5 * np.floor(x / s), 1.0) - 0.5
            return np.where(u * u + v * v < 0.08, v0, v1)

    cv.fill(f)
    for _ in range(rng.integers(2, 5)):
        cx, cy = rng.uniform(x0, x1), rng.uniform(y0, y1)
        w, h = rng.uniform(0.2, 0.45), rng.uniform(0.2, 0.45)
        cv.paint(dr.box(cx, cy, w + 0.05, h + 0.05), rng.uniform(0.05, 0.2))
        pic = dr.box(cx, cy, w, h)
        cv.paint(
            pic,
            dr.gradient(cx - w / 2, cy, cx + w / 2, cy, rng.uniform(0.4, 1), rng.uniform(0, 0.6)),
        )
        for _ in range(rng.integers(2, 6)):
            px, py = cx + rng.uniform(-w / 2, w / 2), cy + rng.uniform(-h / 2, h / 2)
            cv.paint(dr.circle(px, py, rng.uniform(0.02, 0.08)) & pic, rng.uniform(0, 1))
            cv.paint(dr.box(px, py, rng.uniform(0.02, 0.12), 0.012) & pic, rng.uniform(0, 1))


def _book_row(
    cv: dr.Canvas, rng: np.random.Generator, xa: float, xb: float, y_shelf: float, h_max: float
) -> None:
    x = xa + rng.uniform(0.0, 0.03)
    while x < xb - 0.02:
        r = rng.random()
        if r < 0.12:
            x += rng.uniform(0.03, 0.09)
            continue
        if r < 0.3:
            w, h = rng.uniform(0.06, 0.085), min(h_max, rng.uniform(0.26, 0.3))
            w = min(w, xb - x)
            v = rng.uniform(0.1, 0.9)
            cv.paint(
                dr.box(x + w / 2, y_shelf + h / 2, w, h, r=0.004),
                v,
                outline=0.004,
                outline_value=0.05,
            )
            cv.paint(
                dr.box(x + w / 2, y_shelf + h * 0.62, w * 0.6, h * 0.25), 0.95 if v < 0.5 else 0.1
            )
            cv.paint(dr.circle(x + w / 2, y_shelf + h * 0.2, w * 0.18), 0.05)
            x += w + 0.002
            continue
        w, h = rng.uniform(0.018, 0.05), min(h_max, rng.uniform(0.15, 0.28))
        w = min(w, xb - x)
        v = rng.uniform(0.05, 0.95)
        lean = rng.uniform(8, 18) if rng.random() < 0.08 else 0.0
        cx, cy = x + w / 2, y_shelf + h / 2
        book = dr.rotate(dr.box(cx, cy, w, h, r=0.002), lean, x + w, y_shelf)
        cv.paint(book, dr.cylinder(cx, w / 2, v, spec=0.1), outline=0.003, outline_value=0.05)
        for _ in range(rng.integers(0, 3)):
            by = rng.uniform(y_shelf + 0.02, y_shelf + h - 0.03)
            band = dr.rotate(
                dr.box(cx, by, w * 0.9, rng.uniform(0.006, 0.025)), lean, x + w, y_shelf
            )
            cv.paint(band, 1.0 - v if rng.random() < 0.6 else rng.uniform(0, 1))
        x += w + (h * math.sin(math.radians(lean)) if lean else 0.0) + rng.uniform(0.0, 0.004)


def draw_shelf(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a bookshelf: boards and posts with rows of books and binders."""
    x0, y0, x1, y1 = cv.extent
    board = rng.uniform(0.45, 0.8)
    left = x0 if rng.random() < 0.5 else rng.uniform(x0, x0 + 0.3)
    right = x1 if rng.random() < 0.5 else rng.uniform(x1 - 0.3, x1)
    cv.paint(dr.box((left + right) / 2, (y0 + y1) / 2, right - left, y1 - y0 + 0.1), 0.12)
    spacing = rng.uniform(0.3, 0.36)
    ys = np.arange(y0 - rng.uniform(0, spacing), y1 + spacing, spacing)
    posts = np.arange(left, right + 0.01, rng.uniform(0.6, 0.85))
    for y in ys:
        for xa, xb in zip(posts[:-1], posts[1:], strict=False):
            _book_row(cv, rng, xa + 0.025, xb - 0.025, y + 0.012, spacing - 0.05)
        if rng.random() < 0.3:
            _book_row(cv, rng, posts[-1] + 0.025, right - 0.02, y + 0.012, spacing - 0.05)
    for y in ys:
        cv.paint(
            dr.box((left + right) / 2, y, right - left, 0.025),
            dr.gradient(0, y + 0.012, 0, y - 0.012, board, board * 0.6),
            outline=0.003,
            outline_value=0.1,
        )
    for p in list(posts) + [right]:
        cv.paint(
            dr.box(p, (y0 + y1) / 2, 0.03, y1 - y0 + 0.1),
            dr.cylinder(p, 0.015, board, spec=0.1),
            outline=0.003,
            outline_value=0.1,
        )


def _shirt(cv: dr.Canvas, rng: np.random.Generator, cx: float, top: float) -> None:
    w, h = rng.uniform(0.34, 0.44), rng.uniform(0.6, 0.8)
    hook = dr.ring(cx, top + 0.06, 0.035, 0.008) & dr.above(top + 0.05)
    cv.paint(hook, 0.6, outline=0.003)
    cv.paint(
        dr.polygon([(cx, top + 0.03), (cx + w / 2, top - 0.05), (cx - w / 2, top - 0.05)])
        - dr.polygon(
            [(cx, top + 0.01), (cx + w / 2 - 0.04, top - 0.04), (cx - w / 2 + 0.04, top - 0.04)]
        ),
        0.3,
    )
    # Painted as separate pieces (sleeves, torso, shoulders): a union would evaluate every
    # piece's distance over the whole shirt, and the seams between pieces look like seams.
    pieces = [
        dr.box(cx + sx * (w / 2 + 0.02), top - 0.17, 0.11, 0.25, r=0.01, angle_deg=sx * 18.0)
        for sx in (-1.0, 1.0)
    ]
    pieces.append(dr.box(cx, top - (h + 0.05) / 2, w - 0.03, h - 0.05, r=0.01))
    pieces.append(
        dr.polygon(
            [
                (cx - 0.06, top),
                (cx + 0.06, top),
                (cx + w / 2, top - 0.05),
                (cx + w / 2 - 0.015, top - 0.09),
                (cx - w / 2 + 0.015, top - 0.09),
                (cx - w / 2, top - 0.05),
            ]
        )
    )
    pat = rng.choice(["stripes", "check", "solid", "hstripes"])
    v0, v1 = rng.uniform(0.05, 0.45), rng.uniform(0.55, 0.95)
    if pat == "stripes":
        base = dr.stripes(rng.uniform(0.025, 0.06), v0, v1, 0)
    elif pat == "hstripes":
        base = dr.stripes(rng.uniform(0.03, 0.07), v0, v1, 90)
    elif pat == "check":
        p = rng.uniform(0.05, 0.09)

        def base(x, y):
            return v0 + (v1 - v0) * 0.5 * (
                (np.mod(x, p) < p / 2).astype(float) + (np.mod(y, p) < p / 2)
            )

    else:

        def base(x, y):
            return np.full_like(x, v0 + 0.2)

    def folds(x, y):
        return np.clip(base(x, y) * (0.8 + 0.2 * np.sin((x - cx) * 60 + y * 5)), 0, 1)

    for piece in pieces:
        cv.paint(piece, folds, outline=0.004, outline_value=0.05)
    cv.paint(
        dr.polygon([(cx - 0.06, top), (cx, top - 0.07), (cx + 0.06, top), (cx, top - 0.02)]),
        0.9,
        outline=0.003,
    )
    if pat == "solid":
        for k in range(5):
            cv.paint(dr.circle(cx, top - 0.12 - k * 0.1, 0.008), 0.95)


def draw_clothes(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw shirts on hangers along a clothes rail."""
    x0, y0, x1, y1 = cv.extent
    rail_y = y1 - rng.uniform(0.05, 0.2)
    side = rng.choice([-1, 1])
    xa, xb = (x0, rng.uniform(-0.1, 0.25)) if side < 0 else (rng.uniform(-0.25, 0.1), x1)
    cv.paint(
        dr.capsule(xa, rail_y, xb, rail_y, 0.012),
        dr.cylinder(rail_y, 0.012, 0.8, spec=0.3, axis="y"),
        outline=0.003,
    )
    xs = np.sort(rng.uniform(xa + 0.1, xb - 0.1, size=rng.integers(4, 8)))
    for x in xs:
        _shirt(cv, rng, float(x), rail_y - 0.02)


def draw_pinboard(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a cork pin board with notes pinned to it."""
    x0, y0, x1, y1 = cv.extent
    side = rng.choice([-1, 1])
    w, h = rng.uniform(0.5, 0.8), rng.uniform(0.45, 0.65)
    cx = side * rng.uniform(0.15, 0.35)
    cy = rng.uniform(y1 - h / 2 - 0.2, y1 - h / 2)
    cork = dr.smooth_noise(rng, cv.shape, 1.0)
    board = dr.box(cx, cy, w, h)

    def cork_f(x, y):
        rr = np.clip(np.round(cv.r0 - y * cv.ppu).astype(int), 0, cv.shape[0] - 1)
        cc = np.clip(np.round(cv.c0 + x * cv.ppu).astype(int), 0, cv.shape[1] - 1)
        return np.clip(0.55 + 0.25 * cork[rr, cc], 0, 1)

    cv.paint(dr.box(cx, cy, w + 0.04, h + 0.04), 0.25, outline=0.004)
    cv.paint(board, cork_f)
    for _ in range(rng.integers(5, 10)):
        px, py = (
            cx + rng.uniform(-w / 2 + 0.05, w / 2 - 0.05),
            cy + rng.uniform(-h / 2 + 0.06, h / 2 - 0.06),
        )
        pw, ph = rng.uniform(0.08, 0.18), rng.uniform(0.08, 0.2)
        ang = rng.uniform(-12, 12)
        note = dr.rotate(dr.box(px, py, pw, ph), ang, px, py)
        cv.paint(note, rng.choice([0.95, 0.85, 0.75]), outline=0.002, outline_value=0.3)
        for k in range(int(ph / 0.018) - 1):
            ly = py + ph / 2 - 0.02 - k * 0.018
            lw = pw * rng.uniform(0.4, 0.8)
            cv.paint(
                dr.rotate(dr.box(px - pw / 2 + 0.01 + lw / 2, ly, lw, 0.005), ang, px, py), 0.15
            )
        cv.paint(dr.circle(px, py + ph / 2 - 0.012, 0.01), rng.uniform(0, 0.4), outline=0.002)


def draw_cables(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw cables hanging from the top or running across."""
    x0, y0, x1, y1 = cv.extent
    for _ in range(rng.integers(3, 7)):
        if rng.random() < 0.6:  # hanging from the top
            xa, xb = rng.uniform(x0, x1, 2)
            p = [
                (xa, y1 + 0.05),
                (xa + rng.uniform(-0.2, 0.2), rng.uniform(y0, y1)),
                (xb + rng.uniform(-0.2, 0.2), rng.uniform(y0, y1)),
                (xb, rng.choice([y0 - 0.05, y1 + 0.05])),
            ]
        else:  # across
            p = [
                (x0 - 0.05, rng.uniform(y0, y1)),
                (rng.uniform(x0, x1), rng.uniform(y0 - 0.2, y1)),
                (rng.uniform(x0, x1), rng.uniform(y0 - 0.2, y1)),
                (x1 + 0.05, rng.uniform(y0, y1)),
            ]
        pts = dr.bezier(p, 24)
        r = rng.uniform(0.003, 0.007)
        v = rng.uniform(0.02, 0.2) if rng.random() < 0.7 else rng.uniform(0.75, 0.95)
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            cv.paint(dr.capsule(a[0], a[1], b[0], b[1], r), v)
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            cv.paint(
                dr.capsule(a[0] - r / 3, a[1] + r / 3, b[0] - r / 3, b[1] + r / 3, r / 4),
                min(1.0, v + 0.35),
            )


#: The function that draws each background layer, by the layer's name.
BACKGROUNDS: dict[str, Callable[[dr.Canvas, np.random.Generator], None]] = {
    "wall": draw_wall,
    "shelf": draw_shelf,
    "clothes": draw_clothes,
    "pinboard": draw_pinboard,
    "cables": draw_cables,
}
