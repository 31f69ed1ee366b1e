"""Furniture and household things: a desk lamp, a light bulb, an umbrella, a chair, a book.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import math

import numpy as np

from stimuli.objects import drawing as dr
from stimuli.objects.drawing import OUTLINE_UNITS as OL

__all__ = ["draw_desk_lamp", "draw_light_bulb", "draw_umbrella", "draw_chair", "draw_book"]


def draw_desk_lamp(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a desk lamp."""
    base = rng.uniform(0.3, 0.55)
    cv.paint(
        dr.ellipse(0.05, 0.05, 0.32, 0.06),
        dr.gradient(0, 0.1, 0, 0.0, base * 1.3, base * 0.7),
        outline=OL,
    )
    cv.paint(dr.box(0.05, 0.1, 0.3, 0.08, r=0.03), dr.metal(base), outline=OL)
    j1, j2, head = (0.05, 0.13), (-0.22, 0.78), (0.2, 1.12)
    cv.paint(dr.capsule(*j1, *j2, 0.028), dr.metal(base * 1.2, 110), outline=OL)
    cv.paint(dr.capsule(j1[0] + 0.06, j1[1], j2[0] + 0.06, j2[1], 0.01), 0.85, outline=OL / 2)
    cv.paint(dr.capsule(*j2, *head, 0.025), dr.metal(base * 1.2, 40), outline=OL)
    cv.paint(dr.circle(*j2, 0.05), dr.sphere(j2[0], j2[1], 0.05, 0.7), outline=OL)
    cv.paint(dr.circle(*j1, 0.045), dr.sphere(j1[0], j1[1], 0.045, 0.7), outline=OL)
    # Conical shade pointing down to the right; the bulb glows in its mouth.
    shade = dr.rotate(
        dr.polygon([(-0.08, 0.0), (0.08, 0.0), (0.22, -0.34), (-0.22, -0.34)])
        | dr.ellipse(0, 0.0, 0.08, 0.04),
        35.0,
        0,
        0,
    )
    shade = dr.translate(shade, head[0], head[1])
    cv.paint(shade, dr.cylinder(head[0] + 0.1, 0.25, base * 1.3, spec=0.35), outline=OL)
    mouth_x = head[0] + 0.34 * math.sin(math.radians(35))
    mouth_y = head[1] - 0.34 * math.cos(math.radians(35))
    rim = dr.rotate(dr.ellipse(mouth_x, mouth_y, 0.22, 0.06), 35.0, mouth_x, mouth_y)
    cv.paint(rim, 0.97, outline=OL)
    cv.paint(dr.rotate(dr.ellipse(mouth_x, mouth_y, 0.1, 0.035), 35.0, mouth_x, mouth_y), 1.0)
    cv.paint(dr.circle(*head, 0.04), dr.sphere(head[0], head[1], 0.04, 0.7), outline=OL)


def draw_light_bulb(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a light bulb."""
    cy = 0.86
    globe = dr.circle(0, cy, 0.33) | dr.polygon(
        [(-0.26, 0.66), (0.26, 0.66), (0.14, 0.4), (-0.14, 0.4)]
    )
    cv.paint(globe, dr.sphere(0, cy, 0.4, 0.8, spec=0.25), outline=OL)
    fil = [(-0.1, 0.5), (-0.07, 0.86)] + [
        (-0.07 + 0.14 * k / 6, 0.86 + 0.04 * (k % 2)) for k in range(7)
    ]
    fil += [(0.1, 0.5)]
    for p, q in zip(fil[:-1], fil[1:], strict=True):
        cv.paint(dr.capsule(*p, *q, 0.008), 0.2)
    cv.paint(dr.capsule(-0.22, 0.95, -0.14, 1.07, 0.02), 1.0, opacity=0.9)
    cv.paint(dr.box(0, 0.3, 0.3, 0.2, r=0.02), dr.gradient(0, 0.3, 0, 0.3, 0.6, 0.6), outline=OL)

    def thread(x, y):
        return np.clip(
            0.35 + 0.35 * np.sin((y - 0.12 * x) * 110) + 0.25 * dr.cylinder(0, 0.15, 0.6)(x, y),
            0,
            1,
        )

    cv.paint(dr.box(0, 0.3, 0.3, 0.2, r=0.02), thread, outline=OL)
    cv.paint(dr.box(0, 0.16, 0.18, 0.08, r=0.02), 0.12, outline=OL)
    cv.paint(dr.ellipse(0, 0.1, 0.06, 0.035), dr.metal(0.7), outline=OL)
    del rng


def draw_umbrella(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw an umbrella."""
    base = rng.uniform(0.2, 0.45)
    top, cy = (0.0, 1.22), 0.78
    canopy = dr.ellipse(0, cy, 0.56, 0.44) & dr.above(cy)
    for k in range(5):
        canopy = canopy - dr.ellipse(-0.42 + k * 0.21, cy, 0.105, 0.05)
    cv.paint(dr.capsule(0, cy, 0, 0.15, 0.018), dr.metal(0.6), outline=OL)
    hook = dr.ring(0.09, 0.15, 0.09, 0.04) & dr.below(0.15)
    cv.paint(hook, 0.2, outline=OL)

    def panels(x, y):
        ang = np.arctan2(y - cy, x)
        return np.where(np.sin(ang * 8) > 0, base, base * 2.0) * (0.75 + 0.25 * (y - cy) / 0.44)

    cv.paint(canopy, panels, outline=OL)
    for k in range(5):
        end = (-0.42 + k * 0.21, cy + 0.015)
        cv.paint(dr.capsule(*top, *end, 0.006), 0.1)
    cv.paint(dr.capsule(0, 1.2, 0, 1.32, 0.018), 0.3, outline=OL)


def draw_chair(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a chair."""
    wood = rng.uniform(0.45, 0.7)
    grain = dr.stripes(0.03, wood, wood * 0.8, 0)
    for sx in (-1.0, 1.0):
        cv.paint(dr.box(sx * 0.26, 0.35, 0.045, 0.5), wood * 0.6, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(dr.box(sx * 0.28, 1.0, 0.06, 0.9, r=0.02), grain, outline=OL)
    cv.paint(
        dr.box(0, 1.36, 0.7, 0.14, r=0.04),
        dr.gradient(0, 1.43, 0, 1.29, wood * 1.2, wood * 0.8),
        outline=OL,
    )
    for k in range(-1, 2):
        cv.paint(dr.box(k * 0.14, 1.0, 0.06, 0.56), grain, outline=OL)
    seat = dr.polygon([(-0.4, 0.58), (0.4, 0.58), (0.34, 0.7), (-0.34, 0.7)])
    cv.paint(seat, dr.gradient(0, 0.7, 0, 0.58, wood * 1.25, wood * 0.9), outline=OL)
    cv.paint(dr.box(0, 0.555, 0.8, 0.05), wood * 0.6, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(
            dr.box(sx * 0.36, 0.27, 0.06, 0.56), dr.cylinder(sx * 0.36, 0.03, wood), outline=OL
        )
    cv.paint(dr.box(0, 0.2, 0.66, 0.03), wood * 0.7, outline=OL)


def draw_book(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a book."""
    cover = rng.uniform(0.15, 0.4)
    cv.paint(
        dr.polygon([(-0.56, 0.04), (0.56, 0.04), (0.58, 0.8), (0.0, 0.74), (-0.58, 0.8)]),
        cover,
        outline=OL,
    )
    for sx in (-1.0, 1.0):
        page = dr.polygon(
            [
                (0.0, 0.1),
                (sx * 0.25, 0.14),
                (sx * 0.52, 0.1),
                (sx * 0.53, 0.82),
                (sx * 0.25, 0.86),
                (0.0, 0.8),
            ]
        )
        cv.paint(
            page, lambda x, y: np.clip(0.95 - 0.35 * np.exp(-np.abs(x) / 0.06), 0, 1), outline=OL
        )
        for i in range(12):
            y = 0.74 - i * 0.048
            x = 0.06
            while x < 0.44:
                w = rng.uniform(0.03, 0.09)
                x1 = min(x + w, 0.46)
                bow = 0.04 * (1 - abs((x + x1) / 2 - 0.25) / 0.25)
                cv.paint(dr.box(sx * (x + x1) / 2, y + bow, x1 - x, 0.014), 0.2)
                x = x1 + 0.02
    cv.paint(dr.capsule(0, 0.1, 0, 0.8, 0.004), 0.3)
